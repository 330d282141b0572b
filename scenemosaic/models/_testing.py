"""Test helpers: keep a test run off the network.

:func:`block_network` makes every socket ``connect`` to a non-loopback address raise
:class:`NetworkAccessBlocked`, so an offline test that would reach a real server fails
loudly instead of hanging or silently spending tokens. Loopback (127.0.0.0/8, ::1) and
Unix sockets stay allowed: the local integration server and asyncio's self-pipes use them.

Use it as a context manager, or register the pytest fixture from a ``conftest.py``::

    pytest_plugins = ["scenemosaic.models._testing"]   # autouse fixture ``_no_network``
"""

from __future__ import annotations

import ipaddress
import socket
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest

__all__ = ["NetworkAccessBlocked", "block_network"]


class NetworkAccessBlocked(RuntimeError):
    """A test tried to open a connection to a non-loopback address.

    A ``RuntimeError``, not an ``OSError``: HTTP clients would turn an ``OSError`` into a
    retryable connect error and hide the mistake behind retries.
    """


def _is_loopback(address: Any) -> bool:
    if not isinstance(address, tuple) or not address:
        return True  # AF_UNIX paths and abstract sockets
    host = str(address[0])
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host.split("%", 1)[0]).is_loopback
    except ValueError:
        return False  # an unresolved host name: not provably local


@contextmanager
def block_network() -> Iterator[None]:
    """Inside the block, connecting a socket anywhere but loopback raises :class:`NetworkAccessBlocked`."""
    original_connect = socket.socket.connect
    original_connect_ex = socket.socket.connect_ex

    def guarded_connect(self: socket.socket, address: Any) -> None:
        if self.family in (socket.AF_INET, socket.AF_INET6) and not _is_loopback(address):
            raise NetworkAccessBlocked(f"network access blocked in tests: connect to {address!r}")
        original_connect(self, address)

    def guarded_connect_ex(self: socket.socket, address: Any) -> int:
        if self.family in (socket.AF_INET, socket.AF_INET6) and not _is_loopback(address):
            raise NetworkAccessBlocked(f"network access blocked in tests: connect to {address!r}")
        return original_connect_ex(self, address)

    socket.socket.connect = guarded_connect  # type: ignore[method-assign, assignment]
    socket.socket.connect_ex = guarded_connect_ex  # type: ignore[method-assign, assignment]
    try:
        yield
    finally:
        socket.socket.connect = original_connect  # type: ignore[method-assign, assignment]
        socket.socket.connect_ex = original_connect_ex  # type: ignore[method-assign, assignment]


@pytest.fixture(autouse=True)
def _no_network() -> Iterator[None]:
    """Autouse fixture: every test runs inside :func:`block_network`."""
    with block_network():
        yield
