"""Height maps (2-D arrays or greyscale images) as touchable surfaces.

Kim et al.'s earlier work rendered images by their gradient; surfhap renders a height map
with the very same mesh pipeline: each pixel becomes a grid vertex, each 2 x 2 block of
pixels two triangles, so ray casting, gradients, calibration and edges all apply unchanged.

Row 0 of an image is its top edge: it is placed at the largest y, so the picture is seen
the right way up on the screen.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from surfhap.errors import ConfigError, MeshFormatError

__all__ = ["heightmap_mesh", "heightmap_surface", "read_heightmap_image"]

_MAX_PIXELS = 4_000_000


def heightmap_mesh(z: np.ndarray, pixel_size: float, height: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate a height map.

    z          : (ny, nx) float heights, multiplied by ``height`` (m per unit).
    pixel_size : m between neighbouring samples.
    Returns (vertices (ny*nx, 3) float m, faces (2 (ny-1)(nx-1), 3) int), centred on x = y = 0.
    """
    z = np.asarray(z, dtype=float)
    if z.ndim != 2 or z.shape[0] < 2 or z.shape[1] < 2:
        raise ConfigError(f"a height map must be a 2-D array of at least 2 x 2, got shape {z.shape}", field="heightmap")
    if z.size > _MAX_PIXELS:
        raise ConfigError(f"{z.size} pixels is more than {_MAX_PIXELS}; downsample the image", field="heightmap")
    if not np.all(np.isfinite(z)):
        raise ConfigError("the height map contains NaN or inf", field="heightmap")
    if not (np.isfinite(pixel_size) and pixel_size > 0):
        raise ConfigError("must be > 0 m", field="pixel_size")
    if not np.isfinite(height):
        raise ConfigError("must be finite", field="height")
    from surfhap.shape.scenes import _grid_mesh

    ny, nx = z.shape
    xs = (np.arange(nx) - (nx - 1) / 2.0) * pixel_size
    ys = (np.arange(ny) - (ny - 1) / 2.0) * pixel_size
    return _grid_mesh(xs, ys, (z * height)[::-1])  # rows flipped: row 0 (the top) at the largest y


def read_heightmap_image(path: str | Path) -> np.ndarray:
    """Read a greyscale (or colour, converted by luminance) PNG/JPEG as (ny, nx) float in [0, 1]."""
    from PIL import Image, UnidentifiedImageError

    p = Path(path)
    try:
        with Image.open(p) as im:
            img = np.asarray(im.convert("F"), dtype=float)  # luminance, 0..255 for 8-bit
            mode = im.mode
    except FileNotFoundError:
        raise MeshFormatError("no such file", source=str(path)) from None
    except (UnidentifiedImageError, OSError) as exc:
        raise MeshFormatError(f"not a readable image ({exc.__class__.__name__})", source=str(path)) from None
    full = 65535.0 if mode.startswith("I;16") or mode == "I" else 255.0
    return np.clip(img / full, 0.0, 1.0)


def heightmap_surface(source, pixel_size: float, height: float, name: str | None = None):
    """A :class:`~surfhap.shape.topsurface.TopSurface` from a (ny, nx) array or an image path;
    an image's grey level 0..1 becomes 0..``height`` m."""
    from surfhap.shape.topsurface import TopSurface

    if isinstance(source, (str, Path)):
        z = read_heightmap_image(source)
        name = name or Path(source).stem
        src = str(source)
    else:
        z = np.asarray(source, dtype=float)
        name = name or "heightmap"
        src = name
    v, f = heightmap_mesh(z, pixel_size, height)
    return TopSurface(v, f, name=name, source=src)
