"""The output folder of one ``generate`` run: the one owner of every path in it.

Layout (``docs/architecture.md`` draws it)::

    OUT/report.json            what ran, how it ended, per-stage figures
    OUT/base/                  the delivered base scene (scene.json and every delivered format)
    OUT/variant_<i>/           the i-th whole-scene variant, laid out like base/ (i from 1)
    OUT/contact_sheet.png      base and variants side by side
    OUT/evolve/<unit>/<layout>.json   each unit's evolved layouts (and, on request, their views)
    OUT/perception/            what perception saw in a photograph input
    OUT/prompt.png (+ .json)   the image a text prompt was drawn into
    OUT/.checkpoint/           the run's resumable state (one run store: stages and agents)
    OUT/.lock                  held by the run writing here: a second run on the folder is refused
    OUT/rooms/<room>/          a house run: each room's own work (checkpoint, evolve/), a run folder

A house run's ``base/`` and ``variant_<i>/`` each hold a whole house: ``house_scene.json`` (the
room order) and ``rooms/<room>/scene.json`` per room, beside the house-wide formats.

The pipeline, the CLI, batch, :class:`~scenemosaic.pipeline.GenerateResult` and the readers
(:func:`~scenemosaic.exchange.load_scene` with ``variant=``) all ask a :class:`RunFolder` for
these paths; no other module spells them.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

from scenemosaic.exceptions import UsageError

__all__ = ["RunFolder", "safe_name"]

_UNSAFE = re.compile(r"[^A-Za-z0-9._+\-]")


def safe_name(name: str) -> str:
    """``name`` as one file-name component that stays inside its folder: characters other than
    letters, digits, ``. _ + -`` become ``_``, and ``.``/``..``/empty become ``_``."""
    cleaned = _UNSAFE.sub("_", name)
    return "_" if cleaned in ("", ".", "..") else cleaned


class RunFolder:
    """The paths of one run's output folder (nothing is created until a writer asks).

    ``RunFolder(out)`` names the folder; :meth:`is_run` says whether a folder on disk is one
    (it has ``report.json`` or ``base/scene.json``).
    """

    BASE = "base"
    """The base scene's folder."""
    VARIANT_PREFIX = "variant_"
    """Variant folders are ``variant_1``, ``variant_2``..."""
    EVOLVE = "evolve"
    """Each unit's evolved layouts (``evolve/<unit>/<layout>.json``) and, on request, views."""
    PERCEPTION = "perception"
    """What perception saw in a photograph input (photo, inventory, masks, meshes)."""
    REPORT = "report.json"
    """The run's report."""
    CONTACT_SHEET = "contact_sheet.png"
    """The base scene and its variants side by side."""
    PROMPT_IMAGE = "prompt.png"
    """The image a text prompt is drawn into (``prompt.json`` beside it says from what)."""
    LOCK = ".lock"
    """Held (``flock``) by the run writing into the folder: a second run there is refused."""
    CHECKPOINT = ".checkpoint"
    """The run's resumable state."""
    RUN_RECORD = "run.json"
    """In the checkpoint folder: the input and settings of the run (what ``--resume`` reads)."""
    STAGED = "staged"
    """In the checkpoint folder: houses a house run delivered ahead of its export stage, which
    moves them into place (``staged/base``, ``staged/variant_<i>``)."""
    SCENE_FILE = "scene.json"
    """The native scene file in ``base/`` and every ``variant_<i>/``."""
    HOUSE_FILE = "house_scene.json"
    """Instead of ``scene.json``, in a house run's ``base/`` and ``variant_<i>/``: the house's index."""
    ROOMS = "rooms"
    """A house run's per-room work (``OUT/rooms/<room>/``); in a delivered house, its room scenes."""
    TOPDOWN = "topdown.png"
    """The top-down picture in ``base/`` and every ``variant_<i>/``."""
    PARTIAL = "partial.json"
    """Beside the scene (or house) a failed or stopped run kept in ``base/``: why it is partial
    (``status``, ``failed_stage``, ``error``). Loaders refuse such a folder unless asked."""

    def __init__(self, root: str | os.PathLike[str]) -> None:
        self.root = Path(root)
        """The output folder."""

    def __repr__(self) -> str:
        return f"RunFolder({str(self.root)!r})"

    def __fspath__(self) -> str:
        return os.fspath(self.root)

    # -- paths ----------------------------------------------------------------------------------
    @property
    def base(self) -> Path:
        """``base/``: the delivered base scene."""
        return self.root / self.BASE

    def variant(self, index: int) -> Path:
        """``variant_<index>/`` (``index`` from 1)."""
        if index < 1:
            raise UsageError(f"variants are numbered from 1, got {index}")
        return self.root / f"{self.VARIANT_PREFIX}{index}"

    @property
    def report(self) -> Path:
        """``report.json``."""
        return self.root / self.REPORT

    @property
    def contact_sheet(self) -> Path:
        """``contact_sheet.png``."""
        return self.root / self.CONTACT_SHEET

    @property
    def evolve(self) -> Path:
        """``evolve/``."""
        return self.root / self.EVOLVE

    def evolve_layout(self, unit: str, layout_id: str) -> Path:
        """``evolve/<unit>/<layout_id>.json``, both names made safe (an id cannot leave the folder)."""
        return self.evolve / safe_name(unit) / f"{safe_name(layout_id)}.json"

    @property
    def perception(self) -> Path:
        """``perception/``."""
        return self.root / self.PERCEPTION

    @property
    def prompt_image(self) -> Path:
        """``prompt.png``."""
        return self.root / self.PROMPT_IMAGE

    @property
    def rooms(self) -> Path:
        """``rooms/``: a house run's per-room run folders."""
        return self.root / self.ROOMS

    def room(self, room_id: str) -> RunFolder:
        """``rooms/<room_id>/`` (the id made safe) as a run folder of its own."""
        return RunFolder(self.rooms / safe_name(room_id))

    @classmethod
    def holds_scene(cls, folder: Path) -> bool:
        """Whether a delivered folder holds a scene (``scene.json``) or a house (``house_scene.json``)."""
        return (folder / cls.SCENE_FILE).is_file() or (folder / cls.HOUSE_FILE).is_file()

    @classmethod
    def is_delivered(cls, folder: Path) -> bool:
        """Whether a folder holds a delivered scene or house: one a finished run wrote, not the
        partial result a failed or stopped run kept (``partial.json``)."""
        return cls.holds_scene(folder) and not (folder / cls.PARTIAL).exists()

    @classmethod
    def holds_house(cls, folder: Path) -> bool:
        """Whether a delivered folder holds a whole house (``house_scene.json``)."""
        return (folder / cls.HOUSE_FILE).is_file()

    @property
    def lock(self) -> Path:
        """``.lock``: the lock the writing run holds."""
        return self.root / self.LOCK

    @property
    def checkpoint(self) -> Path:
        """``.checkpoint/``."""
        return self.root / self.CHECKPOINT

    @property
    def staged(self) -> Path:
        """``.checkpoint/staged/``: deliveries made ahead of the export stage (:data:`STAGED`)."""
        return self.checkpoint / self.STAGED

    @property
    def run_record(self) -> Path:
        """``.checkpoint/run.json``."""
        return self.checkpoint / self.RUN_RECORD

    # -- what is there --------------------------------------------------------------------------
    def variants(self) -> list[Path]:
        """The variant folders present, in number order."""
        found: list[tuple[int, Path]] = []
        if self.root.is_dir():
            for p in self.root.iterdir():
                tail = p.name[len(self.VARIANT_PREFIX) :]
                if p.name.startswith(self.VARIANT_PREFIX) and tail.isdigit() and p.is_dir():
                    found.append((int(tail), p))
        return [p for _, p in sorted(found)]

    def scenes(self) -> list[tuple[str, Path]]:
        """``[(name, folder)]`` of the base and every variant present, in order."""
        return [(self.BASE, self.base), *((p.name, p) for p in self.variants())]

    def scene_folder(self, variant: int | str | None = None) -> Path:
        """The folder of the base (``variant`` ``None``, ``0`` or ``"base"``) or of a variant
        (its number, or its folder name ``"variant_2"``); raises
        :class:`~scenemosaic.exceptions.UsageError` naming the ones present when it is absent."""
        if variant is None or variant in (0, self.BASE):
            folder = self.base
        elif isinstance(variant, int) or (isinstance(variant, str) and variant.isdigit()):
            folder = self.variant(int(variant))
        elif isinstance(variant, str) and variant.startswith(self.VARIANT_PREFIX):
            folder = self.root / variant
        else:
            raise UsageError(f"variant must be a number, 'base' or 'variant_<i>', got {variant!r}")
        if not self.holds_scene(folder):
            present = ", ".join(name for name, f in self.scenes() if self.holds_scene(f)) or "none"
            raise UsageError(f"{self.root} has no {folder.name}/ scene (present: {present})")
        return folder

    def outputs(self) -> list[Path]:
        """Every path a run writes here (what a fresh run or ``overwrite`` removes first)."""
        fixed = [self.base, self.evolve, self.perception, self.contact_sheet, self.report, self.checkpoint, self.rooms]
        return [*fixed, *self.variants()]

    @classmethod
    def is_run(cls, path: str | os.PathLike[str]) -> bool:
        """Whether ``path`` is a run's output folder (``report.json``, ``base/scene.json`` or
        ``base/house_scene.json`` in it)."""
        p = Path(path)
        return p.is_dir() and ((p / cls.REPORT).is_file() or cls.holds_scene(p / cls.BASE))
