"""Native scene folders: ``scene.json`` plus an ``assets/`` folder of mesh files.

A native scene folder looks like::

    my_scene/
      scene.json                      Scene.to_json(), uris relative to my_scene/
      assets/
        <stem>-<hash12>/              one folder per distinct mesh file
          <file>.gltf                 the mesh file, byte for byte
          gltf_buffer_0.bin ...       the files it references (buffers, textures, .mtl)

Mesh files are copied **as they are** (not converted): the asset keeps its
``source_transform`` (source file -> canonical frame) and its ``sha256``, so nothing has to be
re-derived and the copy is lossless. ``<hash12>`` is the first 12 hex digits of the SHA-256 of
the mesh file's bytes, so two objects sharing a mesh share one copy and saving the same scene
twice gives the same layout and byte-identical JSON.

A ``scene.json`` is untrusted input: reading it checks that every mesh uri names a non-empty
file inside the scene's folder (or an explicitly allowed root), symlinks followed; saving
checks again that every file copied lies where it may (see ``docs/importers.md``).
"""

from __future__ import annotations

import hashlib
import json
import os
import re
from collections.abc import Sequence
from pathlib import Path, PurePosixPath
from typing import Any

import structlog
from pydantic import ValidationError

from scenemosaic.exceptions import (
    AssetError,
    ImportFormatError,
    PartialResultError,
    SceneValidationError,
    UnsafePathError,
)
from scenemosaic.exchange._common import FieldReader, read_json
from scenemosaic.scene import (
    House,
    Provenance,
    RunFolder,
    Scene,
    SceneObject,
    confined_path,
    missing_file,
    real_path,
    safe_name,
    write_atomic,
)

__all__ = [
    "ASSETS_DIR",
    "HOUSE_FORMAT",
    "SCENE_FILE",
    "check_not_partial",
    "read_house",
    "read_scene",
    "save_house",
    "save_scene",
]

log = structlog.get_logger(__name__)

SCENE_FILE = "scene.json"
"""Name of the scene file inside a native scene folder."""
ASSETS_DIR = "assets"
"""Name of the folder (inside a native scene folder) that holds the copied mesh files."""

_HASH_CHARS = 12
HOUSE_FORMAT = "scenemosaic-house"
"""The ``format`` a native house index (``house_scene.json``) declares."""


def save_scene(
    scene: Scene, folder: str | os.PathLike[str], *, base_dir: str | os.PathLike[str] | None = None
) -> Path:
    """Write ``scene`` as a native scene folder and return the path of its ``scene.json``.

    Every ``kind == "mesh"`` asset file (with the buffers, textures and material files it
    references) is copied into ``folder/assets/<stem>-<hash12>/`` and its uri rewritten
    relative to ``folder``. Relative uris in ``scene`` are resolved against ``base_dir``
    (default: the current directory) and must stay inside it, symlinks followed; absolute uris
    are used as they are (the reader that made them checked them). The files a mesh references
    must lie in the mesh's folder. The input scene is not modified. Files are written with the
    mode a plain ``open`` gives (``0644`` under the usual umask).

    Raises:
        AssetError: naming the object, for a missing, empty or directory mesh file or a
            missing side file; :class:`~scenemosaic.exceptions.UnsafePathError` (an
            ``AssetError``) for a file outside where it may be.
    """
    out = Path(folder)
    out.mkdir(parents=True, exist_ok=True)
    base = Path(base_dir) if base_dir is not None else Path.cwd()
    copied: dict[Path, str] = {}
    objects: list[SceneObject] = []
    for obj in scene.objects:
        if obj.asset.kind != "mesh" or obj.asset.uri is None:
            objects.append(obj)
            continue
        src = _mesh_source(obj.asset.uri, base, obj.id)
        if src not in copied:
            copied[src] = copy_mesh(src, out, obj.id)
        asset = obj.asset.model_copy(update={"uri": copied[src]})
        objects.append(obj.model_copy(update={"asset": asset}))
    saved = scene.model_copy(update={"objects": objects})
    target = out / SCENE_FILE
    write_atomic(target, saved.to_json() + "\n")
    log.debug("scene_saved", path=str(target), objects=len(objects), meshes=len(copied))
    return target


def check_not_partial(folder: Path) -> None:
    """Raise :class:`~scenemosaic.exceptions.PartialResultError` when ``folder`` holds what a
    failed or stopped run kept (``partial.json`` beside its scene)."""
    marker = folder / RunFolder.PARTIAL
    if marker.is_file():
        data = read_json(marker)
        raise PartialResultError(str(folder), data if isinstance(data, dict) else {})


def read_scene(
    path: str | os.PathLike[str], *, roots: Sequence[str | os.PathLike[str]] = (), allow_partial: bool = False
) -> Scene:
    """Read a scene from a ``scene.json`` file or from a folder holding one.

    Malformed JSON raises :class:`~scenemosaic.exceptions.ImportFormatError` naming the file;
    a document that breaks the scene model (limits included) raises
    :class:`~scenemosaic.exceptions.SceneValidationError` naming the file, the offending
    object's id and the field. Every mesh uri must name a non-empty file inside the scene's
    folder or one of ``roots``, symlinks followed (an absolute uri too); otherwise an
    ``ImportFormatError`` names the file, the object and the field (``objects[3].asset.uri``).
    Mesh uris stay as stored (relative to the scene folder). The partial result of a failed or
    stopped run raises :class:`~scenemosaic.exceptions.PartialResultError` unless ``allow_partial``.
    """
    p = Path(path)
    file = p / SCENE_FILE if p.is_dir() else p
    if not allow_partial:
        check_not_partial(file.parent)
    if not file.is_file():
        where = f"no {SCENE_FILE} in folder" if p.is_dir() else "file not found"
        raise ImportFormatError(where, path=str(p))
    data = read_json(file)
    return scene_from_data(data, source=str(file), roots=roots)


def scene_from_data(data: Any, *, source: str, roots: Sequence[str | os.PathLike[str]] = ()) -> Scene:
    """Validate already-parsed JSON data read from the file ``source`` as a :class:`Scene`.

    Errors name ``source``, the object id and the field. Mesh uris are checked as
    :func:`read_scene` says, against the folder of ``source`` and ``roots``.
    """
    if not isinstance(data, dict):
        raise ImportFormatError(
            f"expected a JSON object at the top level, got {type(data).__name__}", path=source
        )
    data = _typed_source_facts(data)
    try:
        scene = Scene.model_validate(data)
    except ValidationError as exc:
        raise _scene_validation_error(exc, data, source) from exc
    except SceneValidationError as exc:
        raise SceneValidationError(f"{source}: {exc}", object_id=exc.object_id) from exc
    _check_mesh_files(scene, Path(source), [Path(r) for r in roots])
    return scene


def _check_mesh_files(scene: Scene, source: Path, roots: list[Path]) -> None:
    """Every mesh uri names a non-empty regular file inside the scene's folder or ``roots``."""
    r = FieldReader(source)
    for i, obj in enumerate(scene.objects):
        if obj.asset.kind != "mesh" or obj.asset.uri is None:
            continue
        field = f"objects[{i}].asset.uri"
        what = f"object {obj.id!r}"
        path = r.file(source.parent, obj.asset.uri, field, roots=roots, what=what)
        if path.is_dir():
            r.fail(field, f"{what}: {obj.asset.uri!r} is a directory, not a mesh file")
        if not path.is_file():
            r.fail(field, f"{what}: mesh file {missing_file(path)}")
        if path.stat().st_size == 0:
            r.fail(field, f"{what}: mesh file {path} is empty (0 bytes)")


# -- helpers --------------------------------------------------------------------------------------


_SOURCE_FACTS = {"room_id": "source_room_id", "room_type": "room_type", "source_ids": "source_ids",
                 "asset_ids": "asset_ids", "asset_database": "asset_database", "import_warnings": "import_warnings"}  # fmt: skip
"""Where a scene file written before the readers filled the typed source facts
(``Provenance.room_type``...) kept them: ``metadata["procthor"]`` / ``metadata["holodeck"]``."""


def _typed_source_facts(data: dict[str, Any]) -> dict[str, Any]:
    """``data`` with an older file's source facts moved from its format's metadata into the typed
    provenance fields (a run delivered before, read back or resumed from); a current file as it is."""
    metadata = data.get("metadata")
    if not isinstance(metadata, dict) or not any(isinstance(metadata.get(k), dict) for k in ("procthor", "holodeck")):
        return data
    provenance = dict(data.get("provenance") or {})
    metadata = dict(metadata)
    for key in ("procthor", "holodeck"):
        old = metadata.get(key)
        if not isinstance(old, dict):
            continue
        rest = {k: v for k, v in old.items() if k not in _SOURCE_FACTS}
        for name, field in _SOURCE_FACTS.items():
            value = old.get(name)
            if value is None or provenance.get(field) not in (None, {}, []):
                continue
            if field in ("source_ids", "asset_ids") and isinstance(value, dict):
                value = {str(k): str(v) for k, v in value.items()}
            provenance[field] = str(value) if field == "source_room_id" else value
        if rest:
            metadata[key] = rest
        else:
            del metadata[key]
    return {**data, "metadata": metadata, "provenance": provenance}


def _scene_validation_error(exc: ValidationError, data: dict[str, Any], source: str) -> SceneValidationError:
    """Turn pydantic's errors into one message whose locations name object ids instead of indices."""
    parts: list[str] = []
    first_id: str | None = None
    for err in exc.errors():
        where, object_id = _describe_location(err["loc"], data)
        if first_id is None and object_id is not None:
            first_id = object_id
        message = str(err["msg"])
        if object_id is not None:  # the object's own validator names it; the location already does
            message = message.replace(f"Value error, object {object_id!r}: ", "Value error, ", 1)
        parts.append(f"{where}: {message}")
    count = len(parts)
    plural = "s" if count != 1 else ""
    return SceneValidationError(
        f"{source}: {count} validation error{plural}: " + "; ".join(parts), object_id=first_id
    )


def _describe_location(loc: tuple[int | str, ...], data: dict[str, Any]) -> tuple[str, str | None]:
    """``('objects', 3, 'pose', 'position')`` -> ``("object 'chair_1' (objects[3]) field pose.position", 'chair_1')``."""
    if len(loc) >= 2 and loc[0] in ("objects", "relations") and isinstance(loc[1], int):
        items = data.get(str(loc[0]))
        item = items[loc[1]] if isinstance(items, list) and 0 <= loc[1] < len(items) else None
        key = "id" if loc[0] == "objects" else "child"
        ident = item.get(key) if isinstance(item, dict) else None
        rest = _dotted(loc[2:])
        kind = "object" if loc[0] == "objects" else "relation of object"
        label = f"{kind} {ident!r} ({loc[0]}[{loc[1]}])" if isinstance(ident, str) else f"{loc[0]}[{loc[1]}]"
        return (f"{label} field {rest}" if rest else label), (ident if isinstance(ident, str) else None)
    return f"field {_dotted(loc) or '<root>'}", None


def _dotted(loc: tuple[int | str, ...]) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out


def _mesh_source(uri: str, base: Path, object_id: str) -> Path:
    """The mesh file an object's uri names (see :func:`save_scene` for the rule)."""
    try:
        return confined_path(base, uri) if not Path(uri).is_absolute() else real_path(uri)
    except UnsafePathError as exc:
        raise UnsafePathError(f"object {object_id!r}: mesh uri {exc}", reference=uri, resolved=exc.resolved) from exc


def copy_mesh(src: Path, folder: Path, object_id: str, subfolder: str = ASSETS_DIR) -> str:
    """Copy a mesh file and its side files under ``folder/<subfolder>``; return the new relative uri.

    ``src`` is resolved. Side files must lie in its folder; every file written must land in the
    copy's own folder (a symlink planted in the destination does not redirect a copy).
    """
    # imported here: the assets package loads trimesh, and reading a scene needs none of it
    from scenemosaic.assets import referenced_files

    if src.is_dir():
        raise AssetError(f"object {object_id!r}: mesh uri names a directory, not a file: {src}")
    if not src.is_file():
        raise AssetError(f"object {object_id!r}: mesh file {missing_file(src)}")
    if src.stat().st_size == 0:
        raise AssetError(f"object {object_id!r}: mesh file is empty (0 bytes): {src}")
    try:
        side_files = referenced_files(src)
    except UnsafePathError as exc:
        raise UnsafePathError(f"object {object_id!r}: {exc}", reference=exc.reference, resolved=exc.resolved) from exc
    except AssetError as exc:
        raise AssetError(f"object {object_id!r}: {exc}") from exc
    digest = hashlib.sha256(src.read_bytes()).hexdigest()[:_HASH_CHARS]
    stem = re.sub(r"[^A-Za-z0-9_.\-]", "_", src.stem)[:40] or "mesh"
    rel_dir = Path(subfolder) / f"{stem}-{digest}"
    dest_dir = folder / rel_dir
    for rel, from_path in [(src.name, src), *side_files]:
        if not from_path.is_file():
            raise AssetError(f"object {object_id!r}: mesh {src} references missing file {rel!r}")
        to_path = confined_path(dest_dir, rel)
        if to_path == from_path:
            continue  # saving a scene into the folder it was read from
        to_path.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(to_path, from_path.read_bytes())  # never through a symlink planted at ``to_path``
    return (rel_dir / src.name).as_posix()


# -- houses ----------------------------------------------------------------------------------------


def save_house(house: House, folder: str | os.PathLike[str], *, base_dir: str | os.PathLike[str] | None = None) -> Path:
    """Write ``house`` as a native house folder: ``house_scene.json`` (its id, room order, metadata
    and provenance) and one native scene folder per room, ``rooms/<room id>/``; returns the index."""
    root = Path(folder)
    for scene in house.rooms:
        save_scene(scene, root / RunFolder.ROOMS / safe_name(scene.id), base_dir=base_dir)
    index = {
        "format": HOUSE_FORMAT,
        "version": 1,
        "id": house.id,
        "rooms": house.room_ids,
        "metadata": house.metadata,
        "provenance": house.provenance.model_dump(mode="json"),
    }
    target = root / RunFolder.HOUSE_FILE
    write_atomic(target, json.dumps(index, indent=2, ensure_ascii=False) + "\n")
    return target


def read_house(path: str | os.PathLike[str], *, allow_partial: bool = False) -> House:
    """Read a native house folder (or its ``house_scene.json``): every room's scene, in the index's
    order. The rooms' files are checked as :func:`read_scene` checks a scene's; their relative mesh
    uris are made relative to the house folder (one folder resolves every room's meshes). The
    partial result of a failed or stopped run raises
    :class:`~scenemosaic.exceptions.PartialResultError` unless ``allow_partial``."""
    p = Path(path)
    file = p / RunFolder.HOUSE_FILE if p.is_dir() else p
    if not allow_partial:
        check_not_partial(file.parent)
    r = FieldReader(file)
    data = read_json(file)
    top = r.mapping(data, "")
    if top.get("format") != HOUSE_FORMAT:
        r.fail("format", f"expected {HOUSE_FORMAT!r}, got {top.get('format')!r}")
    ids = r.array(r.get(top, "rooms", ""), "rooms")
    rooms = [_rooted(read_scene(file.parent / RunFolder.ROOMS / safe_name(r.text(rid, f"rooms[{i}]")))) for i, rid in enumerate(ids)]
    try:
        return House(
            id=str(top.get("id") or "house"),
            rooms=rooms,
            metadata=dict(r.mapping(top.get("metadata") or {}, "metadata")),
            provenance=Provenance.model_validate(top.get("provenance") or {}),
        )
    except ValidationError as exc:
        raise ImportFormatError(f"not a valid house: {exc.errors()[0]['msg']}", path=str(file)) from exc


def _rooted(scene: Scene) -> Scene:
    """A room read from ``rooms/<room id>/`` with its relative mesh uris made relative to the house
    folder two levels up."""
    prefix = PurePosixPath(RunFolder.ROOMS, safe_name(scene.id))
    objects = []
    for obj in scene.objects:
        uri = obj.asset.uri
        if obj.asset.kind == "mesh" and uri is not None and not Path(uri).is_absolute():
            obj = obj.model_copy(update={"asset": obj.asset.model_copy(update={"uri": str(prefix / uri)})})
        objects.append(obj)
    return scene.model_copy(update={"objects": objects})
