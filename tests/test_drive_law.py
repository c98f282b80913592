"""The drive laws against their published equations, evaluated independently with numpy.

otake2022: F = (mu_p(fn, v) + beta mu_t) fn (003 eq. 6, mu_p eq. 3); otake2021: F = (mu0 + beta
mu_t) fn (001 eq. 5); friction-only: F = mu_low fn; then V = alpha sqrt(max(F, 0)). mu_t comes
from a CoF bank (mu_t = g x), an acceleration bank (mu_t = g m_eff x / fn) or a calibrated
relative scale (mu_t = g s mu_low x). The live engine runs these laws for a few samples per
block through one compiled pass; this checks that pass sample by sample, edges included.
"""

import dataclasses

import numpy as np
import pytest

from surfhap.exchange.materials import load_material
from surfhap.models.friction import CoulombLaw
from surfhap.models.texture import ARModel, TextureBank
from surfhap.render.drive import DriveParams, make_drive_law

ALPHA, BETA, GAIN, M_EFF = 140.0, 1.8, 0.7, 0.05


def _inputs(n=4000, seed=3):
    rng = np.random.default_rng(seed)
    load = rng.uniform(-0.2, 1.2, n)
    speed = rng.normal(0.0, 0.2, n)
    texture = rng.normal(0.0, 2.0, n)
    load[:5] = [0.0, np.nan, -0.5, 0.26, 0.96]
    speed[5:7] = [np.nan, -0.25]
    return load, speed, texture


def _materials():
    """cork (quasi-static law, calibrated relative texture), the same with its acceleration
    bank read as such, with a CoF bank, and with only Coulomb's mu0."""
    cork = load_material("cork")
    accel = dataclasses.replace(cork, texture_relative_scale=None)
    cof_bank = TextureBank("cof", 100.0, (ARModel([0.5], 1e-4, 0.1),))
    cof = dataclasses.replace(accel, texture=cof_bank)
    coulomb_only = dataclasses.replace(cof, quasi_static=None, coulomb=CoulombLaw(0.43))
    return {"relative": cork, "acceleration": accel, "cof": cof, "coulomb": coulomb_only}


def _reference(material, method, load, speed, texture):
    """(mu_low, mu_t, F) from the papers' equations."""
    if method == "otake2021" or material.quasi_static is None:
        mu_low = np.full(load.shape, material.coulomb.mu0)
    else:
        qs = material.quasi_static
        s = np.abs(speed)
        with np.errstate(all="ignore"):
            mu_low = np.where(load > 0, qs.a * np.maximum(load, 1e-300) ** qs.b * (1 + qs.d * s**qs.q) / (1 + qs.c * s), 0.0)
    if method == "friction-only":
        mu_t = np.zeros_like(load)
    elif material.texture_relative_scale is not None:
        mu_t = GAIN * material.texture_relative_scale * mu_low * texture
    elif material.texture.quantity == "cof":
        mu_t = GAIN * texture
    else:
        with np.errstate(all="ignore"):
            mu_t = np.where(load > 0, GAIN * M_EFF * texture / load, 0.0)
    beta = 0.0 if method == "friction-only" else BETA
    return mu_low, mu_t, (mu_low + beta * mu_t) * load


CASES = [(kind, method) for kind in ("relative", "acceleration", "cof", "coulomb")
         for method in ("otake2022", "otake2021", "friction-only")
         if not (kind == "coulomb" and method == "otake2022")]


@pytest.mark.parametrize("kind, method", CASES)
def test_law_matches_published_equations_sample_by_sample(kind, method):
    material = _materials()[kind]
    if method == "otake2021" and material.coulomb is None:
        pytest.skip("no Coulomb mu0")
    law = make_drive_law(method, material, DriveParams(ALPHA, BETA, M_EFF, texture_gain=GAIN), 2000)
    load, speed, texture = _inputs()
    mu_low, mu_t, target = _reference(material, method, load, speed, texture)
    with np.errstate(all="ignore"):
        voltage = np.where(target > 0, ALPHA * np.sqrt(np.maximum(target, 0.0)), np.where(np.isnan(target), np.nan, 0.0))
    got = [law.process(speed[i : i + 7], load[i : i + 7], texture[i : i + 7]) for i in range(0, load.size, 7)]  # live-sized blocks
    for field, ref in (("mu_low", mu_low), ("mu_tex", mu_t), ("target", target), ("voltage", voltage)):
        np.testing.assert_allclose(np.concatenate([getattr(b, field) for b in got]), ref, rtol=1e-13, atol=0.0,
                                   err_msg=f"{kind} {method} {field}")
    touching = load > 0
    assert law.touching == int(touching.sum())
    assert law.clipped == int((touching & (target < 0)).sum())
    if method != "friction-only" and kind in ("relative", "acceleration"):
        assert law.clipped > 0  # strong negative textures are clipped and counted, not rendered
    assert np.isnan(got[0].voltage[1]) == np.isnan(target[1])  # a NaN target stays NaN for the safety stage


def test_law_rejects_arrays_of_different_lengths():
    law = make_drive_law("otake2022", load_material("cork"), DriveParams(ALPHA), 2000)
    with pytest.raises(ValueError, match="one length"):
        law.process(np.zeros(3), np.zeros(4), np.zeros(4))
