"""Files a scene refers to: where they may lie, and how scene files are written.

A scene file is input we do not control. Every file it names (mesh uris, and the buffers,
images and material files those meshes name in turn) must lie inside the folder the scene came
from or inside a folder the caller allowed explicitly. :func:`confined_path` is the one check:
readers call it on every uri, and the places that read or copy files call it again. Symlinks
are followed first, so a link inside the folder that points outside is refused like ``../``.

:func:`write_atomic` writes a file through a temporary name in the same folder, with the mode
an ordinary ``open`` would give it (``0666`` less the umask, usually ``0644``). It is the one way
the library writes a file: a full disk leaves nothing half-written and raises
:class:`~scenemosaic.exceptions.OutputSpaceError`.
"""

from __future__ import annotations

import errno
import os
import secrets
import stat
from collections.abc import Sequence
from pathlib import Path
from typing import BinaryIO

from scenemosaic.exceptions import OutputSpaceError, UnsafePathError

__all__ = ["confined_path", "missing_file", "not_a_regular_file", "real_path", "write_atomic"]


def real_path(path: str | os.PathLike[str]) -> Path:
    """``path`` made absolute with every symlink followed (it need not exist).

    Raises:
        UnsafePathError: for a symlink loop or a path the system cannot take (a NUL byte).
    """
    try:
        # not strict: a missing file is the caller's business (it has its own message for it)
        return Path(path).resolve()
    except RuntimeError as exc:  # Python < 3.13 reports a symlink loop as RuntimeError
        raise UnsafePathError(f"{os.fspath(path)}: symlink loop", reference=os.fspath(path)) from exc
    except (OSError, ValueError) as exc:
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise UnsafePathError(f"{os.fspath(path)}: cannot resolve ({reason})", reference=os.fspath(path)) from exc


def confined_path(
    base: str | os.PathLike[str], uri: str, *, roots: Sequence[str | os.PathLike[str]] = ()
) -> Path:
    """The file ``uri`` names, resolved, provided it lies inside ``base`` or one of ``roots``.

    A relative ``uri`` is taken from ``base``; an absolute one as it is. Symlinks (in the uri
    and in the folders) are followed before the check, so the *resolved* path is what must lie
    inside a resolved ``base`` or ``roots`` folder. The file need not exist.

    Raises:
        UnsafePathError: naming ``uri``, when it is empty, looks like a URL (``file://``,
            ``http://``), resolves outside every allowed folder, or cannot be resolved
            (symlink loop).
    """
    if not uri or not uri.strip():
        raise UnsafePathError("empty file reference", reference=uri)
    if "://" in uri:
        raise UnsafePathError(f"{uri!r} is a URL, not a file path", reference=uri)
    given = Path(uri)
    resolved = real_path(given if given.is_absolute() else Path(base) / given)
    allowed = [real_path(base), *(real_path(r) for r in roots)]
    if not any(resolved.is_relative_to(folder) for folder in allowed):
        where = " or ".join(str(folder) for folder in allowed)
        raise UnsafePathError(
            f"{uri!r} resolves to {resolved}, outside {where}", reference=uri, resolved=str(resolved)
        )
    return resolved


_SPECIAL_KINDS = (
    (stat.S_ISDIR, "a directory"),
    (stat.S_ISFIFO, "a FIFO (named pipe)"),
    (stat.S_ISCHR, "a character device"),
    (stat.S_ISBLK, "a block device"),
    (stat.S_ISSOCK, "a socket"),
)


def not_a_regular_file(path: str | os.PathLike[str]) -> str | None:
    """What ``path`` is when it exists but is no regular file (``"a FIFO (named pipe)"``, ``"a
    character device"``...), found without opening it (opening a FIFO waits for a writer, reading
    ``/dev/zero`` never ends); ``None`` for a regular file or nothing at all. Symlinks are followed."""
    try:
        mode = os.stat(path).st_mode
    except (OSError, ValueError):
        return None
    if stat.S_ISREG(mode):
        return None
    return next((what for test, what in _SPECIAL_KINDS if test(mode)), "not a regular file")


def missing_file(path: str | os.PathLike[str]) -> str:
    """Why ``path``, which is no readable regular file, cannot be read, to follow "mesh file":
    ``"not found: P"``, or ``"P is a FIFO (named pipe), not a regular file"``."""
    special = not_a_regular_file(path)
    return f"not found: {path}" if special is None else f"{path} is {special}, not a regular file"


def write_atomic(target: str | os.PathLike[str], data: str | bytes) -> Path:
    """Write ``data`` (text is UTF-8) to ``target`` through a temporary file renamed over it.

    Readers see the old file or the new one, never half of either. The file gets the mode a
    plain ``open`` gives (``0666`` less the process umask), not the owner-only mode of
    ``tempfile.mkstemp``: scene files are meant to be shared. A symlink at ``target`` is
    replaced by the file, never written through. Returns ``target`` as a path.

    Raises:
        OutputSpaceError: the disk is full (or over quota); the temporary file is removed and
            whatever was at ``target`` before is still there.
    """
    path = Path(target)
    payload = data.encode("utf-8") if isinstance(data, str) else data
    tmp = path.with_name(f".{path.name}.{secrets.token_hex(6)}.tmp")
    try:
        # O_EXCL: never write through a file (or a symlink) someone else put at the temporary name
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_BINARY", 0), 0o666)
        try:
            with os.fdopen(fd, "wb") as fh:
                _write_all(fh, payload, tmp)
            os.replace(tmp, path)  # rename(2) replaces a symlink at ``path`` itself, not its target
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
    except OSError as exc:
        if _disk_full(exc):
            raise OutputSpaceError(str(path), exc.errno or errno.ENOSPC) from exc
        raise
    return path


def _write_all(fh: BinaryIO, payload: bytes, tmp: Path) -> None:
    """Write ``payload`` to the open temporary file ``tmp`` (one seam, so tests can fill the disk)."""
    fh.write(payload)


def _disk_full(exc: OSError) -> bool:
    """Whether ``exc`` says the disk is full or over quota."""
    return not isinstance(exc, OutputSpaceError) and exc.errno in (errno.ENOSPC, getattr(errno, "EDQUOT", errno.ENOSPC))
