"""Display calibration: recovers known device curves from synthetic tribometer recordings."""

import json

import numpy as np
import pytest

from surfhap.cli import main
from surfhap.errors import RecordingFormatError
from surfhap.exchange.tribometer import read_tribometer, write_tribometer_csv, write_tribometer_npz
from surfhap.lab.calibration import calibrate
from surfhap.models.device_curve import DeviceCurve
from surfhap.lab.tribometer_synth import synthetic_tribometer
from surfhap.signal.tribometer import fit_quadratic
from live_support.figures import assert_png_drawn

NOISE = 0.005  # N


def _intensity_set(static=(0.01, 0.02, 0.18), amplitude=(0.0, 0.05, 0.2), seed=0, duration=8.0):
    return [synthetic_tribometer(lv, "intensity", mu_panel=0.45, static=static, amplitude=amplitude, noise=NOISE,
                                 duration=duration, seed=seed + i)
            for i, lv in enumerate(np.round(np.arange(0.1, 1.01, 0.1), 2))]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_intensity_curve_recovered_within_noise(seed):
    static, amplitude = (0.01, 0.02, 0.18), (0.0, 0.05, 0.2)
    cal = calibrate(_intensity_set(static, amplitude, seed=seed))
    grid = np.linspace(0.1, 1.0, 10)
    want = np.polyval(static[::-1], grid)
    # static increase: mean of ~40k samples -> error far below the sample noise
    assert np.max(np.abs(cal.static_fit(grid) - want)) < NOISE / 5
    assert cal.mu_panel == pytest.approx(0.45, abs=1e-3)
    # amplitude: the mean of the 50 largest swings is biased up by the noise, by a few sd at most
    err = cal.amplitude_fit(grid) - np.polyval(amplitude[::-1], grid)
    assert np.all(err > -NOISE) and np.all(err < 6 * NOISE)
    assert cal.k is None
    assert cal.static_fit.residuals.shape == (10,)


def test_voltage_gives_k_and_mu_panel():
    k, mu = 3.0e-6, 0.52
    recs = [synthetic_tribometer(v, "voltage", mu_panel=mu, k=k, noise=NOISE, duration=6.0, seed=i)
            for i, v in enumerate([50.0, 100.0, 150.0, 200.0, 250.0])]
    cal = calibrate(recs)
    assert cal.k == pytest.approx(k, rel=0.01)
    assert cal.mu_panel == pytest.approx(mu, rel=0.002)
    # the static device curve is mu k V^2: c2 = mu k, c0 and c1 about zero
    c0, c1, c2 = cal.static_fit.coefficients
    assert c2 == pytest.approx(mu * k, rel=0.03)
    # inverse map: the level that gives a force gives that force back
    f = np.array([0.01, 0.03, 0.06])
    curve = cal.device_curve
    assert np.allclose(curve.force(curve.drive_for_force(f)), f, atol=1e-5)
    assert np.allclose(curve.drive_for_force(f), np.sqrt(f / (mu * k)), rtol=0.02)


def test_intensity_with_gain_gives_k():
    gain = 200.0  # V per unit intensity
    k, mu = 4.0e-6, 0.5
    static = (0.0, 0.0, mu * k * gain ** 2)
    recs = [synthetic_tribometer(i, "intensity", mu_panel=mu, static=static, noise=NOISE, duration=6.0, seed=j)
            for j, i in enumerate([0.2, 0.4, 0.6, 0.8, 1.0])]
    cal = calibrate(recs, volts_per_unit=gain)
    assert cal.k == pytest.approx(k, rel=0.02)


def test_fit_quadratic_matches_numpy_polyfit():
    rng = np.random.default_rng(3)
    x = np.linspace(0, 1, 12)
    y = 0.3 * x ** 2 - 0.1 * x + 0.02 + rng.normal(0, 0.01, x.size)
    fit = fit_quadratic(x, y)
    assert np.allclose(fit.coefficients, np.polyfit(x, y, 2)[::-1])
    assert np.allclose(fit.residuals, y - np.polyval(np.polyfit(x, y, 2), x))


def test_device_curve_inverse_monotone_and_clipped():
    lv = DeviceCurve(input="intensity", coefficients=(0.05, 0.0, 0.2)).drive_for_force(np.array([0.0, 0.05, 0.1, 0.25, 1.0]))
    assert lv[0] == 0.0 and lv[1] == 0.0
    assert lv[2] == pytest.approx(np.sqrt(0.05 / 0.2), abs=1e-3)
    assert lv[3] == pytest.approx(1.0, abs=1e-3) and lv[4] == 1.0


def test_round_trip_csv_npz(tmp_path):
    rec = synthetic_tribometer(0.5, duration=2.0, sample_rate=2000.0)
    for writer, name in ((write_tribometer_csv, "r.csv"), (write_tribometer_npz, "r.npz")):
        back = read_tribometer(writer(rec, tmp_path / name))
        assert back.input == "intensity" and back.sample_rate == pytest.approx(2000.0)
        assert np.allclose(back.lateral_force, rec.lateral_force, rtol=1e-7)
        assert back.drive_level == 0.5


def test_bad_recordings_name_file_and_field(tmp_path):
    p = tmp_path / "bad.csv"
    p.write_text("time,lateral_force,normal_force,level\n0,1,1,0\n")
    with pytest.raises(RecordingFormatError, match="bad.csv: input"):
        read_tribometer(p)
    p.write_text("# input: intensity\ntime,lateral_force,level\n0,1,0\n")
    with pytest.raises(RecordingFormatError, match="bad.csv: normal_force"):
        read_tribometer(p)


def test_cli_writes_display_schema(tmp_path, capsys):
    paths = []
    for i, v in enumerate([60.0, 120.0, 180.0, 240.0]):
        rec = synthetic_tribometer(v, "voltage", k=5e-6, mu_panel=0.5, duration=4.0, sample_rate=4000.0, seed=i)
        paths.append(str(write_tribometer_npz(rec, tmp_path / f"v{i}.npz")))
    out = tmp_path / "cal.json"
    assert main(["calibrate", "tribometer", *paths, "--out", str(out), "--plot", str(tmp_path / "cal.png")]) == 0
    assert_png_drawn(tmp_path / "cal.png")
    doc = json.loads(out.read_text())
    assert doc["format"] == "surfhap-display" and doc["version"] == 1
    assert doc["k"] == pytest.approx(5e-6, rel=0.02) and doc["mu_panel"] == pytest.approx(0.5, rel=0.01)
    assert doc["device_curve"]["input"] == "voltage" and len(doc["device_curve"]["coefficients"]) == 3
    assert set(doc["provenance"]) == {"source", "command"}
    assert len(doc["calibration"]["static_fit"]["residuals_N"]) == 4


def test_cli_bad_file_exit_2(tmp_path, capsys):
    p = tmp_path / "x.csv"
    p.write_text("# input: pressure\ntime,lateral_force,normal_force,level\n")
    assert main(["calibrate", "tribometer", str(p), "--out", str(tmp_path / "c.json")]) == 2
    err = capsys.readouterr().err
    assert "x.csv" in err and "Traceback" not in err


@pytest.mark.parametrize("tau", [0.01, 0.05, 0.3])
def test_leakage_time_constant_recovered(tau):
    from surfhap.lab.calibration import fit_leakage

    recs = [synthetic_tribometer(v, "voltage", k=4e-6, mu_panel=0.5, leakage_time_constant=tau, duration=6.0,
                                 noise=NOISE, seed=i) for i, v in enumerate([150.0, 250.0])]
    fit = fit_leakage(recs)
    assert fit.time_constant == pytest.approx(tau, rel=0.03)
    # a polarity-carrier recording has no decay: refused, not fitted to noise
    with pytest.raises(ValueError):
        fit_leakage([synthetic_tribometer(250.0, "voltage", k=4e-6, amplitude_ratio=0.0, duration=4.0, seed=9)])


def test_cli_leakage_into_display_file(tmp_path):
    paths, dc = [], []
    for i, v in enumerate([60.0, 120.0, 180.0, 240.0]):
        rec = synthetic_tribometer(v, "voltage", k=5e-6, mu_panel=0.5, duration=4.0, sample_rate=4000.0, seed=i)
        paths.append(str(write_tribometer_npz(rec, tmp_path / f"v{i}.npz")))
    for i, v in enumerate([150.0, 240.0]):
        rec = synthetic_tribometer(v, "voltage", k=5e-6, mu_panel=0.5, leakage_time_constant=0.05, duration=6.0,
                                   sample_rate=4000.0, seed=10 + i)
        dc += ["--leakage", str(write_tribometer_npz(rec, tmp_path / f"dc{i}.npz"))]
    out = tmp_path / "cal.json"
    assert main(["calibrate", "tribometer", *paths, *dc, "--out", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["leakage_time_constant"] == pytest.approx(0.05, rel=0.03)
    assert "--leakage" in doc["provenance"]["command"]


def test_calibration_file_is_what_the_renderers_read(tmp_path):
    """The file `calibrate tribometer` writes loads through `--display` and carries k and mu_panel."""
    from surfhap.exchange.display_file import load_display

    k, mu = 5e-6, 0.45
    paths = []
    for i, v in enumerate([60.0, 120.0, 180.0, 240.0]):
        rec = synthetic_tribometer(v, "voltage", k=k, mu_panel=mu, duration=4.0, sample_rate=4000.0, seed=i)
        paths.append(str(write_tribometer_npz(rec, tmp_path / f"v{i}.npz")))
    out = tmp_path / "cal.json"
    assert main(["calibrate", "tribometer", *paths, "--out", str(out)]) == 0
    disp = load_display(str(out))
    assert disp.k == pytest.approx(k, rel=0.02)
    assert disp.mu_panel == pytest.approx(mu, rel=0.01)
    assert disp.calibrated_alpha == pytest.approx(1 / np.sqrt(mu * k), rel=0.02)
    assert disp.device_curve.input == "voltage"


def test_intensity_calibration_without_k_loads_with_the_assumed_k(tmp_path):
    from surfhap.exchange.display_file import load_display
    from surfhap.models.panel import DisplayModel

    paths = [str(write_tribometer_npz(rec, tmp_path / f"i{j}.npz")) for j, rec in enumerate(_intensity_set(duration=3.0))]
    out = tmp_path / "cal.json"
    assert main(["calibrate", "tribometer", *paths, "--out", str(out)]) == 0
    assert json.loads(out.read_text())["k"] is None
    disp = load_display(str(out))
    assert disp.k == pytest.approx(DisplayModel().k)  # not measured: the documented assumption
    assert "k not measured" in disp.source
    assert disp.mu_panel == pytest.approx(0.45, abs=2e-3)
    assert disp.device_curve.input == "intensity"
