"""The touch page feeds the force-feedback loop through the unchanged page server."""

import asyncio
import json
import time

import websockets

from surfhap.ff import FALCON, FFEngine
from surfhap.ff.scene import load_scene
from surfhap.live.ff_devices import SimDeviceBackend
from surfhap.live.ff_loop import FFLoop
from surfhap.web.ff import build_ff_session
from surfhap.render.kinematics import TouchPredictor
from surfhap.sim.ff_device import SimDevice


def test_page_touches_press_the_button_under_them():
    from surfhap.web import create_app
    from surfhap.live.config import ServerConfig
    from surfhap.web.server import ServerThread

    sc = load_scene("buttons")
    eng = FFEngine(sc.effects, FALCON, TouchPredictor(), touch_latency=0.0)
    loop = FFLoop(eng, SimDeviceBackend(SimDevice(gain=FALCON.gain), FALCON.gain))
    session = build_ff_session(sc, loop, max(FALCON.f_max))
    loop.feedback = lambda t, px, py, pz, dx, dy, fx, fy, fz: session.engine.record(t, px, py, pz, fx, fy, fz)
    srv = ServerThread(create_app(ServerConfig(), touch=session), port=0).start()
    session.start()
    seen = {}

    async def client():
        url = f"ws://127.0.0.1:{srv.port}/ws"
        async with websockets.connect(url, origin=f"http://127.0.0.1:{srv.port}") as ws:
            await ws.send(json.dumps({"type": "hello", "w": 800, "h": 600}))
            t0 = time.perf_counter()
            # the hardest button spans x 0.150-0.185 m of 0.197 m, y 0.055-0.093 of 0.148 m
            for i in range(200):
                await ws.send(json.dumps({"type": "move", "seq": i, "t": (time.perf_counter() - t0) * 1e3,
                                          "x": 0.85, "y": 0.5, "p": 0.5}))
                await asyncio.sleep(0.016)
                if eng.mask == 1:
                    seen["mask"] = True
                    seen["k"] = sc.effects[0].k_mat.value(eng.state.fx, eng.state.fy)
                    break
            await ws.send(json.dumps({"type": "up", "seq": 999, "t": (time.perf_counter() - t0) * 1e3}))
            await asyncio.sleep(0.3)

    try:
        asyncio.run(client())
        rows, _ = session.engine.trace_since(0)
        st = session.engine.status()
    finally:
        session.stop()
        srv.stop()
    assert seen.get("mask") and seen["k"] == 1000.0
    assert st["touches_received"] >= 2 and loop.error is None
    assert rows.shape[0] > 0 and rows[:, 5].max() > 0.0  # |F| traced for the page
