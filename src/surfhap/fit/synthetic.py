"""Synthetic recordings generated from known models, for tests, benchmarks and tutorials.

Nothing here is a material measurement: the laws and AR spectra are whatever the caller
passes in, and the output exists to check that the fitting pipeline recovers them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from scipy.signal import lfilter

from surfhap.exchange.recordings import Recording
from surfhap.models.friction import QuasiStaticLaw

__all__ = ["ar_process", "random_ar", "scale_to_std", "synthetic_friction_recordings", "piecewise_ar",
           "synthetic_accel_recording"]


def ar_process(phi: np.ndarray, variance: float, n: int, rng: np.random.Generator, burn: int = 2000) -> np.ndarray:
    """n samples of ``x[n] = sum phi_j x[n-j] + w``, w ~ N(0, variance) (after a burn-in)."""
    w = rng.standard_normal(n + burn) * np.sqrt(variance)
    return lfilter([1.0], np.concatenate(([1.0], -np.asarray(phi, dtype=float))), w)[burn:]


def random_ar(order: int, rng: np.random.Generator, sample_rate: float, freq_range: tuple = (20.0, 900.0),
              radius_range: tuple = (0.85, 0.97)) -> np.ndarray:
    """Prediction coefficients phi (order,) of a stable AR process whose poles are drawn at
    random: order // 2 resonances with radii uniform in ``radius_range`` and frequencies
    stratified over ``freq_range`` Hz (one uniform draw in each of order // 2 equal slices, so
    the peaks spread over the band as in a broadband texture and the spectrum has no
    valley deeper than a Yule–Walker estimate can resolve), plus one real pole in
    [0.5, 0.9] when the order is odd.

    The order is identifiable from data only when the last coefficient (the product of
    the pole radii) clearly exceeds the sampling noise of a partial autocorrelation,
    about 2 / sqrt(n); the default radii keep |phi_p| >= ~0.02 up to order 40.
    """
    m = order // 2
    edges = np.linspace(freq_range[0], freq_range[1], m + 1)
    f = rng.uniform(edges[:-1], edges[1:]) if m else np.zeros(0)
    r = rng.uniform(*radius_range, m)
    roots = np.concatenate((r * np.exp(2j * np.pi * f / sample_rate), r * np.exp(-2j * np.pi * f / sample_rate)))
    if order % 2:
        roots = np.concatenate((roots, [rng.uniform(0.5, 0.9)]))
    return -np.real(np.poly(roots))[1:]


def scale_to_std(phi: np.ndarray, std: float) -> float:
    """Innovation variance that gives the AR process ``phi`` the standard deviation ``std``
    (from the impulse response of 1 / A(z): var = sigma2 sum h_k^2)."""
    phi = np.asarray(phi, dtype=float)
    imp = np.zeros(1 << 15)
    imp[0] = 1.0
    h = lfilter([1.0], np.concatenate(([1.0], -phi)), imp)
    return float(std**2 / np.sum(h * h))


def synthetic_friction_recordings(
    law: QuasiStaticLaw | Sequence[QuasiStaticLaw],
    textures: Mapping[float, tuple[np.ndarray, float]],
    participants: int = 6,
    duration: float = 60.0,
    sample_rate: float = 2000.0,
    stroke: float = 1.2,
    gap: float = 0.3,
    speed_wobble: float = 0.004,
    loads: Sequence[float] | None = None,
    noise: float = 0.0,
    seed: int = 0,
) -> list[Recording]:
    """One recording per (participant, reference velocity): strokes of ``stroke`` s in
    contact separated by ``gap`` s off the surface.

    In contact, speed = vref + speed_wobble sin(...), normal force = load_p (1 + 0.3 sin(...))
    (both slower than 1 Hz), CoF = law(fn, v) + AR texture of that velocity (``law`` may be
    one law per participant)
    (``textures[vref] = (phi, variance)``) + white noise of std ``noise``.
    """
    rng = np.random.default_rng(seed)
    n = int(round(duration * sample_rate))
    t = np.arange(n) / sample_rate
    period = stroke + gap
    in_contact = (t % period) < stroke
    loads = list(loads) if loads is not None else list(np.linspace(0.35, 0.9, participants))
    laws = list(law) if isinstance(law, (list, tuple)) else [law] * participants
    recs = []
    for p in range(participants):
        for vref, (phi, var) in textures.items():
            ph1, ph2 = rng.uniform(0, 2 * np.pi, 2)
            speed = vref + speed_wobble * np.sin(2 * np.pi * 0.45 * t + ph1)
            fn = loads[p % len(loads)] * (1.0 + 0.3 * np.sin(2 * np.pi * 0.3 * t + ph2))
            mu = laws[p].coefficient(fn, speed) + ar_process(phi, var, n, rng)
            if noise > 0:
                mu = mu + noise * rng.standard_normal(n)
            normal = np.where(in_contact, fn, 0.0)
            shear = np.where(in_contact, mu * fn, 0.0)
            speed_rec = np.where(in_contact, speed, 0.0)
            recs.append(Recording.from_arrays(t, source=f"P{p + 1}_v{vref * 1000:g}.npz", participant=f"P{p + 1}",
                                              trial=f"{vref * 1000:g} mm/s", normal_force=normal, shear_force=shear,
                                              speed=speed_rec))
    return recs


def piecewise_ar(pieces: Sequence[tuple[np.ndarray, float, int]], seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Concatenated AR pieces ``(phi, variance, length)``; each piece continues from the
    previous output history. Returns the signal (n,) and the change points (k - 1,)."""
    rng = np.random.default_rng(seed)
    out = []
    zi_hist = np.zeros(0)
    bounds = []
    pos = 0
    for phi, var, length in pieces:
        phi = np.asarray(phi, dtype=float)
        w = rng.standard_normal(length) * np.sqrt(var)
        p = phi.size
        hist = np.zeros(p)
        if zi_hist.size:
            m = min(p, zi_hist.size)
            hist[:m] = zi_hist[-1 : -m - 1 : -1]
        y = np.empty(length)
        for i in range(length):
            acc = w[i] + phi @ hist
            y[i] = acc
            hist = np.roll(hist, 1)
            if p:
                hist[0] = acc
        out.append(y)
        zi_hist = np.concatenate((zi_hist, y))[-64:]
        pos += length
        bounds.append(pos)
    return np.concatenate(out), np.array(bounds[:-1], dtype=np.int64)


def synthetic_accel_recording(
    pieces: Sequence[tuple[np.ndarray, float, int, float, float]],
    sample_rate: float = 1000.0,
    mu: float | None = None,
    seed: int = 0,
    source: str = "accel.npz",
) -> Recording:
    """A tool-scan recording from AR pieces ``(phi, variance, length, speed m/s, force N)``:
    acceleration from the piecewise AR process, speed and normal force constant per piece
    (plus shear = mu * normal when mu is given)."""
    x, _ = piecewise_ar([(p[0], p[1], p[2]) for p in pieces], seed=seed)
    speed = np.concatenate([np.full(p[2], p[3]) for p in pieces])
    force = np.concatenate([np.full(p[2], p[4]) for p in pieces])
    t = np.arange(x.size) / sample_rate
    extra = {} if mu is None else {"shear_force": mu * force}
    return Recording.from_arrays(t, source=source, participant="tool", acceleration=x, speed=speed, normal_force=force, **extra)
