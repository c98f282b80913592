"""Scalar fields over the content plane: the haptic maps and height fields of a scene.

A field answers ``value(x, y) -> float`` for a point in content coordinates (m, the
display's touch coordinates when the screen is at the workspace centre). ``NaN`` means
"undefined here": an effect driven by a field is inactive where its field is NaN.

Fields are evaluated once per haptic tick, so ``value`` is scalar Python arithmetic on
arrays built up front (a few hundred ns); nothing allocates.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod

import numpy as np

__all__ = ["Field", "ConstantField", "GridField", "RectsField", "MeshHeightField"]

NAN = math.nan


class Field(ABC):
    """Base class: ``value(x, y)`` in the field's unit (documented by its user)."""

    @abstractmethod
    def value(self, x: float, y: float) -> float:
        """The field at (x, y) m."""

    def sample(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Vectorised convenience for figures and tests: (n,) values at (n,) points."""
        return np.array([self.value(float(a), float(b)) for a, b in zip(np.ravel(x), np.ravel(y))]).reshape(np.shape(x))


class ConstantField(Field):
    """The same value everywhere (NaN = nowhere)."""

    def __init__(self, value: float):
        self.v = float(value)

    def value(self, x: float, y: float) -> float:
        return self.v


class GridField(Field):
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
        self.sx = self.nx / self.width  # pixels per metre
        self.sy = self.ny / self.height
        self.outside = float(outside)
        self._rows = self.data.tolist()  # nested lists: scalar reads without numpy overhead

    def value(self, x: float, y: float) -> float:
        u = (x - self.x0) * self.sx - 0.5
        v = (y - self.y0) * self.sy - 0.5
        if not (-0.5 <= u <= self.nx - 0.5 and -0.5 <= v <= self.ny - 0.5):
            return self.outside
        nx1, ny1 = self.nx - 1, self.ny - 1
        if u < 0.0:
            u = 0.0
        elif u > nx1:
            u = float(nx1)
        if v < 0.0:
            v = 0.0
        elif v > ny1:
            v = float(ny1)
        i = int(u)
        j = int(v)
        fu = u - i
        fv = v - j
        i1 = i + 1 if i < nx1 else i
        j1 = j + 1 if j < ny1 else j
        r0 = self._rows[j]
        r1 = self._rows[j1]
        top = r0[i] + fu * (r0[i1] - r0[i])
        bot = r1[i] + fu * (r1[i1] - r1[i])
        return top + fv * (bot - top)


class RectsField(Field):
    """Piecewise field of axis-aligned rectangles; the last rectangle containing the point wins.

    rects   : sequence of ``(x0, y0, x1, y1, value)``; a value may be a float or a callable
              ``f(x, y) -> float`` (stairs are ramps).
    default : value where no rectangle contains the point (NaN = undefined).
    """

    def __init__(self, rects, default: float = NAN):
        self.rects = [(float(a), float(b), float(c), float(d), v) for a, b, c, d, v in rects]
        for a, b, c, d, _ in self.rects:
            if not (c > a and d > b):
                raise ValueError("a rectangle needs x1 > x0 and y1 > y0")
        self.default = float(default)

    def value(self, x: float, y: float) -> float:
        for k in range(len(self.rects) - 1, -1, -1):
            a, b, c, d, v = self.rects[k]
            if a <= x <= c and b <= y <= d:
                return v(x, y) if callable(v) else v
        return self.default


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
