"""Contact sheets: several pictures in one labelled grid (a run's base and variants side by side)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

__all__ = ["contact_sheet"]

LABEL_PX = 28
"""Height of the label strip above each tile, in pixels."""


def contact_sheet(tiles: Sequence[tuple[str, Path]], target: Path, tile_px: int = 512, columns: int = 3) -> Path:
    """Write ``target``: the images ``tiles`` (``(label, png path)``) resized to ``tile_px`` squares
    in a grid of up to ``columns`` columns, each under its label. Returns ``target``."""
    from PIL import Image, ImageDraw, ImageFont

    cols = min(columns, len(tiles))
    rows = (len(tiles) + cols - 1) // cols
    sheet = Image.new("RGB", (cols * tile_px, rows * (tile_px + LABEL_PX)), (255, 255, 255))
    draw = ImageDraw.Draw(sheet)
    try:
        font: ImageFont.FreeTypeFont | ImageFont.ImageFont = ImageFont.load_default(size=20)
    except (OSError, ValueError, ImportError):
        font = ImageFont.load_default()
    for i, (label, path) in enumerate(tiles):
        x, y = (i % cols) * tile_px, (i // cols) * (tile_px + LABEL_PX)
        with Image.open(path) as view:
            sheet.paste(view.convert("RGB").resize((tile_px, tile_px)), (x, y + LABEL_PX))
        draw.text((x + 8, y + 4), label, fill=(25, 25, 30), font=font)
    sheet.save(target)
    return target
