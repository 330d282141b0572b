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

This module belongs to the ``scene`` layer: it copies files but never parses a mesh.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import tempfile
from pathlib import Path
from typing import Any

import structlog
from pydantic import ValidationError

from scenemosaic.exceptions import AssetError, ImportFormatError, SceneValidationError
from scenemosaic.scene import Scene, SceneObject

__all__ = ["ASSETS_DIR", "SCENE_FILE", "read_scene", "save_scene"]

log = structlog.get_logger(__name__)

SCENE_FILE = "scene.json"
"""Name of the scene file inside a native scene folder."""
ASSETS_DIR = "assets"
"""Name of the folder (inside a native scene folder) that holds the copied mesh files."""

_HASH_CHARS = 12


def save_scene(
    scene: Scene, folder: str | os.PathLike[str], *, base_dir: str | os.PathLike[str] | None = None
) -> Path:
    """Write ``scene`` as a native scene folder and return the path of its ``scene.json``.

    Every ``kind == "mesh"`` asset file (with the buffers, textures and material files it
    references) is copied into ``folder/assets/<stem>-<hash12>/`` and its uri rewritten
    relative to ``folder``. Relative uris in ``scene`` are resolved against ``base_dir``
    (default: the current directory); absolute uris are used as they are. The input scene is
    not modified. A missing mesh file raises :class:`~scenemosaic.exceptions.AssetError`.
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
        src = Path(obj.asset.uri)
        if not src.is_absolute():
            src = base / src
        src = src.resolve()
        if src not in copied:
            copied[src] = _copy_mesh(src, out, obj.id)
        asset = obj.asset.model_copy(update={"uri": copied[src]})
        objects.append(obj.model_copy(update={"asset": asset}))
    saved = scene.model_copy(update={"objects": objects})
    target = out / SCENE_FILE
    _write_atomic(target, saved.to_json() + "\n")
    log.debug("scene_saved", path=str(target), objects=len(objects), meshes=len(copied))
    return target


def read_scene(path: str | os.PathLike[str]) -> Scene:
    """Read a scene from a ``scene.json`` file or from a folder holding one.

    Malformed JSON raises :class:`~scenemosaic.exceptions.ImportFormatError` naming the file;
    a document that breaks the scene model raises
    :class:`~scenemosaic.exceptions.SceneValidationError` naming the file, the offending
    object's id and the field. Mesh uris stay as stored (relative to the scene folder).
    """
    p = Path(path)
    file = p / SCENE_FILE if p.is_dir() else p
    if not file.is_file():
        where = f"no {SCENE_FILE} in folder" if p.is_dir() else "file not found"
        raise ImportFormatError(where, path=str(p))
    try:
        data = json.loads(file.read_text(encoding="utf-8"))
    except UnicodeDecodeError as exc:
        raise ImportFormatError(f"not UTF-8 text ({exc.reason})", path=str(file)) from exc
    except json.JSONDecodeError as exc:
        raise ImportFormatError(
            f"invalid JSON at line {exc.lineno} column {exc.colno}: {exc.msg}", path=str(file)
        ) from exc
    return scene_from_data(data, source=str(file))


def scene_from_data(data: Any, *, source: str) -> Scene:
    """Validate already-parsed JSON data as a :class:`Scene`; errors name ``source``, object id and field."""
    if not isinstance(data, dict):
        raise ImportFormatError(
            f"expected a JSON object at the top level, got {type(data).__name__}", path=source
        )
    try:
        return Scene.model_validate(data)
    except ValidationError as exc:
        raise _scene_validation_error(exc, data, source) from exc
    except SceneValidationError as exc:
        raise SceneValidationError(f"{source}: {exc}", object_id=exc.object_id) from exc


# -- helpers --------------------------------------------------------------------------------------


def _scene_validation_error(exc: ValidationError, data: dict[str, Any], source: str) -> SceneValidationError:
    """Turn pydantic's errors into one message whose locations name object ids instead of indices."""
    parts: list[str] = []
    first_id: str | None = None
    for err in exc.errors():
        where, object_id = _describe_location(err["loc"], data)
        if first_id is None and object_id is not None:
            first_id = object_id
        parts.append(f"{where}: {err['msg']}")
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


def _copy_mesh(src: Path, folder: Path, object_id: str) -> str:
    """Copy a mesh file and its side files under ``folder/assets``; return the new relative uri."""
    if not src.is_file():
        raise AssetError(f"object {object_id!r}: mesh file not found: {src}")
    digest = hashlib.sha256(src.read_bytes()).hexdigest()[:_HASH_CHARS]
    stem = re.sub(r"[^A-Za-z0-9_.\-]", "_", src.stem)[:40] or "mesh"
    rel_dir = Path(ASSETS_DIR) / f"{stem}-{digest}"
    dest_dir = folder / rel_dir
    for rel in [src.name, *_side_files(src)]:
        from_path = (src.parent / rel).resolve()
        if not from_path.is_relative_to(src.parent.resolve()):
            raise AssetError(f"object {object_id!r}: mesh {src} references {rel!r} outside its folder")
        if not from_path.is_file():
            raise AssetError(f"object {object_id!r}: mesh {src} references missing file {rel!r}")
        to_path = dest_dir / rel
        if to_path.resolve() == from_path:
            continue  # saving a scene into the folder it was read from
        to_path.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(from_path, to_path)
    return (rel_dir / src.name).as_posix()


def _side_files(mesh: Path) -> list[str]:
    """Relative paths of the files a mesh file references (glTF buffers/images, OBJ materials/textures)."""
    suffix = mesh.suffix.lower()
    if suffix == ".gltf":
        try:
            doc = json.loads(mesh.read_text(encoding="utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise AssetError(f"cannot read glTF {mesh}: {exc}") from exc
        uris = [
            entry.get("uri")
            for key in ("buffers", "images")
            for entry in (doc.get(key) or [])
            if isinstance(entry, dict)
        ]
        return sorted({u for u in uris if isinstance(u, str) and not u.startswith("data:")})
    if suffix == ".obj":
        files: set[str] = set()
        for line in mesh.read_text(encoding="utf-8", errors="replace").splitlines():
            if line.startswith("mtllib "):
                mtl = line.split(maxsplit=1)[1].strip()
                files.add(mtl)
                mtl_path = mesh.parent / mtl
                if mtl_path.is_file():
                    for mline in mtl_path.read_text(encoding="utf-8", errors="replace").splitlines():
                        token = mline.strip().split()
                        if (
                            token
                            and token[0].lower().startswith(("map_", "bump", "disp", "norm"))
                            and len(token) > 1
                        ):
                            files.add(token[-1])
        return sorted(files)
    return []


def _write_atomic(target: Path, text: str) -> None:
    fd, tmp = tempfile.mkstemp(dir=target.parent, prefix=".scene-", suffix=".json.tmp")
    try:
        with os.fdopen(fd, "w", encoding="utf-8", newline="\n") as fh:
            fh.write(text)
        os.replace(tmp, target)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
