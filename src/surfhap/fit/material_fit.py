"""The friction-recording pipeline: recordings -> validated material model (Otake route).

``fit_friction(recordings, name)`` runs, per recording, contact selection and the band
split (:mod:`surfhap.fit.preprocess`); fits Coulomb mu0 and the quasi-static law per
participant and pooled (:mod:`surfhap.fit.friction`); splices the high band at each
reference velocity and fits one AR model per velocity from spectra averaged across
participants (:mod:`surfhap.fit.texture`). The result object turns into a
:class:`~surfhap.models.material.Material` with recording provenance
(:meth:`FrictionFit.to_material`) and into figures (:meth:`FrictionFit.plot`).

Parallelism: ``jobs`` runs the per-recording and per-velocity work with joblib; inside a
``joblib.parallel_backend("dask")`` context (``surfhap.batch.schedulers.joblib_backend``) the same code
runs on a Dask cluster.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from surfhap.errors import ConfigError, RecordingFormatError
from surfhap.exchange.recordings import Recording
from surfhap.fit.friction import CoulombFit, QuasiStaticFit, coulomb_from_sums, fit_quasi_static, summarize_fits
from surfhap.fit.preprocess import PreparedRecording, prepare_friction_recording
from surfhap.fit.texture import VelocityTexture, fit_velocity_texture
from surfhap.results import Result, jsonable
from surfhap.signal.splice import speed_spans

__all__ = ["DEFAULT_REFERENCE_SPEEDS", "FrictionFit", "fit_friction", "recording_provenance"]

#: m/s, Otake et al. 2022
DEFAULT_REFERENCE_SPEEDS = (0.05, 0.075, 0.10, 0.125, 0.15)


def _map(fn, items, jobs: int):
    if jobs == 1 or len(items) <= 1:
        return [fn(*it) for it in items]
    from joblib import Parallel, delayed

    return Parallel(n_jobs=jobs)(delayed(fn)(*it) for it in items)


def recording_provenance(recordings: Sequence[tuple], command: str):
    """A function ``note -> Provenance`` for parameters fitted from ``recordings``, the
    (source, participant, sha256) of each file: their names, comma-separated, and a sha256 over
    their SHA-256 hex digests in order (said in the note unless ``digest_note=False``)."""
    from surfhap.models.material import Provenance

    names = ", ".join(r[0] for r in recordings)
    digest = hashlib.sha256("".join(r[2] for r in recordings).encode()).hexdigest()

    def prov(what: str, digest_note: bool = True) -> Provenance:
        note = f"{what}; sha256 is taken over the per-file SHA-256 hex digests, in the order listed" if digest_note else what
        return Provenance(source="recording", recording=names, sha256=digest, command=command, note=note)

    return prov


@dataclass(frozen=True)
class FrictionFit(Result):
    """Everything fitted from one material's friction recordings.

    name, sample_rate (Hz), cutoff (Hz), reference_speeds (m/s).
    coulomb            : pooled CoulombFit; coulomb_by_participant : list.
    quasi_static       : the law written to the material (mean over participants with
                         across-participant SEs; the pooled fit when one participant).
    quasi_static_pooled, quasi_static_by_participant : the other fits.
    textures           : list of VelocityTexture (velocities with too little data skipped).
    notes              : human-readable remarks (skipped velocities, data amounts).
    low_band           : dict of decimated arrays used for the law fit: fn, v, mu, participant (index).
    example            : dict t, cof, low, high of the longest contact run (for the band-split figure).
    recordings         : (source, participant, sha256) per recording.
    """

    name: str
    sample_rate: float
    cutoff: float
    reference_speeds: tuple
    coulomb: CoulombFit
    coulomb_by_participant: list
    quasi_static: QuasiStaticFit
    quasi_static_pooled: QuasiStaticFit
    quasi_static_by_participant: list
    textures: list[VelocityTexture]
    notes: list
    low_band: dict
    example: dict
    recordings: list
    criterion: str = "aic"
    estimator: str = "yule-walker"
    participants: tuple = field(default_factory=tuple)
    edge_trim: float = 0.0

    def to_material(self, command: str = "surfhap fit friction", description: str = ""):
        """A :class:`~surfhap.models.material.Material` with recording provenance."""
        from surfhap.models.material import ARModelSpec, CoulombSpec, FrictionSpec, Material, MaterialFile, QuasiStaticSpec, TextureSpec

        prov = recording_provenance(self.recordings, command)
        qs = self.quasi_static
        friction = FrictionSpec(
            coulomb=CoulombSpec(mu0=self.coulomb.mu0, provenance=prov("mu0 = mean shear / mean normal over contact samples")),
            quasi_static=QuasiStaticSpec(**qs.params, standard_errors=qs.standard_errors,
                                         provenance=prov(f"quasi-static law, {qs.label}, cut-off {self.cutoff:g} Hz; "
                                                         f"mean R^2 {qs.r2:.3f}; fn in N, v in m/s")),
        )
        texture = None
        if self.textures:
            texture = TextureSpec(
                quantity="cof", sample_rate=self.sample_rate,
                models=[ARModelSpec(coefficients=[float(c) for c in t.model.coefficients], variance=float(t.model.variance),
                                    reference_speed=t.reference_speed,
                                    order_selection=f"{t.selection.criterion.upper()} over orders {int(t.selection.orders[0])}.."
                                                    f"{int(t.selection.orders[-1])} (AIC minimum {t.selection.aic_order}, "
                                                    f"BIC minimum {t.selection.bic_order}, n_eff {t.n_effective:.0f}), "
                                                    f"{t.estimator}, {len(t.participants)} "
                                                    f"participant(s), {t.n_samples} samples in {t.n_spans} spans"
                                                    + (f", Tukey {t.taper:g} taper, notch below {t.fill_below:g} Hz continued flat"
                                                       if t.estimator == "yule-walker" else "")
                                                    + f"; similarity index {t.similarity_mean:.3f}")
                        for t in self.textures],
                provenance=prov(f"high band (>= {self.cutoff:g} Hz) of the CoF, spans >= 100 ms within +-20 mm/s of each "
                                f"reference velocity, {self.edge_trim * 1000:.0f} ms cut from both ends of every contact run"),
            )
        spec = MaterialFile(name=self.name, description=description or f"Fitted from {len(self.recordings)} friction recording(s).",
                            friction=friction, texture=texture, notes=list(self.notes))
        return Material.from_spec(spec)

    panels = 6  # of the "summary" figure

    def summary(self) -> dict:
        qs = self.quasi_static
        return jsonable({"name": self.name, "sample_rate": self.sample_rate, "cutoff": self.cutoff,
                         "participants": self.participants, "mu0": self.coulomb.mu0,
                         "quasi_static": {**qs.params, "r2": qs.r2, "label": qs.label},
                         "textures": [t.summary() for t in self.textures], "notes": list(self.notes)})

    def plot(self, ax=None, kind: str = "summary"):
        """Figures: kind in "band-split", "friction-law", "aic", "spectra", "similarity",
        "summary" (see :mod:`surfhap.report.fit_figures`)."""
        from surfhap.report.fit_figures import plot_friction_fit

        return plot_friction_fit(self, ax, kind)


def _velocity_job(groups, labels, fs, vref, max_order, criterion, estimator, f_lo, taper, fill_below):
    try:
        return fit_velocity_texture(groups, labels, fs, vref, max_order=max_order, criterion=criterion,
                                    estimator=estimator, f_lo=f_lo, taper=taper, fill_below=fill_below)
    except ValueError as exc:
        return str(exc)


def fit_friction(
    recordings: Sequence[Recording],
    name: str,
    cutoff: float = 3.5,
    reference_speeds: Sequence[float] = DEFAULT_REFERENCE_SPEEDS,
    tolerance: float = 0.020,
    min_span: float = 0.100,
    max_order: int = 60,
    criterion: str = "aic",
    estimator: str = "yule-walker",
    decimate_to: float | None = None,
    jobs: int = 1,
    edge_trim: float | None = None,
    taper: float = 0.5,
    fill_below: float | None = None,
) -> FrictionFit:
    """Fit a material from friction recordings (see the module docstring).

    recordings : Recording objects with normal_force, shear_force (or cof) and speed
    (or position), all at one sample rate. cutoff Hz; reference_speeds, tolerance m/s;
    min_span s. ``decimate_to`` (Hz) is the rate of the low-band law fit (default 4 x
    cutoff, twice the low band's Nyquist rate).

    Texture order (docs/fitting.md, "Why the orders were 50-60"): ``edge_trim`` s are cut
    from both ends of every contact run before splicing (default one cut-off period, where
    the band split is an extrapolation); ``taper`` is the Tukey fraction on each span and
    ``fill_below`` Hz (default 2 x cutoff; 0 = off) where the band split's DC notch is
    continued flat before the Yule–Walker fit.
    """
    if edge_trim is None:
        edge_trim = 1.0 / cutoff
    if fill_below is None:
        fill_below = 2.0 * cutoff
    if edge_trim < 0 or not 0 <= taper <= 1 or fill_below < 0:
        raise ConfigError("edge_trim and fill_below must be >= 0 and taper within [0, 1]", source="fit_friction")
    if not recordings:
        raise RecordingFormatError("no recordings given")
    rates = {round(r.sample_rate, 6) for r in recordings}
    if len(rates) > 1:
        raise RecordingFormatError(f"recordings have different sample rates ({', '.join(f'{x:g}' for x in sorted(rates))} Hz); "
                                   "resample them to one rate", source=recordings[0].source, field="time")
    refs = tuple(float(v) for v in reference_speeds)
    if not refs or any(not (v > 0) for v in refs) or len(set(refs)) != len(refs):
        raise ConfigError("reference velocities must be distinct and > 0", source="--reference-velocities")
    prepared: list[PreparedRecording] = _map(prepare_friction_recording, [(r, cutoff) for r in recordings], jobs)
    fs = prepared[0].sample_rate
    participants = tuple(dict.fromkeys(p.participant for p in prepared))
    by_part = {lab: [p for p in prepared if p.participant == lab] for lab in participants}

    # low band
    step = max(1, int(round(fs / (decimate_to or 4.0 * cutoff))))
    pieces = [(k, p, slice(a + step // 2, b, step)) for k, lab in enumerate(participants) for p in by_part[lab] for a, b in p.runs]
    low = {key: np.concatenate([getattr(p, name)[sl] for _, p, sl in pieces])
           for key, name in (("fn", "normal_low"), ("v", "speed_low"), ("mu", "cof_low"))}
    low["participant"] = np.concatenate([np.full(len(p.normal_low[sl]), k) for k, p, sl in pieces])

    def coulomb_of(ps, label="pooled"):
        return coulomb_from_sums(sum(p.shear_sum for p in ps), sum(p.normal_sum for p in ps), sum(p.n_kept for p in ps), label)

    sel = [low["participant"] == k for k in range(len(participants))]
    qs_parts = [fit_quasi_static(low["fn"][m], low["v"][m], low["mu"][m], label=lab) for m, lab in zip(sel, participants)]
    coul_parts = [coulomb_of(by_part[lab], lab) for lab in participants]
    summary = summarize_fits(qs_parts) if len(qs_parts) > 1 else None
    pooled = fit_quasi_static(low["fn"], low["v"], low["mu"], label="pooled",
                              x0=None if summary is None else summary.theta)
    chosen = summary if summary is not None else pooled
    coulomb = coulomb_of(prepared)

    # high band
    notes = []
    jobs_v = []
    trim = int(round(edge_trim * fs))
    valid = {}  # id(recording) -> its contact runs without ``trim`` samples at either end
    for p in prepared:
        ok = valid[id(p)] = np.ones(p.n_kept, dtype=bool)
        for a, b in p.runs:
            ok[a:min(a + trim, b)] = False
            ok[max(b - trim, a):b] = False
    for vref in refs:  # spans never cross from one contact run into the next
        groups = [[p.cof_high[s0:s1] for p in by_part[lab]
                   for s0, s1 in speed_spans(p.speed, fs, vref, tolerance, min_span, valid=valid[id(p)], breaks=p.runs[:, 0])]
                  for lab in participants]
        jobs_v.append((groups, participants, fs, vref, max_order, criterion, estimator, cutoff, taper, fill_below or None))
    results = _map(_velocity_job, jobs_v, jobs)
    textures = []
    for vref, res in zip(refs, results):
        if isinstance(res, str):
            notes.append(f"no texture model at {vref * 1000:g} mm/s: {res}")
        else:
            textures.append(res)
    # example for the band-split figure: the longest run
    best = max(prepared, key=lambda p: int(np.max(p.runs[:, 1] - p.runs[:, 0])))
    i = int(np.argmax(best.runs[:, 1] - best.runs[:, 0]))
    a, b = best.runs[i]
    example = {"t": np.arange(b - a) / fs, "cof": best.cof_low[a:b] + best.cof_high[a:b], "low": best.cof_low[a:b], "high": best.cof_high[a:b],
               "source": best.source}
    recs = [(r.source, r.participant, r.sha256) for r in recordings]
    return FrictionFit(name, fs, float(cutoff), refs, coulomb, coul_parts, chosen, pooled, qs_parts, textures, notes, low,
                       example, recs, criterion, estimator, participants, float(edge_trim))
