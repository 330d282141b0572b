"""Contact sheets: several pictures in one labelled grid (a run's base and variants side by side)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from scenemosaic.render._view import png_bytes
from scenemosaic.scene import write_atomic

__all__ = ["ContactSheet", "contact_sheet"]

LABEL_PX = 40
"""Height of the label strip above each tile, in pixels."""
TITLE_FONT_PX = 28
"""Font size of a tile's label (``base``, ``variant_1``...), pixels."""


def contact_sheet(
    tiles: Sequence[tuple[str, Path]], target: Path, tile_px: int | None = None, columns: int = 3
) -> Path:
    """Write ``target``: the images ``tiles`` (``(label, png path)``) as ``tile_px`` squares in a
    grid of up to ``columns`` columns, each under its label. Returns ``target``.

    By default (``tile_px=None``) the tiles keep the first image's size, so the object labels in
    the plans read at 100 % as in each ``topdown.png``; a smaller ``tile_px`` shrinks them with
    the picture.
    """
    sheet = ContactSheet(len(tiles), tile_px=tile_px, columns=columns)
    for label, path in tiles:
        sheet.add(label, path)
    return sheet.save(target)


class ContactSheet:
    """A contact sheet of ``count`` tiles built a tile at a time (:func:`contact_sheet` in pieces):
    each tile is read and placed as soon as its picture exists (a house run's plans, as each house
    is delivered), and only the encoding is left for :meth:`save`."""

    def __init__(self, count: int, *, tile_px: int | None = None, columns: int = 3) -> None:
        if count < 1:
            raise ValueError("a contact sheet needs at least one tile")
        self.count, self.tile_px = count, tile_px
        self.cols = min(columns, count)
        self.rows = (count + self.cols - 1) // self.cols
        self._sheet: Any = None
        self._draw: Any = None
        self._font: Any = None
        self._next = 0

    def add(self, label: str, path: Path) -> None:
        """Place the picture at ``path`` as the next tile, under ``label`` (the first one sets the
        tile size when none was given)."""
        from PIL import Image, ImageDraw, ImageFont

        if self._next >= self.count:
            raise ValueError(f"the contact sheet holds {self.count} tile(s) only")
        with Image.open(path) as view:
            if self._sheet is None:
                if self.tile_px is None:
                    self.tile_px = max(view.size)
                side = self.tile_px
                self._sheet = Image.new("RGB", (self.cols * side, self.rows * (side + LABEL_PX)), (255, 255, 255))
                self._draw = ImageDraw.Draw(self._sheet)
                try:
                    self._font = ImageFont.load_default(size=TITLE_FONT_PX)
                except (OSError, ValueError, ImportError):
                    self._font = ImageFont.load_default()
            px = self.tile_px
            assert px is not None
            i = self._next
            x, y = (i % self.cols) * px, (i // self.cols) * (px + LABEL_PX)
            tile = view.convert("RGB")
            if tile.size != (px, px):
                tile = tile.resize((px, px))
            self._sheet.paste(tile, (x, y + LABEL_PX))
        self._draw.text((x + 10, y + 6), label, fill=(25, 25, 30), font=self._font)
        self._next += 1

    def save(self, target: Path) -> Path:
        """Write the sheet to ``target`` (PNG) once every tile is in; returns ``target``."""
        if self._next != self.count:
            raise ValueError(f"the contact sheet has {self._next} of its {self.count} tile(s)")
        write_atomic(target, png_bytes(self._sheet))
        return target
