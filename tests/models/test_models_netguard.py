"""block_network: non-loopback connects fail loudly, loopback still works."""

from __future__ import annotations

import socket

import httpx
import pytest

from scenemosaic.models._testing import NetworkAccessBlocked, block_network


def test_non_loopback_connect_is_blocked_and_restored() -> None:
    original = socket.socket.connect
    with block_network():
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock, pytest.raises(NetworkAccessBlocked):
            sock.connect(("203.0.113.5", 443))  # TEST-NET-3: never routed anyway
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as sock, pytest.raises(NetworkAccessBlocked):
            sock.connect_ex(("example.invalid", 80))
    assert socket.socket.connect is original


def test_loopback_is_allowed() -> None:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as server:
        server.bind(("127.0.0.1", 0))
        server.listen(1)
        port = server.getsockname()[1]
        with block_network(), socket.create_connection(("127.0.0.1", port), timeout=2):
            conn, _ = server.accept()
            conn.close()


async def test_httpx_to_a_public_host_fails_without_retries_hiding_it() -> None:
    with block_network():
        async with httpx.AsyncClient() as client:
            # anyio's happy-eyeballs connect may wrap it in an exception group; either way it
            # is our error, not an httpx.ConnectError that retry logic would swallow.
            with pytest.raises((NetworkAccessBlocked, BaseExceptionGroup)) as info:
                await client.get("http://203.0.113.5/")
    if isinstance(info.value, BaseExceptionGroup):
        assert info.group_contains(NetworkAccessBlocked)
