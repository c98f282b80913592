"""``surfhap ff``: scenes, simulate, run; one clear line and exit code 2 on bad input."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from surfhap.cli import main
from surfhap.exchange.trajectory_csv import write_trajectory_csv
from surfhap.ff.scene import builtin_scene_names, load_scene
from surfhap.models.trajectory import Trajectory
from live_support.figures import assert_png_drawn

SRC = Path(__file__).resolve().parents[1] / "src"


def run(capsys, *args):
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def strokes_csv(path, dur=2.0, x0=0.1, y0=0.07, freq=0.5, rate=120.0):
    t = np.arange(0.0, dur, 1.0 / rate)
    write_trajectory_csv(Trajectory(t, x0 + 0.03 * np.sin(2 * np.pi * freq * t), np.full(t.size, y0), np.ones(t.size)),
                         path)
    return path


def test_scenes_lists_the_examples(capsys):
    code, out, _ = run(capsys, "ff", "scenes")
    assert code == 0
    for name in ("garden", "buttons", "mall", "suzanne", "follow", "reverse"):
        assert name in out


@pytest.mark.parametrize("name", ["garden", "buttons", "mall", "follow", "reverse"])
def test_every_example_scene_loads_and_keeps_forces_within_limits(name, tmp_path, capsys):
    out = tmp_path / name
    csv = strokes_csv(tmp_path / "t.csv", y0=0.07 if name != "garden" else 0.09)
    code, _, err = run(capsys, "ff", "simulate", name, "--trajectory", str(csv), "--out", str(out), "--no-figures")
    assert code == 0, err
    s = json.loads((out / "summary.json").read_text())
    assert max(s["force_abs_max_N"]) <= 8.0 + 1e-9
    assert s["touched_fraction"] > 0.5
    d = np.load(out / "ff_simulation.npz")
    for key in ("t", "force", "screen", "sliding", "mask", "touched"):
        assert key in d
    assert np.any(d["mask"] != 0)  # some effect was active under the finger


def test_simulate_writes_figures_and_switch_log(tmp_path, capsys):
    out = tmp_path / "o"
    code, _, err = run(capsys, "ff", "simulate", "follow", "--out", str(out))
    assert code == 0, err
    assert_png_drawn(out / "ff_simulation.png")
    assert_png_drawn(out / "ff_top_view.png")
    s = json.loads((out / "summary.json").read_text())
    assert s["sliding_speed_rms_m_s"] < 0.2 * s["finger_speed_rms_m_s"]  # Follow
    assert s["switch_log"][0]["active"] == [] and ["sliding"] in [e["active"] for e in s["switch_log"]]


def test_mesh_scene_loads():
    sc = load_scene("suzanne")
    h = sc.effects[0].height
    assert 0.02 < h.value(sc.size[0] / 2, sc.size[1] / 2) <= 0.025 + 1e-9
    assert h.value(0.005, 0.005) == 0.0


def _scene(tmp_path, body):
    p = tmp_path / "bad.json"
    p.write_text(body if isinstance(body, str) else json.dumps(body))
    return p


GOOD = {"format": "surfhap-ff-scene", "schema_version": 1, "name": "x", "size_m": [0.2, 0.15],
        "effects": [{"type": "stiffness", "k_mat": 300.0}]}


@pytest.mark.parametrize("body,field", [
    ("{not json", None),
    ({**GOOD, "effects": [{"type": "stiffness"}]}, "effects.0.k_mat"),
    ({**GOOD, "effects": [{"type": "wobble"}]}, "effects.0"),
    ({**GOOD, "size_m": [0.2]}, "size_m"),
    ({**GOOD, "size_m": [0.2, 5.0]}, "size_m.1"),  # the side out of range is named
    ({**GOOD, "effects": [{"type": "roughness", "depth": 1e-4, "period_m": -1}]}, "effects.0.period_m"),
    ({**GOOD, "effects": [{"type": "stiffness", "k_mat": {"image": "missing.png"}}]}, "effects.0.k_mat.image"),
    ({**GOOD, "effects": [{"type": "shape", "height": {"rects": [{"x0": 0, "y0": 0, "x1": -1, "y1": 1, "value": 1}]}}]},
     "effects.0.height.rects.0"),
    ({**GOOD, "schema_version": 2}, "schema_version"),
])
def test_bad_scene_file_is_one_line_naming_file_and_field(tmp_path, capsys, body, field):
    p = _scene(tmp_path, body)
    code, _, err = run(capsys, "ff", "simulate", str(p), "--out", str(tmp_path / "o"), "--no-figures")
    assert code == 2
    lines = [ln for ln in err.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and "Traceback" not in err, err
    assert str(p) in err.replace("\n", "")
    if field:
        assert field in err, err


def test_bad_trajectory_and_options_exit_2(tmp_path, capsys):
    bad = tmp_path / "t.csv"
    bad.write_text("time,x,y\n0,0,0\n1,0,0\n")
    code, _, err = run(capsys, "ff", "simulate", "follow", "--trajectory", str(bad), "--out", str(tmp_path / "o"))
    assert code == 2 and "load" in err
    code, _, err = run(capsys, "ff", "simulate", "follow", "--smoothing", "0", "--out", str(tmp_path / "o"))
    assert code == 2 and "--smoothing" in err
    code, _, err = run(capsys, "ff", "run", "follow", "--device", "serial:/dev/x", "--duration", "1")
    assert code == 2 and "--device" in err
    code, _, err = run(capsys, "ff", "simulate", "no-such-scene", "--out", str(tmp_path / "o"))
    assert code == 2 and "no-such-scene" in err


@pytest.mark.parametrize("option,value", [("--touch-latency-ms", "250"), ("--smoothing", "1.5"),
                                          ("--velocity-alpha", "0"), ("--k-pred", "101")])
def test_predictor_options_out_of_range_name_their_option(tmp_path, capsys, option, value):
    """The predictor's own range checks (render/kinematics.py, the one check) surface as one
    line naming the CLI option, exit 2, also with --no-predict."""
    for predict in ("--predict", "--no-predict"):
        code, _, err = run(capsys, "ff", "simulate", "follow", option, value, predict, "--out", str(tmp_path / "o"))
        lines = [ln for ln in err.strip().splitlines() if ln.strip()]
        assert code == 2 and option in err and len(lines) == 1 and "Traceback" not in err, err


def test_old_alpha_option_is_one_line_naming_the_new_one(tmp_path, capsys):
    """``--alpha`` is V/sqrt(N) in render; ff's smoothing factor is ``--smoothing`` (issue 20)."""
    code, _, err = run(capsys, "ff", "simulate", "follow", "--alpha", "0.15", "--out", str(tmp_path / "o"))
    assert code == 2 and "--alpha" in err and "--smoothing" in err and "Traceback" not in err


def test_touch_page_keeps_its_address_with_an_osc_device(monkeypatch, capsys):
    """``--device osc://... --touch web`` served the page on the device's address (issue 20)."""
    import surfhap.cli.ff as ff_cli

    served = []

    class FakePage:
        def __init__(self, scene, loop, dev, host, port):
            served.append((host, port))

        def start(self):
            pass

        def stop(self):
            pass

    monkeypatch.setattr(ff_cli, "_WebSource", FakePage)
    code, _, err = run(capsys, "ff", "run", "follow", "--device", "osc://127.0.0.1:9", "--device-listen", "127.0.0.1:0",
                       "--touch", "web", "--host", "127.0.0.1", "--port", "8799", "--duration", "0.1")
    assert code == 0, err
    assert served == [("127.0.0.1", 8799)]


def test_run_with_sim_device_and_replay(tmp_path, capsys):
    csv = strokes_csv(tmp_path / "t.csv", dur=1.0)
    code, out, err = run(capsys, "ff", "run", "follow", "--json", "--device", "sim", "--trajectory", str(csv))
    assert code == 0, err
    st = json.loads(out.strip().splitlines()[-1])
    assert st["ticks"] > 500 and st["error"] is None
    assert st["safety"]["stopped"] >= 1  # the run ended through the stop ramp


def test_run_stops_cleanly_on_sigterm(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    proc = subprocess.Popen([sys.executable, "-c", "import sys; from surfhap.cli import main; sys.exit(main(sys.argv[1:]))",
                             "ff", "run", "buttons", "--json", "--device", "sim", "--touch", "osc://127.0.0.1:0"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        # wait for the start line, then stop it like a service manager would
        end = time.monotonic() + 60
        line = ""
        while time.monotonic() < end and "Ctrl-C" not in line:
            line += proc.stderr.readline()
        assert "Ctrl-C" in line, line
        time.sleep(0.5)
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 130, err
    st = json.loads(out.strip().splitlines()[-1])
    assert st["safety"]["stopped"] >= 1 and st["error"] is None


def test_builtin_scene_names_match_package_files():
    assert set(builtin_scene_names()) >= {"garden", "buttons", "mall", "suzanne", "follow", "reverse"}


from hypothesis import HealthCheck, example, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from surfhap.errors import SceneFormatError  # noqa: E402

json_values = st.recursive(st.none() | st.booleans() | st.floats(allow_nan=True) | st.integers() | st.text(max_size=8),
                           lambda c: st.lists(c, max_size=4) | st.dictionaries(st.text(max_size=8), c, max_size=4),
                           max_leaves=12)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(key=st.sampled_from(["format", "schema_version", "name", "size_m", "picture", "effects", "provenance", "extra"]),
       value=json_values, effect_key=st.sampled_from(["type", "k_mat", "alpha", "depth", "period_m", "height", "mesh",
                                                     "points", "nu"]),
       effect_value=json_values)
@example(key="picture", value={"\n": None}, effect_key="type", effect_value=None)  # a line break in a key
def test_any_mangled_scene_is_a_scene_format_error_or_loads(tmp_path, key, value, effect_key, effect_value):
    """Random values in any field: loading either works or raises SceneFormatError (never
    another exception), so the CLI always prints one line and exits 2."""
    body = json.loads(json.dumps(GOOD))
    body["effects"] = [{"type": "sliding", "alpha": 0.5}]
    body[key] = value
    if isinstance(body.get("effects"), list) and body["effects"] and isinstance(body["effects"][0], dict):
        body["effects"][0][effect_key] = effect_value
    p = tmp_path / "fuzz.json"
    try:
        p.write_text(json.dumps(body, allow_nan=True))
    except ValueError:
        return
    try:
        sc = load_scene(p)
    except SceneFormatError as exc:
        assert str(p) in str(exc) and "\n" not in str(exc)
    else:
        assert sc.effects
