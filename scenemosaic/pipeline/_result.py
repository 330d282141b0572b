"""What ``generate`` returns: :class:`GenerateResult`."""

from __future__ import annotations

import html
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from scenemosaic.exceptions import UsageError
from scenemosaic.pipeline._report import RunReport
from scenemosaic.scene import House, RunFolder, Scene

__all__ = ["GenerateResult"]


@dataclass
class GenerateResult:
    """What ``generate`` produced: the final base scene (a :class:`~scenemosaic.scene.House` for a
    whole-house run), the base as a house whatever the run (:attr:`house`: a one-room run is a
    house of one room; its rooms by :attr:`rooms` and :meth:`room`), the output folder and
    the report; its variants and metrics on demand. In Jupyter it displays as a summary table (a
    house's: its house figures and each room's) and the contact sheet of the base and its
    variants."""

    scene: Scene | House
    out_dir: Path
    report: dict[str, Any] = field(repr=False)  # the text repr stays short; ``report`` has it all
    """The report as ``report.json`` holds it (:attr:`run_report` is the same, typed)."""
    _variants: list[Scene | House] | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def folder(self) -> RunFolder:
        """The run's output folder and every path in it."""
        return RunFolder(self.out_dir)

    @property
    def base_dir(self) -> Path:
        """The delivered base scene's folder (``base/``)."""
        return self.folder.base

    @property
    def run_report(self) -> RunReport:
        """The report as the typed :class:`~scenemosaic.pipeline.RunReport` (rooms and houses alike)."""
        return RunReport.model_validate(self.report)

    @property
    def status(self) -> str:
        """``ok`` or ``degraded`` (a failed run raises instead of returning)."""
        return str(self.report.get("status", "ok"))

    @property
    def variant_dirs(self) -> list[Path]:
        """The variants' folders, ``variant_1`` ... ``variant_n`` (empty without variants)."""
        n = int(self.report.get("variants_written", 0) or 0)
        return [self.folder.variant(i) for i in range(1, n + 1)]

    @property
    def variants(self) -> list[Scene | House]:
        """The delivered whole-scene (or whole-house) variants, as delivered: read from their
        folders on first use."""
        if self._variants is None:
            from scenemosaic.exchange import (  # the readers load the exporters' backends
                read_house,
                read_scene,
            )

            self._variants = [read_house(d) if RunFolder.holds_house(d) else read_scene(d) for d in self.variant_dirs]
        return list(self._variants)

    @property
    def house(self) -> House:
        """The base as a house, whatever the run: a whole-house run's house, or a one-room run's
        scene as a house of that one room (so a notebook reads ``result.house.rooms`` without
        asking which kind of run it was)."""
        return self.scene if isinstance(self.scene, House) else _one_room_house(self.scene)

    @property
    def rooms(self) -> list[str]:
        """The ids of the run's rooms, in the house's order (a one-room run: its scene's id)."""
        return self.house.room_ids

    def room(self, room_id: str, *, variant: int | None = None) -> Scene:
        """One room's scene: of the delivered base, or of variant ``variant`` (1 ... n). ``room_id``
        is the room's id (``result.rooms``) or its source id (ProcTHOR's ``room|4``); a one-room
        run's room is its scene. Raises ``KeyError`` naming the rooms for an unknown room, and
        :class:`~scenemosaic.exceptions.UsageError` for a variant that was not written."""
        house = self.house
        if variant is not None:
            written = self.variants
            if not 1 <= variant <= len(written):
                wrote = f"variant_1 ... variant_{len(written)}" if written else "no variants"
                raise UsageError(f"no variant {variant}: the run wrote {wrote}")
            chosen = written[variant - 1]
            house = chosen if isinstance(chosen, House) else _one_room_house(chosen)
        return house.room(room_id)

    def room_report(self, room_id: str) -> dict[str, Any]:
        """One room's part of the report (its ``stages``, ``warnings``, ``validation``...): a
        whole-house run's ``report["rooms"][room_id]``, a one-room run's report itself. Raises
        ``KeyError`` naming the rooms for an unknown room."""
        room = self.room(room_id)  # by its id or its source's
        rooms = self.report.get("rooms")
        if isinstance(rooms, dict):
            part: dict[str, Any] = rooms[room.id]
            return part
        return self.report

    @property
    def metrics(self) -> dict[str, Any] | None:
        """COL, OOB, NAV of the base and each variant, RelKeep and the diversity (``None`` when
        the evaluate stage did not run). For a whole-house run: ``{"house": {"base", "variants",
        "diversity"}, "rooms": {room id: a room's figures}}``."""
        value = self.report.get("metrics")
        return value if isinstance(value, dict) else None

    @property
    def preview_path(self) -> Path | None:
        """The contact sheet (base and variants side by side), else the base's top-down view."""
        for p in (self.folder.contact_sheet, self.base_dir / RunFolder.TOPDOWN):
            if p.is_file():
                return p
        return None

    def _repr_png_(self) -> bytes | None:
        """Jupyter shows the preview image."""
        p = self.preview_path
        return p.read_bytes() if p is not None else None

    def _repr_html_(self) -> str:
        """Jupyter shows a summary table (status, objects, each scene's metrics; for a house the
        house figures, each room's COL / OOB and the house diversity) over the preview."""
        import base64

        rows = [("status", html.escape(self.status))]
        if isinstance(self.scene, House):
            rows.append(("rooms", html.escape(", ".join(self.scene.room_ids))))
        rows.append(("objects", str(len(self.scene.objects))))
        rows.append(("output", f"<code>{html.escape(str(self.out_dir))}</code>"))
        out = ["<table>" + "".join(f"<tr><th>{k}</th><td>{v}</td></tr>" for k, v in rows) + "</table>"]
        m = self.metrics
        if m and isinstance(self.scene, House):
            out += self._house_metrics_html(m)
        elif m:
            scenes = self._named(m)
            out.append(_table(["COL", "OOB", "NAV", "RelKeep"], scenes))
            out.append(_diversity(m.get("diversity"), "Div-IoU"))
        png = self._repr_png_()
        if png is not None:
            data = base64.b64encode(png).decode("ascii")
            out.append(f'<img src="data:image/png;base64,{data}" style="max-width:100%"/>')
        return "\n".join(part for part in out if part)

    def _named(self, m: dict[str, Any]) -> list[tuple[str, dict[str, Any]]]:
        """``(base, its figures), (variant_1, ...), ...`` of a ``{"base", "variants"}`` block."""
        base = m.get("base")
        named = [(RunFolder.BASE, base if isinstance(base, dict) else {})]
        for i, v in enumerate(m.get("variants") or [], 1):
            named.append((self.folder.variant(i).name, v if isinstance(v, dict) else {}))
        return named

    def _house_metrics_html(self, m: dict[str, Any]) -> list[str]:
        """The house figures of the base and each variant, each room's COL / OOB, the diversity."""
        house = m.get("house")
        house = house if isinstance(house, dict) else {}
        columns = {
            "house_nav": "house NAV",
            "door_blockers": "door blockers",
            "unreachable_rooms": "unreachable rooms",
            "wall_crossings": "across walls",
            "RelKeep": "RelKeep",
        }
        scenes = [(name, {label: _count(v.get(k, "")) for k, label in columns.items()}) for name, v in self._named(house)]
        out = ["<p>house</p>" + _table(list(columns.values()), scenes)]
        rooms = m.get("rooms")
        if isinstance(rooms, dict) and rooms:
            cells = [
                (rid, {name: f"{v.get('COL', '')} / {v.get('OOB', '')}" for name, v in self._named(figures)})
                for rid, figures in rooms.items()
                if isinstance(figures, dict)
            ]
            out.append("<p>each room: COL / OOB</p>" + _table([name for name, _ in scenes], cells))
        out.append(_diversity(house.get("diversity"), "house Div-IoU"))
        return out


def _count(value: Any) -> Any:
    """A list of findings (door blockers, unreachable rooms) as its length; anything else as it is
    (the base's house checks list their findings, a variant's count them)."""
    return len(value) if isinstance(value, list) else value


def _table(columns: list[str], rows: list[tuple[str, dict[str, Any]]]) -> str:
    head = "".join(f"<th>{html.escape(k)}</th>" for k in columns)
    body = "".join(
        f"<tr><td>{html.escape(name)}</td>" + "".join(f"<td>{html.escape(str(v.get(k, '')))}</td>" for k in columns) + "</tr>"
        for name, v in rows
    )
    return f"<table><tr><th></th>{head}</tr>{body}</table>"


def _diversity(div: Any, label: str) -> str:
    if not isinstance(div, dict):
        return ""
    return f"<p>{label} {html.escape(str(div.get('Div-IoU')))}, Div-N {html.escape(str(div.get('Div-N')))}</p>"


def _one_room_house(scene: Scene) -> House:
    """``scene`` as a house of one room (its id and provenance)."""
    return House(id=scene.id, rooms=[scene], provenance=scene.provenance.model_copy())
