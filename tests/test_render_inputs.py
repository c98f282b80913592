"""Inputs that used to render silently wrong (issue 17, item 11): trajectory files in millimetres
or grams are refused with the --scan bounds, and a render the safety stage mostly zeroed fails."""

import json

import numpy as np
import pytest

from surfhap.cli import main
from surfhap.exchange.trajectory_csv import read_trajectory_csv
from surfhap.models import trajectory as trajectory_model
from surfhap.models.trajectory import MAX_ACCELERATION, MAX_LOAD, MAX_SPEED, implausible, strokes


def run(capsys, *args):
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def error_lines(err: str) -> list[str]:
    return [ln for ln in err.splitlines() if ln.startswith("error:")]


def finger_csv(path, *, scale_xy=1.0, scale_load=1.0, speed=0.1, load=0.5, seconds=2.0, rate=125.0):
    """A plausible straight scan in SI, its positions / load multiplied by the given scales (1000:
    the same finger written in millimetres or grams)."""
    t = np.arange(0.0, seconds, 1.0 / rate)
    cols = [t, scale_xy * speed * t, np.zeros_like(t), np.full(t.size, scale_load * load)]
    np.savetxt(path, np.column_stack(cols), delimiter=",", header="time,x,y,load", comments="", fmt="%.9g")
    return path


def test_a_trajectory_in_millimetres_is_refused_naming_file_and_column(tmp_path, capsys):
    csv = finger_csv(tmp_path / "finger_mm.csv", scale_xy=1000.0)
    code, _, err = run(capsys, "render", "cork", "--trajectory", str(csv), "--out", str(tmp_path / "o"))
    assert code == 2
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert str(csv) in lines[0] and ": x: " in lines[0] and "speed" in lines[0] and "mm" in lines[0]
    assert not (tmp_path / "o").exists()


def test_a_trajectory_with_the_load_in_grams_is_refused(tmp_path, capsys):
    csv = finger_csv(tmp_path / "finger_g.csv", scale_load=1000.0)  # 0.5 N written as 500 g
    code, _, err = run(capsys, "render", "cork", "--trajectory", str(csv), "--out", str(tmp_path / "o"))
    assert code == 2
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert str(csv) in lines[0] and ": load: " in lines[0] and "grams" in lines[0]


def test_every_reader_of_trajectory_files_has_the_bounds(tmp_path, capsys):
    csv = finger_csv(tmp_path / "finger_mm.csv", scale_xy=1000.0)
    code, _, err = run(capsys, "ff", "simulate", "follow", "--trajectory", str(csv), "--out", str(tmp_path / "ff"))
    assert code == 2 and str(csv) in err and "mm" in err
    code, _, err = run(capsys, "shape", "gaussian-bump", "--trajectory", str(csv), "--out", str(tmp_path / "sh"))
    assert code == 2 and str(csv) in err and "mm" in err


def test_the_bounds_are_the_ones_scan_uses(tmp_path, capsys, monkeypatch):
    """One definition: lowering the module's bound changes what --scan and files accept."""
    csv = finger_csv(tmp_path / "ok.csv", speed=0.1, load=0.5)
    assert read_trajectory_csv(csv).duration > 1
    code, _, err = run(capsys, "render", "cork", "--scan", f"speed={MAX_SPEED * 1.5:g},load=0.3,duration=1",
                       "--out", str(tmp_path / "o"))
    assert code == 2 and "--scan: speed:" in err and "mm/s" in err
    monkeypatch.setattr(trajectory_model, "MAX_SPEED", 0.05)
    with pytest.raises(ValueError, match="speed"):
        read_trajectory_csv(csv)
    monkeypatch.setattr(trajectory_model, "MAX_LOAD", 0.2)
    with pytest.raises(ValueError, match="load"):
        read_trajectory_csv(csv)
    code, _, err = run(capsys, "render", "cork", "--scan", "speed=0.1,load=0.1,duration=1", "--out", str(tmp_path / "o"))
    assert code == 2 and "--scan: speed:" in err


def test_acceleration_bound_admits_strokes_up_to_1_m_per_s_and_catches_sharper_reversals(tmp_path, capsys):
    for rate in (10.0, 125.0, 10_000.0):
        tr = strokes(1.0, MAX_LOAD, 0.3, length=0.01, sensor_rate=rate)
        assert implausible(tr.t, tr.x, tr.y, tr.load) is None
    # a reversal at 1.8 m/s within one 1 kHz sample: speed within its bound, ~180 m/s^2 over 20 ms
    t = np.arange(0.0, 0.2, 0.001)
    x = np.where(t < 0.1, 1.8 * t, 0.18 - 1.8 * (t - 0.1))
    bad = implausible(t, x, 0 * t, np.full(t.size, 0.5))
    assert bad is not None and bad.quantity == "acceleration" and bad.value > MAX_ACCELERATION
    assert abs(t[bad.index] - 0.1) < 0.03  # located at the reversal
    lifted = np.where(np.abs(t - 0.1) < 0.002, 0.0, 0.5)  # the finger lifted at the turn: no violation
    assert implausible(t, x, 0 * t, lifted) is None
    code, _, err = run(capsys, "render", "cork", "--scan", "speed=1.8,load=0.3,duration=1,length=0.05", "--out", str(tmp_path / "o"))
    assert code == 2 and "--scan: speed:" in err and "m/s^2" in err
    csv = tmp_path / "jerk.csv"
    np.savetxt(csv, np.column_stack([t, 0 * t, x, np.full(t.size, 0.5)]), delimiter=",", header="time,x,y,load", comments="")
    with pytest.raises(ValueError, match=r"y: row \d+: acceleration"):
        read_trajectory_csv(csv)


def test_a_render_the_safety_stage_mostly_zeroed_fails_with_one_line(tmp_path, capsys):
    out = tmp_path / "o"
    # --alpha 5000 asks for ~2.7 kV at 0.3 N: beyond the absurd limit, the safety stage outputs 0 V as a fault
    code, _, err = run(capsys, "render", "cork", "--alpha", "5000", "--scan", "speed=0.1,load=0.3,duration=1",
                       "--out", str(out), "--no-figure")
    assert code == 1
    lines = error_lines(err)
    assert len(lines) == 1 and "faults" in lines[0], err
    s = json.loads((out / "summary.json").read_text())
    assert s["safety"]["faults"] > 0.01 * s["safety"]["samples"]  # the files stay, for diagnosis
    code, _, err = run(capsys, "render", "cork", "--scan", "speed=0.1,load=0.3,duration=1", "--out", str(tmp_path / "ok"),
                       "--no-figure")
    assert code == 0 and not error_lines(err)


def test_a_batch_job_the_safety_stage_mostly_zeroed_is_a_failed_job(tmp_path, capsys):
    out = tmp_path / "grid"
    code, _, err = run(capsys, "render", "cork", "--alpha", "5000", "--scan", "speed=0.1,duration=0.5",
                       "--grid", "load=0.3,0.5", "--out", str(out), "--no-figure")
    assert code == 1
    rows = json.loads((out / "index.json").read_text())
    rows = rows["rows"]
    assert [r["status"] for r in rows] == ["failed", "failed"]
    assert all("faults" in (r["error"] or "") for r in rows)
