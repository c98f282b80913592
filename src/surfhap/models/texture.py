"""High-frequency texture models: AR models and banks of them over reference speeds.

A :class:`TextureBank` holds AR models of one quantity (``"cof"``, the textural coefficient
of friction mu_t, or ``"acceleration"`` in m/s^2) at one control rate. Live rendering picks
the model whose reference speed is nearest the finger speed (Otake et al. 2022, Sec. III-B).

:class:`TextureModel` is the interface every texture a Material can hold provides (this
speed-selected bank and :class:`surfhap.models.interpolated.InterpolatedARMABank`): renderers,
the gain plan and the expected spectrum ask it for its model at a (speed, load), never which
kind it is.
"""

from __future__ import annotations

from functools import cached_property
from typing import Annotated, Literal, Protocol

import numpy as np
from pydantic import Field, field_validator

from surfhap.checked import FiniteArray, checked_dataclass
from surfhap.signal.ar import ar_is_stable, ar_moments, ar_psd

__all__ = ["ARModel", "TextureBank", "TextureModel", "TextureSynthesizer", "TEXTURE_QUANTITIES"]

TEXTURE_QUANTITIES = ("cof", "acceleration")


class TextureSynthesizer(Protocol):
    """Streaming synthesis at the control rate: speed (n,) m/s, load (n,) N -> (n,) samples."""

    def process(self, speed: np.ndarray, load: np.ndarray | None = None) -> np.ndarray: ...
    def reset(self) -> None: ...


class TextureModel(Protocol):
    """A texture of one quantity ("cof" or "acceleration") at ``sample_rate`` Hz whose model
    depends on the scan speed (m/s) and load (N): ``psd_at`` gives its one-sided PSD
    (quantity^2/Hz) at freqs (m,) Hz, ``moments_at`` (at (n,) speeds and loads, (2, n)) the
    standard deviations of the texture and of its rate of change (quantity/s) as a band-limited
    signal at ``sample_rate``."""

    quantity: str
    sample_rate: float

    @property
    def max_order(self) -> int: ...
    def synthesizer(self, seed=0) -> TextureSynthesizer: ...
    def psd_at(self, speed: float, load: float, freqs: np.ndarray) -> np.ndarray: ...
    def moments_at(self, speed: np.ndarray, load: np.ndarray) -> np.ndarray: ...


@checked_dataclass
class ARModel:
    """One AR model ``x[n] = sum phi_j x[n-j] + w[n]``, ``w ~ N(0, variance)``.

    coefficients    : (p,) float, prediction coefficients phi.
    variance        : innovation variance (quantity units squared).
    reference_speed : m/s, or None for a model used at every speed.
    """

    coefficients: FiniteArray
    variance: Annotated[float, Field(ge=0, allow_inf_nan=False)]
    reference_speed: float | None = None

    @field_validator("coefficients")
    @classmethod
    def _stable(cls, phi):
        phi = phi.reshape(-1)
        if not ar_is_stable(phi):
            raise ValueError("AR model is unstable (a root of A(z) on or outside the unit circle)")
        return phi

    @property
    def order(self) -> int:
        return int(self.coefficients.size)

    def psd(self, sample_rate: float, freqs: np.ndarray) -> np.ndarray:
        """One-sided PSD (units^2/Hz) at freqs (m,) Hz."""
        return ar_psd(self.coefficients, self.variance, sample_rate, freqs)

    def moments(self, sample_rate: float) -> tuple[float, float]:
        """:func:`~surfhap.signal.ar.ar_moments` at ``sample_rate`` Hz, computed once per rate
        (the model is frozen; the gain plan of every render asks for it)."""
        cache = self.__dict__.setdefault("_moments", {})
        rate = float(sample_rate)
        if rate not in cache:
            cache[rate] = ar_moments(self.coefficients, self.variance, rate)
        return cache[rate]


@checked_dataclass
class TextureBank:
    """AR models of one quantity at one control rate, keyed by reference speed.

    quantity    : "cof" (dimensionless mu_t) or "acceleration" (m/s^2).
    sample_rate : control rate, Hz (2 kHz for Otake's data, 1 kHz for HaTT).
    models      : tuple of ARModel, sorted by reference speed; a single model may have
                  ``reference_speed=None``.
    """

    quantity: Literal[TEXTURE_QUANTITIES]
    sample_rate: Annotated[float, Field(gt=0, allow_inf_nan=False)]
    models: Annotated[tuple[ARModel, ...], Field(min_length=1)]

    @field_validator("models")
    @classmethod
    def _by_speed(cls, models):
        speeds = [m.reference_speed for m in models]
        if None in speeds:
            if len(models) != 1:
                raise ValueError("only a single-model bank may omit reference_speed")
            return models
        if len(set(speeds)) != len(speeds):
            raise ValueError("reference speeds must be distinct")
        return tuple(models[i] for i in np.argsort(speeds))

    @property
    def reference_speeds(self) -> np.ndarray:
        """(m,) float reference speeds in m/s (NaN for a speed-independent model)."""
        return np.array([np.nan if m.reference_speed is None else m.reference_speed for m in self.models])

    @property
    def max_order(self) -> int:
        return max(m.order for m in self.models)

    def synthesizer(self, seed=0):
        """A fresh streaming synthesiser for this bank (see :class:`surfhap.models.synth.ARSynthesizer`).

        (:class:`TextureModel`: the synthesiser's ``process(speed, load)`` returns (n,) samples.)
        """
        from surfhap.models.synth import ARSynthesizer

        return ARSynthesizer(self, seed=seed)

    def psd_at(self, speed: float, load: float, freqs: np.ndarray) -> np.ndarray:
        """:class:`TextureModel`: the model nearest ``speed`` (the load does not select)."""
        return self.models[int(self.select(np.array([speed]))[0])].psd(self.sample_rate, freqs)

    def moments_at(self, speed: np.ndarray, load: np.ndarray) -> np.ndarray:
        """:class:`TextureModel`: (2, n) sd and slope sd of the model nearest each speed (n,)."""
        return np.array(self.moments).T[:, self.select(speed)]

    @cached_property
    def moments(self) -> list[tuple[float, float]]:
        """(sd, slope sd) of each model at the bank's sample rate (see :meth:`ARModel.moments`)."""
        return [m.moments(self.sample_rate) for m in self.models]

    def select(self, speed: np.ndarray) -> np.ndarray:
        """Index of the nearest-reference-speed model for each speed (n,) m/s -> (n,) int."""
        from surfhap.models.synth import nearest_model  # compiled (numba): imported when used

        speed = np.ascontiguousarray(speed, dtype=float).ravel()
        out = np.empty(speed.shape, dtype=np.int64)
        nearest_model(self.midpoints, speed, out)
        return out

    @cached_property
    def midpoints(self) -> np.ndarray:
        """(models - 1,) m/s: the speeds half-way between successive reference speeds."""
        refs = self.reference_speeds
        return 0.5 * (refs[1:] + refs[:-1])
