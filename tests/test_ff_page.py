"""The touch page's force-feedback panel data: an ff web session (page server in its own
process, as ``surfhap ff run SCENE --touch web`` runs it) streams the device position and
the force of the loop, per trace point, in SI units."""

import asyncio
import json
import time
import urllib.request

import numpy as np
import websockets

from surfhap.ff import FALCON, FFEngine
from surfhap.ff.params import GRAVITY
from surfhap.ff.scene import load_scene
from surfhap.live.ff_devices import SimDeviceBackend
from surfhap.live.ff_loop import FFLoop
from surfhap.web.ff import build_ff_session
from surfhap.render.kinematics import TouchPredictor
from surfhap.sim.ff_device import SimDevice


def _ff_session(scene="buttons"):
    sc = load_scene(scene)
    eng = FFEngine(sc.effects, FALCON, TouchPredictor(), touch_latency=0.0, buttons=sc.buttons)
    loop = FFLoop(eng, SimDeviceBackend(SimDevice(gain=FALCON.gain), FALCON.gain))
    session = build_ff_session(sc, loop, max(FALCON.f_max))
    log = []  # the loop's own feedback samples: (t s, p (3,) m, F (3,) N)

    def feedback(t, px, py, pz, dx, dy, fx, fy, fz):
        log.append((t, np.array([px, py, pz]), np.array([fx, fy, fz])))
        session.engine.record(t, px, py, pz, fx, fy, fz)

    loop.feedback = feedback
    return sc, eng, loop, session, log


def test_texture_page_frames_carry_no_ff_data():
    from surfhap.live.session import FrameBuilder
    from surfhap.live.session import build_session

    s = build_session("denim")
    frame = FrameBuilder(s.engine, s.backend).frame()
    assert "ff" not in frame and s.ff is None and set(frame) == {"t", "v", "f", "target", "speed"}


def test_ff_stream_carries_the_loops_position_and_force():
    from surfhap.live.config import ServerConfig
    from surfhap.web.process import WebProcess

    sc, eng, loop, session, log = _ff_session()
    easy = sc.buttons[0]
    k_easy = sc.effects[0].k_mat.value((easy.x0 + easy.x1) / 2, (easy.y0 + easy.y1) / 2)
    w, h = sc.size
    web = WebProcess(session, ServerConfig(port=0)).start()
    loop.start()
    frames = []
    phase = {}

    async def client():
        async with websockets.connect(f"ws://127.0.0.1:{web.port}/ws", origin=f"http://127.0.0.1:{web.port}") as ws:
            await ws.send(json.dumps({"type": "hello", "w": 800, "h": 600}))
            t0 = time.perf_counter()

            async def pump(seconds, touch):
                end = time.perf_counter() + seconds
                i = 0
                while time.perf_counter() < end:
                    if touch:
                        await ws.send(json.dumps({"type": "move", "seq": i, "t": (time.perf_counter() - t0) * 1e3,
                                                  "x": (easy.x0 + easy.x1) / 2 / w, "y": (easy.y0 + easy.y1) / 2 / h,
                                                  "p": 0.5}))
                        i += 1
                    try:
                        m = json.loads(await asyncio.wait_for(ws.recv(), 0.016))
                        if m.get("type") == "trace":
                            frames.append((touch, m))
                    except asyncio.TimeoutError:
                        pass

            await pump(0.5, False)
            await pump(2.5, True)
            phase["up"] = len(frames)
            await ws.send(json.dumps({"type": "up", "seq": 10**6, "t": (time.perf_counter() - t0) * 1e3}))
            await pump(1.0, False)

    try:
        info = json.loads(urllib.request.urlopen(f"http://127.0.0.1:{web.port}/api/info", timeout=30).read())
        asyncio.run(client())
    finally:
        loop.stop()
        web.stop()
    assert loop.error is None
    ff = info["ff"]
    assert ff["workspace_m"] == list(FALCON.workspace) and ff["f_max_n"] == list(FALCON.f_max)
    assert ff["effects"] == ["stiffness"] and ff["buttons"] == ["easy", "soft", "firm", "hard"]

    log_t = np.array([q[0] for q in log])  # the page's t is rounded to 0.1 ms
    matched = 0
    pts = []  # (touching, p, F, mask, button) per trace point
    for touching, m in frames:
        d = m["ff"]
        n = len(m["t"])
        assert len(d["p"]) == len(d["F"]) == len(d["mask"]) == len(d["button"]) == n
        for i in range(n):
            p, F = np.array(d["p"][i]), np.array(d["F"][i])
            assert p.shape == (3,) and F.shape == (3,)
            near = np.nonzero(np.abs(log_t - m["t"][i]) <= 1e-4)[0]  # more than one if the thread ran late
            assert near.size, "a trace point the loop never produced"
            assert any(np.allclose(p, log[j][1], atol=1e-6, rtol=0) and np.allclose(F, log[j][2], atol=1e-4, rtol=0)
                       for j in near), (p, F, [log[j] for j in near])
            matched += 1
            pts.append((touching, p, F, d["mask"][i], d["button"][i]))
    assert matched >= 60
    # units: at rest under the 0.5 N page load the easy button's spring (k N/m) is pushed
    # down 0.5 / k m, and the device pushes back the tablet's weight plus that load (N)
    load = 0.5 * session.space.max_load
    held = [q for q in pts[: sum(len(m["t"]) for _, m in frames[: phase["up"]])] if q[0]][-20:]
    assert len(held) == 20
    pz = np.array([q[1][2] for q in held])
    fz = np.array([q[2][2] for q in held])
    assert np.allclose(pz, -load / k_easy, rtol=0.1), pz
    assert np.allclose(fz, FALCON.moving_mass * GRAVITY + load, rtol=0.05), fz
    assert all(q[3] == 1 and q[4] == 0 for q in held), "stiffness active and the easy button pressed"
    assert np.all(np.abs([q[1][:2] for q in held]) < 1e-3)  # lateral axes held at K_max
    after = [q for q in pts[-15:]]
    assert all(q[4] == -1 for q in after) and abs(after[-1][1][2]) < 0.2 * load / k_easy  # released, back up
