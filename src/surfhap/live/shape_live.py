"""Shapes in the live engine: loading a mesh for a session and its preview picture.

The renderer itself is the shape chain (:class:`surfhap.render.shape_chain.ShapeChain`, a
:class:`~surfhap.render.block.Renderer` like the texture chain); ``LiveShapeRenderer`` is its
name in the live package.
"""

from __future__ import annotations

import numpy as np

from surfhap.render.shape_chain import ShapeChain as LiveShapeRenderer

__all__ = ["LiveShapeRenderer", "load_live_shape", "shape_preview"]


def load_live_shape(path, drive_rate: int, surface_size: tuple[float, float], seed: int = 0, display=None):
    """Mesh file or built-in shape name -> (LiveShapeRenderer, title). The mesh is scaled so its larger xy side
    spans 90 % of the smaller side of the touch surface; a ``MESH.calibration.json`` next
    to it (``surfhap shape calibrate``) is used when present, else it is calibrated now.
    ``display``: the DisplayModel rendered for (None: the documented assumptions)."""
    from pathlib import Path

    from surfhap.exchange.shape_files import default_calibration_path, read_calibration
    from surfhap.render.shape_renderer import ShapeConfig
    from surfhap.shape.calibration import calibrate
    from surfhap.shape.surfaces import load_surface

    size = 0.9 * min(surface_size)
    surface = load_surface(str(path), size=size)  # a file, an image or a built-in name, as `surfhap shape`
    cfg = ShapeConfig(drive_rate=int(drive_rate), seed=seed, **({} if display is None else {"display": display}))
    cal_path = default_calibration_path(path) if Path(path).is_file() else None
    cal = read_calibration(cal_path) if cal_path is not None and cal_path.is_file() else calibrate(surface, fz=cfg.fz)
    return LiveShapeRenderer(surface, cal, cfg, surface_size=surface_size), f"{surface.name} (mesh, {size * 100:.1f} cm)"


def shape_preview(surface, surface_size: tuple[float, float], width: int = 256, height: int = 160) -> dict:
    """Hill-shaded grey image of the mesh over the touch surface (page orientation)."""
    w_m, h_m = surface_size
    xs = (np.arange(width) + 0.5) / width * w_m - w_m / 2
    ys = h_m / 2 - (np.arange(height) + 0.5) / height * h_m
    gx, gy = np.meshgrid(xs, ys)
    z, _ = surface.query(np.column_stack([gx.ravel(), gy.ravel()]))
    z = z.reshape(height, width)
    off = ~np.isfinite(z)
    zf = np.where(off, np.nanmin(z) if np.any(~off) else 0.0, z)
    dzdy, dzdx = np.gradient(zf, h_m / height, w_m / width)
    # light from the upper left (page), normals of the height field
    nx, ny, nz = -dzdx, dzdy, np.ones_like(zf)
    norm = np.sqrt(nx * nx + ny * ny + nz * nz)
    light = np.array([-0.5, 0.5, 0.7])
    light /= np.linalg.norm(light)
    shade = np.clip((nx * light[0] + ny * light[1] + nz * light[2]) / norm, 0, 1)
    img = 0.15 + 0.8 * shade
    img[off] = 0.08
    return {"w": width, "h": height, "data": np.round(255 * img).astype(int).ravel().tolist()}
