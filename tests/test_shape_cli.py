"""``surfhap shape`` / ``surfhap shape calibrate`` / ``surfhap scenes``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from surfhap.cli import main
from live_support.figures import assert_png_drawn

BUNNY = Path(__file__).resolve().parents[1] / ".." / "shared" / "data" / "stanford-bunny" / "bun_zipper_res2.ply"
NPZ_KEYS = {"t", "x", "y", "z", "force", "intensity", "edge"}


def test_shape_scan_writes_npz_summary_and_figure(tmp_path):
    out = tmp_path / "o"
    assert main(["shape", "frustum-bump", "--scan", "-0.03,0.001,0.03,0.001,0.1", "--out", str(out)]) == 0
    data = np.load(out / "shape.npz")
    assert NPZ_KEYS <= set(data.files)
    assert np.count_nonzero(data["edge"]) == 2
    assert np.all((data["intensity"] >= 0.3) & (data["intensity"] <= 1.0))
    assert_png_drawn(out / "figure.png")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["ticks"] == 2


def test_calibrate_then_render_with_it(tmp_path):
    mesh = tmp_path / "suz.obj"
    mesh.write_bytes(Path(__import__("surfhap").__file__).with_name("data").joinpath("suzanne.obj").read_bytes())
    assert main(["shape", "calibrate", str(mesh), "--directions", "12", "--speeds", "3", "--size", "0.1"]) == 0
    cal_path = tmp_path / "suz.obj.calibration.json"
    cal = json.loads(cal_path.read_text())
    assert cal["fmin"] < 0 < cal["fmax"] and cal["plan"]["directions"] == 12
    traj = tmp_path / "traj.csv"
    t = np.arange(60) / 60
    np.savetxt(traj, np.column_stack([t, np.linspace(-0.05, 0.05, 60), np.zeros(60), np.ones(60)]), delimiter=",",
               header="time,x,y,load", comments="")
    out = tmp_path / "o"
    assert main(["shape", str(mesh), "--size", "0.1", "--trajectory", str(traj), "--calibration", str(cal_path),
                 "--out", str(out), "--no-figure", "--grain", "area-grainy"]) == 0
    s = json.loads((out / "summary.json").read_text())
    assert s["fsq_range"] == pytest.approx([cal["fmin"], cal["fmax"]])
    assert s["on_mesh_fraction"] > 0.5
    # the calibration saved next to the mesh is found without --calibration
    out2 = tmp_path / "o2"
    assert main(["shape", str(mesh), "--size", "0.1", "--trajectory", str(traj), "--out", str(out2), "--no-figure"]) == 0
    s2 = json.loads((out2 / "summary.json").read_text())
    assert s2["fsq_range"] == pytest.approx([cal["fmin"], cal["fmax"]])


def test_bunny_loads_and_renders(tmp_path):
    if not BUNNY.exists():
        pytest.skip("Stanford bunny not available (../shared/data)")
    out = tmp_path / "b"
    assert main(["shape", str(BUNNY), "--up", "y", "--scan", "-0.09,0.0,0.06,0.0,0.1", "--out", str(out), "--no-figure"]) == 0
    data = np.load(out / "shape.npz")
    assert np.mean(np.isfinite(data["z"])) > 0.8


@pytest.mark.parametrize("content,suffix", [(b"", ".stl"), (b"garbage\n", ".obj"), (b"ply\nformat ascii 1.0\nelement vertex 3\n"
                                                                                    b"property float x\nend_header\n1\n", ".ply"),
                                             (b"v 0 0 0\nv 1 0 0\nf 1 2 7\n", ".obj"), (b"solid x\nendsolid x\n", ".stl"),
                                             (b"\x00\x01", ".xyz")])
def test_malformed_or_empty_mesh_gives_one_line_and_code_2(tmp_path, capsys, content, suffix):
    bad = tmp_path / f"bad{suffix}"
    bad.write_bytes(content)
    rc = main(["shape", str(bad), "--scan", "0,0,0.01,0,0.1", "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert rc == 2
    assert err.count("\n") == 0 and str(bad) in err.replace("\n", "") and "Traceback" not in err
    rc = main(["shape", "calibrate", str(bad), "--out", str(tmp_path / "c.json")])
    assert rc == 2


def test_bad_options_give_code_2(tmp_path, capsys):
    assert main(["shape", "frustum-bump", "--scan", "0,0,1", "--out", str(tmp_path)]) == 2
    assert main(["shape", "frustum-bump", "--out", str(tmp_path)]) == 2
    assert main(["shape", "no-such-shape", "--scan", "0,0,0.01,0,0.1", "--out", str(tmp_path)]) == 2
    assert main(["shape", "frustum-bump", "--scan", "0,0,0.01,0,0.1", "--calibration", str(tmp_path / "x.json"),
                 "--out", str(tmp_path)]) == 2
    capsys.readouterr()


def test_scenes_lists_twenty(capsys):
    assert main(["scenes"]) == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.strip()]
    assert len(lines) == 20 and lines[0].startswith("gaussian-0B4H-spot")


def test_profile_command(tmp_path):
    assert main(["shape", "profile", "hole", "--mapping", "IP0.7", "--piecewise", "--out", str(tmp_path)]) == 0
    data = np.load(tmp_path / "profile.npz")
    assert data["intensity"].max() <= 1.0 and (tmp_path / "figure.png").exists()
    assert main(["shape", "profile", "ridge", "--out", str(tmp_path)]) == 2
