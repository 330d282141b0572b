"""The files a mesh file names: glTF/GLB buffers and images, OBJ material libraries and their
textures, a PLY texture; and the declaration of its movable parts beside it
(``<mesh stem>.parts.json``, ``docs/articulation.md``). Each must lie inside the mesh file's own
folder.

The same list serves two places: :func:`~scenemosaic.assets.load_source_mesh` checks it before
trimesh reads anything, and ``save_scene`` copies it beside the mesh. Both therefore refuse the
same references, and a mesh that loads is a mesh that copies.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Any
from urllib.parse import unquote, urlsplit

from scenemosaic.exceptions import AssetError, UnsafePathError
from scenemosaic.scene import confined_path

__all__ = ["MESH_SUFFIXES", "PARTS_FILE_SUFFIX", "referenced_files"]

MESH_SUFFIXES = frozenset({".glb", ".gltf", ".obj", ".ply", ".stl", ".off"})
"""Mesh file types read. Others (URDF, COLLADA, 3MF...) are refused: they can name files we do not check."""
PARTS_FILE_SUFFIX = ".parts.json"
"""The suffix, in place of the mesh's own, of the file beside a mesh asset declaring its drawers,
doors and lids (``cabinet.glb`` -> ``cabinet.parts.json``)."""

_GLB_MAGIC = b"glTF"
_GLB_JSON_CHUNK = 0x4E4F534A  # "JSON", little-endian
_PLY_HEADER_BYTES = 65536  # a PLY header is a few hundred bytes; stop looking well after it
_MTL_MAPS = ("map_", "bump", "disp", "norm", "refl")


def referenced_files(mesh: Path) -> list[tuple[str, Path]]:
    """The files ``mesh`` references, as ``(reference as written, resolved path)``, in file order.

    ``data:`` uris (embedded buffers) are not files and are left out. Files need not exist
    (a missing texture is the caller's business).

    Raises:
        UnsafePathError: naming ``mesh`` and the reference, when one is absolute, is a URL,
            resolves (symlinks followed) outside the mesh's folder, or cannot be resolved.
        AssetError: when a glTF's JSON cannot be read.
    """
    folder = mesh.parent
    suffix = mesh.suffix.lower()
    found: dict[str, Path] = {}

    def add(reference: str) -> Path:
        if reference not in found:
            found[reference] = _confine(mesh, folder, reference)
        return found[reference]

    if suffix in (".gltf", ".glb"):
        doc = _gltf_json(mesh) if suffix == ".gltf" else _glb_json(mesh)
        for uri in _gltf_uris(doc):
            if uri.startswith("data:"):
                continue
            scheme = urlsplit(uri).scheme
            if len(scheme) > 1:  # one letter is a Windows drive, refused below as absolute
                raise UnsafePathError(f"{mesh}: references {uri!r}, a URL, not a file", reference=uri)
            add(uri)
            decoded = unquote(uri)  # what a reader that follows the glTF spec opens
            if decoded != uri:
                _confine(mesh, folder, decoded)
    elif suffix == ".obj":
        for library in _obj_libraries(mesh):
            path = add(library)
            if path.is_file():
                for texture, listed in _mtl_textures(path):
                    if listed:
                        add(texture)
                    else:
                        _confine(mesh, folder, texture)
    elif suffix == ".ply":
        ply_texture = _ply_texture(mesh)
        if ply_texture:
            add(ply_texture)
    if mesh.with_suffix(PARTS_FILE_SUFFIX).is_file():  # the parts it declares travel with it
        add(mesh.with_suffix(PARTS_FILE_SUFFIX).name)
    return list(found.items())


def _confine(mesh: Path, folder: Path, reference: str) -> Path:
    if Path(reference).is_absolute():
        raise UnsafePathError(
            f"{mesh}: references {reference!r} by absolute path; files beside a mesh are named relative to it",
            reference=reference,
        )
    try:
        return confined_path(folder, reference)
    except UnsafePathError as exc:
        raise UnsafePathError(f"{mesh}: references {exc}", reference=reference, resolved=exc.resolved) from exc


def _gltf_json(mesh: Path) -> Any:
    try:
        return json.loads(mesh.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise AssetError(f"{mesh}: cannot read glTF ({exc})") from exc


def _glb_json(mesh: Path) -> Any:
    """The JSON chunk of a binary glTF; ``{}`` when the file is no GLB (trimesh then says why)."""
    try:
        with mesh.open("rb") as fh:
            header = fh.read(20)
            if len(header) < 20 or header[:4] != _GLB_MAGIC:
                return {}
            length, kind = struct.unpack("<II", header[12:20])
            if kind != _GLB_JSON_CHUNK:
                return {}
            text = fh.read(length)
        return json.loads(text.decode("utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise AssetError(f"{mesh}: cannot read the JSON chunk of the GLB ({exc})") from exc


def _gltf_uris(doc: Any) -> list[str]:
    if not isinstance(doc, dict):
        return []
    uris: list[str] = []
    for key in ("buffers", "images"):
        entries = doc.get(key)
        for entry in entries if isinstance(entries, list) else []:
            uri = entry.get("uri") if isinstance(entry, dict) else None
            if isinstance(uri, str):
                uris.append(uri)
    return uris


def _obj_libraries(mesh: Path) -> list[str]:
    """Every ``mtllib`` an OBJ names. Any line holding the word counts (trimesh takes the first
    occurrence anywhere in the text, comments included), so this errs on the side of checking more."""
    out: list[str] = []
    for line in mesh.read_text(encoding="utf-8", errors="replace").splitlines():
        at = line.find("mtllib")
        if at < 0:
            continue
        name = line[at + len("mtllib") :].strip()
        if name and not line.lstrip().startswith("#"):
            out.append(name)
        elif name:
            # a commented-out library is still what trimesh may open: check it, do not require it
            _confine(mesh, mesh.parent, name)
    return out


def _mtl_textures(mtl: Path) -> list[tuple[str, bool]]:
    """Texture names in a material library, each with whether it is a file to copy (``True``) or
    only a reading to check (``False``)."""
    out: list[tuple[str, bool]] = []
    for line in mtl.read_text(encoding="utf-8", errors="replace").splitlines():
        tokens = line.strip().split()
        if len(tokens) < 2 or not tokens[0].lower().startswith(_MTL_MAPS):
            continue
        out.append((tokens[-1], True))  # options come first: the file name is the last token
        whole = line.strip()[len(tokens[0]) :].strip()
        if whole != tokens[-1]:
            out.append((whole, False))  # trimesh reads the whole rest of the line (names with spaces)
    return out


def _ply_texture(mesh: Path) -> str | None:
    with mesh.open("rb") as fh:
        head = fh.read(_PLY_HEADER_BYTES)
    end = head.find(b"end_header")
    text = head[: end if end >= 0 else len(head)].decode("utf-8", errors="replace")
    for line in text.splitlines():
        at = line.lower().find("texturefile")
        if at >= 0:
            return line[at + len("texturefile") :].strip() or None
    return None
