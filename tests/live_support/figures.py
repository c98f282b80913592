"""Checks on written figures that look at what was drawn, not at the file's size.

A PNG is decoded by Pillow (independent of matplotlib, which wrote it) and must be a real
image of at least the given size whose ink (pixels that differ from the background colour)
covers a share of the canvas and is spread over it, so an empty canvas, a figure with one
stray line or a crushed thumbnail fails where a byte count would pass.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image

__all__ = ["assert_png_drawn"]


def assert_png_drawn(path: Path, min_width: int = 300, min_height: int = 200, min_ink: float = 0.02,
                     min_cells: int = 5) -> np.ndarray:
    """Assert ``path`` is a PNG of at least ``min_width`` x ``min_height`` px whose non-background
    pixels cover at least ``min_ink`` of the canvas and reach at least ``min_cells`` of the
    cells of a 4 x 4 grid. Returns the (h, w, 3) uint8 image."""
    with Image.open(path) as im:
        assert im.format == "PNG", f"{path}: {im.format}"
        rgb = np.asarray(im.convert("RGB"))
    h, w, _ = rgb.shape
    assert w >= min_width and h >= min_height, f"{path}: {w}x{h} px"
    flat = rgb.reshape(-1, 3)
    colours, counts = np.unique(flat, axis=0, return_counts=True)
    background = colours[np.argmax(counts)]
    ink = np.any(rgb != background, axis=2)
    assert ink.mean() >= min_ink, f"{path}: {ink.mean():.3%} of the canvas drawn"
    cells = sum(bool(ink[i * h // 4:(i + 1) * h // 4, j * w // 4:(j + 1) * w // 4].any())
                for i in range(4) for j in range(4))
    assert cells >= min_cells, f"{path}: ink in {cells} of 16 cells"
    assert len(colours) >= 8, f"{path}: {len(colours)} colours"
    return rgb
