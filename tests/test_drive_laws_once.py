"""Each drive law is written once: its law object against the paper's equation (written here
independently, over the loads 0.26-0.96 N of 003 Sec. II and speeds up to 1 m/s), and no other
module carries its own copy of the arithmetic.

otake2022: F = (mu_p(fn, v) + beta mu_t) fn, mu_p = a fn^b (1 + d v^q) / (1 + c v) (003 eq. 6, 3);
otake2021: F = (mu0 + beta mu_t) fn, beta = 1.8 (001 eq. 5); zhao: F = mu0 fn_c + m_eff acc with
fn_c = 1.6 N and m_eff = 0.05 kg (000 eq. 3-4); friction-only: F = mu_p fn (003 Sec. IV-B); square:
V_sq = alpha sqrt(2 F_ref) in the first half of each period (000 Sec. 3); V = alpha sqrt(max(F, 0)).
"""

import dataclasses
import io
import re
import tokenize
from pathlib import Path

import numpy as np
import pytest

from surfhap.exchange.materials import load_material
from surfhap.models.texture import ARModel, TextureBank
from surfhap.render.drive import LAWS, DriveParams, make_drive_law
from surfhap.render.gain_plan import plan_gains

ALPHA, GAIN = 150.0, 0.8
PAPER_BETA, ZHAO_LOAD, ZHAO_MASS = 1.8, 1.6, 0.05  # 001 Sec. IV-C; 000 Sec. 2.2
SRC = Path(__file__).resolve().parents[1] / "src" / "surfhap"


def _grid(n=400, seed=5):
    rng = np.random.default_rng(seed)
    return rng.uniform(0.0, 1.0, n), rng.uniform(0.26, 0.96, n), rng.normal(0.0, 1.5, n)  # speed, load, texture


def _mu_p(qs, fn, v):
    return qs.a * fn ** qs.b * (1 + qs.d * v ** qs.q) / (1 + qs.c * v)


def _materials():
    cork = load_material("cork")  # quasi-static + Coulomb, an acceleration bank calibrated relative to friction
    accel = dataclasses.replace(cork, texture_relative_scale=None)
    cof = dataclasses.replace(accel, texture=TextureBank("cof", 100.0, (ARModel([0.5], 1e-4, 0.1),)))
    return {"relative": cork, "acceleration": accel, "cof": cof}


def _paper_target(method, material, v, fn, x):
    """The papers' target force (N) with the textural CoF mu_t of the material's texture."""
    qs, mu0 = material.quasi_static, material.coulomb.mu0
    mu_low = _mu_p(qs, fn, v) if method in ("otake2022", "friction-only") else np.full(fn.shape, mu0)
    if method == "zhao":
        texture = GAIN * ZHAO_MASS * x if material.texture.quantity == "acceleration" else GAIN * x * ZHAO_LOAD
        return mu0 * ZHAO_LOAD + texture
    if method == "friction-only":
        return mu_low * fn
    if material.texture_relative_scale is not None:
        mu_t = GAIN * material.texture_relative_scale * mu_low * x
    elif material.texture.quantity == "cof":
        mu_t = GAIN * x
    else:
        mu_t = GAIN * ZHAO_MASS * x / fn
    return (mu_low + PAPER_BETA * mu_t) * fn


def test_defaults_are_the_papers_constants():
    p = DriveParams(alpha=ALPHA)
    assert (p.beta, p.constant_load, p.effective_mass) == (PAPER_BETA, ZHAO_LOAD, ZHAO_MASS)
    assert set(LAWS) == {"otake2022", "otake2021", "zhao", "friction-only", "square"}


@pytest.mark.parametrize("kind", ["relative", "acceleration", "cof"])
@pytest.mark.parametrize("method", ["otake2022", "otake2021", "zhao", "friction-only"])
def test_law_object_is_the_papers_equation(method, kind):
    material = _materials()[kind]
    law = make_drive_law(method, material, DriveParams(ALPHA, texture_gain=GAIN), 2000)
    v, fn, x = _grid()
    target = _paper_target(method, material, v, fn, x)
    block = law.process(v, fn, x)
    np.testing.assert_allclose(block.target, target, rtol=1e-12)
    np.testing.assert_allclose(block.voltage, ALPHA * np.sqrt(np.maximum(target, 0.0)), rtol=1e-12)
    low = _paper_target(method, material, v, fn, np.zeros_like(x))
    np.testing.assert_allclose(law.low_force(v, fn), low, rtol=1e-12)
    per_unit = _paper_target(method, material, v, fn, np.ones_like(x)) - low
    np.testing.assert_allclose(law.texture_force_per_unit(v, fn), per_unit, rtol=1e-9, atol=1e-15)


def test_square_law_is_a_constant_square_wave_matched_at_the_reference():
    material = load_material("leather")
    rate, f_sq = 2000, 100.0
    law = make_drive_law("square", material, DriveParams(ALPHA, square_frequency=f_sq), rate)
    v, fn, x = _grid()
    f_ref = _mu_p(material.quasi_static, 0.5, 0.1) * 0.5  # 0.5 N, 0.1 m/s
    v_sq = ALPHA * np.sqrt(2 * f_ref)
    got = np.concatenate([law.process(v[i:i + 7], fn[i:i + 7], x[i:i + 7]).voltage for i in range(0, v.size, 7)])
    on = (np.arange(v.size) % (rate / f_sq)) < rate / f_sq / 2
    np.testing.assert_allclose(got, np.where(on, v_sq, 0.0), rtol=1e-12)
    np.testing.assert_allclose(law.low_force(v, fn), f_ref, rtol=1e-12)  # its mean, whatever the load
    assert np.all(law.texture_force_per_unit(v, fn) == 0.0)


def test_gain_plan_uses_zhaos_constant_load():
    """The plan's friction range for zhao is mu0 x 1.6 N at every load (and the measured load
    when the constant load is None), at the rendering gain."""
    material = load_material("denim")
    plan = plan_gains(material, "zhao")
    mu0 = material.coulomb.mu0
    np.testing.assert_allclose(plan.friction_low_n, plan.rendering_gain * mu0 * ZHAO_LOAD, rtol=1e-12)
    measured = plan_gains(material, "zhao", constant_load=None)
    np.testing.assert_allclose(measured.friction_high_n, measured.rendering_gain * mu0 * measured.loads, rtol=1e-12)


# ------------------------------------------------------------- the equation appears once

LAW_MODULES = {"render/drive.py", "render/drive_kernel.py", "models/friction_kernel.py"}
# texture calibration computes relative_scale = r^2 / (beta sd): not the drive law
CALIBRATION = {"models/texture_calibration.py", "models/material.py"}
PATTERNS = {
    "rendering gain (alpha / alpha_calibrated)^2": (r"alpha_cal\w*\s*\)\s*\*\*\s*2", set()),
    "eq. 3 numerator a fn^b": (r"\*\*\s*(\w+\.)?b\b|power\s*\(\s*[\w.]+\s*,\s*(\w+\.)?b\s*\)", set()),
    # lab/quest.py: Watson & Pelli's Weibull slope, also named beta, no textural CoF
    "beta times the textural CoF": (r"\bbeta\s*\*|\*\s*(\w+\.)?beta\b", CALIBRATION | {"lab/quest.py"}),
    "Zhao's m_eff acc": (r"\b(effective_mass|m_eff)\s*\*|\*\s*(\w+\.)?(effective_mass|m_eff)\b", set()),
    "Coulomb's mu0 fn": (r"\bmu0\s*\*|\*\s*(\w+\.)?mu0\b", set()),
}
# the law's consumers do not multiply a CoF with a load themselves
CONSUMERS = ("render/gain_plan.py", "render/expected.py", "lab/compare.py", "fit/friction.py")
CONSUMER_PATTERN = r"\bmu\w*\s*\*\s*(\w+\.)?(fn|load)\w*\b"


def _code(path: Path) -> str:
    """The module's code without comments and strings (docstrings describe the equations)."""
    toks = [t.string for t in tokenize.generate_tokens(io.StringIO(path.read_text()).readline)
            if t.type not in (tokenize.COMMENT, tokenize.STRING, tokenize.NL, tokenize.NEWLINE)]
    return re.sub(r" ?\. ?", ".", " ".join(toks)) + "\n"  # "p . x" -> "p.x"; tokens one space apart


def test_each_law_equation_is_written_once():
    hits = []
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC).as_posix()
        if rel in LAW_MODULES:
            continue
        code = _code(path)
        for name, (pattern, allowed) in PATTERNS.items():
            if rel not in allowed and re.search(pattern, code):
                hits.append(f"{rel}: {name}")
        if rel in CONSUMERS and re.search(CONSUMER_PATTERN, code):
            hits.append(f"{rel}: a CoF times a load")
    assert not hits, "drive-law arithmetic outside the law modules (call the law object):\n" + "\n".join(hits)


def test_the_law_modules_hold_each_equation():
    """The check above looks for the right thing: the law modules do match its patterns."""
    code = "".join(_code(SRC / m) for m in sorted(LAW_MODULES))
    for name, (pattern, _) in PATTERNS.items():
        assert re.search(pattern, code), name
