"""Contact sheets: several pictures in one labelled grid (a run's base and variants side by side)."""

from __future__ import annotations

import io
from collections.abc import Sequence
from pathlib import Path

from scenemosaic.scene import write_atomic

__all__ = ["contact_sheet"]

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
    from PIL import Image, ImageDraw, ImageFont

    cols = min(columns, len(tiles))
    rows = (len(tiles) + cols - 1) // cols
    if tile_px is None:
        with Image.open(tiles[0][1]) as first:
            tile_px = max(first.size)
    sheet = Image.new("RGB", (cols * tile_px, rows * (tile_px + LABEL_PX)), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    try:
        font: ImageFont.FreeTypeFont | ImageFont.ImageFont = ImageFont.load_default(size=TITLE_FONT_PX)
    except (OSError, ValueError, ImportError):
        font = ImageFont.load_default()
    for i, (label, path) in enumerate(tiles):
        x, y = (i % cols) * tile_px, (i // cols) * (tile_px + LABEL_PX)
        with Image.open(path) as view:
            tile = view.convert("RGB")
            if tile.size != (tile_px, tile_px):
                tile = tile.resize((tile_px, tile_px))
            sheet.paste(tile, (x, y + LABEL_PX))
        draw.text((x + 10, y + 6), label, fill=(25, 25, 30), font=font)
    buf = io.BytesIO()
    sheet.save(buf, format="PNG")
    write_atomic(target, buf.getvalue())
    return target
