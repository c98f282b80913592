"""Materials as data: a versioned JSON schema (pydantic) with provenance for every parameter.

A material file (``schema_version`` 1) holds a low-frequency friction law (Coulomb ``mu0``
and/or the quasi-static law of Otake et al. 2022) and optionally a high-frequency texture
bank of AR models. Every parameter group carries a :class:`Provenance`: either the paper
table it came from, or the recording and the exact command that fitted it. A material with
no real recording has ``texture: null`` and is rendered friction-only.

The domain object :class:`Material` is what the renderers use; :class:`MaterialFile` is the
on-disk schema. Reading and writing files lives in :mod:`surfhap.exchange.materials`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from pydantic.dataclasses import dataclass as pydantic_dataclass

from surfhap.models.friction import LAW_CONFIG, CoulombLaw, QuasiStaticLaw
from surfhap.models.texture import ARModel, TextureBank

__all__ = [
    "SCHEMA_VERSION",
    "Provenance",
    "CoulombSpec",
    "QuasiStaticSpec",
    "FrictionSpec",
    "ARModelSpec",
    "TextureCalibrationSpec",
    "TextureSpec",
    "InterpolatedModelSpec",
    "InterpolatedTextureSpec",
    "MaterialFile",
    "Material",
]

SCHEMA_VERSION = 1


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Provenance(_Strict):
    """Where a group of parameters came from.

    source "paper": ``reference`` names the paper file and table.
    source "recording": ``recording`` (file name), ``sha256`` of its bytes and the
    ``command`` that produced the parameters from it.
    """

    source: Literal["paper", "recording"]
    reference: str | None = None
    recording: str | None = None
    sha256: str | None = None
    command: str | None = None
    note: str | None = None

    @model_validator(mode="after")
    def _complete(self):
        if self.source == "paper" and not self.reference:
            raise ValueError("a 'paper' provenance needs a 'reference' (paper file and table)")
        if self.source == "recording" and not (self.recording and self.command):
            raise ValueError("a 'recording' provenance needs 'recording' and 'command'")
        return self


@pydantic_dataclass(frozen=True, config=LAW_CONFIG, kw_only=True)
class CoulombSpec(CoulombLaw):
    """The Coulomb law (its ranges) with its provenance."""

    provenance: Provenance


@pydantic_dataclass(frozen=True, config=LAW_CONFIG, kw_only=True)
class QuasiStaticSpec(QuasiStaticLaw):
    """The quasi-static law (its ranges) with standard errors and provenance."""

    standard_errors: dict[str, float] | None = None
    provenance: Provenance


class FrictionSpec(_Strict):
    coulomb: CoulombSpec | None = None
    quasi_static: QuasiStaticSpec | None = None

    @model_validator(mode="after")
    def _at_least_one(self):
        if self.coulomb is None and self.quasi_static is None:
            raise ValueError("a material needs a 'coulomb' or a 'quasi_static' friction law")
        return self


class ARModelSpec(_Strict):
    """x[n] = sum_j coefficients[j-1] x[n-j] + w[n], w ~ N(0, variance)."""

    coefficients: list[float] = Field(min_length=1, max_length=400)
    variance: float = Field(ge=0)
    reference_speed: float | None = Field(default=None, ge=0, le=5, description="m/s")
    order_selection: str | None = Field(default=None, description="how the order was chosen")


class TextureCalibrationSpec(_Strict):
    """Strength of a texture recorded in another modality than a textural CoF (e.g. stick
    acceleration), calibrated to a published friction:texture voltage ratio.

    The drive laws of Otake et al. then use ``mu_t = relative_scale * mu_low(fn, v) * x`` where
    ``x`` is the texture in its own unit: the textural CoF is a fraction of the quasi-static
    one, so the voltage ratio holds at every load and speed (see docs/texture.md).

    target_voltage_ratio : texture:friction voltage ratio r (0.3 for 10:3), see
                           :mod:`surfhap.models.texture_calibration` for the definition.
    beta                 : the textural gain of the drive law the calibration assumed.
    reference_std        : standard deviation of the texture above the band split (its own unit).
    relative_scale       : r^2 / (beta * reference_std), per unit of the texture quantity.
    """

    mode: Literal["relative-to-friction"] = "relative-to-friction"
    target_voltage_ratio: float = Field(gt=0, le=2)
    beta: float = Field(gt=0, le=100)
    reference_std: float = Field(gt=0)
    relative_scale: float = Field(gt=0)
    provenance: Provenance

    @model_validator(mode="after")
    def _consistent(self):
        expected = self.target_voltage_ratio ** 2 / (self.beta * self.reference_std)
        if not math.isclose(self.relative_scale, expected, rel_tol=1e-9):
            raise ValueError(f"relative_scale must equal target_voltage_ratio^2 / (beta reference_std) = {expected:.6g}")
        return self


class TextureSpec(_Strict):
    quantity: Literal["cof", "acceleration"]
    sample_rate: float = Field(gt=0, le=100_000, description="rate the texture models were fitted at, Hz")
    models: list[ARModelSpec] = Field(min_length=1)
    provenance: Provenance
    calibration: TextureCalibrationSpec | None = None

    @model_validator(mode="after")
    def _models(self):
        self.bank()  # the domain checks (stable, finite, distinct speeds), reported as a schema error
        return self

    def bank(self) -> TextureBank:
        """The texture model this entry describes."""
        return TextureBank(self.quantity, self.sample_rate,
                           tuple(ARModel(m.coefficients, m.variance, m.reference_speed) for m in self.models))


class InterpolatedModelSpec(_Strict):
    """One vertex of an interpolated ARMA bank (HaTT style): speed m/s, force N, AR and MA
    line spectral frequencies (rad, strictly increasing in (0, pi)), excitation variance,
    MA gain. A(z) = 1 + a_1 z^-1 + ..., y = -sum a_i y[n-i] + gain (e + sum b_j e[n-j])."""

    speed: float = Field(ge=0, le=5, description="m/s")
    force: float = Field(ge=0, le=100, description="N")
    ar_lsf: list[float] = Field(min_length=1, max_length=400)
    ma_lsf: list[float] = Field(default_factory=list, max_length=400)
    variance: float = Field(ge=0)
    gain: float = 1.0


class InterpolatedTextureSpec(_Strict):
    """A texture of ARMA models interpolated over (speed, force) in the LSF domain
    (:class:`surfhap.models.interpolated.InterpolatedARMABank`). Optional addition to
    schema version 1: files without it are unchanged."""

    kind: Literal["interpolated-arma"]
    quantity: Literal["cof", "acceleration"]
    sample_rate: float = Field(gt=0, le=100_000, description="rate the texture models were fitted at, Hz")
    max_speed: float = Field(gt=0, le=5, description="m/s, clamp")
    max_force: float = Field(gt=0, le=100, description="N, clamp")
    triangles: list[tuple[int, int, int]] = Field(default_factory=list, description="0-based model indices")
    models: list[InterpolatedModelSpec] = Field(min_length=1)
    provenance: Provenance

    @model_validator(mode="after")
    def _consistent(self):
        p = {len(m.ar_lsf) for m in self.models}
        q = {len(m.ma_lsf) for m in self.models}
        if len(p) != 1 or len(q) != 1:
            raise ValueError("all models of an interpolated bank need the same AR and MA orders")
        self.bank()  # the domain checks (LSFs within (0, pi), triangle indices ...), reported as a schema error
        return self

    @classmethod
    def of_bank(cls, b: "InterpolatedARMABank", provenance: Provenance) -> "InterpolatedTextureSpec":
        """The file entry of a bank (the inverse of :meth:`bank`)."""
        return cls(kind="interpolated-arma", quantity=b.quantity, sample_rate=b.sample_rate, max_speed=float(b.max_speed),
                   max_force=float(b.max_force), triangles=[tuple(t) for t in b.triangles.tolist()], provenance=provenance,
                   models=[InterpolatedModelSpec(speed=v, force=f, ar_lsf=ar, ma_lsf=ma, variance=var, gain=g) for v, f, ar, ma, var, g
                           in zip(*(getattr(b, k).tolist() for k in ("speeds", "forces", "ar_lsf", "ma_lsf", "variances", "gains")))])

    def bank(self) -> "InterpolatedARMABank":
        """The texture model this entry describes."""
        from surfhap.models.interpolated import InterpolatedARMABank

        m = self.models
        return InterpolatedARMABank(self.quantity, self.sample_rate, [x.speed for x in m], [x.force for x in m],
                                    [x.ar_lsf for x in m], [x.ma_lsf for x in m], [x.variance for x in m],
                                    [x.gain for x in m], [list(t) for t in self.triangles], self.max_speed, self.max_force)


class MaterialFile(_Strict):
    """The JSON schema of a material file (version 1)."""

    schema_version: Literal[1] = SCHEMA_VERSION
    name: str = Field(min_length=1, max_length=80)
    description: str = ""
    friction: FrictionSpec
    texture: TextureSpec | InterpolatedTextureSpec | None = None
    notes: list[str] = Field(default_factory=list)

    @field_validator("name")
    @classmethod
    def _name(cls, v: str) -> str:
        if v.strip() != v or "/" in v:
            raise ValueError("name must not start/end with spaces or contain '/'")
        return v

    @property
    def texture_calibration(self) -> TextureCalibrationSpec | None:
        """The texture's strength calibration (only an AR bank's entry has one), or None."""
        return self.texture.calibration if isinstance(self.texture, TextureSpec) else None


@dataclass(frozen=True)
class Material:
    """A material ready to render (thin object over :class:`MaterialFile`).

    coulomb      : CoulombLaw or None (needed by the otake2021 and zhao methods).
    quasi_static : QuasiStaticLaw or None (needed by otake2022).
    texture      : TextureBank, InterpolatedARMABank, or None (friction-only when None).
    spec         : the validated file contents, provenance included.
    texture_relative_scale : per texture unit, or None: when set, the Otake drive laws use
                   ``mu_t = texture_relative_scale * mu_low * x`` (a calibrated texture from
                   another modality, :class:`TextureCalibrationSpec`).
    """

    name: str
    coulomb: CoulombLaw | None
    quasi_static: QuasiStaticLaw | None
    texture: "TextureBank | InterpolatedARMABank | None"
    spec: MaterialFile
    texture_relative_scale: float | None = None

    @classmethod
    def from_spec(cls, spec: MaterialFile) -> "Material":
        fr = spec.friction  # the laws themselves (with their provenance)
        calibration = spec.texture_calibration
        return cls(spec.name, fr.coulomb, fr.quasi_static, None if spec.texture is None else spec.texture.bank(), spec,
                   None if calibration is None else calibration.relative_scale)

    @property
    def low_frequency_law(self) -> CoulombLaw | QuasiStaticLaw:
        """The richest friction law available (quasi-static before Coulomb)."""
        return self.quasi_static if self.quasi_static is not None else self.coulomb

    @property
    def texture_rate(self) -> float | None:
        """Rate (Hz) the texture models were fitted at, or None when friction-only."""
        return None if self.texture is None else self.texture.sample_rate

    def texture_text(self) -> str:
        """The texture in one line: quantity, models, largest order, rate and calibration."""
        t, cal = self.texture, self.spec.texture_calibration
        if t is None:
            return "none (friction-only)"
        text = f"{t.quantity}, {len(self.spec.texture.models)} model(s) of order <= {t.max_order} @ {t.sample_rate:g} Hz"
        return text if cal is None else f"{text}, voltage ratio 10:{10 * cal.target_voltage_ratio:g} (calibrated)"
