"""The display-curve test (issue 20, Done when): a measured device curve in a display file
changes the voltages of ``render`` and ``shape`` to the inverse of that curve (written here
independently), and every command that drives a display accepts ``--display FILE``."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest

from surfhap.cli import main

K, MU = 5e-6, 0.5
C0, C1, C2 = 0.0, 2e-4, 1e-6  # measured F(V) = C1 V + C2 V^2 (N): not the square law mu k V^2
V_MAX = 250.0


def inverse(force):
    """The voltage at which C0 + C1 V + C2 V^2 equals ``force``: the positive root."""
    f = np.maximum(np.asarray(force, dtype=float), 0.0)
    return (-C1 + np.sqrt(C1 ** 2 - 4 * C2 * (C0 - f))) / (2 * C2)


def display_file(path, curve: bool = True):
    doc = {"format": "surfhap-display", "version": 1, "k": K, "mu_panel": MU, "provenance": {"source": "test"}}
    if curve:
        doc["device_curve"] = {"input": "voltage", "coefficients": [C0, C1, C2], "input_max": 400.0}
    path.write_text(json.dumps(doc))
    return path


@pytest.fixture
def panels(tmp_path):
    return display_file(tmp_path / "measured.json"), display_file(tmp_path / "square.json", curve=False)


def test_render_voltages_are_the_inverse_of_the_measured_curve(tmp_path, panels):
    measured, square = panels
    runs = {}
    for name, panel in (("measured", measured), ("square", square)):
        out = tmp_path / name
        assert main(["render", "wood", "--scan", "speed=0.1,load=0.5,duration=0.3", "--display", str(panel),
                     "--out", str(out), "--format", "npz", "--no-figure"]) == 0
        z = np.load(out / "render.npz")
        gain = json.loads((out / "summary.json").read_text())["rendering_gain"]
        runs[name] = (z["voltage"].astype(float), z["target"].astype(float), gain)
    v, target, gain = runs["measured"]
    touching = target > 0
    assert touching.mean() > 0.9
    np.testing.assert_allclose(v[touching], inverse(gain * target[touching]), rtol=2e-5)
    # without the curve: V = sqrt(G F / (mu k)), and the measured curve changed the voltages
    v2, target2, gain2 = runs["square"]
    np.testing.assert_allclose(v2, np.sqrt(gain2 * np.maximum(target2, 0) / (MU * K)), rtol=2e-5)
    assert np.max(np.abs(v[touching] - v2[touching])) > 5.0


def test_shape_voltages_are_the_inverse_of_the_measured_curve(tmp_path, panels):
    measured, square = panels
    res = {}
    for name, panel in (("measured", measured), ("square", square)):
        out = tmp_path / name
        assert main(["shape", "gaussian-bump", "--scan=-0.02,0,0.02,0,0.1", "--display", str(panel),
                     "--out", str(out), "--no-figure"]) == 0
        z = np.load(out / "shape.npz")
        res[name] = (np.abs(z["drive"]), z["target"])
    drive, target = res["measured"]
    want = inverse(target)
    free = want < 0.95 * V_MAX  # not clamped by the safety stage
    assert free.mean() > 0.3
    # after carrier and safety stage |drive| is the envelope (one start-up sample is rise-limited)
    assert np.mean(np.isclose(drive[free], want[free], rtol=1e-9, atol=1e-9)) > 0.99
    drive2, target2 = res["square"]
    np.testing.assert_allclose(target2, target)  # the same target forces ...
    assert np.max(np.abs(drive2[free] - drive[free])) > 5.0  # ... at other voltages


def _bad_display(tmp_path):
    p = tmp_path / "bad_panel.json"
    p.write_text(json.dumps({"format": "surfhap-display", "version": 1, "mu_panel": -1, "provenance": {"source": "x"}}))
    return p


def _study(tmp_path):
    study = tmp_path / "study"
    assert main(["study", "new", "kim-shapes", "--out", str(study), "--participants", "1"]) == 0
    return study


@pytest.mark.parametrize("command", ["render", "play", "serve", "serve --mesh", "shape", "study run"])
def test_every_display_command_reads_display_file(tmp_path, capsys, command):
    bad = str(_bad_display(tmp_path))
    args = {
        "render": ["render", "wood", "--scan", "speed=0.1,load=0.5,duration=0.2", "--out", str(tmp_path / "o")],
        "play": ["play", "cork", "--output", f"file:{tmp_path / 'p.npz'}", "--scan", "speed=0.1,load=0.5,duration=0.2"],
        "serve": ["serve", "--output", f"file:{tmp_path / 's.npz'}", "--duration", "0.2"],
        "serve --mesh": ["serve", "--mesh", "no-mesh.obj", "--duration", "0.2"],
        "shape": ["shape", "gaussian-bump", "--scan=-0.02,0,0.02,0,0.1", "--out", str(tmp_path / "o")],
        "study run": ["study", "run", str(_study(tmp_path)) if command == "study run" else "", "-p", "P01",
                      "--simulate", "1"],
    }[command]
    capsys.readouterr()
    assert main([*args, "--display", bad]) == 2
    err = capsys.readouterr().err
    assert "bad_panel.json" in err and "mu_panel" in err and "Traceback" not in err


def test_play_and_study_run_render_for_the_display_file(tmp_path, panels):
    measured, _ = panels
    assert main(["play", "cork", "--output", f"file:{tmp_path / 'p.npz'}", "--scan",
                 "speed=0.1,load=0.5,duration=0.2", "--display", str(measured)]) == 0
    study = _study(tmp_path)
    assert main(["study", "run", str(study), "-p", "P01", "--simulate", "1", "--display", str(measured)]) == 0
    head = json.loads((study / "logs" / "P01.jsonl").read_text().splitlines()[0])
    assert head["config"]["display"]["device_curve"]["coefficients"] == [C0, C1, C2]


def test_study_stimuli_and_mesh_sessions_use_the_display(tmp_path, panels):
    from surfhap.exchange.display_file import load_display
    from surfhap.lab.stimuli import StimulusPlayer
    from surfhap.live.session import TouchSpace, build_session

    disp = load_display(str(panels[0]))
    session = SimpleNamespace(engine=SimpleNamespace(drive_rate=20000), space=TouchSpace())
    player = StimulusPlayer(session, gain=1.0, display=disp)
    for render in ({"material": "wood"}, {"mesh": "gaussian-bump"}, {"profile1d": "bump"}):
        chain, _ = player._build(render)
        assert chain.config.display == disp
    import trimesh

    mesh = tmp_path / "bump.obj"
    xs = np.linspace(-0.03, 0.03, 13)
    gx, gy = np.meshgrid(xs, xs)
    verts = np.column_stack([gx.ravel(), gy.ravel(), 0.005 * np.exp(-(gx.ravel() ** 2 + gy.ravel() ** 2) / 2e-4)])
    faces = [[i * 13 + j, i * 13 + j + 1, i * 13 + j + 13] for i in range(12) for j in range(12)]
    faces += [[i * 13 + j + 1, i * 13 + j + 14, i * 13 + j + 13] for i in range(12) for j in range(12)]
    trimesh.Trimesh(verts, np.array(faces), process=False).export(mesh)
    live = build_session(mesh=mesh, display=disp)
    assert live.engine.renderer.config.display == disp


def test_the_writer_refuses_a_display_file_the_reader_would_refuse(tmp_path):
    from surfhap.errors import ConfigError
    from surfhap.exchange.display_file import read_display_json, write_display_json

    doc = {"format": "surfhap-display", "version": 1, "k": K, "mu_panel": MU, "provenance": {"source": "test"},
           "device_curve": {"input": "voltage", "coefficients": [C0, C1, C2], "input_max": 300.0}}
    back = read_display_json(write_display_json(doc, tmp_path / "ok.json"))
    assert back.device_curve.coefficients == (C0, C1, C2) and back.device_curve.u_max == 300.0
    doc["device_curve"]["coefficients"] = [0.1, 0.0, -1e-6]  # never rises: no inverse
    with pytest.raises(ConfigError) as err:
        write_display_json(doc, tmp_path / "bad.json")
    assert err.value.field == "device_curve" and not (tmp_path / "bad.json").exists()
