"""GUI buttons (KinesTouch use case 3): press events when the screen is pushed past a
button's click depth, with hysteresis; in the engine, the simulation, its figure and OSC."""

import json
import math
import socket

import numpy as np
import pytest

from surfhap.errors import SceneFormatError
from surfhap.ff import FALCON, FFEngine
from surfhap.ff.buttons import Button, ButtonPresses
from surfhap.ff.scene import load_scene
from surfhap.render.kinematics import TouchPredictor
from surfhap.live.ff_loop import simulate_ff
from surfhap.sim.ff_device import SimDevice, SimFinger
from surfhap.models.trajectory import Trajectory

B = [Button("a", 0.0, 0.0, 0.01, 0.01, 1e-3, 5e-4), Button("b", 0.02, 0.0, 0.03, 0.01, 1e-3, 5e-4)]


def test_hysteresis_gives_one_press_per_push():
    bp = ButtonPresses(B)
    # depth (m) = -pz: up, past the click depth, chatter inside the band, back up, again down
    depths = [0, 4e-4, 1.1e-3, 7e-4, 1.05e-3, 6e-4, 9e-4, 4e-4, 2e-4, 1.2e-3, 3e-4]
    out = [bp.update(True, 0.005, 0.005, -d) for d in depths]
    assert out == [-1, -1, 0, 0, 0, 0, 0, -1, -1, 0, -1]
    assert bp.presses == [2, 0] and bp.events == 4


def test_slide_onto_a_button_pushed_down_does_not_click_it_and_lift_releases():
    bp = ButtonPresses(B)
    assert bp.update(True, 0.005, 0.005, -2e-3) == 0  # landing on "a" with the screen moving: armed
    assert bp.update(True, 0.025, 0.005, -2e-3) == -1  # slid onto "b" still deep: "a" released, "b" not armed
    assert bp.update(True, 0.025, 0.005, -1.5e-3) == -1
    assert bp.update(True, 0.025, 0.005, -3e-4) == -1  # up: armed
    assert bp.update(True, 0.025, 0.005, -1.2e-3) == 1
    assert bp.update(False, 0.025, 0.005, -1.2e-3) == -1  # lift releases
    assert bp.update(True, 0.015, 0.005, -2e-3) == -1  # between the buttons: nothing
    assert bp.update(True, 0.015, 0.005, -7e-4) == -1
    assert bp.update(True, 0.005, 0.005, -7e-4) == -1  # onto "a" above its click depth: armed
    assert bp.update(True, 0.005, 0.005, -1.1e-3) == 0  # sinks past it: a press
    assert bp.presses == [2, 1]


def test_scene_buttons_validated():
    from surfhap.ff.scene import builtin_scene_path

    raw = json.loads(builtin_scene_path("buttons").read_text())
    assert [b["name"] for b in raw["buttons"]] == ["easy", "soft", "firm", "hard"]
    raw["buttons"][2]["release_depth_m"] = 0.001  # above its click depth
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / "bad.json"
        p.write_text(json.dumps(raw))
        with pytest.raises(SceneFormatError) as e:
            load_scene(p)
    assert "buttons.2" in str(e.value) and "bad.json" in str(e.value)


def test_a_bad_button_is_one_config_error_naming_the_field():
    """Issue 20: one pydantic type for a scene file's button and the detector's (no second
    hand-written validator): a library caller gets the scene file's checks and field names."""
    from surfhap.errors import ConfigError

    for args, field in (((0.0, 0.0, 0.01, 0.01, 0.06, 5e-4), "click_depth_m"),
                        ((0.0, 0.0, 0.01, 0.01, 1e-3, -1e-4), "release_depth_m"),
                        ((0.0, 0.0, 0.01, math.nan, 1e-3, 5e-4), "y1"),
                        ((0.0, 0.0, 0.01, 0.01, 1e-3, 2e-3), "(top)")):
        with pytest.raises(ConfigError) as e:
            Button("a", *args)
        assert e.value.field == field


def _presses_trajectory(peak_load: float, sc):
    """One 0.75 s push on the centre of each button in turn, load ramped 0 -> peak -> 0."""
    t = np.arange(0.0, 3.0, 1 / 60)
    ph = t % 0.75
    load = np.interp(ph, [0, 0.05, 0.35, 0.65, 0.7, 0.75], [0, 0.05, peak_load, 0.05, 0.0, 0.0])
    cx = np.array([(b.x0 + b.x1) / 2 for b in sc.buttons])[(t // 0.75).astype(int)]
    cy = (sc.buttons[0].y0 + sc.buttons[0].y1) / 2
    return Trajectory(t, cx, np.full(t.size, cy), load)


@pytest.mark.parametrize("peak", [0.3, 1.2])
def test_simulated_pushes_click_the_buttons_whose_click_force_they_pass(peak):
    sc = load_scene("buttons")
    eng = FFEngine(sc.effects, FALCON, TouchPredictor(), buttons=sc.buttons)
    res = simulate_ff(eng, SimFinger(_presses_trajectory(peak, sc)), SimDevice(gain=FALCON.gain))
    # independent reference: a spring of stiffness k is pushed down d by the force k d
    ks = [sc.effects[0].k_mat.value((b.x0 + b.x1) / 2, (b.y0 + b.y1) / 2) for b in sc.buttons]
    expect = [b.name for b, k in zip(sc.buttons, ks) if k * b.click_depth_m < 0.85 * peak]
    assert expect and (peak < 1.0) == (len(expect) < 4)
    assert [name for _, name in res.presses()] == expect
    assert eng.button_presses.presses == [int(b.name in expect) for b in sc.buttons]
    # every pressed tick is on that button with the screen below the release depth
    on = res.button >= 0
    assert np.all(-res.screen[on, 2] >= 0.4e-3 - 1e-12)
    assert res.summary()["button_presses"][0]["button"] == expect[0]
    fig = res.plot()
    labels = [t.get_text() for ax in fig.axes for t in ax.texts]
    assert [f"press {n}" for n in expect] == labels


def test_osc_feedback_sends_press_and_release():
    from pythonosc.osc_message import OscMessage

    from surfhap.live.ff_loop import OscFeedback

    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(2.0)
    sc = load_scene("buttons")
    eng = FFEngine(sc.effects, FALCON, TouchPredictor(), buttons=sc.buttons)
    fb = OscFeedback("127.0.0.1", rx.getsockname()[1], engine=eng)
    got = []
    try:
        for b in (-1, 2, 2, -1):
            eng.button = b
            fb(0.0, 0.0, 0.0, -1e-3, 0.0, 0.0, 0.0, 0.0, 4.0)
        while True:
            try:
                m = OscMessage(rx.recv(4096))
            except socket.timeout:
                break
            if m.address == "/surfhap/ff/button":
                got.append(m.params)
            if fb.sent == 4 and len(got) == 2:
                break
    finally:
        rx.close()
    assert got == [[2, 1, "firm"], [2, 0, "firm"]]


def test_ff_simulate_of_the_buttons_scene_shows_one_press_per_button(tmp_path, capsys):
    from surfhap.cli import main

    code = main(["ff", "simulate", "buttons", "--out", str(tmp_path), "--no-figures"])
    out = capsys.readouterr().out
    assert code == 0 and "4 button presses" in " ".join(out.split())
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert [p["button"] for p in summary["button_presses"]] == ["easy", "soft", "firm", "hard"]
    z = np.load(tmp_path / "ff_simulation.npz")
    assert z["button"].shape == z["t"].shape and list(z["buttons"]) == ["easy", "soft", "firm", "hard"]
    assert set(np.unique(z["button"])) == {-1, 0, 1, 2, 3}
