"""``surfhap fit friction|accel`` and ``surfhap import hatt`` end to end, report included."""

import json

import numpy as np
import pytest

from surfhap.cli import main
from surfhap.exchange.recordings import write_recording_csv, write_recording_npz
from surfhap.fit.synthetic import synthetic_accel_recording, synthetic_friction_recordings
from surfhap.models.friction import QuasiStaticLaw
from live_support.figures import assert_png_drawn


def run(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def rec_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("recs")
    tex = {0.05: (np.array([0.5]), 1e-6), 0.1: (np.array([-0.3]), 1e-6)}
    recs = synthetic_friction_recordings(QuasiStaticLaw(0.4, 0.3, 1.0, 1.0, 0.5), tex, participants=2, duration=4.0, seed=0)
    paths = []
    for i, r in enumerate(recs):
        paths.append((write_recording_csv if i % 2 else write_recording_npz)(r, d / f"rec{i}.{'csv' if i % 2 else 'npz'}"))
    return paths


def test_fit_friction_writes_material_and_report(rec_files, tmp_path, capsys):
    out = tmp_path / "m.json"
    code, stdout, err = run(capsys, "fit", "friction", *rec_files, "--material", "syn", "--out", out,
                            "--reference-velocities", "50,100", "--report", tmp_path / "rep")
    assert code == 0, err
    spec = json.loads(out.read_text())
    assert spec["name"] == "syn" and len(spec["texture"]["models"]) == 2
    assert spec["friction"]["quasi_static"]["provenance"]["source"] == "recording"
    html = (tmp_path / "rep" / "index.html").read_text()
    for png in ("band_split.png", "friction_law.png", "aic.png", "spectra.png", "similarity.png"):
        assert f'src="{png}"' in html
        assert_png_drawn(tmp_path / "rep" / png)
    code, _, err = run(capsys, "render", out, "--out", tmp_path / "r", "--scan", "speed=0.1,load=0.5,duration=0.5")
    assert code == 0, err


@pytest.mark.parametrize("content,words", [
    ("time,normal_force,shear_force,speed\n" + "".join(f"{t},1,0.5,0.1\n" for t in [0, 1e-3, 5e-4] + [i * 1e-3 for i in range(3, 30)]),
     "time: not strictly increasing"),
    ("time,normal_force,speed\n" + "".join(f"{i * 1e-3},1,0.1\n" for i in range(40)), "shear_force: missing column"),
    ("time,normal_force,shear_force,speed\n" + "".join(f"{i * 1e-3},{'nan' if 10 <= i < 13 else 1},0.5,0.1\n" for i in range(40)),
     "normal_force: NaN"),
])
def test_malformed_recording_gives_one_line_and_exit_2(tmp_path, capsys, content, words):
    path = tmp_path / "bad.csv"
    path.write_text(content)
    code, _, err = run(capsys, "fit", "friction", path, "--material", "x", "--out", tmp_path / "x.json")
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and words in err and str(path) in err


def test_fit_accel_and_import_hatt(tmp_path, capsys):
    pieces = [(np.array([1.4, -0.8]), 1.0, 1500, 0.05, 0.5), (np.array([-0.5]), 2.0, 1500, 0.15, 1.0)]
    path = write_recording_npz(synthetic_accel_recording(pieces, seed=3), tmp_path / "scan.npz")
    out = tmp_path / "tool.json"
    code, _, err = run(capsys, "fit", "accel", path, "--material", "tool", "--out", out, "--mu0", "0.3", "--highpass", "0",
                       "--max-order", "6", "--report", tmp_path / "rep")
    assert code == 0, err
    assert json.loads(out.read_text())["texture"]["kind"] == "interpolated-arma"
    assert (tmp_path / "rep" / "models.png").exists()
    # an interpolated bank is shown through the texture protocol (its text read `.models` and raised)
    code, stdout, err = run(capsys, "materials", "--show", out)
    assert code == 0 and "acceleration, 7 model(s) of order <= 2" in " ".join(stdout.split()), err
    # export to HaTT, import back through the CLI, render the XML directly
    from surfhap.exchange.hatt import bank_to_hatt, write_hatt_xml
    from surfhap.exchange.material_json import read_material_json

    bank = read_material_json(out).texture
    hatt = tmp_path / "hatt" / "Models_Tool.xml"
    hatt.parent.mkdir()
    write_hatt_xml(bank_to_hatt(bank, "Tool", 0.3), hatt)
    code, stdout, err = run(capsys, "import", "hatt", hatt.parent, "--out", tmp_path / "mats")
    assert code == 0 and (tmp_path / "mats" / "tool.json").exists(), err
    code, _, err = run(capsys, "render", hatt, "--out", tmp_path / "r", "--scan", "speed=0.1,load=0.8,duration=0.5", "--method", "zhao")
    assert code == 0, err
    code, _, err = run(capsys, "import", "hatt", tmp_path / "empty", "--out", tmp_path / "m2")
    assert code == 2 and len(err.strip().splitlines()) == 1
