"""The friction pipeline on recordings generated from known models."""

import numpy as np
import pytest

from surfhap.exchange.material_json import read_material_json, write_material_json
from surfhap.fit.friction import PARAMETERS, fit_quasi_static, quasi_static_model
from surfhap.fit.material_fit import fit_friction
from surfhap.fit.preprocess import prepare_friction_recording
from surfhap.fit.synthetic import synthetic_friction_recordings
from surfhap.models.friction import QUASI_STATIC_RANGES, QuasiStaticLaw
from surfhap.render.chain import TextureChain
from surfhap.signal.ar import ar_psd

FS = 2000.0
TRUE = QuasiStaticLaw(0.4, 0.35, 2.0, 3.0, 0.6)


def resonance(f, r):
    th = 2 * np.pi * f / FS
    return np.array([2 * r * np.cos(th), -r * r])


TEXTURES = {0.05: (resonance(40, 0.9), 1e-6), 0.075: (resonance(60, 0.9), 1.5e-6), 0.10: (resonance(80, 0.88), 2e-6),
            0.125: (resonance(120, 0.85), 3e-6), 0.15: (resonance(150, 0.8), 4e-6)}


@pytest.fixture(scope="module")
def fitted():
    recs = synthetic_friction_recordings(TRUE, TEXTURES, participants=4, duration=20.0, sample_rate=FS, seed=3)
    return recs, fit_friction(recs, "synthetic")


def test_quasi_static_fit_recovers_parameters_within_standard_errors():
    rng = np.random.default_rng(0)
    fn = rng.uniform(0.2, 1.5, 3000)
    v = rng.uniform(0.01, 0.4, 3000)
    theta = np.array([0.4, 0.35, 2.0, 3.0, 0.6])
    mu = quasi_static_model(theta, fn, v) + 0.01 * rng.standard_normal(fn.size)
    fit = fit_quasi_static(fn, v, mu)
    for k, true in zip(PARAMETERS, theta):
        assert abs(fit.params[k] - true) < 3 * fit.standard_errors[k], k
    assert 0.9 < fit.r2 <= 1


def _eq3_minimum(fn, v, mu, x0):
    """Independent reference: eq. 3 of Otake et al. 2022 and its derivatives written out in
    numpy, minimised by scipy's bounded trust-region solver to machine tolerances."""
    from scipy.optimize import least_squares

    def model(th):
        a, b, c, d, q = th
        return a * np.power(fn, np.full_like(fn, b)) * (1 + d * np.power(v, np.full_like(v, q))) / (1 + c * v)

    def jac(th):
        a, b, c, d, q = th
        m, vq = model(th), np.power(v, q)
        g = vq / (1 + d * vq)
        return np.column_stack([m / a, m * np.log(fn), -m * v / (1 + c * v), m * g, m * d * g * np.log(np.where(v > 0, v, 1.0))])

    lo = [QUASI_STATIC_RANGES[k][0] for k in PARAMETERS]
    return least_squares(lambda th: model(th) - mu, x0, jac=jac, bounds=(np.add(lo, [1e-9, 0, 0, 0, 0]), [QUASI_STATIC_RANGES[k][1] for k in PARAMETERS]),
                         method="trf", x_scale="jac", max_nfev=5000, ftol=1e-15, xtol=1e-15, gtol=1e-15)


def _assert_at_minimum(fit, ref, fn, rtol):
    np.testing.assert_allclose([fit.params[k] for k in PARAMETERS], ref.x, rtol=rtol)
    se = np.sqrt(np.diag(float(ref.fun @ ref.fun) / (fn.size - 5) * np.linalg.pinv(ref.jac.T @ ref.jac)))
    np.testing.assert_allclose([fit.standard_errors[k] for k in PARAMETERS], se, rtol=100 * rtol)


def test_quasi_static_fit_reaches_the_least_squares_minimum_of_eq3():
    rng = np.random.default_rng(4)
    fn, v = rng.uniform(0.2, 1.5, 2000), rng.uniform(0.0, 0.3, 2000)
    v[:5] = 0.0
    mu = 0.4 * fn**0.35 * (1 + 3 * v**0.6) / (1 + 2 * v) + 0.01 * rng.standard_normal(fn.size)
    x0 = np.array([0.3, 0.2, 1.0, 1.0, 0.4])
    _assert_at_minimum(fit_quasi_static(fn, v, mu, x0=x0), _eq3_minimum(fn, v, mu, x0), fn, 1e-7)


def test_quasi_static_fit_converges_in_the_flat_valley_of_a_narrow_speed_range():
    # one participant of the bench material: speeds only around the five reference velocities
    # (50-150 mm/s), where c, d and q trade off along a flat valley. The previous bounded
    # trust-region fit (tolerances 1e-8, at most 200 evaluations) stopped 3e-3 away from the
    # minimum here (up to 0.9 on some bench participants); the fit now reaches it
    rng = np.random.default_rng(0)
    n = 3400
    fn = rng.uniform(0.2, 1.5, n)
    v = rng.choice([0.05, 0.075, 0.1, 0.125, 0.15], n) + 0.01 * rng.standard_normal(n)
    mu = 0.4 * fn**0.35 * (1 + 3 * np.abs(v) ** 0.6) / (1 + 2 * np.abs(v)) + 0.005 * rng.standard_normal(n)
    fit = fit_quasi_static(fn, v, mu)
    A = np.column_stack([np.ones(n), np.log(fn)])
    coef, *_ = np.linalg.lstsq(A, np.log(mu), rcond=None)
    _assert_at_minimum(fit, _eq3_minimum(fn, np.abs(v), mu, np.array([np.exp(coef[0]), coef[1], 0.5, 0.5, 0.5])), fn, 5e-5)


def test_quasi_static_fit_keeps_the_bounds_when_the_minimum_is_outside():
    # mu convex in v (q would exceed 1): the unbounded solver leaves the bounds, the bounded one
    # takes over and ends on q = 1, at the bounded minimum
    rng = np.random.default_rng(6)
    fn, v = rng.uniform(0.2, 1.5, 2000), rng.uniform(0.0, 0.3, 2000)
    mu = 0.4 * fn**0.35 * (1 + 5 * v**2) + 0.002 * rng.standard_normal(fn.size)
    x0 = np.array([0.3, 0.2, 1.0, 1.0, 0.4])
    fit = fit_quasi_static(fn, v, mu, x0=x0)
    ref = _eq3_minimum(fn, v, mu, x0)
    assert fit.params["q"] == pytest.approx(1.0, abs=1e-6)
    assert all(QUASI_STATIC_RANGES[k][0] <= fit.params[k] <= QUASI_STATIC_RANGES[k][1] for k in PARAMETERS)
    theta = np.array([fit.params[k] for k in PARAMETERS])
    cost = 0.5 * float(np.sum((quasi_static_model(theta, fn, v) - mu) ** 2))
    assert cost <= ref.cost * (1 + 1e-9)


def test_contact_selection_and_band_split(fitted):
    recs, _ = fitted
    rec = recs[0]
    prep = prepare_friction_recording(rec, cutoff=3.5)
    contact = (rec.get("normal_force") > 0.05) & (rec.get("shear_force") > 0.05)
    assert prep.n_kept == contact.sum()
    np.testing.assert_allclose(prep.cof_low + prep.cof_high, (rec.get("shear_force") / np.where(contact, rec.get("normal_force"), 1))[contact])
    assert prep.shear_sum / prep.normal_sum == pytest.approx(rec.get("shear_force")[contact].sum() / rec.get("normal_force")[contact].sum())


def test_pipeline_recovers_friction_law():
    # participants explore a wide speed range (30-330 mm/s) so that c, d and q are identified
    # and each participant has their own law around the population law TRUE (Table I of
    # Otake et al. 2022 reports means and standard errors across participants)
    rng = np.random.default_rng(8)
    theta = np.array([getattr(TRUE, k) for k in PARAMETERS])
    laws = [QuasiStaticLaw(*np.clip(theta * (1 + 0.1 * rng.standard_normal(5)), 0, [5, 2, 99, 99, 1])) for _ in range(6)]
    small = {v: (resonance(100, 0.5), 1e-6) for v in (0.03, 0.1, 0.2, 0.3)}
    recs = synthetic_friction_recordings(laws, small, participants=6, duration=6.0, sample_rate=FS, speed_wobble=0.03, seed=5)
    fit = fit_friction(recs, "synthetic", reference_speeds=(0.1,))
    qs = fit.quasi_static
    assert qs.n == 6 and fit.participants == tuple(f"P{i}" for i in range(1, 7))
    population = np.mean([[getattr(law, k) for k in PARAMETERS] for law in laws], axis=0)
    for k, true in zip(PARAMETERS, population):
        assert abs(qs.params[k] - true) <= 2 * qs.standard_errors[k], k
    for k, true in zip(PARAMETERS, theta):
        assert abs(qs.params[k] - true) <= 3 * qs.standard_errors[k], k
    assert qs.r2 > 0.9


def test_pipeline_coulomb(fitted):
    recs, fit = fitted
    # Coulomb: mean shear / mean normal over all contact samples, computed independently
    num = den = 0.0
    for r in recs:
        c = (r.get("normal_force") > 0.05) & (r.get("shear_force") > 0.05)
        num += r.get("shear_force")[c].sum()
        den += r.get("normal_force")[c].sum()
    assert fit.coulomb.mu0 == pytest.approx(num / den, rel=1e-12)


def test_pipeline_recovers_ar_spectra_within_1db(fitted):
    _, fit = fitted
    assert [t.reference_speed for t in fit.textures] == list(TEXTURES)
    f = np.linspace(5 * fit.cutoff, 0.45 * FS, 300)
    for t in fit.textures:
        phi, var = TEXTURES[t.reference_speed]
        d = 10 * np.log10(t.model.psd(FS, f) / ar_psd(phi, var, FS, f))
        assert np.max(np.abs(d)) < 1.0, t.reference_speed
        assert t.similarity.shape == (4,) and t.similarity_mean > 0.9


def test_material_from_fit_is_valid_and_renders(fitted, tmp_path):
    _, fit = fitted
    mat = fit.to_material(command="surfhap fit friction test")
    path = write_material_json(mat, tmp_path / "m.json")
    back = read_material_json(path)
    assert back.texture.quantity == "cof" and back.texture.sample_rate == FS and len(back.texture.models) == 5
    assert back.spec.friction.quasi_static.standard_errors is not None
    assert back.spec.texture.provenance.source == "recording" and back.spec.texture.provenance.command
    chain = TextureChain(back)
    n = 2000
    out = chain.process(np.full(n, 0.1), np.full(n, 0.5), np.zeros(n))
    assert np.all(np.isfinite(out.drive))


def test_jobs_give_the_same_result(fitted):
    recs, fit = fitted
    fit2 = fit_friction(recs[:4], "synthetic", jobs=2, reference_speeds=(0.05, 0.075))
    fit1 = fit_friction(recs[:4], "synthetic", jobs=1, reference_speeds=(0.05, 0.075))
    for a, b in zip(fit1.textures, fit2.textures):
        np.testing.assert_array_equal(a.model.coefficients, b.model.coefficients)
    assert fit1.quasi_static.params == fit2.quasi_static.params
