"""One representation of the friction laws: the material file's Coulomb and quasi-static entries
are the laws themselves (plus provenance), so a law and a file accept exactly the same
parameters, and a loaded material's law carries where it came from."""

import itertools

import numpy as np
import pytest
from pydantic import ValidationError

from surfhap.exchange.materials import load_material
from surfhap.models.friction import CoulombLaw, QuasiStaticLaw
from surfhap.models.material import MaterialFile

PAPER = {"source": "paper", "reference": "003 Table I"}


def _file_accepts(**law) -> bool:
    kind = "coulomb" if "mu0" in law else "quasi_static"
    try:
        MaterialFile.model_validate({"name": "x", "friction": {kind: {**law, "provenance": PAPER}}})
    except ValidationError:
        return False
    return True


def _law_accepts(cls, **law) -> bool:
    try:
        cls(**law)
    except ValueError:
        return False
    return True


# values inside, on and outside each range of 003 eq. 3's parameters (and NaN / inf)
VALUES = {"a": (0.0, 0.5, 5.0, 6.0, -0.1), "b": (-2.5, -2.0, 0.3, 2.0, 2.1), "c": (-0.1, 0.0, 3.0, np.inf),
          "d": (-1.0, 0.0, 1e3), "q": (-0.01, 0.0, 0.5, 1.0, 1.2, np.nan)}


@pytest.mark.parametrize("a", VALUES["a"])
def test_law_and_file_accept_the_same_quasi_static_parameters(a):
    for b, c, d, q in itertools.product(VALUES["b"], VALUES["c"], VALUES["d"], VALUES["q"]):
        law = dict(a=a, b=b, c=c, d=d, q=q)
        expected = (0 <= a <= 5 and -2 <= b <= 2 and 0 <= c < np.inf and 0 <= d < np.inf and 0 <= q <= 1)  # 003 eq. 3
        assert _law_accepts(QuasiStaticLaw, **law) == _file_accepts(**law) == expected, law


@pytest.mark.parametrize("mu0", [-0.1, 0.0, 0.45, 5.0, 5.5, np.nan])
def test_law_and_file_accept_the_same_coulomb_coefficient(mu0):
    assert _law_accepts(CoulombLaw, mu0=mu0) == _file_accepts(mu0=mu0) == (0 <= mu0 <= 5)


def test_a_materials_laws_are_the_file_entries_with_their_provenance():
    cork = load_material("cork")
    assert isinstance(cork.quasi_static, QuasiStaticLaw) and isinstance(cork.coulomb, CoulombLaw)
    assert cork.quasi_static is cork.spec.friction.quasi_static
    assert cork.quasi_static.provenance.source == "paper"
    fn, v = np.array([0.5]), np.array([0.1])
    qs = cork.quasi_static
    assert qs.coefficient(fn, v)[0] == pytest.approx(qs.a * 0.5 ** qs.b * (1 + qs.d * 0.1 ** qs.q) / (1 + qs.c * 0.1), rel=1e-12)
