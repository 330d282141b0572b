"""The format registry: every reader and writer behind one table, and ``load_scene`` over it.

A format is one module plus one :func:`register_format` call: a :class:`SceneFormat` names a
content test and a reader (for inputs), a writer (for outputs), or both. ``load_scenes`` picks
the reader by name or by content (:func:`detect_format`); the pipeline writes every delivered
format through :func:`write_scene`. Detection tries the registered readers in registration order
(more specific formats first), so a plugin format registered later never shadows a built-in one.
A format that can write a whole :class:`~scenemosaic.scene.House` as one world says so
(``writes_houses``): its one writer takes a room's scene or a house, as :func:`write_scene` does.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

import structlog

from scenemosaic.exceptions import ImportFormatError, SceneMosaicError, UsageError
from scenemosaic.exchange._common import read_json
from scenemosaic.exchange._dataset import (
    dataset_entries,
    dataset_entry,
    dataset_size,
    dataset_stem,
    is_dataset,
)
from scenemosaic.exchange._native import check_not_partial, read_house
from scenemosaic.scene import House, Provenance, Room, RunFolder, Scene, safe_name

if TYPE_CHECKING:
    from scenemosaic.assets import HullCache

__all__ = [
    "FORMATS",
    "ImportFormat",
    "ReadOptions",
    "SceneFormat",
    "detect_format",
    "get_format",
    "house_formats",
    "is_house_source",
    "load_house",
    "load_scene",
    "load_scenes",
    "plugin_formats",
    "register_format",
    "writable_formats",
    "write_scene",
]

log = structlog.get_logger(__name__)

ImportFormat = Literal["auto", "native", "front3d", "procthor", "holodeck", "sam3d", "sceneeval"]
"""Input formats built in; ``auto`` detects by content. Registered plugin formats are accepted by name too."""


@dataclass(frozen=True)
class ReadOptions:
    """What a reader may be told besides the file."""

    room: Room | None = None
    """Replaces the recovered room of single-room formats that accept one (``takes_room``)."""
    asset_database: Any = None
    """ProcTHOR asset database (a path or a parsed mapping); default: the one shipped with the package."""
    asset_dir: Path | None = None
    """Folder holding mesh assets a scene file names but does not carry (SceneEval ``assetId`` meshes)."""
    allow_orphans: bool = False
    """A house whose objects lie outside every room, or whose doors open onto rooms it does not
    hold, is read (each put in the nearest room, the rooms' metadata saying so) instead of refused."""
    index: int | None = None
    """Which house of a dataset file (``.jsonl``/``.jsonl.gz``, one house a line) is read, from 0."""


Reader = Callable[[Any, Path, ReadOptions], list[Scene]]
"""``read(parsed_json, path, options)`` -> the scenes the file holds."""
Writer = Callable[["Scene | House", Path, "Path | None"], Path]
"""``write(scene, destination, base_dir)`` -> the main file written; ``base_dir`` resolves relative
mesh uris. A format that ``writes_houses`` is also handed a whole :class:`~scenemosaic.scene.House`."""


@dataclass(frozen=True)
class SceneFormat:
    """One file format: how to recognise, read and/or write it."""

    name: str
    """Registry key, used by ``--format`` and ``load_scene(format=...)``."""
    description: str
    """One line for help texts and error messages."""
    detect: Callable[[Any], bool] | None = None
    """Content test on the parsed JSON of a file (readers only)."""
    read: Reader | None = None
    """Reader; ``None`` for export-only formats."""
    write: Writer | None = None
    """Writer; ``None`` for import-only formats."""
    uses_hulls: bool = False
    """Whether the writers take ``hull_cache=`` (the formats that carry collision hulls: the
    caller's CoACD cache is then the one they read, not the default)."""
    writes_houses: bool = False
    """Whether ``write`` also takes a whole :class:`~scenemosaic.scene.House` (every room in one
    file or world, at the same destination); ``False``: the format writes one room at a time."""
    folder_file: str | None = None
    """A folder holding a file of this name is this format (``scene.json``, ``poses.json``)."""
    takes_room: bool = False
    """Whether ``ReadOptions.room`` may replace the room this format recovers."""
    room_doors: bool = False
    """Whether the writers get the rooms' doors hung on their doorways (the simulator formats:
    :func:`~scenemosaic.assets.with_room_doors` adds each door as an object held in place whose
    leaves are parts on hinges, ``docs/articulation.md``)."""
    holds_houses: bool = False
    """Whether one file of this format may hold a whole house (rooms sharing walls and doors in one
    world frame): such a file with more than one room is run as a house (:func:`is_house_source`)."""
    delivered: str | None = None
    """Where every delivered folder (``base/``, ``variant_<i>/``) holds this format: the
    destination :func:`write_scene` is given, relative to the folder (``""``: the folder itself);
    ``None``: written on request only (``scenemosaic export``)."""
    written_back: bool = False
    """Whether a scene or house read from this format is also written back in it in every delivered
    folder, at its new poses (ProcTHOR's ``house.json``)."""
    extra: tuple[str, str] | None = None
    """``(module, install command)`` when the writer needs an optional dependency: without the
    module, delivery leaves the format out and says which ``pip install`` adds it."""
    builtin: bool = False
    """One of the formats the package registers itself (``exchange/_builtin.py``), known in every
    process of a run; a plugin format is registered in the user's process only, so a run that has
    one keeps its house's rooms and deliveries in that process."""


FORMATS: dict[str, SceneFormat] = {}
"""Every registered format by name, in registration order (the order detection tries them)."""


def register_format(fmt: SceneFormat, *, replace: bool = False) -> SceneFormat:
    """Add ``fmt`` to the registry (``replace=True`` to swap a format of the same name)."""
    if not fmt.name or fmt.name == "auto":
        raise UsageError(f"invalid format name {fmt.name!r}")
    if fmt.name in FORMATS and not replace:
        raise UsageError(f"format {fmt.name!r} is already registered; pass replace=True to swap it")
    if fmt.read is None and fmt.write is None:
        raise UsageError(f"format {fmt.name!r} has neither a reader nor a writer")
    FORMATS[fmt.name] = fmt
    return fmt


def get_format(name: str) -> SceneFormat:
    """The registered format ``name``; an unknown name raises naming the known ones."""
    try:
        return FORMATS[name]
    except KeyError:
        raise UsageError(f"unknown format {name!r}; known: {', '.join(FORMATS)}") from None


def _readers() -> list[SceneFormat]:
    return [f for f in FORMATS.values() if f.read is not None]


def detect_format(path: str | os.PathLike[str], *, index: int | None = None) -> str:
    """Name the format of ``path`` by looking at its content (rules in ``docs/importers.md``).

    A folder is the format whose ``folder_file`` it holds (``scene.json`` -> native,
    ``poses.json`` -> sam3d). A JSON file is the first registered reader whose ``detect``
    accepts it; a dataset of houses (``.jsonl``/``.jsonl.gz``) the format of its house ``index``
    (default: its first). Anything else raises :class:`ImportFormatError`.
    """
    p = Path(path)
    if p.is_dir():
        fmt = _folder_format(p)
        if fmt is None:
            wanted = " nor ".join(f.folder_file for f in _readers() if f.folder_file)
            raise ImportFormatError(f"folder holds neither {wanted}", path=str(p))
        return fmt.name
    if is_dataset(p) and index is None:
        first = next(dataset_entries(p), None)
        if first is None:
            raise ImportFormatError("the dataset holds no house", path=str(p))
        return _detect_data(first.parse(p), p).name
    return _detect_data(_input_data(p, index), p).name


def load_scenes(
    path: str | os.PathLike[str],
    format: ImportFormat | str = "auto",
    *,
    room: Room | str | None = None,
    asset_database: Any = None,
    asset_dir: str | os.PathLike[str] | None = None,
    variant: int | str | None = None,
    allow_partial: bool = False,
    allow_orphans: bool = False,
    index: int | None = None,
) -> list[Scene]:
    """Import every scene ``path`` holds, in a stable order.

    ``path`` is a file, a native scene folder, a SAM3D folder (with ``poses.json``), or any
    other folder, whose ``*.json`` files are each imported (sorted by name). A ProcTHOR house
    gives one scene per room. A :class:`Room` ``room`` replaces the recovered room of
    single-room formats (``front3d``, ``sam3d``); a string ``room`` keeps only the scene whose
    id, room id or source room id (ProcTHOR's ``room|2``) equals it. ``asset_database`` (a path
    or a parsed mapping) replaces the ProcTHOR asset sizes shipped with the package;
    ``asset_dir`` is where SceneEval asset meshes are looked up (default: ``assets/`` beside the file).
    A ``generate`` output folder (:class:`RunFolder`) gives its base scene, or with ``variant``
    (a number from 1, or ``"variant_2"``) that variant. What a failed or stopped run kept
    (``partial.json`` beside it) raises :class:`~scenemosaic.exceptions.PartialResultError`
    unless ``allow_partial``. A house with objects outside every room or doors onto rooms it
    does not hold raises :class:`~scenemosaic.exceptions.ImportFormatError` naming them, unless
    ``allow_orphans`` (each then goes to the nearest room; ``docs/importers.md``). A dataset of
    houses (``.jsonl``/``.jsonl.gz``, one house a line) needs ``index``, the house's, from 0; it
    is read lazily (``docs/importers.md``).
    """
    fmt = _check_format(format, path)
    p = Path(path)
    if RunFolder.is_run(p):
        p = RunFolder(p).scene_folder(variant)
    elif variant is not None:
        raise UsageError(f"variant={variant!r} needs a generate output folder; {os.fspath(path)} is not one")
    if not allow_partial:
        check_not_partial(p if p.is_dir() else p.parent)
    options = ReadOptions(
        room=room if isinstance(room, Room) else None,
        asset_database=asset_database,
        asset_dir=Path(asset_dir) if asset_dir is not None else None,
        allow_orphans=allow_orphans,
        index=index,
    )
    if index is not None and not is_dataset(p):
        raise UsageError(f"index={index} picks a house of a dataset (.jsonl, .jsonl.gz); {os.fspath(path)} is not one")
    scenes: list[Scene] = []
    if p.is_dir() and RunFolder.holds_house(p):
        scenes = read_house(p, allow_partial=True).rooms  # checked above
    elif p.is_dir():
        inner = _folder_format(p)
        if inner is not None and fmt in ("auto", inner.name):
            assert inner.folder_file is not None
            scenes = _load_file(p / inner.folder_file, inner.name, options)
        else:
            files = sorted(q for q in p.glob("*.json") if q.is_file())
            if not files:
                raise ImportFormatError(
                    "folder holds no scene file (scene.json, poses.json or *.json)", path=str(p)
                )
            for f in files:
                scenes.extend(_load_file(f, fmt, options))
    else:
        scenes = _load_file(p, fmt, options)
    if isinstance(room, str):
        scenes = _select_room(scenes, room, p)
    return scenes


def load_scene(
    path: str | os.PathLike[str],
    format: ImportFormat | str = "auto",
    *,
    room: Room | str | None = None,
    asset_database: Any = None,
    asset_dir: str | os.PathLike[str] | None = None,
    variant: int | str | None = None,
    allow_partial: bool = False,
    allow_orphans: bool = False,
    index: int | None = None,
) -> Scene | House:
    """Import the one scene ``path`` holds (see :func:`load_scenes`), or the whole house.

    A multi-room house (an AI2-THOR / ProcTHOR house file, or the ``base/`` or a variant of a
    house run) gives a :class:`~scenemosaic.scene.House` (:func:`load_house`); ``room="<room id>"``
    gives that one room's scene. Any other source holding several scenes (a folder of layouts)
    raises :class:`~scenemosaic.exceptions.UsageError` naming them: use :func:`load_scenes`.
    """
    scenes = load_scenes(
        path, format, room=room, asset_database=asset_database, asset_dir=asset_dir, variant=variant,
        allow_partial=allow_partial, allow_orphans=allow_orphans, index=index,
    )  # fmt: skip
    if len(scenes) == 1:
        return scenes[0]
    if room is None and _one_house(scenes):
        return load_house(
            path, format, asset_database=asset_database, variant=variant, allow_partial=allow_partial,
            allow_orphans=allow_orphans, index=index,
        )
    ids = ", ".join(s.id for s in scenes[:8])
    raise UsageError(
        f"{os.fspath(path)} holds {len(scenes)} scenes ({ids}); use load_scenes() to read them all"
    )


def plugin_formats() -> list[str]:
    """The registered formats that are not built in (``SceneFormat.builtin``), in registration order."""
    return [name for name, fmt in FORMATS.items() if not fmt.builtin]


def house_formats() -> frozenset[str]:
    """The registered formats one file of which may hold a whole house (``holds_houses``)."""
    return frozenset(name for name, fmt in FORMATS.items() if fmt.holds_houses)


def _one_house(scenes: list[Scene]) -> bool:
    sources = {(s.provenance.source_format, s.provenance.source_path) for s in scenes}
    return len(sources) == 1 and next(iter(sources))[0] in house_formats()


def is_house_source(
    path: str | os.PathLike[str], format: ImportFormat | str = "auto", *, allow_orphans: bool = False, index: int | None = None
) -> bool:
    """Whether ``path`` is one file of a format that holds houses (``holds_houses``) holding more
    than one room: an input a run works on as a whole house. A file that cannot be read as one is
    no house (the one-scene import then says what is wrong with it)."""
    p = Path(path)
    if not p.is_file():
        return False
    try:
        name = detect_format(p, index=index) if format == "auto" else format
        if name not in house_formats():
            return False
        return len(load_house(p, name, allow_orphans=allow_orphans, index=index).rooms) > 1
    except SceneMosaicError:
        return False


def load_house(
    path: str | os.PathLike[str],
    format: ImportFormat | str = "auto",
    *,
    asset_database: Any = None,
    variant: int | str | None = None,
    allow_partial: bool = False,
    allow_orphans: bool = False,
    index: int | None = None,
) -> House:
    """Import a whole house: every room of an AI2-THOR / ProcTHOR house file, in its room order,
    or a delivered house (the ``base/`` or ``variant_<i>/`` of a house run; ``variant`` picks one
    of a run folder; ``index`` a house of a dataset, which is named ``<file stem>-<index>``). Raises
    :class:`~scenemosaic.exceptions.UsageError` for a source that is not a house;
    ``allow_orphans`` as for :func:`load_scenes`."""
    p = Path(path)
    if RunFolder.is_run(p):
        p = RunFolder(p).scene_folder(variant)
    elif variant is not None:
        raise UsageError(f"variant={variant!r} needs a generate output folder; {os.fspath(path)} is not one")
    if p.is_dir() and RunFolder.holds_house(p):
        return read_house(p, allow_partial=allow_partial)
    scenes = load_scenes(
        p, format, asset_database=asset_database, allow_partial=allow_partial, allow_orphans=allow_orphans, index=index
    )
    if not _one_house(scenes):
        raise UsageError(f"{os.fspath(path)} is not a house (a multi-room AI2-THOR / ProcTHOR house file or a delivered house)")
    first = scenes[0].provenance
    return House(
        id=_house_name(p, index),
        rooms=scenes,
        provenance=Provenance(
            source_format=first.source_format, source_path=first.source_path, importer=first.importer, source_index=index
        ),
    )


def write_scene(
    scene: Scene | House,
    format: str,
    destination: str | os.PathLike[str],
    base_dir: str | os.PathLike[str] | None = None,
    *,
    hull_cache: HullCache | None = None,
) -> Path:
    """Write a scene, or a whole house, in the registered ``format``; returns the main file written.

    A :class:`~scenemosaic.scene.House` is written by the format's house writer (``native``: a
    native house folder; ``mjcf``, ``urdf``, ``usd``, ``glb``, ``sceneeval``: the whole house as
    one world; ``procthor``: the AI2-THOR house file it came from); a format without one raises
    :class:`~scenemosaic.exceptions.UsageError` naming those that have one. ``base_dir`` resolves
    the relative mesh uris of what is written (the folder it was read from).

    ``hull_cache`` is the CoACD cache the formats that carry collision hulls read (default: the
    user's default cache). A simulator format (``SceneFormat.room_doors``) gets the rooms' doors
    hung on their doorways (:func:`~scenemosaic.assets.with_room_doors`).

    If the writer fails, what it created is removed: a ``destination`` (or a folder above it) that
    did not exist is gone again, and in a folder that did exist, the entries the writer added are.
    """
    fmt = get_format(format)
    base = Path(base_dir) if base_dir is not None else None
    target = Path(destination)
    options: dict[str, Any] = {"hull_cache": hull_cache} if fmt.uses_hulls and hull_cache is not None else {}
    if fmt.room_doors:
        from scenemosaic.assets import with_room_doors  # here: registering loads no backend

        scene = with_room_doors(scene)
    writer = fmt.write
    if isinstance(scene, House) and (writer is None or not fmt.writes_houses):
        raise UsageError(f"format {format!r} cannot write a whole house; {_writers_note(house=True)}")
    if writer is None:
        raise UsageError(f"format {format!r} cannot write a single scene; {_writers_note(house=False)}")
    with _removed_on_error(target):
        return writer(scene, target, base, **options)


def writable_formats(*, house: bool = False) -> list[str]:
    """The registered formats that can write a scene (``house=True``: a whole house), in registration order."""
    return [name for name, f in FORMATS.items() if f.write is not None and (f.writes_houses or not house)]


# -- internals ------------------------------------------------------------------------------------


def _writers_note(*, house: bool) -> str:
    note = f"formats that write a {'house' if house else 'scene'}: {', '.join(writable_formats(house=house))}"
    return note + ("; write one room with house.room('<room id>')" if house else "")


@contextmanager
def _removed_on_error(destination: Path) -> Iterator[None]:
    """Undo what a failed writer created at ``destination``: the topmost of it and its parents that
    did not exist, or else, in an existing folder, the entries that were not there."""
    missing = [p for p in (destination, *destination.parents) if not os.path.lexists(p)]
    created = missing[-1] if missing else None
    before = set(destination.iterdir()) if created is None and destination.is_dir() else None
    try:
        yield
    except BaseException:
        if created is not None:
            _remove(created)
        elif before is not None:
            for entry in set(destination.iterdir()) - before:
                _remove(entry)
        raise


def _remove(path: Path) -> None:
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        path.unlink(missing_ok=True)


def _check_format(format: str, path: str | os.PathLike[str]) -> str:
    if format != "auto" and (format not in FORMATS or FORMATS[format].read is None):
        readable = ", ".join(f.name for f in _readers())
        raise ImportFormatError(
            f"unknown format {format!r} for input; use 'auto' or one of {readable}",
            path=os.fspath(path),
            field="format",
        )
    return format


def _select_room(scenes: list[Scene], room: str, path: Path) -> list[Scene]:
    """The scenes named ``room``: by our ids first (a scene's or its room's, unique by
    construction), else by the source file's room id. A house may hold both ``room|2`` and
    ``room_2``: they become ``room_2`` and ``room_2_2``, and ``room_2`` names the first."""

    def ours(scene: Scene) -> set[str]:
        return {scene.id} | ({scene.room.id} if scene.room is not None else set())

    def source(scene: Scene) -> set[str]:
        value = scene.provenance.source_room_id
        return {value} if value is not None else set()

    def names(scene: Scene) -> set[str]:
        return ours(scene) | source(scene)

    picked = [s for s in scenes if room in ours(s)] or [s for s in scenes if room in source(s)]
    if not picked:
        known = ", ".join(sorted({n for s in scenes for n in names(s)}))
        raise UsageError(f"{path} has no room {room!r}; it has: {known}")
    return picked


def _folder_format(p: Path) -> SceneFormat | None:
    for fmt in _readers():
        if fmt.folder_file and (p / fmt.folder_file).is_file():
            return fmt
    return None


def _detect_data(data: Any, path: Path) -> SceneFormat:
    for fmt in _readers():
        if fmt.detect is not None and fmt.detect(data):
            return fmt
    keys = sorted(data)[:6] if isinstance(data, dict) else type(data).__name__
    kinds = "; ".join(f"{f.name} ({f.description})" for f in _readers())
    raise ImportFormatError(f"unknown format (top-level {keys}); expected one of: {kinds}", path=str(path))


def _house_name(path: str | os.PathLike[str], index: int | None = None) -> str:
    """The id a house read from ``path`` gets: the file's stem, ``<stem>-<index>`` for a house
    of a dataset, the folder's name for a folder."""
    p = Path(path)
    if index is not None:
        return safe_name(f"{dataset_stem(p)}-{index}")
    return safe_name(p.stem) if p.is_file() else safe_name(p.name)


def _input_data(path: Path, index: int | None) -> Any:
    """The parsed JSON of a file, or of house ``index`` of a dataset (which needs one)."""
    if not is_dataset(path):
        return read_json(path)
    if index is None:
        raise UsageError(
            f"{path} is a dataset of {dataset_size(path)} houses: pick one with index= (generate --index N), "
            "or run them all with batch"
        )
    return dataset_entry(path, index).parse(path)


def _load_file(path: Path, name: str, options: ReadOptions) -> list[Scene]:
    data = _input_data(path, options.index)
    fmt = _detect_data(data, path) if name == "auto" else FORMATS[name]
    if options.room is not None and not fmt.takes_room:
        takers = ", ".join(f.name for f in _readers() if f.takes_room)
        raise UsageError(f"room= only applies to {takers} inputs; {path} is {fmt.name}")
    log.debug("import", path=str(path), format=fmt.name)
    assert fmt.read is not None
    scenes = fmt.read(data, path, options)
    if options.index is not None:  # which line of the dataset: what is written back, and where to read it again
        for scene in scenes:
            scene.provenance.source_index = options.index
    return scenes

