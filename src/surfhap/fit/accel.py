"""The acceleration route (HaTT / Zhao et al.): tool-scan recordings -> interpolated ARMA bank.

For each recording (acceleration, speed, normal force): resample to the texture rate
(1 kHz, as the HaTT models), high-pass the acceleration (hand motion and gravity out),
split it into stationary pieces (:func:`surfhap.signal.segmentation.segment_ar`), and label
each piece with its mean speed and force. Pieces slower than ``min_speed`` or lighter than
``min_force`` are dropped. One AR order common to all pieces (LSF interpolation needs one
order) minimises the summed AIC (or BIC); each piece's Yule–Walker model at that order is
converted to line spectral frequencies. As in HaTT, zero-variance copies of the models on
the speed = 0 and force = 0 axes close the triangulation, so the texture fades to silence
when the tool stops or lifts. A Delaunay triangulation over (speed, force), scaled by their
ranges, completes the :class:`~surfhap.models.interpolated.InterpolatedARMABank`.
Texture force at render time is m_eff x acceleration (Zhao et al.; drive law ``zhao``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
from scipy.signal import butter, resample_poly, sosfiltfilt

from surfhap.errors import ConfigError, RecordingFormatError
from surfhap.exchange.recordings import Recording
from surfhap.fit.friction import CoulombFit, coulomb_from_sums
from surfhap.fit.material_fit import _map, recording_provenance
from surfhap.models.interpolated import InterpolatedARMABank
from surfhap.results import Result, jsonable
from surfhap.signal.ar import information_criteria, levinson_durbin
from surfhap.signal.bands import BandSplit
from surfhap.signal.lsf import ar_to_lsf
from surfhap.signal.segmentation import Segmentation, segment_ar
from surfhap.signal.spectra import average_spectra

__all__ = ["AccelSegment", "AccelFit", "fit_accel", "ORDER_TAPER"]

#: Tukey fraction of the taper on each segment before its Yule–Walker fit (as the friction route)
ORDER_TAPER = 0.5
#: the high-pass (4th order, forward-backward) has power gain 0.5 at 1.1 x its corner; below
#: this multiple of the corner the spectrum is continued flat, above it the gain is divided out
HIGHPASS_FILL = 1.1


@dataclass(frozen=True)
class AccelSegment:
    """One stationary piece: source recording, [start, stop) at the texture rate, mean speed
    m/s and force N, MDL order of the segmentation, the chosen criterion curve (orders
    0..P), the AIC and BIC curves, and the equivalent sample count of the tapered segment."""

    source: str
    start: int
    stop: int
    speed: float
    force: float
    mdl_order: int
    criterion: np.ndarray
    levinson: object
    aic: np.ndarray | None = None
    bic: np.ndarray | None = None
    n_effective: float = 0.0

    @property
    def n(self) -> int:
        return self.stop - self.start


@dataclass(frozen=True)
class AccelFit(Result):
    """Result of :func:`fit_accel`.

    bank           : InterpolatedARMABank (quantity "acceleration").
    segments       : list of AccelSegment kept for models.
    segmentations  : {source: Segmentation}.
    order          : the common AR order; orders / total_criterion : the summed criterion.
    aic_order, bic_order : the minima of the summed AIC and of the summed BIC.
    coulomb        : CoulombFit (from shear / normal) or None when mu0 was given.
    mu0            : the Coulomb coefficient written to the material.
    """

    name: str
    sample_rate: float
    bank: InterpolatedARMABank
    segments: list[AccelSegment]
    segmentations: dict[str, Segmentation]
    order: int
    orders: np.ndarray
    total_criterion: np.ndarray
    criterion: str
    coulomb: CoulombFit | None
    mu0: float
    notes: list
    recordings: list
    signals: dict
    aic_order: int = 0
    bic_order: int = 0

    def to_material(self, command: str = "surfhap fit accel", description: str = ""):
        """Material with Coulomb mu0 and the interpolated acceleration texture."""
        from surfhap.models.material import CoulombSpec, FrictionSpec, InterpolatedTextureSpec, Material, MaterialFile

        prov = recording_provenance(self.recordings, command)
        prov_t = prov(f"{len(self.segments)} segments, AR({self.order}) by summed {self.criterion.upper()} (AIC minimum "
                      f"{self.aic_order}, BIC minimum {self.bic_order}); MA part empty: see docs/fitting.md")
        prov_f = (prov("mu0 = mean shear / mean normal over contact samples") if self.coulomb is not None
                  else prov("mu0 given on the command line (--mu0), not fitted", digest_note=False))
        texture = InterpolatedTextureSpec.of_bank(self.bank, prov_t)
        spec = MaterialFile(name=self.name, description=description or f"Fitted from {len(self.recordings)} acceleration recording(s).",
                            friction=FrictionSpec(coulomb=CoulombSpec(mu0=self.mu0, provenance=prov_f)), texture=texture,
                            notes=list(self.notes))
        return Material.from_spec(spec)

    panels = 4  # of the "summary" figure

    def summary(self) -> dict:
        return jsonable({"name": self.name, "sample_rate": self.sample_rate, "order": self.order,
                         "criterion": self.criterion, "aic_order": self.aic_order, "bic_order": self.bic_order,
                         "segments": len(self.segments), "mu0": self.mu0, "recordings": [r[0] for r in self.recordings],
                         "notes": list(self.notes)})

    def plot(self, ax=None, kind: str = "summary", source: str | None = None):
        """Figures: kind "summary", "segments" (of recording ``source``), "models", "aic" (see
        :mod:`surfhap.report.fit_figures`)."""
        from surfhap.report.fit_figures import plot_accel_fit

        return plot_accel_fit(self, ax, kind, source)


def _resample(x: np.ndarray, fs: float, target: float) -> np.ndarray:
    """Polyphase resampling of the acceleration to the texture rate. ``padtype="line"``: the
    default zero padding makes every channel start and end with a transient."""
    if abs(fs - target) < 1e-9 * target:
        return x
    fr = Fraction(target / fs).limit_denominator(1000)
    return resample_poly(x, fr.numerator, fr.denominator, padtype="line")


def _resample_slow(x: np.ndarray, fs: float, target: float, n_out: int) -> np.ndarray:
    """Speed and force to the texture rate: zero-phase anti-alias low-pass at 0.45 x the lower
    rate (line-through edge extension, so a constant or a ramp passes unchanged up to
    rounding), then linear interpolation onto the model-rate grid (n_out,). A polyphase
    resampler zero-pads the ends (a constant 50 mm/s read 27 mm/s at t = 0) and has a
    DC-gain ripple of ~1e-4 across its phases; these channels only label segments, so a
    slow, exact path is the right one."""
    if abs(fs - target) < 1e-9 * target:
        return x
    y = BandSplit(cutoff=0.45 * min(fs, target)).low(x, fs) if x.size > 2 else x
    return np.interp(np.arange(n_out) / target, np.arange(x.size) / fs, y)


def _segment_recording(rec: Recording, texture_rate, highpass, max_order, min_segment, step, min_speed, min_force, max_segment):
    rec.require("acceleration", "speed", "normal_force")
    fs = rec.sample_rate
    if texture_rate > fs * 1.0001:
        raise RecordingFormatError(f"sampled at {fs:g} Hz, below the texture rate {texture_rate:g} Hz", source=rec.source, field="time")
    acc = _resample(rec.get("acceleration"), fs, texture_rate)
    speed = np.abs(_resample_slow(rec.get("speed"), fs, texture_rate, acc.size))
    force = _resample_slow(rec.get("normal_force"), fs, texture_rate, acc.size)
    comp = {}
    if highpass and highpass > 0:  # HaTT's pre-filter against hand motion and gravity (not the band split)
        if not highpass < texture_rate / 2:
            raise ConfigError(f"must be below {texture_rate / 2:g} Hz", source="--highpass")
        acc = sosfiltfilt(butter(4, highpass, btype="high", fs=texture_rate, output="sos"), acc)
        # a Butterworth high-pass and low-pass of one corner are power complementary: its gain
        # |H_hp|^4 is the texture band's gain (1 - |H_lp|^2)^2 of the band split at that corner
        comp = {"fill_below": HIGHPASS_FILL * highpass, "gain": lambda f: BandSplit(cutoff=highpass).high_gain(f, texture_rate)}
    seg = segment_ar(acc, max_order=max_order, min_length=int(min_segment * texture_rate), step=max(1, int(step * texture_rate)),
                     max_length=None if not max_segment else int(max_segment * texture_rate))
    pieces = []
    for (a, b), p in zip(seg.segments, seg.orders):
        v = float(np.mean(speed[a:b]))
        f = float(np.mean(force[a:b]))
        if v < min_speed or f < min_force:
            continue
        # tapered periodogram; the high-pass's gain divided out where it is >= 0.5 and its
        # notch continued flat below (the all-pole model would otherwise spend its poles on
        # the notch; docs/fitting.md)
        avg = average_spectra([[acc[a:b]]], texture_rate, max_order, taper=ORDER_TAPER, **comp)
        lev = levinson_durbin(avg.autocovariance, max_order)
        pieces.append((a, b, v, f, int(p), lev, avg.n_effective))
    return seg, pieces, {"acceleration": acc, "speed": speed, "force": force}


def fit_accel(
    recordings: Sequence[Recording],
    name: str,
    texture_rate: float = 1000.0,
    highpass: float = 20.0,
    max_order: int = 20,
    criterion: str = "aic",
    min_segment: float = 0.25,
    step: float = 0.025,
    min_speed: float = 0.005,
    min_force: float = 0.1,
    mu0: float | None = None,
    jobs: int = 1,
    max_segment: float | None = 10.0,
) -> AccelFit:
    """Fit an interpolated acceleration texture (module docstring).

    recordings need acceleration (m/s^2), speed (m/s) and normal_force (N); shear_force (or
    cof) for mu0 unless ``mu0`` is given. min_segment, step, max_segment (None: unlimited) : s;
    min_speed m/s; min_force N.
    """
    if not recordings:
        raise RecordingFormatError("no recordings given")
    criterion = criterion.lower()
    if criterion not in ("aic", "bic"):
        raise ConfigError(f"must be 'aic' or 'bic', got {criterion!r}", source="--criterion")
    results = _map(_segment_recording, [(r, texture_rate, highpass, max_order, min_segment, step, min_speed, min_force, max_segment)
                                        for r in recordings], jobs)
    segments = []
    segmentations = {}
    signals = {}
    for rec, (seg, pieces, sig) in zip(recordings, results):
        segmentations[rec.source] = seg
        signals[rec.source] = sig
        for a, b, v, f, p, lev, n in pieces:
            aic, bic = information_criteria(lev.variances, n)
            segments.append(AccelSegment(rec.source, a, b, v, f, p, aic if criterion == "aic" else bic, lev, aic, bic, float(n)))
    if not segments:
        raise RecordingFormatError(f"no stationary segment with speed >= {min_speed * 1000:g} mm/s and force >= {min_force:g} N",
                                   source=recordings[0].source, field="speed")
    total = np.sum([s.criterion for s in segments], axis=0)
    orders = np.arange(total.size)
    order = int(1 + np.argmin(total[1:]))
    aic_order = int(1 + np.argmin(np.sum([s.aic for s in segments], axis=0)[1:]))
    bic_order = int(1 + np.argmin(np.sum([s.bic for s in segments], axis=0)[1:]))
    models = [s.levinson.order(order) for s in segments]
    lsfs = np.array([ar_to_lsf(phi) for phi, _ in models])
    variances = np.array([var for _, var in models])
    speeds = np.array([s.speed for s in segments])
    forces = np.array([s.force for s in segments])
    # zero-variance edge models (HaTT): copies on the speed = 0 and force = 0 axes, and the origin
    vmax, fmax = speeds.max(), forces.max()
    sx, sy = max(np.ptp(speeds), vmax, 1e-6), max(np.ptp(forces), fmax, 1e-6)
    pts = [(v, f, i, var) for i, (v, f, var) in enumerate(zip(speeds, forces, variances))]
    pts += [(0.0, f, i, 0.0) for i, f in enumerate(forces)]
    pts += [(v, 0.0, i, 0.0) for i, v in enumerate(speeds)]
    nearest0 = int(np.argmin((speeds / sx) ** 2 + (forces / sy) ** 2))
    pts.append((0.0, 0.0, nearest0, 0.0))
    seen = {}
    for v, f, i, var in pts:
        key = (round(v / sx, 9), round(f / sy, 9))
        if key not in seen:
            seen[key] = (v, f, i, var)
    uniq = list(seen.values())
    bank = InterpolatedARMABank.from_models(
        "acceleration", texture_rate, [u[0] for u in uniq], [u[1] for u in uniq], lsfs[[u[2] for u in uniq]],
        [u[3] for u in uniq], max_speed=vmax, max_force=fmax)
    notes = [f"{len(segments)} stationary segments from {len(recordings)} recording(s); AR({order}) by summed "
             f"{criterion.upper()} (AIC minimum {aic_order}, BIC minimum {bic_order}; Tukey {ORDER_TAPER:g} taper per segment"
             + (f", high-pass notch below {2 * highpass:g} Hz continued flat" if highpass and highpass > 0 else "")
             + f"); high-pass {highpass:g} Hz; texture rate {texture_rate:g} Hz",
             "MA part left empty (AR-only models): the available ARMA estimators (statsmodels ARIMA, innovations, "
             "Hannan-Rissanen) fit the full band in the time domain, and on high-passed segments of a pure AR texture "
             "BIC then asks for the largest MA order tried and the MA polynomial digs a notch at DC, i.e. the MA part "
             "models the high-pass, not the texture (docs/fitting.md, 'The MA part')"]
    coulomb = None
    if mu0 is None:
        if not all(r.has("shear_force") for r in recordings):
            missing = next(r for r in recordings if not r.has("shear_force"))
            raise RecordingFormatError("missing column, needed for mu0 (or give --mu0)", source=missing.source, field="shear_force")
        sh = fn = 0.0
        n = 0
        for r in recordings:
            f_ = r.get("normal_force")
            s_ = np.abs(r.get("shear_force"))
            c = (f_ > 0.05) & (s_ > 0.05)
            sh += float(s_[c].sum())
            fn += float(f_[c].sum())
            n += int(c.sum())
        coulomb = coulomb_from_sums(sh, fn, n)
        mu = coulomb.mu0
    else:
        if not (np.isfinite(mu0) and 0 <= mu0 <= 5):
            raise ConfigError("must be within 0..5", source="--mu0")
        mu = float(mu0)
    recs = [(r.source, r.participant, r.sha256) for r in recordings]
    return AccelFit(name, float(texture_rate), bank, segments, segmentations, order, orders, total, criterion, coulomb, mu, notes,
                    recs, signals, aic_order, bic_order)
