"""Run stores: where node outputs are kept by (node name, input hash) so a run can resume.

A node's *input hash* is the SHA-256 of its name, its definition key, the output hashes of
its dependencies, the run's config key and (optionally) its cache policy's extra key. Outputs
are content-addressed by that hash, so a stored output is only reused when everything it was
computed from is the same.

Encoding (shared by hashing and :class:`FileRunStore`):

* a pydantic model -> its JSON (``model_dump_json``) plus the class's import path; read back
  with ``model_validate_json``, so the class must be importable at module level;
* a value that survives a JSON round trip unchanged (dicts with string keys, lists, strings,
  numbers, booleans, ``None``) -> canonical JSON;
* anything else -> pickle (its hash may differ between processes, which only costs a
  recomputation downstream).
"""

from __future__ import annotations

import abc
import base64
import hashlib
import importlib
import json
import os
import pickle
import shutil
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any
from urllib.parse import quote

import structlog
from pydantic import BaseModel

from scenemosaic.dag._graph import GraphFingerprint
from scenemosaic.exceptions import GraphChangedError

__all__ = [
    "FileRunStore",
    "GraphChangedError",
    "MemoryRunStore",
    "RunStore",
    "StoredOutput",
    "decode_output",
    "encode_output",
    "input_hash",
]

_log = structlog.get_logger(__name__)


@dataclass(frozen=True, slots=True)
class StoredOutput:
    """One stored node output."""

    output: Any
    """The node's output."""
    output_hash: str
    """Hash of the encoded output (what dependents' input hashes are built from)."""
    added_nodes: tuple[str, ...] = ()
    """Nodes the node added at run time; such a node is re-run on resume to rebuild them."""
    encoded: tuple[str, str, bytes] | None = field(default=None, compare=False, repr=False)
    """:func:`encode_output` of ``output`` when already made (:meth:`of`), so a store writes it
    without encoding the output a second time."""

    @classmethod
    def of(cls, output: Any, added_nodes: tuple[str, ...] = ()) -> StoredOutput:
        """The record of ``output``: encoded once, for its hash and for the store."""
        encoded = encode_output(output)
        return cls(output, _hash_encoded(*encoded), added_nodes, encoded)


def encode_output(value: Any) -> tuple[str, str, bytes]:
    """``(kind, type path, payload)`` of a node output; see the module docstring."""
    if isinstance(value, BaseModel):
        cls = type(value)
        return "pydantic", f"{cls.__module__}:{cls.__qualname__}", value.model_dump_json().encode()
    try:
        text = json.dumps(value, sort_keys=True, separators=(",", ":"), allow_nan=False)
        if json.loads(text) == value and _same_json_types(value):
            return "json", "", text.encode()
    except (TypeError, ValueError, RecursionError):
        pass
    return "pickle", "", pickle.dumps(value, protocol=pickle.HIGHEST_PROTOCOL)


def _same_json_types(value: Any) -> bool:
    """Whether JSON reproduces ``value`` with the same container types (no tuples, no subclasses)."""
    if value is None or type(value) in (str, int, float, bool):
        return True
    if type(value) is list:
        return all(_same_json_types(v) for v in value)
    if type(value) is dict:
        return all(type(k) is str and _same_json_types(v) for k, v in value.items())
    return False


def decode_output(kind: str, type_path: str, payload: bytes) -> Any:
    """Inverse of :func:`encode_output`."""
    if kind == "pydantic":
        module, _, qualname = type_path.partition(":")
        obj: Any = importlib.import_module(module)
        for part in qualname.split("."):
            obj = getattr(obj, part)
        return obj.model_validate_json(payload)
    if kind == "json":
        return json.loads(payload)
    if kind == "pickle":
        return pickle.loads(payload)
    raise ValueError(f"unknown stored output kind {kind!r}")


def output_hash(value: Any) -> str:
    """Content hash of a node output."""
    return _hash_encoded(*encode_output(value))


def _hash_encoded(kind: str, type_path: str, payload: bytes) -> str:
    h = hashlib.sha256(f"{kind}\x00{type_path}\x00".encode())
    h.update(payload)
    return h.hexdigest()


def input_hash(
    name: str, definition_key: str, dependency_hashes: dict[str, str], config_key: str, extra_key: str = ""
) -> str:
    """The input hash of a node (see the module docstring)."""
    payload = json.dumps(
        [name, definition_key, sorted(dependency_hashes.items()), config_key, extra_key],
        separators=(",", ":"),
    )
    return hashlib.sha256(payload.encode()).hexdigest()


class RunStore(abc.ABC):
    """Where node outputs and the graph fingerprint of a run are kept.

    Calls are synchronous and made from the event loop: keep them small (one file per node).
    """

    @abc.abstractmethod
    def get(self, node: str, input_hash: str) -> StoredOutput | None:
        """The stored output of ``node`` for ``input_hash``, or ``None``."""

    @abc.abstractmethod
    def put(self, node: str, input_hash: str, record: StoredOutput) -> None:
        """Store ``record`` for ``node`` under ``input_hash``."""

    @abc.abstractmethod
    def get_fingerprint(self) -> GraphFingerprint | None:
        """The fingerprint of the graph whose outputs this store holds, if any."""

    @abc.abstractmethod
    def set_fingerprint(self, fingerprint: GraphFingerprint) -> None:
        """Record the graph the following outputs belong to."""

    @abc.abstractmethod
    def scoped(self, name: str) -> RunStore:
        """A separate store for another graph of the same run (e.g. a plan, then the planned work).

        Each graph keeps its own fingerprint, so two graphs never look like one graph that changed.
        """

    @abc.abstractmethod
    def clear(self) -> None:
        """Forget every stored output and the fingerprint."""


class MemoryRunStore(RunStore):
    """A run store in a dict (outputs are kept as objects, not copied)."""

    def __init__(self) -> None:
        self._records: dict[tuple[str, str], StoredOutput] = {}
        self._fingerprint: GraphFingerprint | None = None
        self._scopes: dict[str, MemoryRunStore] = {}

    def get(self, node: str, input_hash: str) -> StoredOutput | None:
        return self._records.get((node, input_hash))

    def put(self, node: str, input_hash: str, record: StoredOutput) -> None:
        self._records[(node, input_hash)] = record

    def get_fingerprint(self) -> GraphFingerprint | None:
        return self._fingerprint

    def set_fingerprint(self, fingerprint: GraphFingerprint) -> None:
        self._fingerprint = fingerprint

    def clear(self) -> None:
        self._records.clear()
        self._fingerprint = None

    def scoped(self, name: str) -> MemoryRunStore:
        """A store for another graph of the same run (the same object for the same name)."""
        return self._scopes.setdefault(name, MemoryRunStore())

    def __len__(self) -> int:
        return len(self._records)


class FileRunStore(RunStore):
    """A run store in a directory; the default for resumable runs.

    Layout::

        <root>/graph.json                          the graph fingerprint
        <root>/nodes/<node>/<input hash>.json      one record per output

    A record is JSON: ``node``, ``input_hash``, ``output_hash``, ``added_nodes``, ``kind``
    (``pydantic`` | ``json`` | ``pickle``), ``type`` (import path of a pydantic class) and
    ``value`` (the JSON value; for pickles, base64 text). Files are written atomically.
    """

    def __init__(self, root: str | os.PathLike[str]) -> None:
        self.root = Path(root)
        """The store's directory (created on first write)."""

    def _record_path(self, node: str, input_hash: str) -> Path:
        return self.root / "nodes" / quote(node, safe="") / f"{input_hash}.json"

    def get(self, node: str, input_hash: str) -> StoredOutput | None:
        """The record's output, or ``None`` when there is none, or when it is damaged (truncated,
        not a record, a value its type no longer reads): the node then runs again, as on a miss."""
        path = self._record_path(node, input_hash)
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            return None
        except (OSError, ValueError, RecursionError) as exc:
            _damaged(path, exc)
            return None
        try:
            kind = data["kind"]
            payload = base64.b64decode(data["value"]) if kind == "pickle" else json.dumps(data["value"]).encode()
            return StoredOutput(
                output=decode_output(kind, data["type"], payload),
                output_hash=str(data["output_hash"]),
                added_nodes=tuple(data.get("added_nodes", ())),
            )
        except (KeyError, TypeError, ValueError, AttributeError, ImportError, RecursionError, pickle.UnpicklingError) as exc:
            _damaged(path, exc)
            return None

    def put(self, node: str, input_hash: str, record: StoredOutput) -> None:
        kind, type_path, payload = record.encoded or encode_output(record.output)
        value = json.dumps(base64.b64encode(payload).decode()) if kind == "pickle" else payload.decode()
        head = {
            "node": node,
            "input_hash": input_hash,
            "output_hash": record.output_hash,
            "added_nodes": list(record.added_nodes),
            "kind": kind,
            "type": type_path,
        }
        # the encoded value goes in as it is (it is JSON already; a run's state is megabytes, and
        # parsing it to write it again cost more than making it); keys keep their order, so a
        # pydantic value's free-form dicts (metadata) read back as they were
        text = json.dumps(head, indent=1)
        _write_atomic(self._record_path(node, input_hash), f'{text[:-2]},\n "value": {value}\n}}')

    def get_fingerprint(self) -> GraphFingerprint | None:
        try:
            data = json.loads((self.root / "graph.json").read_text(encoding="utf-8"))
        except FileNotFoundError:
            return None
        return GraphFingerprint.from_json(data)

    def set_fingerprint(self, fingerprint: GraphFingerprint) -> None:
        _write_atomic(self.root / "graph.json", json.dumps(fingerprint.to_json(), indent=1, sort_keys=True))

    def clear(self) -> None:
        shutil.rmtree(self.root / "nodes", ignore_errors=True)
        (self.root / "graph.json").unlink(missing_ok=True)

    def scoped(self, name: str) -> FileRunStore:
        """A store for another graph of the same run, in ``<root>/scopes/<name>``."""
        return FileRunStore(self.root / "scopes" / quote(name, safe=""))


def _damaged(path: Path, exc: BaseException) -> None:
    """A stored record that cannot be read counts as absent (its node runs again); said in the log."""
    _log.warning("run_store_record_damaged", path=str(path), error=f"{type(exc).__name__}: {str(exc)[:200]}")


def _write_atomic(path: Path, text: str) -> None:
    """The one atomic write (``scene.write_atomic``: a temporary name, then a rename; the
    ordinary file mode, not ``mkstemp``'s owner-only one), its folder made first."""
    from scenemosaic.scene import write_atomic  # the run store itself knows nothing of scenes

    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, text)
