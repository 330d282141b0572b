"""What ``generate`` returns: :class:`GenerateResult`."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from scenemosaic.scene import House, RunFolder, Scene

__all__ = ["GenerateResult"]


@dataclass
class GenerateResult:
    """What ``generate`` produced: the final base scene (a :class:`~scenemosaic.scene.House` for a
    whole-house run: ``scene.rooms``), the output folder and the report; its variants and metrics
    on demand. In Jupyter it displays as a summary table and the contact sheet of the base and its
    variants."""

    scene: Scene | House
    out_dir: Path
    report: dict[str, Any]
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
    def metrics(self) -> dict[str, Any] | None:
        """COL, OOB, NAV of the base and each variant, RelKeep and the diversity (``None`` when
        the evaluate stage did not run)."""
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
        """Jupyter shows a summary table (status, objects, each scene's metrics) over the preview."""
        import base64
        import html

        rows = [f"<tr><th>status</th><td>{html.escape(self.status)}</td></tr>"]
        rows.append(f"<tr><th>objects</th><td>{len(self.scene.objects)}</td></tr>")
        rows.append(f"<tr><th>output</th><td><code>{html.escape(str(self.out_dir))}</code></td></tr>")
        out = [f"<table>{''.join(rows)}</table>"]
        m = self.metrics
        if m:
            scenes = [(RunFolder.BASE, m.get("base") or {})] + [
                (self.folder.variant(i).name, v) for i, v in enumerate(m.get("variants") or [], 1)
            ]
            keys = ["COL", "OOB", "NAV", "RelKeep"]
            head = "".join(f"<th>{k}</th>" for k in keys)
            body = "".join(
                f"<tr><td>{name}</td>" + "".join(f"<td>{html.escape(str(v.get(k, '')))}</td>" for k in keys) + "</tr>"
                for name, v in scenes
            )
            out.append(f"<table><tr><th></th>{head}</tr>{body}</table>")
            div = m.get("diversity")
            if isinstance(div, dict):
                out.append(f"<p>Div-IoU {html.escape(str(div.get('Div-IoU')))}, Div-N {html.escape(str(div.get('Div-N')))}</p>")
        png = self._repr_png_()
        if png is not None:
            data = base64.b64encode(png).decode("ascii")
            out.append(f'<img src="data:image/png;base64,{data}" style="max-width:100%"/>')
        return "\n".join(out)
