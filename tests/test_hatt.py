"""HaTT model sets: writer/reader round trip, rendering identical, synthesis against an
independent re-implementation of the HaTT recursion, clamping, errors."""

import numpy as np
import pytest
from scipy.spatial import Delaunay

from surfhap.errors import MaterialFormatError
from surfhap.exchange.hatt import bank_to_hatt, hatt_to_bank, import_hatt_folder, read_hatt_material, read_hatt_xml, write_hatt_xml
from surfhap.exchange.material_json import read_material_json
from surfhap.exchange.materials import load_material
from surfhap.models.interpolated import InterpolatedARMABank
from surfhap.signal.lsf import poly_to_lsf


def stable_poly(rng, p, rmax=0.9):
    m = p // 2
    r = rng.uniform(0.3, rmax, m)
    th = rng.uniform(0.1, 3.0, m)
    roots = np.r_[r * np.exp(1j * th), r * np.exp(-1j * th)]
    if p % 2:
        roots = np.r_[roots, rng.uniform(-0.5, 0.5)]
    return np.real(np.poly(roots))


def make_bank(seed=0, p=6, q=4, k=9):
    """A small synthetic HaTT-like bank: a 3 x 3 grid of (speed, force) vertices."""
    rng = np.random.default_rng(seed)
    sp, fo = np.meshgrid([0.0, 0.1, 0.2], [0.0, 1.0, 2.0])
    speeds, forces = sp.ravel()[:k], fo.ravel()[:k]
    ar = np.array([poly_to_lsf(stable_poly(rng, p)) for _ in range(k)])
    ma = np.array([poly_to_lsf(stable_poly(rng, q, 0.7)) for _ in range(k)])
    var = np.where((speeds == 0) | (forces == 0), 0.0, rng.uniform(0.005, 0.02, k))
    gains = rng.uniform(1, 5, k)
    return InterpolatedARMABank.from_models("acceleration", 1000.0, speeds, forces, ar, var, ma, gains)


@pytest.fixture()
def hatt_file(tmp_path):
    path = tmp_path / "Models_Synthetic Cork.xml"
    write_hatt_xml(bank_to_hatt(make_bank(), "Synthetic Cork", 0.55, texture="24"), path)
    return path


def path_inputs(n=3000):
    t = np.arange(n) / 1000
    return 0.1 + 0.12 * np.sin(2 * np.pi * 0.7 * t), 1.0 + 1.2 * np.sin(2 * np.pi * 0.45 * t + 1)


def test_reader_gets_every_field(hatt_file):
    ms = read_hatt_xml(hatt_file)
    assert ms.material == "Synthetic Cork" and ms.texture == "24" and ms.mu == 0.55 and ms.sample_rate == 1000
    assert len(ms.models) == 9 and ms.num_ar == 6 and ms.num_ma == 4
    assert ms.triangles.min() == 1  # 1-based in the file
    np.testing.assert_allclose(ms.speeds, [0, 100, 200] * 3)
    assert ms.max_speed == pytest.approx(200) and ms.max_force == pytest.approx(2)
    m = ms.models[4]
    np.testing.assert_allclose(poly_to_lsf(m.ar_coeff), m.ar_lsf, atol=1e-10)


def test_written_and_read_back_renders_identically(hatt_file, tmp_path):
    bank = make_bank()
    mat = read_hatt_material(hatt_file)
    speed, force = path_inputs()
    ref = bank.synthesizer(5).process(speed, force)
    np.testing.assert_array_equal(mat.texture.synthesizer(5).process(speed, force), ref)
    # through a surfhap material JSON as well
    out = import_hatt_folder(hatt_file.parent, tmp_path / "json")
    assert [p.name for p in out] == ["synthetic-cork.json"]
    back = read_material_json(out[0])
    np.testing.assert_array_equal(back.texture.synthesizer(5).process(speed, force), ref)
    assert back.coulomb.mu0 == 0.55 and back.spec.texture.provenance.sha256
    assert load_material(hatt_file).texture.triangles.shape == bank.triangles.shape


def test_blocks_do_not_matter_and_reset_restarts():
    bank = make_bank(1)
    speed, force = path_inputs(2000)
    syn = bank.synthesizer(3)
    whole = syn.process(speed, force)
    syn.reset()
    parts = np.concatenate([syn.process(speed[i : i + 137], force[i : i + 137]) for i in range(0, 2000, 137)])
    np.testing.assert_array_equal(parts, whole)


def reference_hatt(bank, speed, force, z):
    """Independent HaTT recursion: scipy Delaunay point location, barycentric LSF/var/gain
    interpolation, numpy.poly for the polynomials, one history kept across changes."""
    scale = np.array([np.ptp(bank.speeds), np.ptp(bank.forces)])
    tri = Delaunay(np.column_stack([bank.speeds, bank.forces]) / scale)
    p, q = bank.ar_lsf.shape[1], bank.ma_lsf.shape[1]
    yh, eh = np.zeros(p), np.zeros(q)
    out = np.empty(speed.size)

    def poly(lsf):
        wp, wq = lsf[0::2], lsf[1::2]
        P = np.real(np.poly(np.r_[np.exp(1j * wp), np.exp(-1j * wp)]))
        Q = np.real(np.poly(np.r_[np.exp(1j * wq), np.exp(-1j * wq)]))
        if lsf.size % 2 == 0:
            P, Q = np.convolve(P, [1, 1]), np.convolve(Q, [1, -1])
        else:
            Q = np.convolve(Q, [1, 0, -1])
        return (0.5 * (P + Q))[: lsf.size + 1]

    for n in range(speed.size):
        x = min(abs(speed[n]), bank.max_speed - 1e-5)
        y = min(force[n], bank.max_force - 0.01)
        x = 0.0 if x < 5e-5 else x
        y = 0.0 if y < 0.05 else y
        pt = np.array([x, y]) / scale
        s = int(tri.find_simplex(pt))
        T = tri.transform[s]
        b = T[:2] @ (pt - T[2])
        w = np.r_[b, 1 - b.sum()]
        idx = tri.simplices[s]
        A = poly(w @ bank.ar_lsf[idx])
        B = poly(w @ bank.ma_lsf[idx])
        var, gain = w @ bank.variances[idx], w @ bank.gains[idx]
        e = np.sqrt(var) * z[n]
        yn = -A[1:] @ yh + gain * (e + B[1:] @ eh)
        yh = np.r_[yn, yh[:-1]]
        eh = np.r_[e, eh[:-1]]
        out[n] = yn
    return out


def test_synthesis_matches_independent_hatt_recursion():
    bank = make_bank(2)
    speed, force = path_inputs(600)
    speed[100:120] = 0.5  # above max speed: clamped
    force[200:210] = 0.01  # below 0.05 N: zero-variance edge
    z = np.random.default_rng(9).standard_normal(600)
    out = bank.synthesizer(9).process(speed, force)
    np.testing.assert_allclose(out, reference_hatt(bank, speed, force, z), rtol=1e-9, atol=1e-12)


def test_clamp_and_interpolation_stability():
    bank = make_bank(3)
    a = bank.interpolate(10.0, 50.0)
    b = bank.interpolate(bank.max_speed - 1e-5, bank.max_force - 0.01)
    np.testing.assert_array_equal(a.ar_poly, b.ar_poly)
    assert bank.interpolate(0.1, 0.02).variance == 0.0
    rng = np.random.default_rng(0)
    for v, f in rng.uniform([0, 0], [0.2, 2.0], (50, 2)):
        m = bank.interpolate(v, f)
        assert np.all(np.abs(np.roots(m.ar_poly)) < 1) and m.weights.sum() == pytest.approx(1)


def test_hatt_to_bank_round_trip():
    bank = make_bank(4)
    back = hatt_to_bank(bank_to_hatt(bank, "x", 0.3))
    np.testing.assert_allclose(back.speeds, bank.speeds, rtol=1e-15)
    np.testing.assert_array_equal(back.triangles, bank.triangles)


@pytest.mark.parametrize("edit,field", [
    (lambda s: s.replace("<numMod>9</numMod>", "<numMod>10</numMod>"), "speedList"),
    (lambda s: s.replace("<numARCoeff>6</numARCoeff>", "<numARCoeff>5</numARCoeff>"), "model[1].ARlsf"),
    (lambda s: s.replace("<SpeedUnits>mm/s</SpeedUnits>", "<SpeedUnits>m/s</SpeedUnits>"), "SpeedUnits"),
    (lambda s: s[:-30], None),
])
def test_malformed_hatt_files(hatt_file, edit, field):
    hatt_file.write_text(edit(hatt_file.read_text()))
    with pytest.raises(MaterialFormatError) as err:
        read_hatt_xml(hatt_file)
    assert err.value.field == field and err.value.source == str(hatt_file)


def test_import_of_empty_folder_fails(tmp_path):
    with pytest.raises(MaterialFormatError):
        import_hatt_folder(tmp_path, tmp_path / "out")


def test_json_schema_errors_are_located(hatt_file, tmp_path):
    import json

    out = import_hatt_folder(hatt_file, tmp_path / "json")[0]
    spec = json.loads(out.read_text())
    spec["texture"]["models"][3]["ar_lsf"][0] = 3.5  # not increasing within (0, pi)
    out.write_text(json.dumps(spec))
    with pytest.raises(MaterialFormatError) as err:
        read_material_json(out)
    assert err.value.source == str(out) and err.value.field.startswith("texture")


def test_degenerate_triangles_are_ignored():
    bank = make_bank(5)
    tris = np.vstack([[[0, 1, 2]], bank.triangles])  # collinear vertices (force 0 row)
    bad = InterpolatedARMABank(bank.quantity, bank.sample_rate, bank.speeds, bank.forces, bank.ar_lsf, bank.ma_lsf,
                               bank.variances, bank.gains, tris, bank.max_speed, bank.max_force)
    speed, force = path_inputs(500)
    np.testing.assert_array_equal(bad.synthesizer(1).process(speed, force), bank.synthesizer(1).process(speed, force))
