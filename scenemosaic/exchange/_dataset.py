"""Datasets of houses: a ``.jsonl`` or ``.jsonl.gz`` file holding one house a line.

ProcTHOR-10k, ProcTHOR-100k and the Objaverse houses are shipped this way. Such a file is an
input wherever a house file is, with the house's index (0-based, counting the lines that hold
anything): ``load_scene(path, index=3)``, ``generate FILE --index 3``, a batch over the whole file
or a range of it (``docs/batch.md``). Lines are read one at a time as the file is streamed, so a
file of 100,000 houses is never held in memory; reaching house N reads the N lines before it.
"""

from __future__ import annotations

import gzip
import hashlib
import io
import os
import zlib
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from scenemosaic._memo import Memo
from scenemosaic.exceptions import ImportFormatError, UsageError
from scenemosaic.exchange._common import parse_json

__all__ = [
    "DATASET_SUFFIXES",
    "DatasetEntry",
    "dataset_entries",
    "dataset_entry",
    "dataset_size",
    "dataset_stem",
    "is_dataset",
]

DATASET_SUFFIXES = (".jsonl", ".jsonl.gz")
"""The names of a dataset file: JSON lines, plain or gzip-compressed."""


def is_dataset(path: str | os.PathLike[str]) -> bool:
    """Whether ``path`` names a dataset file (by its suffix, :data:`DATASET_SUFFIXES`)."""
    return Path(path).name.lower().endswith(DATASET_SUFFIXES)


def dataset_stem(path: str | os.PathLike[str]) -> str:
    """The file's name without its dataset suffix (``procthor-10k-val`` of ``procthor-10k-val.jsonl.gz``)."""
    name = Path(path).name
    for suffix in sorted(DATASET_SUFFIXES, key=len, reverse=True):
        if name.lower().endswith(suffix):
            return name[: -len(suffix)] or name
    return Path(path).stem


class DatasetEntry:
    """One house of a dataset: its index, the line it is on (1-based) and the line's text."""

    __slots__ = ("index", "line", "text")

    def __init__(self, index: int, line: int, text: str) -> None:
        self.index = index
        self.line = line
        self.text = text

    def parse(self, path: Path) -> Any:
        """The line's JSON; malformed text raises ``ImportFormatError`` naming the file, house and line."""
        return parse_json(self.text, Path(f"{path}, house {self.index} (line {self.line})"))

    @property
    def digest(self) -> str:
        """SHA-256 of the line's text: what a run of this house depends on (not the whole file)."""
        return hashlib.sha256(self.text.encode("utf-8")).hexdigest()


def _open(path: Path) -> io.TextIOBase:
    try:
        if path.name.lower().endswith(".gz"):
            return io.TextIOWrapper(gzip.open(path, "rb"), encoding="utf-8")
        return open(path, encoding="utf-8")
    except FileNotFoundError as exc:
        raise ImportFormatError("file not found", path=str(path)) from exc
    except OSError as exc:
        raise ImportFormatError(f"cannot read: {exc.strerror}", path=str(path)) from exc


def dataset_entries(path: str | os.PathLike[str]) -> Iterator[DatasetEntry]:
    """The houses of a dataset, in file order, read lazily (blank lines skipped, not counted).
    An unreadable or corrupt file raises ``ImportFormatError`` naming it."""
    p = Path(path)
    index = 0
    with _open(p) as handle:
        try:
            for number, text in enumerate(handle, start=1):
                if text.strip():
                    yield DatasetEntry(index, number, text)
                    index += 1
        except (OSError, EOFError, zlib.error, UnicodeDecodeError) as exc:
            raise ImportFormatError(f"cannot read the dataset after house {index}: {exc}", path=str(p)) from exc


_ENTRIES: Memo[tuple[str, int, int, int], DatasetEntry] = Memo(8)
"""The houses read lately, by the file (its path, modification time and size) and the index: a run
asks for its house several times (is it a house, its checkpoint digest, the import), and each
time would stream the file up to it."""


def dataset_entry(path: str | os.PathLike[str], index: int) -> DatasetEntry:
    """House ``index`` (0-based) of a dataset; an index past its end raises ``UsageError`` saying how many it holds."""
    if index < 0:
        raise UsageError(f"index {index}: a house's index in a dataset counts from 0")
    p = Path(path)
    try:
        stat = p.stat()
    except OSError:
        return _find_entry(p, index)  # the reader names what is wrong with the file
    return _ENTRIES.get((str(p.resolve()), stat.st_mtime_ns, stat.st_size, index), lambda: _find_entry(p, index))


def _find_entry(path: Path, index: int) -> DatasetEntry:
    count = 0
    for entry in dataset_entries(path):
        if entry.index == index:
            return entry
        count += 1
    raise UsageError(f"{os.fspath(path)} holds {count} houses (indices 0 to {count - 1}); there is no house {index}")


def dataset_size(path: str | os.PathLike[str]) -> int:
    """How many houses a dataset holds (the file is streamed once)."""
    return sum(1 for _ in dataset_entries(path))
