"""The electrostatic friction panel: its parameters and its simulation (the embedded default backend).

From drive voltage (drive rate) and finger load to the lateral friction force::

    f_s = mu_panel (fn + k V_eff^2)          (Otake et al. 2022, eq. 5)

``V_eff`` is the voltage that still attracts the finger. Charge leaks through the skin, so
the finger/insulator stack behaves as a first-order high-pass with time constant
``leakage_time_constant``: a DC drive fades (the residual-charge problem that makes Otake et
al. switch polarity, citing Nakamura and Yamamoto 2017) while a polarity carrier keeps
``V_eff^2`` equal to the envelope squared. The friction is low-pass filtered and decimated to
the model rate for comparison with the material model.

``mu_panel`` (0.5) and the 50 ms leakage constant are documented assumptions for a
simulated panel, not measurements; the electrostatic constant ``k`` comes from
:class:`~surfhap.models.electrostatics.ElectrostaticStack` (eq. 1 of Zhao et al.) unless a
measured ``k_measured`` is given (``--display k=...`` or a display file,
:mod:`surfhap.exchange.display_file`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np

from surfhap.models.electrostatics import ElectrostaticStack
from surfhap.signal.resample import RationalResampler

__all__ = ["DisplayModel", "SimulatedDisplay"]


@dataclass(frozen=True)
class DisplayModel:
    """Parameters of the panel the drive laws render for and the simulator simulates (SI).

    mu_panel              : panel friction coefficient (assumed 0.5 by default).
    stack                 : finger/insulator stack giving k by eq. 1 (assumed values).
    leakage_time_constant : s, charge leakage of the simulated finger (assumed 50 ms).
    k_measured            : N/V^2, a measured electrostatic constant; overrides the stack's.
    device_curve          : optional measured (input, (c0, c1, c2)) lateral-force curve, carried
                            from a display file (not used by the texture drive laws).
    source                : where the numbers come from ("assumed defaults", a file, ...).
    """

    mu_panel: float = 0.5
    stack: ElectrostaticStack = field(default_factory=ElectrostaticStack)
    leakage_time_constant: float = 0.050
    k_measured: float | None = None
    device_curve: tuple | None = None
    source: str = "assumed defaults (docs/texture.md)"

    def __post_init__(self):
        if not (np.isfinite(self.mu_panel) and self.mu_panel > 0):
            raise ValueError("mu_panel must be > 0")
        if not (np.isfinite(self.leakage_time_constant) and self.leakage_time_constant > 0):
            raise ValueError("leakage_time_constant must be > 0 s")
        if self.k_measured is not None and not (np.isfinite(self.k_measured) and self.k_measured > 0):
            raise ValueError("k must be > 0 N/V^2")

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
                "device_curve": None if self.device_curve is None else
                {"input": self.device_curve[0], "coefficients": list(self.device_curve[1])},
                "source": self.source}

    @property
    def calibrated_alpha(self) -> float:
        """Gain V/sqrt(N) for which the added friction equals the target: 1/sqrt(mu_panel k)."""
        return 1.0 / np.sqrt(self.mu_panel * self.k)


@numba.njit(cache=True, nogil=True)
def _display_kernel(drive, load, state, a, mu, k, out):
    # state: [previous drive, previous V_eff]
    pv = state[0]
    ve = state[1]
    for i in range(drive.shape[0]):
        v = drive[i]
        ve = a * (ve + v - pv)
        pv = v
        fn = load[i]
        out[i] = mu * (fn + k * ve * ve) if fn > 0.0 else 0.0
    state[0] = pv
    state[1] = ve


class SimulatedDisplay:
    """``process(drive, load) -> friction`` at the model rate.

    drive (m,) V and load (m,) N at the drive rate; returns the friction force (N) low-passed
    and decimated to ``model_rate``. ``last_friction_drive_rate`` keeps the undecimated force of
    the last block and ``last_v_eff`` the effective voltage, for inspection.
    """

    def __init__(self, model: DisplayModel, drive_rate: int, model_rate: int):
        self.model = model
        self.drive_rate = int(drive_rate)
        self.model_rate = int(model_rate)
        dt = 1.0 / self.drive_rate
        tau = model.leakage_time_constant
        self._a = tau / (tau + dt)
        self._k = model.k
        self._state = np.zeros(2)
        self._down = RationalResampler(self.drive_rate, self.model_rate)
        self.delay = self._down.delay
        self.last_friction_drive_rate = np.zeros(0)

    def reset(self) -> None:
        self._state[:] = 0.0
        self._down.reset()

    def process(self, drive: np.ndarray, load: np.ndarray) -> np.ndarray:
        drive = np.ascontiguousarray(drive, dtype=np.float64)
        load = np.ascontiguousarray(load, dtype=np.float64)
        force = np.empty_like(drive)
        _display_kernel(drive, load, self._state, self._a, self.model.mu_panel, self._k, force)
        self.last_friction_drive_rate = force
        return self._down.process(force)
