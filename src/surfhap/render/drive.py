"""Drive laws: from finger speed, load and texture to the voltage envelope (model rate).

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
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from surfhap.errors import ConfigError
from surfhap.models.friction import QuasiStaticLaw
from surfhap.models.material import Material

if TYPE_CHECKING:
    from surfhap.models.panel import DisplayModel

__all__ = ["DriveParams", "DriveBlock", "DriveLaw", "LowBand", "METHODS", "make_drive_law", "default_method",
           "friction_law_for", "texture_force"]

METHODS = ("otake2022", "otake2021", "zhao", "friction-only", "square")


@dataclass(frozen=True)
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

    alpha: float
    beta: float = 1.8
    effective_mass: float = 0.05
    constant_load: float | None = 1.6
    square_frequency: float = 100.0
    square_amplitude: float | None = None
    square_reference_load: float = 0.5
    square_reference_speed: float = 0.1
    texture_gain: float = 1.0

    def __post_init__(self):
        if not (np.isfinite(self.alpha) and self.alpha > 0):
            raise ConfigError(f"must be > 0, got {self.alpha}", field="alpha")
        if not (np.isfinite(self.beta) and self.beta >= 0):
            raise ConfigError(f"must be >= 0, got {self.beta}", field="beta")
        if not 30.0 <= self.square_frequency <= 300.0:
            raise ConfigError(f"must be within 30-300 Hz, got {self.square_frequency}", field="square_frequency")
        if self.constant_load is not None and not self.constant_load > 0:
            raise ConfigError("must be > 0", field="constant_load")
        if self.square_amplitude is not None and not self.square_amplitude >= 0:
            raise ConfigError("must be >= 0", field="square_amplitude")
        if not (np.isfinite(self.square_reference_load) and 0 < self.square_reference_load <= 50):
            raise ConfigError("must be within (0, 50] N", field="square_reference_load")
        if not (np.isfinite(self.square_reference_speed) and 0 <= self.square_reference_speed <= 10):
            raise ConfigError("must be within [0, 10] m/s", field="square_reference_speed")
        if not (np.isfinite(self.texture_gain) and self.texture_gain >= 0):
            raise ConfigError("must be >= 0", field="texture_gain")


class DriveBlock(NamedTuple):
    """One block of drive-law output, all (n,) float at the model rate."""

    voltage: np.ndarray  # V, envelope before the polarity carrier, >= 0
    target: np.ndarray  # N, target added friction before clipping
    mu_low: np.ndarray  # low-frequency CoF
    mu_tex: np.ndarray  # textural CoF (0 where none)


@dataclass(frozen=True)
class LowBand:
    """The low-band part of a drive law's target force: ``mu_low(fn, v)`` (``law.coefficient``)
    times the load the law uses, the measured load or, for Zhao, ``constant_load`` while
    touching. A :class:`DriveLaw` computes its target with it; the figure's law line, the
    expected spectrum and the fidelity metrics take it from there (``RenderResult.low_band``).
    The square baseline's low band is its own mean, ``constant_force`` N while touching (it
    follows neither the load nor the speed)."""

    law: object  # a friction law with coefficient(load, speed), or None (a material without one)
    constant_load: float | None = None
    constant_force: float | None = None

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


def friction_law_for(material: Material, method: str):
    """The low-band friction law ``method`` uses: quasi-static for otake2022, Coulomb's mu0 for
    otake2021 and zhao, the richest available for friction-only and square (None if missing)."""
    if method == "otake2022":
        return material.quasi_static
    if method in ("otake2021", "zhao"):
        return material.coulomb
    return material.low_frequency_law


def texture_force(quantity: str, relative_scale: float | None, method: str, x: float, fn: float, mu_low: float,
                  beta: float, texture_gain: float, effective_mass: float, fn_c: float) -> float:
    """Textural part of the target force (N) for a texture amount ``x`` (its unit; an sd, or 1
    for the force per unit) at load ``fn`` N, low-band CoF ``mu_low`` and Zhao's load ``fn_c`` N:
    zhao ``g m_eff x`` or ``g x fn_c``; the Otake laws ``beta g mu_t fn`` with mu_t as in the
    module docstring (relative scale, CoF bank or acceleration bank)."""
    if x == 0.0:
        return 0.0
    if method == "zhao":
        return texture_gain * (effective_mass * x if quantity == "acceleration" else x * fn_c)
    if relative_scale is not None:
        mu_t = relative_scale * mu_low * x
    elif quantity == "cof":
        mu_t = x
    else:
        mu_t = effective_mass * x / fn
    return beta * texture_gain * mu_t * fn


def default_method(material: Material) -> str:
    """otake2022 when the material has the quasi-static law, else otake2021."""
    return "otake2022" if material.quasi_static is not None else "otake2021"


class DriveLaw:
    """Stateful drive-law processor: ``process(speed, load, texture) -> DriveBlock``.

    speed (n,) m/s, load (n,) N, texture (n,) in the material's texture quantity (zeros for a
    friction-only material). ``clipped`` counts samples whose target was negative while the
    finger touched. ``display`` with a measured device curve: the voltage is the display's map
    of the target (:meth:`~surfhap.models.panel.DisplayModel.voltage_for_force`, scaled by the
    rendering gain (alpha / alpha_cal)^2, ``v_max`` V = intensity 1), else ``alpha sqrt(F)``.
    """

    def __init__(self, method: str, material: Material, params: DriveParams, sample_rate: float, *,
                 display: DisplayModel | None = None, v_max: float = 250.0):
        # the compiled tail, imported here (numba) rather than at module import or per block
        from surfhap.render import drive_kernel

        self._to_voltage = drive_kernel.target_to_voltage
        self._friction_texture = drive_kernel.friction_texture_law
        if method not in METHODS:
            raise ConfigError(f"unknown method {method!r} (choose from {', '.join(METHODS)})", field="method")
        if method == "otake2022" and material.quasi_static is None:
            raise ConfigError(f"material {material.name!r} has no quasi-static friction law, which otake2022 needs; try otake2021", field="method")
        if method in ("otake2021", "zhao") and material.coulomb is None:
            raise ConfigError(f"material {material.name!r} has no Coulomb mu0, which {method} needs; try otake2022", field="method")
        self.method = method
        self.material = material
        self.params = params
        self.sample_rate = float(sample_rate)
        if method == "square" and params.square_frequency >= self.sample_rate / 2:
            raise ConfigError(f"square frequency must be below half the model rate ({self.sample_rate / 2:g} Hz)", field="square_frequency")
        self._quantity = None if material.texture is None else material.texture.quantity
        self._relative = material.texture_relative_scale
        self.friction_law = friction_law_for(material, method)  # the low-band law of the method
        self.square_amplitude = None
        if method == "square":
            self.square_amplitude = self._square_amplitude()
        self.low_band = LowBand(self.friction_law, params.constant_load if method == "zhao" else None,
                                0.5 * (self.square_amplitude / params.alpha) ** 2 if method == "square" else None)
        self._kernel_args = self._friction_texture_args(drive_kernel)
        self._display = display if display is not None and display.device_curve is not None else None
        self._v_max = float(v_max)
        self._gain = 1.0 if display is None else float((params.alpha / display.calibrated_alpha) ** 2)
        self.reset()

    def _friction_texture_args(self, kernel) -> tuple:
        """The law and texture parameters of ``friction_texture_law`` (Otake laws, friction-only)."""
        law, p = self.friction_law, self.params
        if isinstance(law, QuasiStaticLaw):
            friction = (True, law.a, law.b, law.c, law.d, law.q, 0.0)
        else:
            friction = (False, 0.0, 0.0, 0.0, 0.0, 0.0, float(law.mu0))
        g = p.texture_gain
        if not self.uses_texture or self.method == "friction-only":
            texture = (kernel.TEXTURE_NONE, 0.0)
        elif self._relative is not None:
            texture = (kernel.TEXTURE_RELATIVE, g * self._relative)
        elif self._quantity == "cof":
            texture = (kernel.TEXTURE_COF, g)
        else:
            texture = (kernel.TEXTURE_ACCELERATION, g * p.effective_mass)
        beta = p.beta if self.method != "friction-only" else 0.0
        return (*friction, *texture, float(beta), float(p.alpha))

    def _square_amplitude(self) -> float:
        """V: the fixed square amplitude (000 Sec. 3), matched to the friction-only mean at the
        reference load and speed unless given."""
        p = self.params
        if p.square_amplitude is not None:
            return float(p.square_amplitude)
        fr, vr = p.square_reference_load, p.square_reference_speed
        f_ref = float(self.friction_law.coefficient(np.array([fr]), np.array([vr]))[0]) * fr
        return float(p.alpha * np.sqrt(2.0 * f_ref))

    @property
    def uses_texture(self) -> bool:
        return self.method in ("otake2022", "otake2021", "zhao") and self._quantity is not None

    def reset(self) -> None:
        self._n = 0
        self.clipped = 0
        self.touching = 0

    def process(self, speed: np.ndarray, load: np.ndarray, texture: np.ndarray) -> DriveBlock:
        """speed, load, texture: (n,) float (m/s, N, texture quantity) -> a DriveBlock of (n,)."""
        p = self.params
        speed = np.ascontiguousarray(speed, dtype=np.float64)
        load = np.ascontiguousarray(load, dtype=np.float64)
        texture = np.ascontiguousarray(texture, dtype=np.float64)
        n = load.shape[0]
        if not (load.ndim == 1 and speed.shape == texture.shape == (n,)):
            raise ValueError("speed, load and texture must be (n,) arrays of one length")
        m = self.method
        if m not in ("zhao", "square"):  # the Otake laws and friction-only: one compiled pass
            mu_low, mu_tex, target, voltage = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
            clipped, touching = self._friction_texture(load, speed, texture, *self._kernel_args,
                                                       mu_low, mu_tex, target, voltage)
        else:
            mu_low = self.friction_law.coefficient(load, speed)
            if m == "zhao":
                fn = self.low_band.load(load)
                if not self.uses_texture:
                    f_tex = np.zeros_like(load)
                elif self._quantity == "acceleration":
                    f_tex = (p.texture_gain * p.effective_mass) * texture
                else:
                    f_tex = p.texture_gain * texture * fn
                f_tex = np.where(load > 0, f_tex, 0.0)
                target = self.low_band.force(load, mu_low) + f_tex
                with np.errstate(divide="ignore", invalid="ignore"):
                    mu_tex = np.where(fn > 0, f_tex / fn, 0.0)
            else:  # square
                mu_tex = np.zeros_like(load)
                phase = ((self._n + np.arange(n)) * (p.square_frequency / self.sample_rate)) % 1.0
                target = ((self.square_amplitude / p.alpha) ** 2) * (phase < 0.5).astype(float)
            target = np.ascontiguousarray(target, dtype=np.float64)
            voltage = np.empty(n)
            clipped, touching = self._to_voltage(target, load, float(p.alpha), voltage)
        if self._display is not None:  # a measured device curve: the display's force -> voltage map
            voltage = self._display.voltage_for_force(self._gain * target, self._v_max)
        self.clipped += clipped
        self.touching += touching
        self._n += n
        return DriveBlock(voltage, target, mu_low, mu_tex)


def make_drive_law(method: str, material: Material, params: DriveParams, sample_rate: float, *,
                   display: DisplayModel | None = None, v_max: float = 250.0) -> DriveLaw:
    """Build the processor for ``method`` ("auto" picks :func:`default_method`)."""
    if method == "auto":
        method = default_method(material)
    return DriveLaw(method, material, params, sample_rate, display=display, v_max=v_max)
