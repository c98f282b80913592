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
square          2 mu_low fn gated by a 50 % square wave at 30-300 Hz (mean = F_low)  000 Sec. 3
=============== =================================================================== ==========

A texture bank of accelerations enters the friction laws as ``mu_t = m_eff acc / fn``; a
bank of textural CoF enters Zhao's law as ``f_texture = mu_t fn_c``: one texture force,
whichever quantity was recorded.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from surfhap.errors import ConfigError
from surfhap.models.material import Material

__all__ = ["DriveParams", "DriveBlock", "DriveLaw", "METHODS", "make_drive_law", "default_method"]

METHODS = ("otake2022", "otake2021", "zhao", "friction-only", "square")


@dataclass(frozen=True)
class DriveParams:
    """Parameters shared by the drive laws (SI).

    alpha            : V / sqrt(N), gain from target force to voltage.
    beta             : gain of the textural component (Otake et al. 2021: 1.8).
    effective_mass   : kg, hand mass turning acceleration into force (Zhao / HaTT: 0.05).
    constant_load    : N, Zhao's constant load (1.6 N); None uses the measured load.
    square_frequency : Hz, baseline square wave (30-300 Hz, Zhao et al. after Bau et al.).
    square_amplitude : V, fixed baseline amplitude; None matches the friction-only mean.
    """

    alpha: float
    beta: float = 1.8
    effective_mass: float = 0.05
    constant_load: float | None = 1.6
    square_frequency: float = 100.0
    square_amplitude: float | None = None

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


class DriveBlock(NamedTuple):
    """One block of drive-law output, all (n,) float at the model rate."""

    voltage: np.ndarray  # V, envelope before the polarity carrier, >= 0
    target: np.ndarray  # N, target added friction before clipping
    mu_low: np.ndarray  # low-frequency CoF
    mu_tex: np.ndarray  # textural CoF (0 where none)


def default_method(material: Material) -> str:
    """otake2022 when the material has the quasi-static law, else otake2021."""
    return "otake2022" if material.quasi_static is not None else "otake2021"


class DriveLaw:
    """Stateful drive-law processor: ``process(speed, load, texture) -> DriveBlock``.

    speed (n,) m/s, load (n,) N, texture (n,) in the material's texture quantity (zeros for a
    friction-only material). ``clipped`` counts samples whose target was negative while the
    finger touched.
    """

    def __init__(self, method: str, material: Material, params: DriveParams, sample_rate: float):
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
        if method in ("otake2022", "friction-only", "square"):
            self._law = material.low_frequency_law if method != "otake2022" else material.quasi_static
        else:
            self._law = material.coulomb
        self.reset()

    @property
    def uses_texture(self) -> bool:
        return self.method in ("otake2022", "otake2021", "zhao") and self._quantity is not None

    def reset(self) -> None:
        self._n = 0
        self.clipped = 0
        self.touching = 0

    def _texture_cof(self, texture: np.ndarray, load: np.ndarray) -> np.ndarray:
        if not self.uses_texture:
            return np.zeros_like(load)
        if self._quantity == "cof":
            return texture
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(load > 0, self.params.effective_mass * texture / load, 0.0)

    def process(self, speed: np.ndarray, load: np.ndarray, texture: np.ndarray) -> DriveBlock:
        p = self.params
        speed = np.asarray(speed, dtype=float)
        load = np.asarray(load, dtype=float)
        texture = np.asarray(texture, dtype=float)
        mu_low = self._law.coefficient(load, speed)
        m = self.method
        if m == "zhao":
            fn = load if p.constant_load is None else np.where(load > 0, p.constant_load, 0.0)
            if not self.uses_texture:
                f_tex = np.zeros_like(load)
            elif self._quantity == "acceleration":
                f_tex = p.effective_mass * texture
            else:
                f_tex = texture * fn
            f_tex = np.where(load > 0, f_tex, 0.0)
            target = mu_low * fn + f_tex
            with np.errstate(divide="ignore", invalid="ignore"):
                mu_tex = np.where(fn > 0, f_tex / fn, 0.0)
        elif m == "square":
            mu_tex = np.zeros_like(load)
            n = load.shape[0]
            phase = ((self._n + np.arange(n)) * (p.square_frequency / self.sample_rate)) % 1.0
            gate = (phase < 0.5).astype(float)
            if p.square_amplitude is None:
                target = 2.0 * mu_low * load * gate
            else:
                target = np.where(load > 0, (p.square_amplitude / p.alpha) ** 2, 0.0) * gate
        else:
            mu_tex = self._texture_cof(texture, load)
            beta = p.beta if m != "friction-only" else 0.0
            target = (mu_low + beta * mu_tex) * load
        touching = load > 0
        neg = touching & (target < 0)
        self.clipped += int(np.count_nonzero(neg))
        self.touching += int(np.count_nonzero(touching))
        voltage = p.alpha * np.sqrt(np.maximum(target, 0.0))
        self._n += load.shape[0]
        return DriveBlock(voltage, target, mu_low, mu_tex)


def make_drive_law(method: str, material: Material, params: DriveParams, sample_rate: float) -> DriveLaw:
    """Build the processor for ``method`` ("auto" picks :func:`default_method`)."""
    if method == "auto":
        method = default_method(material)
    return DriveLaw(method, material, params, sample_rate)
