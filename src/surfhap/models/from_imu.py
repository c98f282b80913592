"""Fit a texture model from an IMU recording of a tool stroked over a real surface.

Steps (the acceleration route of Zhao et al. / HaTT, with the band split of Otake et al.
2022): combine the three axes with DFT321, keep the part above the cut-off (3.5 Hz,
zero-phase Butterworth), then fit an AR model by Yule–Walker with the order chosen by AIC
(or fixed, e.g. to the order Otake et al. 2021 report in Table II). The result is a
single-model acceleration :class:`~surfhap.models.texture.TextureBank` at the recording rate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from surfhap.models.texture import ARModel, TextureBank
from surfhap.signal.ar import OrderSelection, autocovariance, levinson_durbin, select_order
from surfhap.signal.filters import band_split, dft321

__all__ = ["ImuTextureFit", "fit_imu_texture"]


@dataclass(frozen=True)
class ImuTextureFit:
    """Result of :func:`fit_imu_texture`.

    signal    : (n,) m/s^2, the high-band DFT321 signal the model was fitted to.
    selection : AIC/BIC over candidate orders (the criterion's choice is ``selection.order``).
    order     : the order used (``selection.order`` unless fixed).
    coefficients (order,), variance: the AR model at ``order``.
    sample_rate : Hz.
    """

    signal: np.ndarray
    selection: OrderSelection
    order: int
    coefficients: np.ndarray
    variance: float
    sample_rate: float
    cutoff: float

    @property
    def bank(self) -> TextureBank:
        return TextureBank("acceleration", self.sample_rate, (ARModel(self.coefficients, self.variance, None),))

    def plot(self, fig=None):
        from surfhap.report.figures import plot_imu_fit

        return plot_imu_fit(self, fig=fig)


def fit_imu_texture(accel: np.ndarray, sample_rate: float, *, cutoff: float = 3.5, order: int | None = None,
                    max_order: int = 60, criterion: str = "aic") -> ImuTextureFit:
    """accel (n, 3) m/s^2 at ``sample_rate`` Hz -> :class:`ImuTextureFit`."""
    accel = np.asarray(accel, dtype=float)
    combined = dft321(accel)
    _, high = band_split(combined, sample_rate, cutoff)
    top = max(max_order, order or 0)
    selection = select_order(high, max_order=top, criterion=criterion)
    if order is None:
        phi, var = selection.coefficients, selection.variance
        used = selection.order
    else:
        if order < 1:
            raise ValueError("order must be >= 1")
        phi, var = levinson_durbin(autocovariance(high, order), order).order(order)
        used = int(order)
    return ImuTextureFit(high, selection, used, phi, float(var), float(sample_rate), float(cutoff))
