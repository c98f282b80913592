"""Friction laws, texture banks, material files and the built-in materials."""

import json
from pathlib import Path

import numpy as np
import pytest

from surfhap.errors import ConfigError, MaterialFormatError, UnknownMaterialError
from surfhap.exchange.material_json import read_material_json
from surfhap.exchange.materials import builtin_names, load_material
from surfhap.models.friction import QuasiStaticLaw
from surfhap.models.interpolated import InterpolatedARMABank
from surfhap.models.texture import ARModel, TextureBank
from surfhap.models.trajectory import Trajectory


def test_table_one_ordering_in_si_units():
    """003 Table I at fn = 1 N, v = 0.1 m/s orders leather > cork > denim > wood (the paper's statement)."""
    mu = {n: float(load_material(n).quasi_static.coefficient([1.0], [0.1])[0]) for n in ("leather", "cork", "denim", "wood")}
    assert mu["leather"] > mu["cork"] > mu["denim"] > mu["wood"]
    # with v in mm/s the ordering breaks (the note in the issue): wood's 1 + c v denominator dominates
    mm = {n: float(load_material(n).quasi_static.coefficient([1.0], [100.0])[0]) for n in ("leather", "cork", "denim", "wood")}
    assert not (mm["leather"] > mm["cork"] > mm["denim"] > mm["wood"])


def test_quasi_static_law_values():
    law = QuasiStaticLaw(0.51, 0.36, 0.02, 0.11, 0.89)
    fn, v = 0.5, 0.12
    expected = 0.51 * fn**0.36 * (1 + 0.11 * v**0.89) / (1 + 0.02 * v)
    assert law.coefficient([fn], [v])[0] == pytest.approx(expected, rel=1e-14)
    assert law.coefficient([0.0], [v])[0] == 0.0
    with pytest.raises(ValueError):
        QuasiStaticLaw(0.5, 0.3, -0.1, 0.1, 0.5)
    with pytest.raises(ValueError):
        QuasiStaticLaw(0.5, 0.3, 0.1, 0.1, 1.5)


def test_quasi_static_law_matches_numpy_over_arrays_edges_and_shapes():
    """The compiled law equals eq. 3 evaluated with numpy (to rounding) over random loads and
    speeds, with no contact (<= 0, NaN) giving 0, negative speeds taken as magnitudes, NaN
    speed giving NaN, and broadcasting like numpy."""
    law = QuasiStaticLaw(0.62, -0.27, 1.9, 1.4, 0.55)
    rng = np.random.default_rng(7)
    fn = rng.uniform(-0.2, 2.0, 5000)
    v = rng.normal(0.0, 0.2, 5000)
    fn[:4] = [0.0, np.nan, -1.0, 1e-320]
    v[4:6] = [np.nan, -0.3]
    with np.errstate(all="ignore"):
        ref = np.where(fn > 0, 0.62 * np.maximum(fn, 1e-300) ** -0.27 * (1 + 1.4 * np.abs(v) ** 0.55) / (1 + 1.9 * np.abs(v)), 0.0)
    got = law.coefficient(fn, v)
    assert got.shape == (5000,)
    np.testing.assert_allclose(got, ref, rtol=1e-14, atol=0.0)  # NaN where ref is NaN
    assert got[0] == got[1] == got[2] == 0.0 and np.isnan(got[4])
    grid = law.coefficient(np.array([[0.26], [0.96]]), np.array([0.05, 0.1, 0.2]))
    assert grid.shape == (2, 3)
    assert grid[1, 2] == pytest.approx(law.coefficient([0.96], [0.2])[0], rel=1e-15)


def test_bank_selects_nearest_reference_speed():
    bank = TextureBank("cof", 2000.0, tuple(ARModel([0.5], 1e-4, s) for s in (0.15, 0.05, 0.1)))
    np.testing.assert_allclose(bank.reference_speeds, [0.05, 0.1, 0.15])
    np.testing.assert_array_equal(bank.select([0.0, 0.074, 0.076, 0.2, -0.1]), [0, 0, 1, 2, 1])


def test_every_builtin_loads_with_provenance():
    names = builtin_names()
    assert {"leather", "cork", "denim", "wood", "drawing-paper"} <= set(names)
    for name in names:
        m = load_material(name)
        spec = m.spec
        for part in (spec.friction.coulomb, spec.friction.quasi_static, spec.texture):
            if part is not None:
                p = part.provenance
                assert (p.source == "paper" and "Table" in p.reference) or (p.source == "recording" and p.command.startswith("surfhap fit"))
        if m.texture is None:
            assert any("Friction-only" in n for n in spec.notes)
        else:  # every built-in texture is HapMat acceleration: its strength comes from 003 Sec. IV-D
            cal = spec.texture.calibration
            assert "Sec. IV-D" in cal.provenance.reference and cal.provenance.command.startswith("surfhap calibrate-texture")
        if spec.friction.quasi_static is not None:  # the units of Table I are an assumption, said so
            assert "assumed" in spec.friction.quasi_static.provenance.note
    # cork has no recording of its own: the nearest (wood) texture at cork's published ratio, said so
    cork = load_material("cork")
    assert cork.spec.texture.provenance.recording.endswith("wood_1.csv")
    assert any("nearest" in n for n in cork.spec.notes)


def test_material_file_errors_name_file_and_field(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("{ not json")
    with pytest.raises(MaterialFormatError, match="bad.json: malformed JSON at line 1"):
        read_material_json(bad)
    doc = json.loads(load_material("leather").spec.model_dump_json())
    doc["friction"]["quasi_static"]["q"] = 1.5
    bad.write_text(json.dumps(doc))
    with pytest.raises(MaterialFormatError, match=r"friction\.quasi_static\.q"):
        load_material(str(bad))
    doc["friction"]["quasi_static"]["q"] = 0.5
    doc["texture"]["models"][0]["coefficients"] = [1.5]
    bad.write_text(json.dumps(doc))
    with pytest.raises(MaterialFormatError, match="unstable"):
        load_material(str(bad))
    del doc["friction"]["quasi_static"]["provenance"]
    bad.write_text(json.dumps(doc))
    with pytest.raises(MaterialFormatError, match="provenance"):
        load_material(str(bad))
    with pytest.raises(UnknownMaterialError, match="unknown material"):
        load_material("velvet")


def test_ar_model_moments_match_analytic_ar1_and_quadrature():
    """sd of an AR(1) process is sigma / sqrt(1 - phi^2) (analytic); the sd of its rate of
    change as a band-limited signal is sqrt(int_0^{fs/2} (2 pi f)^2 PSD(f) df), checked by
    adaptive quadrature of the closed-form PSD 2 sigma^2 / fs / |1 - phi e^{-i 2 pi f / fs}|^2."""
    from scipy.integrate import quad

    phi, var, fs = 0.8, 2.5e-3, 100.0
    model = ARModel([phi], var, 0.1)
    sd, sd_rate = model.moments(fs)
    assert sd == pytest.approx(np.sqrt(var / (1 - phi**2)), rel=1e-6)

    def psd(f):
        return 2 * var / fs / abs(1 - phi * np.exp(-2j * np.pi * f / fs)) ** 2

    slope_var, _ = quad(lambda f: (2 * np.pi * f) ** 2 * psd(f), 0, fs / 2, epsabs=0, epsrel=1e-10)
    assert sd_rate == pytest.approx(np.sqrt(slope_var), rel=1e-6)
    assert model.moments(fs) is model.moments(100)  # computed once per rate
    assert model.moments(2 * fs)[1] == pytest.approx(2 * sd_rate, rel=1e-9)  # same samples, twice as fast


def test_input_errors_are_one_line_whatever_the_input_holds(tmp_path):
    """A key with a line break in a material file (quoted into the field by the reader) still
    gives a one-line error: the CLI's single line, and the library's str(err)."""
    from surfhap.errors import InputError

    good = json.loads((Path(__file__).resolve().parents[1] / "src/surfhap/models/builtin/cork.json").read_text())
    good["friction"]["a\nb\u2028c"] = 1
    p = tmp_path / "m.json"
    p.write_text(json.dumps(good))
    with pytest.raises(MaterialFormatError) as err:
        read_material_json(p)
    assert str(p) in str(err.value) and len(str(err.value).splitlines()) == 1
    assert str(InputError("bad\nvalue", source="f.json", field="x\ry")) == "f.json: x y: bad value"


@pytest.mark.parametrize("build, field", [
    (lambda: Trajectory([0, 1], [0, 1], [0, 1], [0, -1]), "load"),
    (lambda: Trajectory([0, 0], [0, 1], [0, 1], [0, 1]), "t"),
    (lambda: Trajectory([0, 1], [0, np.nan], [0, 1], [0, 1]), "x"),
    (lambda: ARModel([1.5], 1.0), "coefficients"),
    (lambda: ARModel([0.5], -1.0), "variance"),
    (lambda: TextureBank("force", 1000.0, (ARModel([0.5], 1.0),)), "quantity"),
    (lambda: TextureBank("cof", 1000.0, (ARModel([0.5], 1.0, 0.1), ARModel([0.2], 1.0, 0.1))), "models"),
    (lambda: InterpolatedARMABank.from_models("cof", 1000.0, [0.1], [1.0], [[0.5]], [-1.0]), "variances"),
    (lambda: InterpolatedARMABank.from_models("cof", 1000.0, [0.1], [1.0], [[0.5]], [1.0], max_speed=0.0), "max_speed"),
])
def test_bad_model_parameters_are_one_config_error_naming_the_field(build, field):
    """The parameter types are pydantic (surfhap.checked): a bad value is one ConfigError line
    whose field is the parameter's name, positional arguments included."""
    with pytest.raises(ConfigError) as exc:
        build()
    assert exc.value.field == field and "\n" not in str(exc.value)
