"""Procedural pictures and haptic maps for the example scenes (no files, no randomness without a seed).

:func:`garden_layers` draws a small plant landscape (sky, leaves, soil) and the haptic maps
that go with it, like the "stiffness map", "friction map" and "roughness map" of the
KinesTouch picture use case (004 Sec. 6). The shipped PNGs of the ``garden`` scene are
these layers (see ``scenes/SOURCES.md``); every layer is grey 0..1.
"""

from __future__ import annotations

import numpy as np

__all__ = ["garden_layers"]


def garden_layers(nx: int = 96, ny: int = 72, seed: int = 7) -> dict[str, np.ndarray]:
    """Layers (ny, nx) in [0, 1]: ``picture``, ``stiffness``, ``friction``, ``roughness``.

    Regions: sky (top third: bright; stiff, neutral friction, smooth), leaves (ellipses in
    the middle: mid grey; soft, slippery, rough), soil (bottom quarter: dark; stiff-ish,
    sticky, roughest). Row 0 is the top of the picture.
    """
    rng = np.random.default_rng(seed)
    y, x = np.mgrid[0:ny, 0:nx] / np.array([ny, nx]).reshape(2, 1, 1)
    pic = np.where(y < 0.35, 0.85 - 0.2 * y, 0.55)
    stiff = np.where(y < 0.35, 1.0, 0.6)
    fric = np.full((ny, nx), 0.5)
    rough = np.zeros((ny, nx))
    leaves = np.zeros((ny, nx), dtype=bool)
    for _ in range(14):
        cx, cy = rng.uniform(0.05, 0.95), rng.uniform(0.35, 0.75)
        a, b, th = rng.uniform(0.05, 0.12), rng.uniform(0.02, 0.05), rng.uniform(0, np.pi)
        dx, dy = x - cx, (y - cy) * ny / nx
        u = dx * np.cos(th) + dy * np.sin(th)
        v = -dx * np.sin(th) + dy * np.cos(th)
        leaves |= (u / a) ** 2 + (v / b) ** 2 <= 1.0
    pic = np.where(leaves, 0.35 + 0.1 * np.sin(40 * x), pic)
    stiff = np.where(leaves, 0.15, stiff)
    fric = np.where(leaves, 0.25, fric)
    rough = np.where(leaves, 0.5, rough)
    soil = y >= 0.78
    pic = np.where(soil, 0.2 + 0.1 * rng.random((ny, nx)), pic)
    stiff = np.where(soil, 0.7, stiff)
    fric = np.where(soil, 0.9, fric)
    rough = np.where(soil, 1.0, rough)
    return {"picture": np.clip(pic, 0, 1), "stiffness": stiff, "friction": fric, "roughness": rough}
