"""1-D force and intensity profiles of Kim et al.'s formative study (Sec. 3.1, Fig. 5-6).

Geometry: a Gaussian ``y(x) = 1 / (sqrt(2 pi) sigma) exp(-(x - mu)^2 / (2 sigma^2))`` with
mu = 0 and sigma = 0.5 (x, y in cm; eq. 1), over a 5 cm long track (height 0.8 cm). Holes are
the bump inverted. surfhap works in SI: x and heights are in metres (the equation is
evaluated in cm and converted).

Force (Sec. 3.1.1, eq. 2): ``Fpx = -Fpy tan(alpha) = -Fpy dy/dx`` with the assumed normal
force Fpy = 1 N; scanning left to right, it resists the ascent and assists the descent.
Its extremes are about +-0.97 N, so the study used Fsq range (-1, 1) (Sec. 4.2).

Intensity (Sec. 3.1.2): the force range [-1, 1] N is mapped linearly onto the display's
input intensity, -1 N (most resisting) to 1.0. IP0.5 maps 0 N to 0.5 and +1 N to 0.0; IP0.7
keeps the full intensity at -1 N but moves the offset to 0.7, where the measured friction
reaches its median (Sec. 3.1.2), so surfhap reads it as the line through (-1 N, 1.0) and
(0 N, 0.7) (+1 N -> 0.4). These are the paper's raw study profiles over the panel's whole
input range 0..1; the mesh renderer's own map (eq. 9) stays within [0.3, 1.0].

Piecewise-linear versions (Fig. 6b, d): the paper approximates the Gaussian profiles by a few
straight segments without giving the knots; surfhap's knots are the track ends, +-3 sigma,
the force extremes at +-sigma and the summit (documented choice).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from surfhap.errors import ConfigError
from surfhap.results import Result, jsonable

__all__ = [
    "SIGMA",
    "TRACK_LENGTH",
    "profile_height",
    "profile_force",
    "ip_intensity",
    "piecewise_knots",
    "Profile1D",
    "formative_profile",
    "OFFSETS",
]

CM = 0.01  # m per cm
SIGMA = 0.5 * CM  # m (eq. 1: 0.5 cm)
MU = 0.0  # m (eq. 1)
TRACK_LENGTH = 5.0 * CM  # m (Sec. 3.1: 5 cm)
FPY = 1.0  # N, assumed normal force (Sec. 3.1.1)
OFFSETS = {"IP0.5": 0.5, "IP0.7": 0.7}


def profile_height(x: np.ndarray, hole: bool = False) -> np.ndarray:
    """Height (m) of the formative bump (or hole) at x (m): eq. 1 evaluated in cm."""
    xc = (np.asarray(x, dtype=float) - MU) / CM
    sc = SIGMA / CM
    y = np.exp(-(xc**2) / (2 * sc**2)) / (np.sqrt(2 * np.pi) * sc) * CM
    return -y if hole else y


def profile_force(x: np.ndarray, hole: bool = False, fpy: float = FPY) -> np.ndarray:
    """Lateral force (N) for a left-to-right scan at x (m), eq. 2: ``-Fpy dy/dx`` with
    ``dy/dx = -(x - mu) / sigma^2 * y`` (dimensionless)."""
    x = np.asarray(x, dtype=float)
    dydx = -(x - MU) / SIGMA**2 * profile_height(x, hole)
    return -fpy * dydx


def ip_intensity(force: np.ndarray, offset: float = 0.5) -> np.ndarray:
    """IP mapping: force (N) in [-1, 1] to intensity through (-1 N, 1.0) and (0 N, offset),
    clipped to the panel's input range [0, 1]. offset 0.5 is IP0.5, 0.7 is IP0.7."""
    if not 0.0 < offset < 1.0:
        raise ConfigError(f"must be within (0, 1), got {offset}", field="offset")
    f = np.asarray(force, dtype=float)
    return np.clip(offset - (1.0 - offset) * f, 0.0, 1.0)


def piecewise_knots() -> np.ndarray:
    """x (m) of the knots of the piecewise-linear profiles."""
    h = TRACK_LENGTH / 2
    return np.array([-h, -3 * SIGMA, -SIGMA, 0.0, SIGMA, 3 * SIGMA, h]) + MU


@dataclass
class Profile1D(Result):
    """One formative-study profile sampled along the track: x (n,) m, height (n,) m,
    force (n,) N, intensity (n,) in [0, 1]."""

    name: str
    x: np.ndarray
    height: np.ndarray
    force: np.ndarray
    intensity: np.ndarray

    def summary(self) -> dict:
        return jsonable({"name": self.name, "samples": self.x.size, "force_range_n": [self.force.min(), self.force.max()],
                         "intensity_range": [self.intensity.min(), self.intensity.max()]})

    def to_dict(self) -> dict:
        return jsonable({**self.summary(), **asdict(self)})  # x, height m; force N

    def plot(self, ax=None):
        """Geometry, force and intensity along the track (matplotlib Figure), as Fig. 6."""
        from surfhap.report.shape_figures import plot_profile

        return plot_profile(self, ax)


def formative_profile(shape: str = "bump", mapping: str = "IP0.5", piecewise: bool = False, n: int = 501) -> Profile1D:
    """A formative-study profile: shape 'bump' | 'hole', mapping 'IP0.5' | 'IP0.7'; with
    ``piecewise`` the intensity is the piecewise-linear version."""
    if shape not in ("bump", "hole"):
        raise ConfigError(f"unknown shape {shape!r} (bump | hole)", field="shape")
    if mapping not in OFFSETS:
        raise ConfigError(f"unknown mapping {mapping!r} ({' | '.join(OFFSETS)})", field="mapping")
    hole = shape == "hole"
    x = np.linspace(-TRACK_LENGTH / 2, TRACK_LENGTH / 2, int(n)) + MU
    force = profile_force(x, hole)
    inten = ip_intensity(force, OFFSETS[mapping])
    if piecewise:
        k = piecewise_knots()
        inten = np.interp(x, k, ip_intensity(profile_force(k, hole), OFFSETS[mapping]))
    name = f"{shape} {mapping}{' piecewise' if piecewise else ''}"
    return Profile1D(name, x, profile_height(x, hole), force, inten)
