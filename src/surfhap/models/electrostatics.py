"""Electrostatic attraction between a finger and an insulated electrode (Zhao et al., eq. 1).

``f_e = eps0 A V^2 / (2 (T_i/eps_i + T_sc/eps_sc) (T_i + T_sc)) = k V^2``

The stack defaults describe a typical display and are *assumptions to calibrate*, not
measurements: the 8 um insulating film is the one of Otake et al. (Kimotect PA8X, a PET
hard-coat film; PET's relative permittivity is about 3.2); the contact area (1 cm^2) and the
stratum corneum (20 um thick, relative permittivity 40) are order-of-magnitude values for a
fingertip on glass. Measure your own display (force vs voltage) and pass its ``k`` instead.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field

__all__ = ["EPSILON_0", "ElectrostaticStack", "electrostatic_constant"]

EPSILON_0 = 8.8541878128e-12  # F/m, vacuum permittivity (CODATA 2018)


class ElectrostaticStack(BaseModel):
    """Finger / insulator stack of eq. 1 (SI).

    contact_area               : m^2, apparent finger contact area A.
    insulator_thickness        : m, T_i.
    insulator_permittivity     : relative permittivity eps_i.
    stratum_corneum_thickness  : m, T_sc.
    stratum_corneum_permittivity : relative permittivity eps_sc.
    """

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)

    contact_area: float = Field(1.0e-4, gt=0)
    insulator_thickness: float = Field(8.0e-6, gt=0)
    insulator_permittivity: float = Field(3.2, gt=0)
    stratum_corneum_thickness: float = Field(20.0e-6, gt=0)
    stratum_corneum_permittivity: float = Field(40.0, gt=0)

    @property
    def k(self) -> float:
        """N / V^2."""
        return electrostatic_constant(self)


def electrostatic_constant(stack: ElectrostaticStack) -> float:
    """k of eq. 1 in N/V^2."""
    s = stack
    series = s.insulator_thickness / s.insulator_permittivity + s.stratum_corneum_thickness / s.stratum_corneum_permittivity
    return EPSILON_0 * s.contact_area / (2.0 * series * (s.insulator_thickness + s.stratum_corneum_thickness))

