"""Scenes switched per trial without dropping the tablet (issue 18 item 3): a scene-recognition
study with three different scenes runs on the simulated output through the participant's page
API and ONE WebSocket, with ONE engine that never restarts or halts; each trial's drive
follows its own scene. Every renderer is built and run once before the engine starts
(:meth:`StimulusPlayer.prepare`): built, or first run, under the running engine, a scene's
renderer held the GIL past the output's 1 s stall limit (numba compiling on a cold cache) and
the engine halted at 0 V for the rest of the session."""

from __future__ import annotations

import json

import numpy as np

from surfhap.cli import main
from surfhap.lab.triallog import read_log
from test_lab_experimenter import call, wait_for

SCENES = ["gaussian-4B0H-spot", "gaussian-0B4H-spot", "frustum-2B2H-spot"]  # top row: bumps, holes, bump + hole


def _slope(name: str, x: np.ndarray, width: float) -> np.ndarray:
    """dz/dx of the scene's geometry along the top row (y = +3 cm, the TL / TR centres), at the
    touch-surface positions ``x`` (the scene is centred on the surface): the reference."""
    from surfhap.shape.scenes import builtin_shape

    z = builtin_shape(name).query(np.column_stack([x - width / 2, np.full(x.size, 0.03)])).z
    return np.gradient(np.nan_to_num(z), x)


def test_three_scenes_one_engine_one_page_session(tmp_path, monkeypatch):
    from websockets.sync.client import connect

    from surfhap.lab.session import SessionRunner
    from surfhap.lab.stimuli import StimulusPlayer
    from surfhap.live.backends.output import SimOutput
    from surfhap.live.config import ServerConfig
    from surfhap.web import create_app
    from surfhap.web.server import ServerThread
    from surfhap.web.study import StudyPage, start_player

    design = {"format": "surfhap-study-design", "version": 1, "kind": "scene-recognition", "name": "switch",
              "participants": 1, "params": {"scenes": SCENES}}
    (tmp_path / "d.json").write_text(json.dumps(design))
    assert main(["study", "new", str(tmp_path / "d.json"), "--out", str(tmp_path / "s")]) == 0
    runner = SessionRunner(tmp_path / "s", "P01")
    built_while_running = []
    build = StimulusPlayer._build

    def spy(self, render):
        built_while_running.append(self.session.started)
        return build(self, render)

    monkeypatch.setattr(StimulusPlayer, "_build", spy)
    player = start_player(runner, SimOutput())  # as 'study run --output sim'
    session, eng = player.session, player.session.engine
    server = ServerThread(create_app(ServerConfig(port=0), study=StudyPage(runner, player))).start()
    port, W, H = server.port, session.space.width, session.space.height
    fy = 0.5 - 0.03 / H  # the page row of the top objects (the page spans the touch surface)
    profiles, blocks = {}, []
    try:
        with connect(server.url.replace("http://", "ws://") + "/ws", open_timeout=60) as ws:
            ws.send(json.dumps({"type": "hello", "w": 800.0, "h": 500.0}))
            seq = 0
            while (st := call(port, "GET", "/api/state")[1])["status"] != "done":
                if st["status"] == "rest":
                    call(port, "POST", "/api/resume")
                    continue
                t = runner.current()
                name, haptic = t.stimuli[0].render["scene"], t.stimuli[0].render["haptic"]
                assert call(port, "POST", "/api/stimulus", {"trial_id": t.id, "index": 0})[1]["ok"]
                c0 = eng.trace_count
                if haptic:  # three strokes left to right along the top row, lifted in between
                    for _ in range(3):
                        for i in range(300):  # paced by the engine: each move taken before the next
                            n = eng.counters["touches"]
                            ws.send(json.dumps({"type": "move", "seq": seq, "t": 4.0 * seq, "x": 0.15 + 0.7 * i / 299,
                                                "y": fy, "p": 0.5}))
                            seq += 1
                            wait_for(lambda: eng.counters["touches"] > n or eng.halted, "the engine to take the touch")
                        ws.send(json.dumps({"type": "up", "seq": seq, "t": 4.0 * seq}))
                        seq += 1
                    wait_for(lambda: eng.trace_count > c0 + 100, "the trace")
                    rows, _ = eng.trace_since(c0)
                    profiles[name] = rows[rows[:, 4] > 0]  # t x y speed load v_peak target friction
                assert call(port, "GET", f"/api/image/{t.id}")[0] == 200  # the page's picture of the scene
                blocks.append(eng.counters["blocks"])
                answer = ",".join(f"{q}=1" for q in t.toggles)
                assert call(port, "POST", "/api/answer", {"trial_id": t.id, "answer": answer})[1]["accepted"]
    finally:
        server.stop()
        session.stop()
        runner.close()
    assert len(read_log(tmp_path / "s" / "logs" / "P01.jsonl").trials) == 6
    # one engine, never reset (its block counter only grows), never failed, all through one socket
    assert blocks == sorted(blocks) and not eng.halted and eng.failure is None
    assert eng.counters["backend_failures"] == 0 and eng.counters["errors"] == 0
    assert built_while_running and not any(built_while_running)  # every scene built before the engine ran
    assert sorted(profiles) == sorted(SCENES)
    # each trial's target force along the row follows ITS scene's slope, not another's
    bins = np.linspace(0.15 * W, 0.85 * W, 41)
    xc = (bins[:-1] + bins[1:]) / 2
    refs = {n: _slope(n, xc, W) for n in SCENES}
    for name, rows in profiles.items():
        idx = np.digitize(rows[:, 1], bins)
        prof = np.array([rows[idx == b, 6].mean() if (idx == b).any() else 0.0 for b in range(1, len(bins))])
        r = {m: float(np.corrcoef(prof, refs[m])[0, 1]) for m in SCENES}
        assert r[name] > 0.5 and all(r[name] > r[m] + 0.3 for m in SCENES if m != name), (name, r)
