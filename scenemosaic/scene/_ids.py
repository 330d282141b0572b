"""Object ids: the alphabet, and the one mapping from any text into it.

Every importer turns the ids of its files into ours with :func:`sanitize_id` and
:func:`unique_id`; nothing else in the library rewrites ids.
"""

from __future__ import annotations

import hashlib
import re
import unicodedata

__all__ = ["CEILING", "FLOOR", "ID_HASH_CHARS", "MAX_ID_LENGTH", "OBJECT_ID_PATTERN", "sanitize_id", "unique_id"]

FLOOR = "floor"
"""Anchor id of the floor."""
CEILING = "ceiling"
"""Anchor id of the ceiling."""

OBJECT_ID_PATTERN = r"^[A-Za-z0-9_.\-]+$"
"""What an object (or room, wall, scene) id may contain."""
MAX_ID_LENGTH = 64
"""Longest id, in characters."""
ID_HASH_CHARS = 6
"""Hex digits of the SHA-256 of the original text appended to an id that lost characters."""

_ID_RE = re.compile(OBJECT_ID_PATTERN)
_KEPT = re.compile(r"[A-Za-z0-9_.\-]")
_OUTSIDE = re.compile(r"[^A-Za-z0-9_.\-]+")
# Separators the source formats themselves use inside ids (ProcTHOR's ``Bed|2|0``, Holodeck's
# ``throw pillow-0|sofa-0``): they become ``_`` without a hash so those ids stay readable and
# stable. Two ids differing only there still get distinct ids from ``unique_id``.
_SEPARATORS = re.compile(r"[\s|]")
_UNDERSCORES = re.compile(r"_{2,}")
_RESERVED = (FLOOR, CEILING)
_WALL_ID = re.compile(r"wall_\d+")


def _transliterate(char: str) -> str:
    """The ASCII letters a character decomposes to (``é`` -> ``e``, ``ﬁ`` -> ``fi``), or ``""``."""
    decomposed = unicodedata.normalize("NFKD", char)
    return "".join(c for c in decomposed if c.isascii() and _KEPT.match(c))


def sanitize_id(raw: str, *, fallback: str = "object") -> str:
    """Map any text into the id alphabet (``[A-Za-z0-9_.-]``, at most :data:`MAX_ID_LENGTH` characters).

    Text already in the alphabet is kept as it is. Otherwise whitespace and ``|`` become ``_``,
    accented letters lose their accents (``café`` -> ``cafe``), and when any other character
    had to go (punctuation, CJK, emoji) a short hash of the original text is appended, so that
    ids differing only there stay distinct and the same text always gives the same id:
    ``mug!`` -> ``mug_<hash>``, ``椅子`` -> ``object_<hash>`` (``fallback`` names what is left
    of an id that had nothing transliterable).
    """
    if _ID_RE.match(raw) and len(raw) <= MAX_ID_LENGTH:
        return raw
    lost = False

    def replace(run: re.Match[str]) -> str:
        nonlocal lost
        out: list[str] = []
        for char in run.group():
            ascii_form = _transliterate(char)
            if ascii_form:
                out.append(ascii_form)
            else:
                out.append("_")
                lost = lost or not _SEPARATORS.match(char)
        return _UNDERSCORES.sub("_", "".join(out))

    # a run of characters outside the alphabet becomes at most one "_" (as ids always did here)
    cleaned = _OUTSIDE.sub(replace, raw).strip("_") or fallback
    if not lost:
        return cleaned[:MAX_ID_LENGTH]
    suffix = "_" + hashlib.sha256(raw.encode("utf-8")).hexdigest()[:ID_HASH_CHARS]
    return cleaned[: MAX_ID_LENGTH - len(suffix)] + suffix


def unique_id(candidate: str, taken: set[str]) -> str:
    """``candidate``, or ``candidate_2``, ``_3``...: the first not in ``taken`` nor an anchor id; adds it to ``taken``."""
    out = candidate
    n = 2
    while out in taken or out in _RESERVED or _WALL_ID.fullmatch(out):
        suffix = f"_{n}"
        out = candidate[: MAX_ID_LENGTH - len(suffix)] + suffix
        n += 1
    taken.add(out)
    return out
