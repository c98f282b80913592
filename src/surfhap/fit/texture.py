"""High-band texture fits: one AR model of the textural CoF per reference velocity.

For each reference velocity the spliced high-band spans of every participant (continuous
runs >= 100 ms with the speed within +-20 mm/s of it, Otake et al. 2022) are collected.
Estimators:

* ``"yule-walker"`` (default, the paper's): the participants' periodograms (each span
  Tukey-tapered) are averaged (:func:`surfhap.signal.spectra.average_spectra`), the bins
  below ``fill_below`` (the band split's DC notch) are continued flat, and the AR model of
  every order comes from the autocovariance of that averaged spectrum (Levinson–Durbin);
  the order is the AIC (or BIC) minimum with n = the equivalent number of samples of the
  tapered spans. Both criteria are kept (``selection.aic_order``, ``selection.bic_order``).
* ``"burg"``: Burg's method over all spans of all participants jointly
  (:func:`surfhap.signal.burg.select_order_burg`), better on short spans; it weights the
  participants by their amount of data instead of equally.

The measured spectrum (Welch, averaged over participants) and the similarity index between
each participant's spectrum and the model (:func:`surfhap.signal.spectra.similarity_index`)
come with every model.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from surfhap.models.texture import ARModel
from surfhap.results import Result, jsonable
from surfhap.signal.ar import OrderSelection, check_criterion, levinson_durbin, order_selection
from surfhap.signal.burg import select_order_burg
from surfhap.signal.spectra import average_spectra, log_spectral_distance, similarity_index, welch_spans

__all__ = ["ESTIMATORS", "VelocityTexture", "fit_velocity_texture"]

ESTIMATORS = ("yule-walker", "burg")


@dataclass(frozen=True)
class VelocityTexture(Result):
    """AR model of the textural CoF at one reference velocity, with its evidence.

    reference_speed : m/s.
    model           : ARModel (reference_speed set).
    selection       : OrderSelection (criteria over candidate orders).
    estimator       : "yule-walker" or "burg".
    n_samples, n_spans : spliced samples and spans used; participants : their labels.
    n_effective     : equivalent samples after the taper (the n of AIC / BIC).
    taper, fill_below : the Tukey fraction and the notch-continuation frequency (Hz or None)
                      used by the Yule–Walker estimator.
    freqs           : (m,) Hz; measured_psd (m,) mean Welch PSD over participants;
    participant_psds: (g, m); model_psd (m,).
    similarity      : (g,) similarity index of each participant's spectrum vs the model,
                      over [f_lo, fs/2]; similarity_pooled: averaged spectrum vs model.
    spectrum_error_db : mean |dB| difference, averaged spectrum vs model, same band.
    """

    reference_speed: float
    model: ARModel
    selection: OrderSelection
    estimator: str
    n_samples: int
    n_spans: int
    participants: tuple
    freqs: np.ndarray
    measured_psd: np.ndarray
    participant_psds: np.ndarray
    model_psd: np.ndarray
    similarity: np.ndarray
    similarity_pooled: float
    spectrum_error_db: float
    sample_rate: float
    band: tuple
    n_effective: float = 0.0
    taper: float = 0.0
    fill_below: float | None = None

    @property
    def similarity_mean(self) -> float:
        return float(np.mean(self.similarity))

    @property
    def similarity_se(self) -> float:
        k = self.similarity.size
        return float(np.std(self.similarity, ddof=1) / np.sqrt(k)) if k > 1 else float("nan")

    def summary(self) -> dict:
        return jsonable({"reference_speed": self.reference_speed, "order": self.model.order, "estimator": self.estimator,
                         "aic_order": self.selection.aic_order, "bic_order": self.selection.bic_order,
                         "n_samples": self.n_samples, "n_spans": self.n_spans, "participants": self.participants,
                         "similarity_mean": self.similarity_mean, "similarity_pooled": self.similarity_pooled,
                         "spectrum_error_db": self.spectrum_error_db})

    def plot(self, ax=None):
        """Measured vs modelled spectrum (see :mod:`surfhap.report.fit_figures`)."""
        from surfhap.report.fit_figures import plot_velocity_spectrum

        return plot_velocity_spectrum(self, ax=ax)


def fit_velocity_texture(
    groups: Sequence[Sequence[np.ndarray]],
    labels: Sequence[str],
    sample_rate: float,
    reference_speed: float,
    max_order: int = 60,
    criterion: str = "aic",
    estimator: str = "yule-walker",
    f_lo: float = 0.0,
    nperseg: int = 256,
    taper: float = 0.0,
    fill_below: float | None = None,
) -> VelocityTexture:
    """Fit one reference velocity from ``groups`` (one list of high-band spans per participant).

    max_order is lowered to a tenth of the spliced samples when data are scarce. ``taper``
    (Tukey fraction) and ``fill_below`` (Hz) go to
    :func:`~surfhap.signal.spectra.average_spectra` (Yule–Walker only); the friction
    pipeline passes 0.5 and twice the band-split cut-off. Raises ValueError when there is
    too little data.
    """
    if estimator not in ESTIMATORS:
        raise ValueError(f"estimator must be one of {ESTIMATORS}, got {estimator!r}")
    criterion = check_criterion(criterion)
    keep = [(lab, [np.asarray(s, dtype=float) for s in g]) for lab, g in zip(labels, groups) if sum(len(s) for s in g) > 0]
    if not keep:
        raise ValueError("no spliced data")
    labels = tuple(lab for lab, _ in keep)
    groups = [g for _, g in keep]
    n_total = sum(s.size for g in groups for s in g)
    n_spans = sum(len(g) for g in groups)
    max_order = int(min(max_order, max(1, n_total // 10)))
    if estimator == "burg":  # Burg needs every span longer than the order
        max_order = int(min(max_order, max(1, min(s.size for g in groups for s in g) - 1)))
    if n_total < 100:
        raise ValueError(f"only {n_total} spliced samples (need >= 100)")
    if estimator == "yule-walker":
        avg = average_spectra(groups, sample_rate, max_order, taper=taper, fill_below=fill_below)
        n_eff = avg.n_effective
        sel = order_selection(levinson_durbin(avg.autocovariance, max_order), n_eff, criterion)
    else:
        n_eff, taper, fill_below = float(n_total), 0.0, None
        sel = select_order_burg([s for g in groups for s in g], max_order=max_order, criterion=criterion)
    model = ARModel(sel.coefficients, sel.variance, reference_speed)
    spectra = [welch_spans(g, sample_rate, nperseg=nperseg) for g in groups]
    freqs, psds = spectra[0][0], np.array([p for _, p in spectra])
    mean_psd = psds.mean(axis=0)
    model_psd = model.psd(sample_rate, freqs)
    model_psd[0] /= 2.0
    if nperseg % 2 == 0:
        model_psd[-1] /= 2.0
    si = np.array([similarity_index(freqs, p, model_psd, f_lo) for p in psds])
    return VelocityTexture(
        float(reference_speed), model, sel, estimator, int(n_total), int(n_spans), labels, freqs, mean_psd, psds, model_psd,
        si, similarity_index(freqs, mean_psd, model_psd, f_lo), log_spectral_distance(freqs, mean_psd, model_psd, f_lo),
        float(sample_rate), (float(f_lo), float(sample_rate) / 2), float(n_eff), float(taper), fill_below,
    )
