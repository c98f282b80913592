"""Fit a texture model from an IMU recording of a tool stroked over a real surface.

Steps (the acceleration route of Zhao et al. / HaTT, with the band split of Otake et al.
2022): combine the three axes with DFT321, keep the part above the cut-off (3.5 Hz,
zero-phase Butterworth, :class:`~surfhap.signal.bands.BandSplit`), then fit an AR model by Yule–Walker with the order chosen by AIC
(or fixed, e.g. to the order Otake et al. 2021 report in Table II). The result is a
single-model acceleration :class:`~surfhap.models.texture.TextureBank` at the recording rate.

The order is chosen as in the friction route (docs/fitting.md): one cut-off period is cut
from both ends (the band split's edge transients), the rest is Tukey-tapered and the
band split's DC notch below twice the cut-off is continued flat before Levinson–Durbin,
and AIC/BIC use the equivalent sample count. Without this, AIC chased the notch (it is
14 % of the band at 100 Hz) and chose 29-60 on the HapMat recordings. The coefficients at
the chosen (or fixed) order are the plain Yule–Walker ones on the whole high band, as
before, so fixed-order fits are unchanged.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from surfhap.models.texture import ARModel, TextureBank
from surfhap.results import Result, jsonable
from surfhap.signal.ar import OrderSelection, check_criterion, levinson_durbin, order_selection, yule_walker
from surfhap.signal.bands import BandSplit
from surfhap.signal.filters import dft321
from surfhap.signal.spectra import average_spectra

__all__ = ["ImuTextureFit", "fit_imu_texture"]


@dataclass(frozen=True)
class ImuTextureFit(Result):
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

    panels = 2

    def summary(self) -> dict:
        return jsonable({"order": self.order, "selected_order": self.selection.order, "criterion": self.selection.criterion,
                         "variance": self.variance, "sample_rate": self.sample_rate, "cutoff": self.cutoff,
                         "samples": self.signal.size})

    def to_dict(self) -> dict:
        return jsonable({**self.summary(), "coefficients": self.coefficients, "selection": self.selection.to_dict()})

    def plot(self, ax=None):
        """Recording vs model spectrum, and the order selection (see :mod:`surfhap.report.figures`)."""
        from surfhap.report.figures import plot_imu_fit

        return plot_imu_fit(self, ax)


def fit_imu_texture(accel: np.ndarray, sample_rate: float, *, cutoff: float = 3.5, order: int | None = None,
                    max_order: int = 60, criterion: str = "aic") -> ImuTextureFit:
    """accel (n, 3) m/s^2 at ``sample_rate`` Hz -> :class:`ImuTextureFit`."""
    accel = np.asarray(accel, dtype=float)
    combined = dft321(accel)
    high = BandSplit(cutoff=cutoff).high(combined, sample_rate)
    top = max(max_order, order or 0)
    criterion = check_criterion(criterion)
    if order is not None and order < 1:
        raise ValueError("order must be >= 1")
    if high.size <= top + 1:
        raise ValueError(f"need more than {top + 1} samples for max_order={top}")
    trim = int(round(sample_rate / cutoff))
    core = high[trim:high.size - trim] if high.size > 2 * trim + 4 * (top + 1) else high
    avg = average_spectra([[core]], sample_rate, top, taper=0.5, fill_below=2.0 * cutoff)
    # the order from the tapered, notch-filled spectrum; the coefficients by Yule–Walker on the whole high band
    selection = order_selection(levinson_durbin(avg.autocovariance, top), avg.n_effective, criterion)
    chosen_phi, chosen_var = yule_walker(high, selection.order)
    selection = replace(selection, coefficients=chosen_phi, variance=chosen_var)
    used = selection.order if order is None else int(order)
    phi, var = yule_walker(high, used)
    return ImuTextureFit(high, selection, used, phi, float(var), float(sample_rate), float(cutoff))
