"""Display calibration from tribometer recordings (Kim et al. 2017 Sec. 2.2; Otake et al. 2022 eq. 5).

Per recording (one drive level, drive switched on and off along the path, see
:mod:`surfhap.exchange.tribometer`):

* vibratory amplitude: 10-500 Hz band-pass, peak-to-peak swings, mean of the 50 largest
  (Sec. 2.2, Fig. 2c); only swings inside "on" stretches, ``guard`` s away from a switch, count;
* static friction: mean lateral and normal force with the drive off and on (same guard);
  the panel's friction coefficient is ``mu = f_off / fn_off`` and the static friction increase
  at the load of the on stretches is ``df = f_on - mu fn_on`` (Fig. 3b-c).

Across recordings: quadratic fits ``df(level)`` and ``amplitude(level)`` with residuals
(Fig. 2c, 3c), ``mu_panel`` = mean of the per-recording ``mu``. With a voltage input the
electrostatic constant follows from ``f = mu (fn + k V^2)`` (Otake et al. 2022 eq. 5):
``df = mu k V^2``, fitted by least squares through the origin. With an intensity input ``k``
is known only if the amplifier gain (V per unit intensity) is given (Kim et al. assume it
constant); otherwise it is left out (null).

The device curve written to the display file is the static-increase fit by default (the
friction the display adds, what the drive laws plan); ``curve="amplitude"`` writes the
vibratory amplitude fit instead (the quantity of Kim et al. Fig. 2c).

Charge leakage (:func:`fit_leakage`, from DC-drive recordings): charge leaks through the skin,
so a constant (DC) drive attracts the finger less and less: the finger/insulator stack acts as a
first-order high-pass with time constant tau (the residual-charge effect that makes Otake et al.
switch the polarity; the model of :mod:`surfhap.models.panel`). After a DC step to V the
effective voltage is ``V exp(-t/tau)`` and the friction increase ``mu k V^2 exp(-2 t / tau)``.
Method (surfhap's; the papers do not measure it): the lateral force minus ``mu fn`` (mu from
the drive-off stretches) is low-passed (80 Hz, zero phase, to remove the vibration), the
stretches around each switch-on are averaged, and the model ``A exp(-2 t / tau) + c`` after
the onset (0 before it), passed through the same low-pass, is fitted by bounded least squares,
so the filter's smearing of the onset does not bias tau. The recordings must use a DC drive (no
polarity carrier) with on-stretches several tau long.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from surfhap.errors import ConfigError
from surfhap.exchange.tribometer import TribometerRecording
from surfhap.models.device_curve import DeviceCurve
from surfhap.models.display import DISPLAY_FORMAT, DISPLAY_VERSION
from surfhap.results import Result, jsonable
from surfhap.signal.tribometer import QuadraticFit, fit_quadratic, tribometer_amplitude

__all__ = ["LevelMeasure", "Calibration", "measure_recording", "calibrate", "calibrate_display", "CURVES", "LeakageFit",
           "fit_leakage"]

CURVES = ("static", "amplitude")
GUARD = 0.1  # s excluded after each on/off switch: the 10 Hz band-pass settles in ~2 time constants
# of its 2nd-order high-pass run forward and backward (design choice; the paper is silent)


@dataclass(frozen=True)
class LevelMeasure:
    """What one recording measures (SI).

    level        : drive level (intensity, or V).
    amplitude    : N, mean of the 50 largest peak-to-peak swings with the drive on.
    friction_off, friction_on : N, mean lateral force with the drive off / on.
    normal_off, normal_on     : N, mean normal force with the drive off / on.
    mu           : friction coefficient without drive, friction_off / normal_off.
    increase     : N, static friction increase at the on-load, friction_on - mu normal_on.
    source       : file name.
    """

    level: float
    amplitude: float
    friction_off: float
    friction_on: float
    normal_off: float
    normal_on: float
    mu: float
    increase: float
    source: str


def _guarded(on: np.ndarray, guard_samples: int) -> tuple[np.ndarray, np.ndarray]:
    """(on, off) masks without the ``guard_samples`` after each switch (and at the start)."""
    switches = np.flatnonzero(np.r_[True, on[1:] != on[:-1]])
    k = np.arange(on.size)
    near = k - switches[np.searchsorted(switches, k, side="right") - 1] < guard_samples  # samples since the last switch
    return on & ~near, ~on & ~near


def measure_recording(rec: TribometerRecording, guard: float = GUARD) -> LevelMeasure:
    """Amplitude and static friction of one recording (see the module docstring)."""
    if not (np.isfinite(guard) and guard >= 0):
        raise ConfigError("must be >= 0 s", field="guard")
    on, off = _guarded(rec.on, int(round(guard * rec.sample_rate)))
    if on.sum() < 16 or off.sum() < 16:
        raise ConfigError("too few samples with the drive on and off after the switching guard "
                          f"({guard:g} s); record longer on/off stretches", source=rec.source, field="level")
    f_off, f_on = (float(rec.lateral_force[m].mean()) for m in (off, on))
    n_off, n_on = (float(rec.normal_force[m].mean()) for m in (off, on))
    if n_off <= 0:
        raise ConfigError("mean normal force with the drive off must be > 0 N", source=rec.source, field="normal_force")
    mu = f_off / n_off
    amp = tribometer_amplitude(rec.lateral_force, rec.sample_rate, mask=on)
    return LevelMeasure(rec.drive_level, amp, f_off, f_on, n_off, n_on, mu, f_on - mu * n_on, rec.source)


LOWPASS_HZ = 80.0  # removes the vibration (Kim et al.'s grains: > 100 Hz) (design choice)
PRE_S = 0.05  # s before each onset included in the fit (drive off: no increase)
EDGE_S = 0.02  # s at both ends of the window left out (edges of the model's filtering)
MIN_DECAY = 0.5  # the decaying part must be at least half of the onset increase (design choice)


@dataclass(frozen=True)
class LeakageFit:
    """time_constant: s (mean over recordings); per_recording (r,) s; t (m,) s and
    profile (m,) N: the averaged onset of the first recording with its fit ``model`` (m,)."""

    time_constant: float
    per_recording: np.ndarray
    t: np.ndarray
    profile: np.ndarray
    model: np.ndarray


def _step_decay(t: np.ndarray, a: float, tau: float, c: float) -> np.ndarray:
    """The friction increase after a DC step at t = 0: a exp(-2 t / tau) + c, 0 before it."""
    return np.where(t >= 0, a * np.exp(-2.0 * np.maximum(t, 0.0) / tau) + c, 0.0)


def fit_leakage(recordings: Sequence[TribometerRecording]) -> LeakageFit:
    """Leakage time constant from DC-drive recordings (see the module docstring: charge leakage)."""
    from scipy.optimize import curve_fit
    from scipy.signal import butter, sosfiltfilt

    taus, first = [], None
    for rec in recordings:
        on = rec.on
        off = ~on
        mu = float(rec.lateral_force[off].sum() / max(rec.normal_force[off].sum(), 1e-12))
        if rec.sample_rate <= 4 * LOWPASS_HZ:
            raise ConfigError(f"sample rate must exceed {4 * LOWPASS_HZ:g} Hz", source=rec.source, field="time")
        sos = butter(4, LOWPASS_HZ, fs=rec.sample_rate, output="sos")
        d = sosfiltfilt(sos, rec.lateral_force - mu * rec.normal_force)
        pre = int(round(PRE_S * rec.sample_rate))
        edge = int(round(EDGE_S * rec.sample_rate))
        starts = [s for s in np.flatnonzero(on[1:] & ~on[:-1]) + 1 if s >= pre and np.all(~on[s - pre:s])]
        lengths = [int(np.argmin(on[s:])) if not np.all(on[s:]) else on.size - s for s in starts]
        if not starts or min(lengths) < int(0.05 * rec.sample_rate) + edge:
            raise ConfigError("needs switch-on stretches of 70 ms or more after 50 ms off", source=rec.source,
                              field="level")
        m = min(lengths)
        prof = np.mean([d[s - pre:s + m] for s in starts], axis=0)  # (pre + m,)
        t = (np.arange(pre + m) - pre) / rec.sample_rate
        fit_sl = slice(edge, pre + m - edge)

        def model(_x, a, tau, c, t=t, sos=sos, sl=fit_sl):
            return sosfiltfilt(sos, _step_decay(t, a, tau, c))[sl]

        a0 = max(float(np.max(prof) - prof[-1]), 1e-9)
        try:
            (a, tau, c), _ = curve_fit(model, t[fit_sl], prof[fit_sl], p0=(a0, max(t[-1] / 5, 2e-3), float(prof[-1])),
                                       bounds=([0.0, 1e-3, -np.inf], [np.inf, 100.0, np.inf]), maxfev=20000)
        except RuntimeError:
            raise ConfigError("no exponential decay found after switch-on", source=rec.source, field="lateral_force") \
                from None
        if not a > MIN_DECAY * (a + abs(c)):  # a DC drive's increase decays (nearly) to 0
            raise ConfigError("the friction increase does not decay after switch-on (a polarity carrier?)",
                              source=rec.source, field="lateral_force")
        taus.append(float(tau))
        if first is None:
            first = (t, prof, _step_decay(t, a, tau, c))
    if not taus:
        raise ConfigError("no DC recordings given", field="leakage")
    return LeakageFit(float(np.mean(taus)), np.array(taus), *first)


@dataclass(frozen=True)
class Calibration(Result):
    """A display calibration.

    input         : "intensity" or "voltage".
    levels        : (n,) the recorded levels, ascending.
    measures      : per-recording :class:`LevelMeasure`, in level order.
    static_fit, amplitude_fit : :class:`QuadraticFit` of increase and amplitude vs level.
    mu_panel      : panel friction coefficient without drive (mean over recordings).
    k             : N/V^2, electrostatic constant (None for an intensity input without gain).
    k_residuals   : (n,) N, df - mu k V^2 of the physics fit (empty without k).
    curve         : which fit is the device curve ("static" or "amplitude").
    volts_per_unit: V per unit intensity used for k (None if not given / voltage input).
    leakage       : :class:`LeakageFit` from DC-drive recordings, or None.
    """

    input: str
    levels: np.ndarray
    measures: tuple[LevelMeasure, ...]
    static_fit: QuadraticFit
    amplitude_fit: QuadraticFit
    mu_panel: float
    k: float | None
    k_residuals: np.ndarray
    curve: str = "static"
    volts_per_unit: float | None = None
    sources: tuple[str, ...] = field(default=())
    leakage: LeakageFit | None = None

    @property
    def device_fit(self) -> QuadraticFit:
        """The fit statistics of the device curve (residuals, rmse, r2)."""
        return self.static_fit if self.curve == "static" else self.amplitude_fit

    @property
    def level_max(self) -> float:
        return 1.0 if self.input == "intensity" else float(self.levels.max())

    @property
    def device_curve(self) -> DeviceCurve:
        """The measured device curve over [0, level_max] (what the display file carries)."""
        return DeviceCurve.of(self.input, self.device_fit.coefficients, self.level_max,
                              f"{self.curve} fit of {len(self.levels)} tribometer recordings")

    def to_display_json(self, source: str, command: str) -> dict:
        """The display file (``surfhap-display`` version 1) as a JSON-ready dict."""
        doc = {
            "format": DISPLAY_FORMAT,
            "version": DISPLAY_VERSION,
            "k": self.k,
            "mu_panel": self.mu_panel,
            "device_curve": self.device_curve.model_dump(),
            "provenance": {"source": source, "command": command},
            "calibration": {
                "method": "Kim et al. 2017 Sec. 2.2 (10-500 Hz band-pass, mean of the 50 largest peak-to-peak "
                          "amplitudes, static friction increase on/off, quadratic fits); k from "
                          "f = mu (fn + k V^2), Otake et al. 2022 eq. 5",
                "device_curve_quantity": "static friction increase (N)" if self.curve == "static"
                else "peak-to-peak vibration amplitude (N)",
                "coefficient_order": "ascending: F = c0 + c1 level + c2 level^2",
                "levels": self.levels.tolist(),
                "static_increase_N": [m.increase for m in self.measures],
                "amplitude_N": [m.amplitude for m in self.measures],
                "mu_per_recording": [m.mu for m in self.measures],
                **{name: {"coefficients": list(fit.coefficients), "residuals_N": fit.residuals.tolist(),
                          "rmse_N": fit.rmse, "r2": fit.r2}
                   for name, fit in (("static_fit", self.static_fit), ("amplitude_fit", self.amplitude_fit))},
                "k_residuals_N": self.k_residuals.tolist(),
                "volts_per_unit_intensity": self.volts_per_unit,
                "recordings": list(self.sources),
            },
        }
        if self.leakage is not None:
            doc["leakage_time_constant"] = self.leakage.time_constant
            doc["calibration"]["leakage_time_constant_per_recording_s"] = self.leakage.per_recording.tolist()
            doc["calibration"]["leakage_method"] = ("DC-drive onsets: A exp(-2 t / tau) + c through the same "
                                                    "80 Hz low-pass, least squares (surfhap.lab.calibration.fit_leakage)")
        return doc

    panels = 2

    def summary(self) -> dict:
        return jsonable({"input": self.input, "curve": self.curve, "levels": self.levels, "mu_panel": self.mu_panel,
                         "k": self.k, "device_curve": self.device_curve.coefficients, "rmse_N": self.device_fit.rmse,
                         "r2": self.device_fit.r2, "recordings": self.sources})

    def to_dict(self) -> dict:
        """The display file's content (:meth:`to_display_json`) without a provenance command."""
        return jsonable(self.to_display_json(", ".join(self.sources), ""))

    def plot(self, ax=None):
        """Fits of the static increase and amplitude over the level, and their residuals."""
        from surfhap.report.lab_figures import plot_calibration

        return plot_calibration(self, ax)


def calibrate(recordings: Sequence[TribometerRecording], curve: str = "static", guard: float = GUARD,
              volts_per_unit: float | None = None,
              leakage_recordings: Sequence[TribometerRecording] = ()) -> Calibration:
    """Calibrate a display from tribometer recordings at three or more distinct levels;
    ``leakage_recordings`` (DC drive, voltage input) add the leakage time constant."""
    if curve not in CURVES:
        raise ConfigError(f"must be one of {', '.join(CURVES)}", field="curve")
    recs = list(recordings)
    if not recs:
        raise ConfigError("no recordings given", field="recordings")
    kinds = {r.input for r in recs}
    if len(kinds) != 1:
        raise ConfigError("recordings mix intensity and voltage inputs", source=recs[0].source, field="input")
    kind = kinds.pop()
    if volts_per_unit is not None:
        if kind != "intensity":
            raise ConfigError("only for an intensity input", field="volts_per_unit")
        if not (np.isfinite(volts_per_unit) and volts_per_unit > 0):
            raise ConfigError("must be > 0 V", field="volts_per_unit")
    measures = sorted((measure_recording(r, guard) for r in recs), key=lambda m: m.level)
    levels = np.array([m.level for m in measures])
    if np.unique(levels).size < 3:
        raise ConfigError(f"need recordings at three distinct levels or more, got {np.unique(levels).size}",
                          field="level")
    inc = np.array([m.increase for m in measures])
    amp = np.array([m.amplitude for m in measures])
    mu = float(np.mean([m.mu for m in measures]))
    static_fit = fit_quadratic(levels, inc)
    amplitude_fit = fit_quadratic(levels, amp)
    k = None
    k_res = np.zeros(0)
    volts = levels if kind == "voltage" else (levels * volts_per_unit if volts_per_unit else None)
    if volts is not None:
        v2 = volts ** 2
        muk = float(np.sum(inc * v2) / np.sum(v2 * v2))  # least squares of df = (mu k) V^2
        if not muk > 0:
            raise ConfigError("the static friction does not increase with the voltage: no electrostatic constant",
                              field="level")
        k = muk / mu
        k_res = inc - muk * v2
    leak = None
    if leakage_recordings:
        for r in leakage_recordings:
            if r.input != "voltage":
                raise ConfigError("leakage recordings need a voltage input (a DC drive)", source=r.source,
                                  field="input")
        leak = fit_leakage(leakage_recordings)
    return Calibration(kind, levels, tuple(measures), static_fit, amplitude_fit, mu, k, k_res, curve,
                       volts_per_unit, tuple(m.source for m in measures), leak)


#: the public name (``surfhap.calibrate`` is the shape calibration)
calibrate_display = calibrate
