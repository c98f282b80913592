"""High-frequency texture models: AR models and banks of them over reference speeds.

A :class:`TextureBank` holds AR models of one quantity (``"cof"``, the textural coefficient
of friction mu_t, or ``"acceleration"`` in m/s^2) at one model rate. Live rendering picks
the model whose reference speed is nearest the finger speed (Otake et al. 2022, Sec. III-B).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from surfhap.signal.ar import ar_is_stable, ar_psd

__all__ = ["ARModel", "TextureBank", "TEXTURE_QUANTITIES"]

TEXTURE_QUANTITIES = ("cof", "acceleration")


@dataclass(frozen=True)
class ARModel:
    """One AR model ``x[n] = sum phi_j x[n-j] + w[n]``, ``w ~ N(0, variance)``.

    coefficients    : (p,) float, prediction coefficients phi.
    variance        : innovation variance (quantity units squared).
    reference_speed : m/s, or None for a model used at every speed.
    """

    coefficients: np.ndarray
    variance: float
    reference_speed: float | None = None

    def __post_init__(self):
        phi = np.asarray(self.coefficients, dtype=float).reshape(-1)
        object.__setattr__(self, "coefficients", phi)
        if not np.all(np.isfinite(phi)) or not np.isfinite(self.variance) or self.variance < 0:
            raise ValueError("AR coefficients and variance must be finite, variance >= 0")
        if not ar_is_stable(phi):
            raise ValueError("AR model is unstable (a root of A(z) on or outside the unit circle)")

    @property
    def order(self) -> int:
        return int(self.coefficients.size)

    def psd(self, sample_rate: float, freqs: np.ndarray) -> np.ndarray:
        """One-sided PSD (units^2/Hz) at freqs (m,) Hz."""
        return ar_psd(self.coefficients, self.variance, sample_rate, freqs)

    def moments(self, sample_rate: float) -> tuple[float, float]:
        """Standard deviation of the process (units) and of its rate of change (units/s) at
        ``sample_rate`` Hz, as a band-limited signal: sqrt of the integrals of the PSD and of
        (2 pi f)^2 PSD over 0 to Nyquist (16385 points). Computed once per rate (the model is
        frozen); the gain plan of every render asks for it."""
        cache = self.__dict__.setdefault("_moments", {})
        rate = float(sample_rate)
        if rate not in cache:
            from scipy.signal import freqz

            f, h = freqz([1.0], np.concatenate(([1.0], -self.coefficients)), worN=1 << 14, fs=rate, include_nyquist=True)
            psd = 2.0 * self.variance * np.abs(h) ** 2 / rate
            var = float(np.trapezoid(psd, f))
            slope_var = float(np.trapezoid(psd * (2 * np.pi * f) ** 2, f))
            cache[rate] = (float(np.sqrt(max(var, 0.0))), float(np.sqrt(max(slope_var, 0.0))))
        return cache[rate]


@dataclass(frozen=True)
class TextureBank:
    """AR models of one quantity at one model rate, keyed by reference speed.

    quantity    : "cof" (dimensionless mu_t) or "acceleration" (m/s^2).
    sample_rate : model rate, Hz (2 kHz for Otake's data, 1 kHz for HaTT).
    models      : tuple of ARModel, sorted by reference speed; a single model may have
                  ``reference_speed=None``.
    """

    quantity: str
    sample_rate: float
    models: tuple[ARModel, ...] = field(default_factory=tuple)

    def __post_init__(self):
        if self.quantity not in TEXTURE_QUANTITIES:
            raise ValueError(f"quantity must be one of {TEXTURE_QUANTITIES}, got {self.quantity!r}")
        if not (np.isfinite(self.sample_rate) and self.sample_rate > 0):
            raise ValueError("sample_rate must be positive")
        models = tuple(self.models)
        if not models:
            raise ValueError("a texture bank needs at least one model")
        speeds = [m.reference_speed for m in models]
        if any(s is None for s in speeds):
            if len(models) != 1:
                raise ValueError("only a single-model bank may omit reference_speed")
        else:
            order = np.argsort(speeds)
            models = tuple(models[i] for i in order)
            if len(set(speeds)) != len(speeds):
                raise ValueError("reference speeds must be distinct")
        object.__setattr__(self, "models", models)

    @property
    def reference_speeds(self) -> np.ndarray:
        """(m,) float reference speeds in m/s (NaN for a speed-independent model)."""
        return np.array([np.nan if m.reference_speed is None else m.reference_speed for m in self.models])

    @property
    def max_order(self) -> int:
        return max(m.order for m in self.models)

    def synthesizer(self, seed=0):
        """A fresh streaming synthesiser for this bank (see :class:`surfhap.models.synth.ARSynthesizer`).

        Every texture kind a Material can hold provides ``quantity``, ``sample_rate`` and
        ``synthesizer(seed)``; the synthesiser's ``process(speed, load)`` returns (n,) samples.
        """
        from surfhap.models.synth import ARSynthesizer

        return ARSynthesizer(self, seed=seed)

    def select(self, speed: np.ndarray) -> np.ndarray:
        """Index of the nearest-reference-speed model for each speed (n,) m/s -> (n,) int."""
        speed = np.asarray(speed, dtype=float)
        if len(self.models) == 1:
            return np.zeros(speed.shape, dtype=np.int64)
        speed = np.abs(speed)
        speed = np.where(speed == speed, speed, 0.0)  # NaN -> slowest model
        return np.searchsorted(self._midpoints, speed, side="left")

    @property
    def _midpoints(self) -> np.ndarray:
        mids = self.__dict__.get("_mids")
        if mids is None:
            refs = self.reference_speeds
            mids = 0.5 * (refs[1:] + refs[:-1])
            object.__setattr__(self, "_mids", mids)
        return mids
