"""Scalar fields over the content plane: the haptic maps and height fields of a scene.

A field answers ``value(x, y) -> float`` for a point in content coordinates (m, the
display's touch coordinates when the screen is at the workspace centre). ``NaN`` means
"undefined here": an effect driven by a field is inactive where its field is NaN.

The built-in constant, grid and rectangle fields are *packed*: ``packed`` is a float array
whose law (:func:`surfhap.ff.effect_kernel.value`) the compiled haptic tick evaluates, built up
front (nothing allocates per tick). A field without ``packed`` (a subclass's own ``value``, a
mesh) is evaluated in Python, and its effect with it.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import NamedTuple

import numpy as np

from surfhap.ff import effect_kernel as ek

__all__ = ["Field", "ConstantField", "GridField", "RectsField", "MeshHeightField", "Ramp"]

NAN = math.nan


class Field(ABC):
    """Base class: ``value(x, y)`` in the field's unit (documented by its user)."""

    packed: np.ndarray | None = None  # the compiled layout, None = Python only

    @abstractmethod
    def value(self, x: float, y: float) -> float:
        """The field at (x, y) m."""


class _Packed(Field):
    def value(self, x: float, y: float) -> float:
        return ek.value(self.packed, 0, float(x), float(y))


class ConstantField(_Packed):
    """The same value everywhere (NaN = nowhere)."""

    def __init__(self, value: float):
        self.v = float(value)
        self.packed = np.array([ek.CONST, self.v])


class GridField(_Packed):
    """A (ny, nx) array spread over the rectangle ``[x0, x0 + width] x [y0, y0 + height]``.

    Row 0 is at ``y0`` (the top of an image when touch y grows downwards), column 0 at
    ``x0``. Values are bilinear between pixel centres; outside the rectangle the field is
    ``outside`` (NaN by default). NaN pixels are allowed (holes in a map).
    """

    def __init__(self, data: np.ndarray, x0: float, y0: float, width: float, height: float, outside: float = NAN):
        a = np.asarray(data, dtype=float)
        if a.ndim != 2 or a.shape[0] < 1 or a.shape[1] < 1:
            raise ValueError("a grid field needs a 2-D array")
        if not (width > 0 and height > 0):
            raise ValueError("a grid field needs a positive size")
        self.data = np.ascontiguousarray(a)
        self.ny, self.nx = a.shape
        self.x0, self.y0, self.width, self.height = float(x0), float(y0), float(width), float(height)
        self.outside = float(outside)
        head = [ek.GRID, self.x0, self.y0, self.nx / self.width, self.ny / self.height, self.nx, self.ny, self.outside]
        self.packed = np.concatenate([head, self.data.ravel()])


class Ramp(NamedTuple):
    """A rectangle's value growing linearly from ``start`` to ``end`` across it along x (``on_x``) or y."""

    on_x: bool
    start: float
    end: float


class RectsField(_Packed):
    """Piecewise field of axis-aligned rectangles; the last rectangle containing the point wins.

    rects   : sequence of ``(x0, y0, x1, y1, value)``; a value is a float or a :class:`Ramp`
              (stairs are ramps).
    default : value where no rectangle contains the point (NaN = undefined).
    """

    def __init__(self, rects, default: float = NAN):
        self.rects = [(float(a), float(b), float(c), float(d), v if isinstance(v, Ramp) else float(v))
                      for a, b, c, d, v in rects]
        rows = []
        for a, b, c, d, v in self.rects:
            if not (c > a and d > b):
                raise ValueError("a rectangle needs x1 > x0 and y1 > y0")
            if isinstance(v, Ramp):  # mode 1 / 2: along x / y from its lower edge over its size
                rows += [a, b, c, d, 1.0 if v.on_x else 2.0, v.start, v.end, a if v.on_x else b, c - a if v.on_x else d - b]
            else:
                rows += [a, b, c, d, 0.0, v, 0.0, 0.0, 1.0]
        self.default = float(default)
        self.packed = np.array([ek.RECTS, len(self.rects), self.default, *rows])


class MeshHeightField(Field):
    """Height of a mesh's top surface under (x, y) (a vertical ray, Kim et al. Sec. 4.1).

    surface : :class:`surfhap.shape.topsurface.TopSurface` in content coordinates (m).
    base    : height where the ray misses the mesh (m).
    """

    def __init__(self, surface, base: float = 0.0):
        self.surface = surface
        self.base = float(base)

    def value(self, x: float, y: float) -> float:
        z, face = self.surface.query_point(x, y)
        return self.base if face < 0 or not math.isfinite(z) else float(z)
