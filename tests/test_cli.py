"""The command line: outputs, and one clear line with exit code 2 on bad input."""

import json

import numpy as np
import pytest
from scipy.io import wavfile

from surfhap.cli import main
from surfhap.exchange.render_store import read_render
from live_support.figures import assert_png_drawn


def run(capsys, *args):
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def test_render_writes_the_promised_files(tmp_path, capsys):
    out = tmp_path / "r"
    code, stdout, err = run(capsys, "render", "leather", "--scan", "speed=0.1,load=0.3,duration=1.5", "--out", str(out), "--seed", "4")
    assert code == 0, err
    data = read_render(out / "render.npz")
    for key in ("t", "speed", "load", "mu_low", "mu_tex", "voltage", "t_drive", "drive", "friction_sim", "acc"):
        assert key in data, key
    summary = json.loads((out / "summary.json").read_text())
    for key in ("max_abs_voltage", "clipped_fraction", "method", "material", "seed"):
        assert key in summary
    assert summary["seed"] == 4 and summary["material"] == "leather"
    rate, wav = wavfile.read(out / "drive.wav")
    assert rate == 20000 and wav.dtype == np.float32
    np.testing.assert_allclose(wav, data["drive"] / 250.0, atol=1e-6)
    assert_png_drawn(out / "figure.png")


def test_materials_lists_builtins(capsys):
    code, stdout, _ = run(capsys, "materials")
    assert code == 0 and "leather" in stdout and "drawing-paper" in stdout


@pytest.mark.parametrize("setup,args,message", [
    (None, ["render", "velvet", "--scan", "speed=0.1,load=0.3,duration=1"], "velvet: unknown material"),
    ("{ oops", ["render", "{file}", "--scan", "speed=0.1,load=0.3,duration=1"], "malformed JSON"),
    ("time,x,y,load\n0,0,0,0.3\n0.01,nan,0,0.3\n0.02,0.002,0,0.3\n", ["render", "cork", "--trajectory", "{file}"], "x: row 2: NaN"),
    ("time,x,load\n0,0,0.3\n0.01,0.001,0.3\n", ["render", "cork", "--trajectory", "{file}"], ": y: missing column"),
    ("time,x,y,load\n0,0,0,0.3\n0,0.001,0,0.3\n", ["render", "cork", "--trajectory", "{file}"], "time: not strictly increasing at row 2"),
    (None, ["render", "cork", "--scan", "speed=0.1,load=0.3"], "--scan: duration: missing"),
    (None, ["render", "cork", "--scan", "speed=0.1,load=0.3,duration=1", "--carrier", "500"], "carrier: must be 0"),
    (None, ["render", "wood", "--method", "zhao", "--scan", "speed=0.1,load=0.3,duration=1"], "no Coulomb mu0"),
])
def test_bad_input_one_line_exit_2(tmp_path, capsys, setup, args, message):
    f = tmp_path / ("bad.json" if setup and setup.startswith("{") else "bad.csv")
    if setup is not None:
        f.write_text(setup)
    args = [a.replace("{file}", str(f)) for a in args] + ["--out", str(tmp_path / "o")]
    code, _, err = run(capsys, *args)
    assert code == 2
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert message in lines[0]
    assert "Traceback" not in err
    assert not (tmp_path / "o" / "render.npz").exists()


def test_demo_writes_report(tmp_path, capsys):
    code, stdout, err = run(capsys, "demo", "--out", str(tmp_path / "d"), "--duration", "1.5")
    assert code == 0, err
    html = (tmp_path / "d" / "report.html").read_text()
    assert "leather" in html and "figures/friction_law.png" in html
    assert (tmp_path / "d" / "figures" / "cork.png").exists()
    assert "report.html" in stdout
