"""The one resolver of a MESH argument or option (``surfhap shape``, ``shape calibrate``,
``serve --mesh``): a mesh file, a greyscale image (a height map), or a built-in name."""

from __future__ import annotations

from pathlib import Path

from surfhap.errors import ConfigError, MeshFormatError

__all__ = ["load_surface", "IMAGE_SUFFIXES"]

IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp"}


def load_surface(mesh: str, *, up: str = "z", scale: float = 1.0, size: float | None = None,
                 resolution: float | None = None, pixel_size: float | None = None, height: float | None = None):
    """Resolve MESH (file, image, or built-in name) to a TopSurface; ``size`` (m) rescales and
    centres it so its larger xy side is ``size``."""
    from surfhap.shape.heightmap import heightmap_surface
    from surfhap.shape.scenes import builtin_shape, builtin_shape_names
    from surfhap.shape.topsurface import TopSurface

    p = Path(mesh)
    if p.exists() and p.suffix.lower() in IMAGE_SUFFIXES:
        if pixel_size is None or height is None:
            raise ConfigError("an image is a height map: give --pixel-size (m) and --height (m for white)", source=mesh)
        return heightmap_surface(p, pixel_size, height)
    if p.exists() or mesh.lower() == "suzanne":
        return TopSurface.from_file(mesh, up=up, scale=scale, size=size)
    surf = builtin_shape(mesh, resolution=resolution)
    if surf is None:
        raise MeshFormatError("no such file, and not a built-in shape (" + ", ".join(
            [n for n in builtin_shape_names() if n.count("-") < 2]) + ", or a scene from 'surfhap scenes')", source=mesh)
    if scale != 1.0 or size is not None or up != "z":
        from surfhap.exchange.mesh import place_mesh

        surf = TopSurface(place_mesh(surf.vertices, up, scale, size, mesh), surf.faces, name=surf.name, source=surf.source)
    return surf
