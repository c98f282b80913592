"""One HTML page per fit: tables of the fitted parameters and the figures of
:mod:`surfhap.report.fit_figures`, written as PNG files next to ``index.html``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from surfhap.report.html import start_page

__all__ = ["write_friction_report", "write_accel_report"]


def write_friction_report(fit, out_dir: str | Path, command: str = "") -> Path:
    """Write ``out_dir/index.html`` and its figures for a FrictionFit; returns the page path."""
    out, page = start_page(out_dir, f"Friction fit — {fit.name}", command)
    page.paragraph(f"{len(fit.recordings)} recording(s), {len(fit.participants)} participant(s), {fit.sample_rate:g} Hz, "
                   f"cut-off {fit.cutoff:g} Hz, estimator {fit.estimator}, order by {fit.criterion.upper()}.")
    page.heading("Band split")
    page.figure(fit.plot(kind="band-split"), out, "band_split.png", "band split")
    page.heading("Low band: friction laws")
    page.table(["fit", "mu0", "a", "b", "c", "d", "q", "R²", "n"],
               [[c.label, f"{c.mu0:.4f}", *[""] * 6, c.n] for c in [fit.coulomb, *fit.coulomb_by_participant]])
    page.table(["quasi-static fit", "a", "b", "c", "d", "q", "R²", "n"],
               [[q.label, *[f"{q.params[k]:.3f} ± {q.standard_errors[k]:.3f}" for k in "abcdq"], f"{q.r2:.3f}", q.n]
                for q in [fit.quasi_static, fit.quasi_static_pooled, *fit.quasi_static_by_participant]])
    page.paragraph("First row: written to the material (mean ± standard error across participants, as Otake et al. 2022 "
                   "Table I; the pooled fit with asymptotic errors when there is one participant).", cls="note")
    page.figure(fit.plot(kind="friction-law"), out, "friction_law.png", "friction law vs data")
    page.heading("High band: AR models per reference velocity")
    page.table(["velocity (mm/s)", "order", "AIC min", "BIC min", "variance", "samples", "n_eff", "spans", "participants",
                "SI mean ± SE", "SI pooled", "mean |ΔdB|"],
               [[f"{t.reference_speed * 1e3:g}", t.model.order, t.selection.aic_order, t.selection.bic_order,
                 f"{t.model.variance:.3g}", t.n_samples, f"{t.n_effective:.0f}", t.n_spans,
                 len(t.participants), f"{t.similarity_mean:.3f} ± {0 if np.isnan(t.similarity_se) else t.similarity_se:.3f}",
                 f"{t.similarity_pooled:.3f}", f"{t.spectrum_error_db:.2f}"] for t in fit.textures])
    for note in fit.notes:
        page.paragraph(note, cls="bad")
    if fit.textures:
        page.figure(fit.plot(kind="aic"), out, "aic.png", "order selection")
        page.figure(fit.plot(kind="spectra"), out, "spectra.png", "measured vs modelled spectra")
        page.figure(fit.plot(kind="similarity"), out, "similarity.png", "similarity index")
    page.paragraph(f"Order: the {fit.criterion.upper()} minimum (both AIC and BIC minima are listed). n_eff is the "
                   "equivalent number of samples of the tapered spans, the n of both criteria. Before the Yule–Walker "
                   f"fit, {fit.edge_trim * 1000:.0f} ms are cut from both ends of every contact run (band-split edge "
                   "transients), each span is Tukey-tapered and the band split's notch below twice the cut-off is "
                   "continued flat (docs/fitting.md).", cls="note")
    page.paragraph("Similarity index SI = 1 − Σ|S_meas − S_model| / Σ(S_meas + S_model) over the band above the cut-off "
                   "(1: identical spectra; see docs/fitting.md).", cls="note")
    return page.write(out / "index.html")


def write_accel_report(fit, out_dir: str | Path, command: str = "") -> Path:
    """Write ``out_dir/index.html`` and its figures for an AccelFit; returns the page path."""
    out, page = start_page(out_dir, f"Acceleration fit — {fit.name}", command)
    for note in fit.notes:
        page.paragraph(note)
    page.paragraph(f"Coulomb mu0 = {fit.mu0:.4f}" + (" (fitted)" if fit.coulomb is not None else " (given)"))
    page.heading("Segmentation")
    for i, src in enumerate(fit.signals):
        page.figure(fit.plot(kind="segments", source=src), out, f"segments_{i}.png", f"segments of {src}")
    page.table(["recording", "start (s)", "stop (s)", "speed (mm/s)", "force (N)", "MDL order"],
               [[s.source, f"{s.start / fit.sample_rate:.3f}", f"{s.stop / fit.sample_rate:.3f}", f"{s.speed * 1e3:.1f}",
                 f"{s.force:.3f}", s.mdl_order] for s in fit.segments])
    page.heading("Order and models")
    page.figure(fit.plot(kind="aic"), out, "aic.png", "summed criterion")
    page.figure(fit.plot(kind="models"), out, "models.png", "models and triangulation")
    return page.write(out / "index.html")
