"""Gain planning, the square baseline, display parameters and texture calibration."""

import dataclasses
import json
import shlex

import numpy as np
import pytest
from statsmodels.tsa.arima_process import arma_acovf

from surfhap import ChainConfig, constant_scan, load_material
from surfhap.texture import render
from surfhap.cli import main
from surfhap.errors import ConfigError
from surfhap.exchange.display_file import load_display, read_display_json
from surfhap.models.electrostatics import ElectrostaticStack
from surfhap.models.panel import DisplayModel
from surfhap.models.texture_calibration import relative_scale, texture_band_std
from surfhap.render.chain import TextureChain
from surfhap.render.gain_plan import OperatingRange, plan_gains
from surfhap.render.safety import SafetyLimits


def run(capsys, *args):
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


# ---------------------------------------------------------------- plan


def test_friction_only_plan_is_the_closed_form():
    """Without texture the plan is alpha = 0.95 v_max / sqrt(max_{fn, v} mu_p fn) (capped at the
    calibrated alpha), computed here from 003 Table I for leather on a dense grid."""
    mat = load_material("leather")
    plan = plan_gains(mat, "friction-only")
    fn = np.linspace(0.1, 1.0, 19)[:, None]
    v = np.linspace(0.02, 0.3, 15)[None, :]
    peak = np.max(0.51 * fn ** 0.36 * (1 + 0.11 * v ** 0.89) / (1 + 0.02 * v) * fn)
    disp = DisplayModel()
    expected = min(1 / np.sqrt(disp.mu_panel * disp.k), 0.95 * 250 / np.sqrt(peak))
    assert plan.alpha == pytest.approx(expected, rel=1e-12)
    assert plan.rendering_gain == pytest.approx((plan.alpha * np.sqrt(disp.mu_panel * disp.k)) ** 2, rel=1e-12)
    assert plan.headroom == pytest.approx(1 / 0.95, rel=1e-9)
    assert plan.binding == "v_max"


def test_plan_peak_is_the_rendered_999th_percentile():
    """The plan's 99.9th-percentile voltage at the top load matches a long render there."""
    mat = load_material("denim")
    rng = OperatingRange(loads=(0.1, 1.0), speeds=(0.1, 0.1))
    plan = plan_gains(mat, "otake2022", operating_range=rng)
    r = render(mat, constant_scan(0.1, 1.0, 120.0), ChainConfig(seed=2, operating_range=rng))
    warm = r.t > 0.5
    assert np.percentile(r.voltage[warm], 99.9) == pytest.approx(plan.peak_voltage[-1], rel=0.05)
    assert r.summary()["saturated_fraction"] <= 1e-3


def test_strong_display_renders_at_gain_one_and_weak_range_saturates_with_a_warning():
    strong = DisplayModel(k_measured=1e-4)
    r = render(load_material("wood"), constant_scan(0.1, 0.5, 2.0), ChainConfig(display=strong))
    assert r.plan.binding == "calibration" and r.rendering_gain == pytest.approx(1.0)
    assert r.saturation_warning() is None
    low = ChainConfig(operating_range=OperatingRange(loads=(0.05, 0.1)))
    r2 = render(load_material("leather"), constant_scan(0.1, 0.96, 2.0), low)
    assert r2.saturated_fraction > 0.01
    msg = r2.saturation_warning()
    assert "saturated" in msg and "--load-range" in msg and "0.96 N" in msg


def test_rise_limit_binds_and_holds():
    """With a slow amplifier (low rise rate) the plan lowers alpha until the texture's slope fits."""
    limits = SafetyLimits(rise_rate=2e3)
    mat = load_material("denim")
    plan = plan_gains(mat, "otake2022", limits=limits)
    assert plan.binding == "rise"
    r = render(mat, constant_scan(0.15, 0.96, 10.0), ChainConfig(limits=limits, carrier=0.0))
    onset = int(0.1 * r.drive_rate)  # the touch-down ramp is always rise-limited
    d = np.abs(r.drive[onset:])
    assert np.mean(np.diff(d) > 2e3 / r.drive_rate * (1 - 1e-9)) <= 1e-3


def test_bad_ranges_are_config_errors():
    with pytest.raises(ConfigError, match="loads: needs low <= high"):
        OperatingRange(loads=(1.0, 0.1))
    with pytest.raises(ConfigError, match="speeds.0"):
        OperatingRange(speeds=(-1.0, 0.1))
    with pytest.raises(ConfigError, match="n_loads"):
        OperatingRange(n_loads=1)


# ---------------------------------------------------------------- square baseline (000 Sec. 3)


def test_square_has_constant_amplitude_independent_of_load_and_speed():
    mat = load_material("cork")
    amps = []
    for fn, v in ((0.3, 0.05), (0.8, 0.2)):
        r = render(mat, constant_scan(v, fn, 2.0), ChainConfig(method="square", square_frequency=50.0))
        warm = r.t > 0.2
        on = r.voltage[warm] > 0
        amps.append(np.unique(np.round(r.voltage[warm][on], 9)))
        assert 0.45 <= np.mean(on) <= 0.55
        s = r.summary()["square_baseline"]
        assert s["reference_load_n"] == 0.5 and s["reference_speed_m_per_s"] == 0.1
    assert amps[0].size == 1 and amps[0][0] == pytest.approx(amps[1][0], rel=1e-12)
    # V_sq = alpha sqrt(2 mu_p(0.5 N, 0.1 m/s) 0.5 N) with 003 Table I for cork
    mu = 0.35 * 0.5 ** 0.39 * (1 + 0.18 * 0.1 ** 0.08) / (1 + 0.02 * 0.1)
    assert amps[0][0] == pytest.approx(r.alpha * np.sqrt(2 * mu * 0.5), rel=1e-9)


def test_square_mean_equals_friction_only_mean_at_the_reference():
    mat = load_material("wood")
    traj = constant_scan(0.1, 0.5, 4.0)
    sq = render(mat, traj, ChainConfig(method="square", square_frequency=100.0, alpha=300.0))
    fo = render(mat, traj, ChainConfig(method="friction-only", alpha=300.0))
    warm = sq.t > 0.5
    assert np.mean(sq.added_friction[warm]) == pytest.approx(np.mean(fo.added_friction[warm]), rel=0.04)


def test_square_is_zero_when_lifted():
    from surfhap.models.trajectory import Trajectory

    t = np.arange(0, 1.0, 0.008)
    traj = Trajectory(t, 0.1 * t, 0 * t, np.where((t > 0.4) & (t < 0.6), 0.0, 0.5))
    r = render(load_material("wood"), traj, ChainConfig(method="square"))
    assert np.all(r.drive[(r.t_drive > 0.41) & (r.t_drive < 0.59)] == 0.0)
    assert np.max(np.abs(r.drive[r.t_drive < 0.4])) > 50


# ---------------------------------------------------------------- defaults per paper


def test_carrier_defaults_follow_the_papers():
    wood, paper = load_material("wood"), load_material("drawing-paper")
    assert TextureChain(wood).carrier_hz == 2000.0  # 003 Sec. IV-D
    assert TextureChain(paper, ChainConfig(drive_rate=48000)).carrier_hz == 20000.0  # 001 Sec. II
    ch = TextureChain(paper, ChainConfig(drive_rate=20000))
    assert ch.carrier_hz == 10000.0 and "capped" in ch.carrier_choice
    assert TextureChain(paper, ChainConfig(carrier=2000.0)).carrier_hz == 2000.0


# ---------------------------------------------------------------- display parameters


def test_display_file_and_inline_values(tmp_path):
    f = tmp_path / "panel.json"
    f.write_text(json.dumps({"format": "surfhap-display", "version": 1, "k": 8e-6, "mu_panel": 0.4,
                             "leakage_time_constant": 0.02, "area": 1.5e-4,
                             "device_curve": {"input": "voltage", "coefficients": [0.0, 0.0, 3.2e-6]},
                             "provenance": {"source": "tribometer", "command": "surfhap calibrate ..."}}))
    d = read_display_json(f)
    assert d.k == 8e-6 and d.mu_panel == 0.4 and d.leakage_time_constant == 0.02
    assert d.calibrated_alpha == pytest.approx(1 / np.sqrt(0.4 * 8e-6))
    assert d.device_curve.input == "voltage" and d.device_curve.coefficients == (0.0, 0.0, 3.2e-6)
    r = render(load_material("wood"), constant_scan(0.1, 0.5, 1.0), ChainConfig(display=d))
    assert r.k == 8e-6 and r.summary()["display"]["source"].startswith("panel.json")
    # inline: area alone rescales k of eq. 1 (k proportional to A)
    base = ElectrostaticStack().k
    d2 = load_display("area=2e-4,mu_panel=0.3")
    assert d2.k == pytest.approx(2 * base, rel=1e-12) and d2.mu_panel == 0.3


@pytest.mark.parametrize("content,field", [
    ({"format": "surfhap-display", "version": 1, "k": -1, "mu_panel": 0.5, "provenance": {"source": "x"}}, "k"),
    ({"format": "surfhap-display", "version": 1, "k": 1e-6, "provenance": {"source": "x"}}, "mu_panel"),
    ({"format": "surfhap-display", "version": 2, "k": 1e-6, "mu_panel": 0.5, "provenance": {"source": "x"}}, "version"),
    ({"format": "surfhap-display", "version": 1, "k": 1e-6, "mu_panel": 0.5, "provenance": {"source": "x"},
      "device_curve": {"input": "volts", "coefficients": [0, 0, 1]}}, "device_curve.input"),
])
def test_bad_display_file_one_line_exit_2(tmp_path, capsys, content, field):
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(content))
    code, _, err = run(capsys, "render", "wood", "--scan", "speed=0.1,load=0.3,duration=0.5", "--out", str(tmp_path / "o"),
                       "--display", str(f))
    assert code == 2
    line = err.strip()
    assert "\n" not in line and "bad.json" in line and f": {field}:" in line


def test_toml_config_display_section(tmp_path, capsys):
    cfg = tmp_path / "lab.toml"
    cfg.write_text("[display]\nk = 2e-5\nmu_panel = 0.6\nload_range = [0.2, 0.6]\n")
    out = tmp_path / "o"
    code, _, err = run(capsys, "render", "wood", "--scan", "speed=0.1,load=0.3,duration=0.5", "--out", str(out),
                       "--config", str(cfg), "--no-figure")
    assert code == 0, err
    s = json.loads((out / "summary.json").read_text())
    assert s["k_n_per_v2"] == 2e-5 and s["mu_panel"] == 0.6
    assert s["gain_plan"]["load_range_n"] == [0.2, 0.6]
    cfg.write_text("[display]\nkk = 1\n")
    code, _, err = run(capsys, "render", "wood", "--scan", "speed=0.1,load=0.3,duration=0.5", "--out", str(out), "--config", str(cfg),
                       "--overwrite")
    assert code == 2 and "lab.toml: display.kk" in err


# ---------------------------------------------------------------- texture calibration


def test_stationary_std_matches_statsmodels():
    phi = load_material("leather").texture.models[0]
    ref = np.sqrt(arma_acovf(np.r_[1.0, -phi.coefficients], np.array([1.0]), nobs=1, sigma2=phi.variance)[0])
    assert texture_band_std(phi.coefficients, phi.variance, 100.0, 0.0) == pytest.approx(ref, rel=1e-6)
    assert texture_band_std(phi.coefficients, phi.variance, 100.0, 3.5) < ref


@pytest.mark.parametrize("name", ["leather", "cork", "denim", "wood", "drawing-paper"])
def test_builtin_calibration_reproduces_from_its_recorded_command(name):
    cal = load_material(name).spec.texture.calibration
    args = shlex.split(cal.provenance.command)
    assert args[:2] == ["surfhap", "calibrate-texture"]
    ratio, beta, cutoff = (float(args[args.index(k) + 1]) for k in ("--ratio", "--beta", "--cutoff"))
    tex = load_material(name).spec.texture
    sd = texture_band_std(tex.models[0].coefficients, tex.models[0].variance, tex.sample_rate, cutoff)
    assert cal.reference_std == pytest.approx(sd, rel=1e-12)
    assert cal.relative_scale == pytest.approx(relative_scale(ratio, beta, sd), rel=1e-12)
    assert ratio == {"leather": 0.3, "cork": 0.6, "denim": 0.6, "wood": 0.4, "drawing-paper": 0.4}[name]


def test_calibrate_texture_command_writes_provenance(tmp_path, capsys):
    from surfhap.exchange.materials import builtin_path

    f = tmp_path / "m.json"
    f.write_text(builtin_path("denim").read_text())
    code, out, err = run(capsys, "calibrate-texture", str(f), "--ratio", "0.5", "--reference", "my paper, Table 3")
    assert code == 0, err
    mat = load_material(str(f))
    cal = mat.spec.texture.calibration
    assert cal.target_voltage_ratio == 0.5 and cal.provenance.reference == "my paper, Table 3"
    r = render(mat, constant_scan(0.1, 0.5, 30.0), ChainConfig(seed=3))
    from surfhap.render.fidelity import fidelity_metrics

    assert fidelity_metrics(r).voltage_ratio == pytest.approx(0.5, rel=0.15)
    code, _, err = run(capsys, "calibrate-texture", str(f), "--ratio", "-1", "--reference", "x")
    assert code == 2 and "--ratio" in err


def test_replacing_the_texture_drops_nothing_silently():
    """A calibration scales only the texture it was made for: a replaced texture with the scale
    cleared renders as its own quantity."""
    mat = dataclasses.replace(load_material("wood"), texture_relative_scale=None)
    r = render(mat, constant_scan(0.1, 0.5, 1.0), ChainConfig(seed=1))
    touching = r.load > 0
    np.testing.assert_allclose(r.mu_tex[touching], 0.05 * r.texture[touching] / 0.5, rtol=1e-12)


# ---------------------------------------------------------------- CLI reporting


def test_render_reports_the_plan_and_warns_once(tmp_path, capsys):
    out = tmp_path / "o"
    code, stdout, err = run(capsys, "render", "leather", "--scan", "speed=0.1,load=0.5,duration=1", "--out", str(out), "--no-figure")
    assert code == 0 and "warning" not in err
    s = json.loads((out / "summary.json").read_text())
    assert s["alpha_source"] == "plan" and s["saturated_fraction"] == 0.0
    plan = s["gain_plan"]
    assert plan["load_range_n"] == [0.1, 1.0] and plan["speed_range_m_per_s"] == [0.02, 0.3]
    assert plan["headroom"] > 1 and len(plan["renderable_friction_n"]["low"]) == len(plan["renderable_friction_n"]["load_n"])
    code, stdout, err = run(capsys, "render", "leather", "--scan", "speed=0.1,load=0.5,duration=1", "--out", str(out),
                            "--no-figure", "--alpha", "616", "--overwrite")
    assert code == 0
    lines = [x for x in err.splitlines() if x.strip()]
    assert len(lines) == 1 and lines[0].startswith("warning:") and "0.50 N" in lines[0] and "--alpha" in lines[0]


def test_materials_show_prints_provenance_and_plan(capsys):
    code, out, _ = run(capsys, "materials", "--show", "cork")
    assert code == 0
    assert "alpha =" in out and "rendering gain" in out and "Sec. IV-D" in out and "wood_1.csv" in out
    code, out, _ = run(capsys, "materials", "--show", "wood", "--display", "k=1e-4")
    assert code == 0 and "bound by calibration" in out


# ---------------------------------------------------------------- plan properties (hypothesis)

from hypothesis import given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402


@settings(max_examples=40, deadline=None)
@given(name=st.sampled_from(["leather", "cork", "denim", "wood", "drawing-paper"]),
       method=st.sampled_from(["auto", "friction-only", "square", "otake2021"]),
       k=st.floats(1e-7, 1e-3), mu_panel=st.floats(0.05, 2.0), v_max=st.floats(20.0, 1000.0),
       lo=st.floats(0.02, 2.0), span=st.floats(1.0, 10.0), vlo=st.floats(0.0, 0.5), vspan=st.floats(0.0, 1.0))
def test_plan_never_exceeds_calibration_or_v_max(name, method, k, mu_panel, v_max, lo, span, vlo, vspan):
    from surfhap.render.drive import default_method

    mat = load_material(name)
    m = default_method(mat) if method == "auto" else method
    if m == "otake2021" and mat.coulomb is None:
        return
    rng = OperatingRange(loads=(lo, min(50.0, lo * span)), speeds=(vlo, vlo + vspan), n_loads=5, n_speeds=4)
    plan = plan_gains(mat, m, DisplayModel(k_measured=k, mu_panel=mu_panel), rng, SafetyLimits(v_max=v_max, rise_rate=v_max * 1e4))
    assert 0 < plan.alpha <= plan.alpha_calibrated * (1 + 1e-12)
    assert 0 < plan.rendering_gain <= 1 + 1e-12
    assert np.all(plan.peak_voltage <= 0.95 * v_max * (1 + 1e-9))
    assert plan.headroom >= 1.0
    assert np.all(plan.friction_low_n <= plan.friction_high_n + 1e-15)
