"""The electrostatic texture chain: synthesis -> drive law -> resampling -> carrier -> safety.

One :class:`TextureChain` turns blocks of finger state at the control rate into drive samples
at the drive rate. Offline rendering (:func:`surfhap.runtime.offline.render`) and live
rendering run this same object; only the clock and the backend differ.

The chain runs at ``control_rate`` (the control rate, 2 kHz by default, or the texture's model
rate when that is higher). Block contract (``process``): inputs are (n,) float arrays at that
rate for the n samples following the previous block: speed (m/s), load (N) and ``touch_time``, the
time stamp (s, on the chain's clock that starts at 0 on reset) of the freshest touch sample
available at each model sample (``-inf`` if none yet). The output holds the control-rate
envelope and the drive-rate samples that became available (n * drive_rate / control_rate on
average), already through the safety stage.
"""

from __future__ import annotations

from dataclasses import field
from typing import Annotated

import numba
import numpy as np
from pydantic import Field, ValidationInfo, field_validator

from surfhap.checked import checked_dataclass

from surfhap.errors import ConfigError
from surfhap.render.block import RenderBlock
from surfhap.models.material import Material
from surfhap.models.panel import DisplayModel, SimulatedDisplay, display_block
from surfhap.render.carrier import PolarityCarrier, check_carrier
from surfhap.render.drive import DriveBlock, DriveParams, default_method, make_drive_law
from surfhap.render.drive_kernel import law_block
from surfhap.render.gain_plan import GainPlan, OperatingRange, plan_gains
from surfhap.render.hold import drive_tail, tail_state
from surfhap.render.safety import SafetyLimits, SafetyStage
from surfhap.render.texture_source import TextureSource, texture_block
from surfhap.signal.resample import RationalResampler, resample_block

__all__ = ["ChainConfig", "ChainBlock", "TextureChain", "PAPER_CARRIERS", "resolve_carrier"]

# polarity carrier of each method's paper: 001 Sec. II (20 kHz), 003 Sec. IV-D (2 kHz)
PAPER_CARRIERS = {"otake2021": 20000.0, "otake2022": 2000.0}
DEFAULT_CARRIER = 2000.0


def resolve_carrier(carrier: float | None, method: str, drive_rate: int) -> tuple[float, str]:
    """The carrier (Hz) to use and why: the given one, else the paper's for the method, capped at
    half the drive rate (a 20 kHz carrier needs a 40 kHz DAC; the cap is reported)."""
    if carrier is not None:
        return float(carrier), "given"
    want = PAPER_CARRIERS.get(method, DEFAULT_CARRIER)
    if want <= drive_rate / 2:
        why = "paper" if method in PAPER_CARRIERS else "default (2 kHz, as 003)"
        return want, why
    capped = float(np.floor(drive_rate / 2))
    return capped, f"the paper's {want:g} Hz needs a drive rate of {2 * want:g} Hz; capped at half of {drive_rate} Hz"


@checked_dataclass
class ChainConfig:
    """Settings of a texture chain.

    method       : "auto", "otake2022", "otake2021", "zhao", "friction-only" or "square".
    drive_rate   : Hz, DAC rate (2-48 kHz).
    carrier      : Hz, polarity carrier (0 = off, else 2-20 kHz); None = the method's paper
                   (otake2021: 20 kHz, 001 Sec. II; otherwise 2 kHz, 003 Sec. IV-D), capped at
                   half the drive rate (see :func:`resolve_carrier`).
    control_rate : Hz, rate of the chain (friction law, drive envelope); a texture model fitted
                   at a lower rate is synthesised at its own rate and resampled up to it.
    alpha        : V/sqrt(N); None = planned by :func:`surfhap.render.gain_plan.plan_gains` over
                   ``operating_range`` (no saturation at the texture's 99.9th percentile, never
                   above the display's calibrated 1/sqrt(mu_panel k)); a number overrides the plan.
    operating_range : loads and speeds the plan must serve (default 0.1-1.0 N, 0.02-0.3 m/s).
    beta, effective_mass, constant_load, square_frequency, square_amplitude,
    square_reference_load, square_reference_speed, texture_gain: see DriveParams.
    seed         : seed of the texture noise.
    display      : the panel rendered for and simulated (DisplayModel; defaults are assumptions).
    """

    method: str = "auto"
    drive_rate: Annotated[int, Field(ge=2000, le=48000)] = 20000
    carrier: float | None = None
    control_rate: Annotated[int, Field(ge=100)] = 2000
    alpha: Annotated[float, Field(gt=0, allow_inf_nan=False)] | None = None
    beta: float = 1.8
    effective_mass: float = 0.05
    constant_load: float | None = 1.6
    square_frequency: float = 100.0
    square_amplitude: float | None = None
    square_reference_load: float = 0.5
    square_reference_speed: float = 0.1
    texture_gain: float = 1.0
    operating_range: OperatingRange = field(default_factory=OperatingRange)
    seed: int = 0
    limits: SafetyLimits = field(default_factory=SafetyLimits)
    display: DisplayModel = field(default_factory=DisplayModel)

    @field_validator("carrier")
    @classmethod
    def _carrier(cls, carrier: float | None, info: ValidationInfo) -> float | None:
        return None if carrier is None else check_carrier(carrier, info.data.get("drive_rate", 48000))


class ChainBlock(RenderBlock):
    """A :class:`~surfhap.render.block.RenderBlock` of the texture chain: drive (m,) V at the
    drive rate after carrier and safety, load_drive (m,) N held at the drive rate (what the
    safety stage saw), target (n,) N at the control rate, detail the law's rows (5, n): voltage,
    target, mu_low, mu_tex and the texture (material quantity, zeros if none); ``texture`` and
    ``drive_law`` (a :class:`~surfhap.render.drive.DriveBlock`, made when read) read them."""

    __slots__ = ()

    @property
    def texture(self) -> np.ndarray:
        return self.detail[4]

    @property
    def drive_law(self) -> DriveBlock:
        return DriveBlock(*self.detail[:4])


_MAX_SPEED = 10.0  # m/s: no finger slides faster; larger inputs are sensor faults


@numba.njit(cache=True, nogil=True)
def _clean_inputs(speed, load, max_load, max_speed, out):
    # out (2, n): loads outside (0, max_load] and non-finite values become 0; speeds |v| <= max_speed
    for i in range(load.shape[0]):
        ld = load[i]
        out[1, i] = ld if (np.isfinite(ld) and ld > 0.0 and ld <= max_load) else 0.0
        v = speed[i]
        out[0, i] = min(abs(v), max_speed) if np.isfinite(v) else 0.0


@numba.njit(cache=True, nogil=True)
def _drive_tail(voltage, load, touch_time, state, work, index, resampler, safety, drive, load_drive):
    # the envelope up to the drive rate, then the chains' tail (hold, carrier, safety); returns m
    return drive_tail(resample_block(voltage, *resampler, drive), load, touch_time, state, work, index, safety, drive, load_drive)


@numba.njit(cache=True, nogil=True)
def _chain_block(kind, params, speed, load, touch_time, tex, rows, state, work, index, resampler, safety, drive, load_drive,
                 display):
    # a chain block in one call: cleaned inputs (in work; idempotent), the texture into rows[4] (texture_block's tex;
    # None: there already), the law (law_block) into rows[:4] of rows (5, n), the tail, then the simulated
    # display (display_block's args; None: none); returns (drive samples, clipped, touching, friction samples)
    n = load.shape[0]
    clean = work[:, :n]
    _clean_inputs(speed, load, state[8], _MAX_SPEED, clean)
    texture_block(clean[0], tex, rows[4])
    clipped, touching = law_block(kind, params, clean[1], clean[0], rows[4], rows)
    m = _drive_tail(rows[0], load, touch_time, state, work, index, resampler, safety, drive, load_drive)
    return m, clipped, touching, display_block(drive[:m], load_drive[:m], display)


class TextureChain:
    """Stateful processor chain, a :class:`~surfhap.render.block.Renderer`; see the module
    docstring for the block contract."""

    uses_position = False

    def __init__(self, material: Material, config: ChainConfig | None = None):
        cfg = config or ChainConfig()
        self.config = cfg
        self.material = material
        self.alpha_calibrated = cfg.display.calibrated_alpha
        method = cfg.method if cfg.method != "auto" else default_method(material)
        # validate the method against the material before planning (one clear error)
        make_drive_law(method, material, DriveParams(self.alpha_calibrated, cfg.beta, cfg.effective_mass, cfg.constant_load,
                                                     cfg.square_frequency, cfg.square_amplitude, cfg.square_reference_load,
                                                     cfg.square_reference_speed, cfg.texture_gain), cfg.control_rate)
        # Zhao et al. render a 1.6 N load no electrostatic display reaches and scale the voltage
        # down proportionally (Sec. 2.2): the plan does this over the operating range.
        self.plan: GainPlan = plan_gains(
            material, method, cfg.display, cfg.operating_range, cfg.limits, beta=cfg.beta, texture_gain=cfg.texture_gain,
            effective_mass=cfg.effective_mass, constant_load=cfg.constant_load,
            square_reference=(cfg.square_reference_load, cfg.square_reference_speed))
        alpha = cfg.alpha if cfg.alpha is not None else self.plan.alpha
        self.alpha_source = "manual (--alpha)" if cfg.alpha is not None else "plan"
        self.params = DriveParams(alpha, cfg.beta, cfg.effective_mass, cfg.constant_load,
                                  cfg.square_frequency, cfg.square_amplitude, cfg.square_reference_load,
                                  cfg.square_reference_speed, cfg.texture_gain)
        probe = make_drive_law(method, material, self.params, cfg.control_rate)
        self.method = probe.method
        self.carrier_hz, self.carrier_choice = resolve_carrier(cfg.carrier, self.method, int(cfg.drive_rate))
        self.control_rate = int(cfg.control_rate)
        self.texture_rate = None
        if probe.uses_texture:
            rate = material.texture_rate
            if int(rate) != rate:
                raise ConfigError(f"texture model's rate {rate} Hz is not a whole number", field="texture.sample_rate")
            self.texture_rate = int(rate)
            self.control_rate = max(self.control_rate, self.texture_rate)
        if self.control_rate > cfg.drive_rate:
            raise ConfigError(f"drive rate {cfg.drive_rate} Hz is below the control rate {self.control_rate} Hz", field="drive_rate")
        self.law = make_drive_law(self.method, material, self.params, self.control_rate, display=cfg.display,
                                  v_max=cfg.limits.v_max)
        self.synth = TextureSource(material.texture, self.control_rate, seed=cfg.seed) if self.law.uses_texture else None
        self.upsampler = RationalResampler(self.control_rate, int(cfg.drive_rate))
        self.carrier = PolarityCarrier(self.carrier_hz, cfg.drive_rate)
        self.safety = SafetyStage(cfg.drive_rate, cfg.limits)
        self.drive_rate = int(cfg.drive_rate)
        self._max_load = cfg.limits.max_load
        self.latency = self.upsampler.delay
        # closed loop (surfhap.runtime.closed_loop): (DriveBlock, load (n,) N) -> the corrected DriveBlock, before the tail
        self.correction = None
        self._law_kernel = self.law.compiled
        self.reset()

    def reset(self) -> None:
        for proc in (self.synth, self.law, self.upsampler, self.carrier, self.safety, self.correction):
            if proc is not None:
                proc.reset()
        self._state = np.append(tail_state(self.control_rate, self.drive_rate, self.carrier.step), self._max_load)
        self._work = np.zeros((2, 64))  # clean speed, load; then the hold's source times, touch ages
        self._index = np.zeros(64, dtype=np.int64)
        self._resampler, self._safety = self.upsampler.kernel_args(), self.safety.kernel_args()

    def process(self, speed: np.ndarray, load: np.ndarray, touch_time: np.ndarray, x=None, y=None, drive_out=None,
                law_out=None, display: SimulatedDisplay | None = None) -> ChainBlock:
        """One block (see the module docstring); ``x``, ``y`` (the finger position) are not
        used by a texture (:class:`~surfhap.render.block.Renderer` protocol); ``drive_out`` (an
        offline render's kept array) receives the drive samples in place of a new array, and
        ``law_out`` ((5, >= n) rows: voltage, target, mu_low, mu_tex, texture) the law's rows and
        the texture when the block's compiled call makes them; ``display`` (a simulated display
        at the drive and control rates) gets the block's drive (its friction in the block's
        ``friction``)."""
        speed = np.ascontiguousarray(speed, dtype=float)
        load = np.ascontiguousarray(load, dtype=float)
        touch_time = np.ascontiguousarray(touch_time, dtype=float)
        n = speed.shape[0]
        if not (load.shape == touch_time.shape == (n,)):
            raise ValueError("speed, load and touch_time must be (n,) arrays of one length")
        size = n * self.drive_rate // self.control_rate + 2  # the most drive samples the block can give
        if n + size > self._work.shape[1]:  # drive_tail's scratch: n model + up to size drive samples
            self._work, self._index = np.zeros((2, 2 * size)), np.zeros(2 * size, dtype=np.int64)
        drive = np.empty(size) if drive_out is None else drive_out[:size]
        if drive.shape[0] < size:
            raise ValueError(f"drive_out holds {drive.shape[0]} samples, the block needs {size}")
        load_drive = np.empty(size)
        rows = np.empty((5, n)) if law_out is None else law_out[:, :n]  # the law's rows and the texture
        if rows.shape != (5, n):  # the kernels write n columns of 5 rows (numba checks no bounds)
            raise ValueError(f"law_out must hold (5, >= {n}) rows, not {law_out.shape}")
        synth = self.synth
        fused = self._law_kernel if self.correction is None else None
        tex = None if synth is None or fused is None else synth.kernel_args(n)
        if synth is None:
            rows[4] = 0.0
        elif tex is None:  # not synthesised in the compiled call; the models see a physical finger state
            clean = self._work[:, :n]
            _clean_inputs(speed, load, self._max_load, _MAX_SPEED, clean)
            rows[4] = synth.process(clean[0], clean[1])
        if fused is not None:  # texture, law, tail and display in one compiled call
            disp = None if display is None else display.kernel_args(size)
            m, clipped, touching, k = _chain_block(*fused, speed, load, touch_time, tex, rows, self._state, self._work,
                                                   self._index, self._resampler, self._safety, drive, load_drive, disp)
            self.law.count(n, clipped, touching)
            friction = None if display is None else display.friction(k)
        else:
            clean = self._work[:, :n]
            _clean_inputs(speed, load, self._max_load, _MAX_SPEED, clean)
            law = self.law.process(clean[0], clean[1], rows[4])
            if self.correction is not None:
                law = self.correction(law, clean[1])
            rows[:4] = law
            m = _drive_tail(rows[0], load, touch_time, self._state, self._work, self._index, self._resampler, self._safety,
                            drive, load_drive)
            friction = None if display is None else display.process(drive[:m], load_drive[:m])
        return ChainBlock(drive[:m], load_drive[:m], rows[1], rows, friction)
