"""The electrostatic friction panel: its parameters and its simulation (the embedded default backend).

From drive voltage (drive rate) and finger load to the lateral friction force::

    f_s = mu_panel (fn + k V_eff^2)          (Otake et al. 2022, eq. 5)

or, for a display with a measured device curve ``F(u)``, ``mu_panel fn + F(|V_eff|)``.

``V_eff`` is the voltage that still attracts the finger. Charge leaks through the skin, so
the finger/insulator stack behaves as a first-order high-pass with time constant
``leakage_time_constant``: a DC drive fades (the residual-charge problem that makes Otake et
al. switch polarity, citing Nakamura and Yamamoto 2017) while a polarity carrier keeps
``V_eff^2`` equal to the envelope squared. The friction is low-pass filtered and decimated to
``friction_rate`` (the renderer's control rate in a render) for comparison with the material model.

``mu_panel`` (0.5) and the 50 ms leakage constant are documented assumptions for a
simulated panel, not measurements; the electrostatic constant ``k`` comes from
:class:`~surfhap.models.electrostatics.ElectrostaticStack` (eq. 1 of Zhao et al.) unless a
measured ``k_measured`` is given (``--display k=...`` or a display file,
:mod:`surfhap.exchange.display_file`).
"""

from __future__ import annotations

import numba
import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from surfhap.models.device_curve import DeviceCurve
from surfhap.models.electrostatics import ElectrostaticStack
from surfhap.signal.resample import RationalResampler, resample_block

__all__ = ["DisplayModel", "SimulatedDisplay", "display_block"]


class DisplayModel(BaseModel):
    """Parameters of the panel the drive laws render for and the simulator simulates (SI).

    mu_panel              : panel friction coefficient (assumed 0.5 by default).
    stack                 : finger/insulator stack giving k by eq. 1 (assumed values).
    leakage_time_constant : s, charge leakage of the simulated finger (assumed 50 ms).
    k_measured            : N/V^2, a measured electrostatic constant; overrides the stack's.
    device_curve          : optional measured :class:`~surfhap.models.device_curve.DeviceCurve`
                            (from a display file); when present it is the force -> drive map of
                            every renderer (:meth:`voltage_for_force`).
    source                : where the numbers come from ("assumed defaults", a file, ...).
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    mu_panel: float = Field(0.5, gt=0)
    stack: ElectrostaticStack = ElectrostaticStack()
    leakage_time_constant: float = Field(0.050, gt=0)
    k_measured: float | None = Field(None, gt=0)
    device_curve: DeviceCurve | None = None
    source: str = "assumed defaults (docs/texture.md)"

    @property
    def k(self) -> float:
        """Electrostatic constant, N/V^2 (measured if given, else eq. 1 of the stack)."""
        return float(self.k_measured) if self.k_measured is not None else self.stack.k

    @property
    def area(self) -> float:
        """m^2, contact area of the stack."""
        return self.stack.contact_area

    def describe(self) -> dict:
        """JSON-ready parameters and their source."""
        return {"k_n_per_v2": self.k, "mu_panel": self.mu_panel, "area_m2": self.area,
                "leakage_time_constant_s": self.leakage_time_constant,
                "k_from": "measured" if self.k_measured is not None else "eq. 1 of the stack",
                "device_curve": None if self.device_curve is None else self.device_curve.model_dump(),
                "source": self.source}

    @property
    def calibrated_alpha(self) -> float:
        """Gain V/sqrt(N) for which the added friction equals the target: 1/sqrt(mu_panel k)."""
        return 1.0 / np.sqrt(self.mu_panel * self.k)

    @property
    def curve(self) -> DeviceCurve:
        """The force -> drive relation renderers invert: the measured :attr:`device_curve`, else
        the square law of eq. 5 over voltage, ``F = mu_panel k V^2``."""
        if self.device_curve is not None:
            return self.device_curve
        return DeviceCurve(input="voltage", coefficients=(0.0, 0.0, self.mu_panel * self.k),
                           source="f = mu_panel k V^2 (Otake et al. 2022 eq. 5)")

    def voltage_for_force(self, force: np.ndarray, v_max: float) -> np.ndarray:
        """The display's one force -> voltage map: the drive (n,) V that adds ``force`` (n,) N.

        The inverse of :attr:`curve`: without a measured curve ``alpha sqrt(max(F, 0))`` with
        alpha = :attr:`calibrated_alpha` (the drive laws' compiled tail computes the same); an
        intensity curve's inverse is scaled by ``v_max`` (intensity 1 = the largest drive, V).
        A NaN force stays NaN for the safety stage to catch."""
        curve = self.curve
        u = curve.drive_for_force(force)
        return u if curve.input == "voltage" else u * float(v_max)


_CHUNK = 1024  # drive samples the display filters, then turns into friction, at a time


@numba.njit(cache=True, nogil=True)
def _friction(ve, fn, g, mu, c0, c1, c2, scale, top):
    # the lateral friction (N) at V_eff = ve (V), load fn (N), curve gain g: mu fn + the curve at
    # u = min(|ve| scale, top) while driven, 0 without contact
    u = min(abs(ve) * scale, top)
    added = ((c2 * u + c1) * u + c0) * g
    added = added if u > 0.0 else 0.0
    return mu * fn + added if fn > 0.0 else 0.0


@numba.njit(cache=True, nogil=True, fastmath={"contract"})
def _display_kernel(drive, load, gain, state, p, force, z, Hr, L, M, t0, out):
    # state: [previous drive, previous V_eff]; p: [a, mu, c0, c1, c2, scale, top]; added friction:
    # the display's curve at u = min(|V_eff| scale, top) while driven (c0 + c1 u + c2 u^2; default
    # 0, 0, mu k), times gain[i] (gain[0] when gain holds one value), into force at the drive rate,
    # then decimated into out by the resampler z .. t0; returns the count.
    # The leakage high-pass V_eff[i] = a (V_eff[i-1] + v[i] - v[i-1]) runs two samples per step,
    # V_eff[i+1] = a^2 V_eff[i-1] + (a d[i] + d[i+1]) with d = a (v[i] - v[i-1]): one multiply-add
    # (contracted: fastmath "contract") on the loop-carried path per two samples.
    a, mu, c0, c1, c2, scale, top = p[0], p[1], p[2], p[3], p[4], p[5], p[6]
    a2 = a * a
    pv = state[0]
    ve = state[1]
    n = drive.shape[0]
    for i0 in range(0, n, _CHUNK):  # per chunk (in the cache): V_eff into force, then the friction in place
        i1 = min(i0 + _CHUNK, n)
        d, f, fn = drive[i0:i1], force[i0:i1], load[i0:i1]  # indices from 0: no wraparound, the loops vectorise
        i = 0
        while i + 1 < f.shape[0]:
            v0 = d[i]
            v1 = d[i + 1]
            d0 = a * (v0 - pv)
            f[i] = a * ve + d0
            ve = a2 * ve + (a * d0 + a * (v1 - v0))
            f[i + 1] = ve
            pv = v1
            i += 2
        if i < f.shape[0]:
            ve = a * ve + a * (d[i] - pv)
            pv = d[i]
            f[i] = ve
        if gain.shape[0] > 1:
            g = gain[i0:i1]
            for k in range(f.shape[0]):
                f[k] = _friction(f[k], fn[k], g[k], mu, c0, c1, c2, scale, top)
        else:
            g0 = gain[0]  # a local: the stores to f could alias gain
            for k in range(f.shape[0]):
                f[k] = _friction(f[k], fn[k], g0, mu, c0, c1, c2, scale, top)
    state[0] = pv
    state[1] = ve
    return resample_block(force, z, Hr, L, M, t0, out)


@numba.njit(cache=True, nogil=True)
def display_block(drive, load, args):
    """The display in a renderer's compiled call: ``args`` = :meth:`SimulatedDisplay.kernel_args`
    (:func:`_display_kernel`'s arguments after the load), or None (no display: a compiled
    variant without it); drive, load (m,) at the drive rate; returns the friction samples
    written into the display's out buffer."""
    if args is None:
        return 0
    return _display_kernel(drive, load, args[0], args[1], args[2], args[3][:drive.shape[0]], *args[4:])


class SimulatedDisplay:
    """``process(drive, load) -> friction`` at ``friction_rate``.

    drive (m,) V and load (m,) N at the drive rate; returns the friction force (N) low-passed
    and decimated to ``friction_rate`` (one compiled call per block). The added friction is the
    display's :attr:`DisplayModel.curve` at ``|V_eff|`` (``mu_panel k V_eff^2`` without a
    measured curve; an intensity curve at ``|V_eff| / v_max``), 0 without drive.
    ``gain`` (m,) scales the added friction per drive sample: a drifting k (k(t) / k, the
    closed-loop simulation :mod:`surfhap.sim.closed_loop`); None = 1.
    A renderer runs the same kernel inside its own compiled call (:func:`display_block` on
    :meth:`kernel_args`) and reads the friction from :meth:`friction`.
    """

    def __init__(self, model: DisplayModel, drive_rate: int, friction_rate: int, v_max: float = 250.0):
        self.model = model
        self.drive_rate = int(drive_rate)
        self.friction_rate = int(friction_rate)
        dt = 1.0 / self.drive_rate
        tau = model.leakage_time_constant
        self._a = tau / (tau + dt)
        curve = model.curve
        self._curve = (*curve.coefficients, 1.0 if curve.input == "voltage" else 1.0 / float(v_max), curve.u_max)
        self._state = np.zeros(2)
        self._down = RationalResampler(self.drive_rate, self.friction_rate)
        self.delay = self._down.delay
        self._unit = np.ones(1)
        self._params = np.array([self._a, model.mu_panel, *self._curve], dtype=np.float64)
        self._resampler = self._down.kernel_args()
        self._force = np.empty(0)
        self.kernel_args(0)

    def reset(self) -> None:
        self._state[:] = 0.0
        self._down.reset()

    def kernel_args(self, m: int) -> tuple:
        """:func:`display_block`'s arguments for a block of up to ``m`` drive samples (kept
        scratch, grown when needed): unit gain, state, parameters, the drive-rate friction
        scratch, the decimator and the out buffer."""
        if self._force.shape[0] < max(m, 1):
            self._force = np.empty(max(64, 2 * m))
            self._out = np.empty(self._force.shape[0] * self._down.L // self._down.M + 2)
            self._args = (self._unit, self._state, self._params, self._force, *self._resampler, self._out)
        return self._args

    def friction(self, count: int) -> np.ndarray:
        """The ``count`` friction samples (N) of the last :func:`display_block` (a copy)."""
        return self._out[:count].copy()

    def process(self, drive: np.ndarray, load: np.ndarray, gain: np.ndarray | None = None) -> np.ndarray:
        drive = np.ascontiguousarray(drive, dtype=np.float64)
        load = np.ascontiguousarray(load, dtype=np.float64)
        gain = self._unit if gain is None else np.ascontiguousarray(gain, dtype=np.float64)
        if gain.shape != (1,) and gain.shape != drive.shape:
            raise ValueError("gain must hold one value or one per drive sample")
        self.kernel_args(drive.shape[0])  # the drive-rate friction before decimation: scratch
        out = np.empty(drive.shape[0] * self._down.L // self._down.M + 2)
        m = _display_kernel(drive, load, gain, self._state, self._params, self._force[:drive.shape[0]], *self._resampler, out)
        return out[:m]
