"""Drive laws: from finger speed, load and texture to the voltage envelope (control rate).

Every law computes a target lateral force ``F`` (N) that the display should add, then
``V = alpha * sqrt(max(F, 0))``: the electrostatic friction is ``mu_panel * k * V^2``, so with
``alpha = 1 / sqrt(mu_panel * k)`` the added friction equals ``F`` (Zhao et al. eq. 4,
``a = 1 / (mu k)``). The display can only *add* friction: negative targets are clipped to
zero and counted.

=============== =================================================================== ==========
method          target force F                                                       paper
=============== =================================================================== ==========
otake2022       (mu_p(fn, v) + beta mu_t) fn                                         003 eq. 6
otake2021       (mu0 + beta mu_t) fn, beta = 1.8                                     001 eq. 5
zhao            mu0 fn_c + m_eff acc, fn_c = 1.6 N, m_eff = 0.05 kg                  000 eq. 3-4
friction-only   mu_low(fn, v) fn (quasi-static if the material has it, else mu0)     003 Sec. IV-B
square          constant V_sq, 50 % square wave at 30-300 Hz, V_sq^2 = alpha^2 2 F_ref  000 Sec. 3
=============== =================================================================== ==========

beta = 1.8 is the value of 001 (Sec. IV-C, after eq. 5). 003 publishes no beta; it publishes the
resulting friction:texture voltage ratios (Sec. IV-D), which the built-in textures are
calibrated to at beta = 1.8 (:mod:`surfhap.models.texture_calibration`), so one beta serves
both methods (a documented choice).

A texture bank of textural CoF enters as ``mu_t``; a calibrated texture from another modality
(``Material.texture_relative_scale`` s) as ``mu_t = s mu_low(fn, v) x``; an uncalibrated bank
of accelerations as ``mu_t = m_eff acc / fn``. Zhao's law uses ``f_texture = m_eff acc`` (or
``mu_t fn_c`` for a CoF bank). ``texture_gain`` multiplies the texture in every law.

The square baseline (000 Sec. 3: "standard square wave signals with constant amplitude") has a
fixed voltage: ``V_sq = alpha sqrt(2 F_ref)`` with ``F_ref = mu_low(fn_ref, v_ref) fn_ref`` at a
reference load and speed (default 0.5 N, 0.1 m/s), so its mean added friction equals the
friction-only mean there. It does not follow the instantaneous load or speed; a lifted finger
still gets 0 V from the safety stage.

One class per method (:data:`LAWS`), each with one vectorised evaluation, its compiled kernel
in :mod:`surfhap.render.drive_kernel`: rendering (``process``), gain planning
(``low_force``, ``texture_force_per_unit``), the expected spectrum and ``compare`` all call it,
so each equation is written once. :func:`rendering_gain` is the one ``(alpha / alpha_cal)^2``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Annotated, ClassVar, NamedTuple

import numpy as np
from pydantic import Field

from surfhap.checked import checked_dataclass
from surfhap.errors import ConfigError
from surfhap.models.friction import QuasiStaticLaw
from surfhap.models.material import Material

if TYPE_CHECKING:
    from surfhap.models.panel import DisplayModel

__all__ = ["DriveParams", "DriveBlock", "DriveLaw", "Otake2022", "Otake2021", "Zhao", "FrictionOnly", "Square",
           "LAWS", "LowBand", "METHODS", "make_drive_law", "default_method", "rendering_gain"]


def rendering_gain(alpha: float, alpha_calibrated: float) -> float:
    """``G = (alpha / alpha_calibrated)^2``: the display adds G times the law's target force."""
    return float((alpha / alpha_calibrated) ** 2)


@checked_dataclass
class DriveParams:
    """Parameters shared by the drive laws (SI).

    alpha            : V / sqrt(N), gain from target force to voltage.
    beta             : gain of the textural component (Otake et al. 2021: 1.8).
    effective_mass   : kg, hand mass turning acceleration into force (Zhao / HaTT: 0.05).
    constant_load    : N, Zhao's constant load (1.6 N); None uses the measured load.
    square_frequency : Hz, baseline square wave (30-300 Hz, Zhao et al. after Bau et al.).
    square_amplitude : V, fixed baseline amplitude; None matches the friction-only mean at
                       (square_reference_load N, square_reference_speed m/s).
    texture_gain     : multiplier on the texture (1 = the material's calibrated strength).
    """

    alpha: Annotated[float, Field(gt=0, allow_inf_nan=False)]
    beta: Annotated[float, Field(ge=0, allow_inf_nan=False)] = 1.8
    effective_mass: Annotated[float, Field(gt=0, allow_inf_nan=False)] = 0.05
    constant_load: Annotated[float, Field(gt=0, allow_inf_nan=False)] | None = 1.6
    square_frequency: Annotated[float, Field(ge=30.0, le=300.0)] = 100.0
    square_amplitude: Annotated[float, Field(ge=0, allow_inf_nan=False)] | None = None
    square_reference_load: Annotated[float, Field(gt=0, le=50)] = 0.5
    square_reference_speed: Annotated[float, Field(ge=0, le=10)] = 0.1
    texture_gain: Annotated[float, Field(ge=0, allow_inf_nan=False)] = 1.0


class DriveBlock(NamedTuple):
    """One block of drive-law output, all (n,) float at the control rate."""

    voltage: np.ndarray  # V, envelope before the polarity carrier, >= 0
    target: np.ndarray  # N, target added friction before clipping
    mu_low: np.ndarray  # low-frequency CoF
    mu_tex: np.ndarray  # textural CoF (0 where none)


@dataclass(frozen=True)
class LowBand:
    """The low-band part of a drive law's target force: ``mu_low(fn, v)`` (``law.coefficient``)
    times the load the law uses, the measured load or, for Zhao, ``constant_load`` while
    touching, for a block's ``mu_low``: the figure's law line, the texture share and the
    fidelity metrics take it from there (``RenderResult.low_band``); ``drive_law`` is the law
    it belongs to (the expected spectrum asks it for its force per texture unit). The square
    baseline's low band is its own mean, ``constant_force`` N while touching (it follows
    neither the load nor the speed)."""

    law: object  # a friction law with coefficient(load, speed), or None (a material without one)
    constant_load: float | None = None
    constant_force: float | None = None
    drive_law: "DriveLaw | None" = None  # the law whose low band this is (its texture_force_per_unit ...)

    def load(self, load: np.ndarray) -> np.ndarray:
        """(n,) N: the load the law multiplies the CoF with (0 where lifted)."""
        load = np.asarray(load, dtype=float)
        if self.constant_load is None:
            return np.where(load > 0, load, 0.0)
        return np.where(load > 0, self.constant_load, 0.0)

    def force(self, load: np.ndarray, mu_low: np.ndarray) -> np.ndarray:
        """(n,) N: the law's low-band target for measured ``load`` (n,) N and the law's ``mu_low`` (n,)."""
        if self.constant_force is not None:
            return np.where(np.asarray(load) > 0, self.constant_force, 0.0)
        return np.asarray(mu_low, dtype=float) * self.load(load)


def default_method(material: Material) -> str:
    """otake2022 when the material has the quasi-static law, else otake2021."""
    return "otake2022" if material.quasi_static is not None else "otake2021"


def _vectors(speed, load) -> tuple[np.ndarray, np.ndarray]:
    """Contiguous float64 (n,) speed and load from scalars or arrays (broadcast)."""
    s, f = np.broadcast_arrays(np.atleast_1d(np.asarray(speed, dtype=np.float64)),
                               np.atleast_1d(np.asarray(load, dtype=np.float64)))
    return np.ascontiguousarray(s.ravel()), np.ascontiguousarray(f.ravel())


class DriveLaw:
    """One drive method (a subclass per method, :data:`LAWS`): ``process(speed, load, texture)
    -> DriveBlock`` renders it block by block; ``low_force`` and ``texture_force_per_unit``
    evaluate the same law (one compiled kernel) for planning and expected spectra.

    speed (n,) m/s, load (n,) N, texture (n,) in the material's texture quantity (zeros for a
    friction-only material). ``clipped`` counts samples whose target was negative while the
    finger touched. ``sample_rate`` (Hz) is needed to render the square baseline only.
    ``display`` with a measured device curve: the voltage is the display's map of the target
    (:meth:`~surfhap.models.panel.DisplayModel.voltage_for_force`, scaled by the rendering gain
    (alpha / alpha_cal)^2, ``v_max`` V = intensity 1), else ``alpha sqrt(F)``.
    """

    method: ClassVar[str]
    textured: ClassVar[bool] = True  # whether the method renders the material's texture
    _kind: int | None = None  # the law_block kind (the square baseline has its own kernel)

    def __init__(self, material: Material, params: DriveParams, sample_rate: float | None = None, *,
                 display: DisplayModel | None = None, v_max: float = 250.0):
        # the compiled kernels, imported here (numba) rather than at module import or per block
        from surfhap.render import drive_kernel

        self._kernels = drive_kernel
        self.friction_law = self.friction_law_of(material)  # the low-band law of the method
        self.material = material
        self.params = params
        self.sample_rate = None if sample_rate is None else float(sample_rate)
        self._quantity = None if material.texture is None else material.texture.quantity
        self._relative = material.texture_relative_scale
        self.square_amplitude = None
        self.low_band = LowBand(self.friction_law, drive_law=self)
        self._display = display if display is not None and display.device_curve is not None else None
        self._v_max = float(v_max)
        self._gain = 1.0 if display is None else rendering_gain(params.alpha, display.calibrated_alpha)
        self.reset()

    @classmethod
    def friction_law_of(cls, material: Material):
        """The method's low-band law; here the richest available (quasi-static before Coulomb)."""
        return material.low_frequency_law

    @property
    def uses_texture(self) -> bool:
        return self.textured and self._quantity is not None

    def reset(self) -> None:
        self._n = 0
        self.clipped = 0
        self.touching = 0

    @property
    def compiled(self) -> tuple[int, np.ndarray] | None:
        """(kind, parameters) of :func:`~surfhap.render.drive_kernel.law_block` when that kernel is
        the whole law (no square wave, no measured device curve), else None."""
        return None if self._kind is None or self._display is not None else (self._kind, self._params)

    def count(self, n: int, clipped: int, touching: int) -> None:
        """Account a block of ``n`` samples the law rendered."""
        self.clipped += clipped
        self.touching += touching
        self._n += n

    def _evaluate(self, speed: np.ndarray, load: np.ndarray, texture: np.ndarray, start: int):
        """The law over contiguous float64 (n,) arrays from sample ``start``: (DriveBlock, clipped,
        touching), by :func:`~surfhap.render.drive_kernel.law_block`, out (4, n) the rows."""
        out = np.empty((4, load.shape[0]))
        clipped, touching = self._kernels.law_block(self._kind, self._params, load, speed, texture, out)
        return DriveBlock(out[0], out[1], out[2], out[3]), clipped, touching

    def process(self, speed: np.ndarray, load: np.ndarray, texture: np.ndarray) -> DriveBlock:
        """speed, load, texture: (n,) float (m/s, N, texture quantity) -> a DriveBlock of (n,)."""
        speed = np.ascontiguousarray(speed, dtype=np.float64)
        load = np.ascontiguousarray(load, dtype=np.float64)
        texture = np.ascontiguousarray(texture, dtype=np.float64)
        n = load.shape[0]
        if not (load.ndim == 1 and speed.shape == texture.shape == (n,)):
            raise ValueError("speed, load and texture must be (n,) arrays of one length")
        block, clipped, touching = self._evaluate(speed, load, texture, self._n)
        if self._display is not None:  # a measured device curve: the display's force -> voltage map
            block = block._replace(voltage=self.voltage_for(block.target))
        self.count(n, clipped, touching)
        return block

    def voltage_for(self, target: np.ndarray) -> np.ndarray:
        """(n,) V the law outputs for ``target`` (n,) N: the display's device-curve map (scaled by
        the rendering gain), else ``alpha sqrt(max(F, 0))`` (the closed loop's feed-forward)."""
        target = np.ascontiguousarray(target, dtype=np.float64)
        if self._display is not None:
            return self._display.voltage_for_force(self._gain * target, self._v_max)
        out = np.empty_like(target)
        self._kernels.target_to_voltage(target, target, float(self.params.alpha), out)
        return out

    def low_force(self, speed, load) -> np.ndarray:
        """(n,) N: the law's target without texture at speed (m/s) and load (N), arrays or
        scalars broadcast to (n,) (the square baseline: its mean while touching)."""
        speed, load = _vectors(speed, load)
        return self._evaluate(speed, load, np.zeros(load.shape[0]), 0)[0].target

    def texture_force_per_unit(self, speed, load) -> np.ndarray:
        """(n,) N of target force per unit of texture at speed (m/s) and load (N): the law is
        linear in the texture, so this is its target at texture 1 minus its target at 0."""
        speed, load = _vectors(speed, load)
        n = load.shape[0]
        return self._evaluate(speed, load, np.ones(n), 0)[0].target - self._evaluate(speed, load, np.zeros(n), 0)[0].target


class _FrictionTexture(DriveLaw):
    """``F = (mu_low(fn, v) + beta mu_t) fn`` (``friction_texture_law``)."""

    def __init__(self, material: Material, params: DriveParams, sample_rate: float | None = None, *,
                 display: DisplayModel | None = None, v_max: float = 250.0):
        super().__init__(material, params, sample_rate, display=display, v_max=v_max)
        law, p, k = self.friction_law, params, self._kernels
        if isinstance(law, QuasiStaticLaw):
            friction = (True, law.a, law.b, law.c, law.d, law.q, 0.0)
        else:
            friction = (False, 0.0, 0.0, 0.0, 0.0, 0.0, float(law.mu0))
        g = p.texture_gain
        if not self.uses_texture:
            texture = (k.TEXTURE_NONE, 0.0)
        elif self._relative is not None:
            texture = (k.TEXTURE_RELATIVE, g * self._relative)
        elif self._quantity == "cof":
            texture = (k.TEXTURE_COF, g)
        else:
            texture = (k.TEXTURE_ACCELERATION, g * p.effective_mass)
        self._kind = k.LAW_FRICTION_TEXTURE
        self._params = np.array([*friction, *texture, p.beta if self.textured else 0.0, p.alpha], dtype=np.float64)


class Otake2022(_FrictionTexture):
    """003 eq. 6: ``F = (mu_p(fn, v) + beta mu_t) fn`` with the quasi-static law mu_p (eq. 3)."""

    method = "otake2022"

    @classmethod
    def friction_law_of(cls, material: Material):
        if material.quasi_static is None:
            raise ConfigError(f"material {material.name!r} has no quasi-static friction law, which otake2022 needs; try otake2021", field="method")
        return material.quasi_static


class _Coulomb:
    """A method on Coulomb's mu0 (otake2021, zhao)."""

    @classmethod
    def friction_law_of(cls, material: Material):
        if material.coulomb is None:
            raise ConfigError(f"material {material.name!r} has no Coulomb mu0, which {cls.method} needs; try otake2022", field="method")
        return material.coulomb


class Otake2021(_Coulomb, _FrictionTexture):
    """001 eq. 5: ``F = (mu0 + beta mu_t) fn``."""

    method = "otake2021"


class FrictionOnly(_FrictionTexture):
    """003 Sec. IV-B: ``F = mu_low(fn, v) fn``, no texture."""

    method = "friction-only"
    textured = False


class Zhao(_Coulomb, DriveLaw):
    """000 eq. 3-4: ``F = mu0 fn_c + m_eff acc`` (``mu_t fn_c`` for a CoF bank), ``fn_c`` =
    ``constant_load`` (1.6 N) while touching, or the measured load when it is None."""

    method = "zhao"

    def __init__(self, material: Material, params: DriveParams, sample_rate: float | None = None, *,
                 display: DisplayModel | None = None, v_max: float = 250.0):
        super().__init__(material, params, sample_rate, display=display, v_max=v_max)
        p, k = params, self._kernels
        self.low_band = LowBand(self.friction_law, p.constant_load, drive_law=self)
        if not self.uses_texture:
            texture = (k.TEXTURE_NONE, 0.0)
        elif self._quantity == "acceleration":
            texture = (k.TEXTURE_ACCELERATION, p.texture_gain * p.effective_mass)
        else:
            texture = (k.TEXTURE_COF, p.texture_gain)
        fn_c = -1.0 if p.constant_load is None else float(p.constant_load)
        self._kind = k.LAW_ZHAO
        self._params = np.array([self.friction_law.mu0, fn_c, *texture, p.alpha], dtype=np.float64)


class Square(DriveLaw):
    """000 Sec. 3: a 50 % square wave of constant ``V_sq``, ``V_sq^2 = alpha^2 2 F_ref`` with
    ``F_ref`` the friction-only target at the reference load and speed (unless
    ``square_amplitude`` is given). ``on_force`` = (V_sq / alpha)^2 N; its mean is half that."""

    method = "square"
    textured = False

    def __init__(self, material: Material, params: DriveParams, sample_rate: float | None = None, *,
                 display: DisplayModel | None = None, v_max: float = 250.0):
        super().__init__(material, params, sample_rate, display=display, v_max=v_max)
        if self.sample_rate is not None and params.square_frequency >= self.sample_rate / 2:
            raise ConfigError(f"square frequency must be below half the control rate ({self.sample_rate / 2:g} Hz)", field="square_frequency")
        p = params
        if p.square_amplitude is not None:
            self.square_amplitude = float(p.square_amplitude)
        else:  # matched to the friction-only mean at the reference load and speed
            f_ref = float(FrictionOnly(material, p).low_force(p.square_reference_speed, p.square_reference_load)[0])
            self.square_amplitude = float(p.alpha * np.sqrt(2.0 * f_ref))
        self.on_force = float((self.square_amplitude / p.alpha) ** 2)
        self.low_band = LowBand(self.friction_law, None, 0.5 * self.on_force, drive_law=self)
        self._step = np.nan if self.sample_rate is None else p.square_frequency / self.sample_rate

    def low_force(self, speed, load) -> np.ndarray:
        speed, load = _vectors(speed, load)
        return self.low_band.force(load, np.zeros(load.shape[0]))

    def _evaluate(self, speed, load, texture, start):
        if self.sample_rate is None:
            raise ConfigError("the square baseline needs the control rate to render", field="sample_rate")
        out = np.zeros((4, load.shape[0]))
        clipped, touching = self._kernels.square_law(start, self._step, self.on_force, load, float(self.params.alpha), out[1], out[0])
        out[2] = self.friction_law.coefficient(load, speed)
        return DriveBlock(out[0], out[1], out[2], out[3]), clipped, touching


LAWS: dict[str, type[DriveLaw]] = {cls.method: cls for cls in (Otake2022, Otake2021, Zhao, FrictionOnly, Square)}
METHODS = tuple(LAWS)


def make_drive_law(method: str, material: Material, params: DriveParams, sample_rate: float | None = None, *,
                   display: DisplayModel | None = None, v_max: float = 250.0) -> DriveLaw:
    """The law object of ``method`` ("auto" picks :func:`default_method`)."""
    if method == "auto":
        method = default_method(material)
    if method not in LAWS:
        raise ConfigError(f"unknown method {method!r} (choose from {', '.join(METHODS)})", field="method")
    return LAWS[method](material, params, sample_rate, display=display, v_max=v_max)
