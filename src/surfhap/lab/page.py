"""The participant's page for ``surfhap study run``: a small FastAPI app (static HTML/JS).

The page polls ``GET /api/state`` and shows the current trial: its prompt, one button per
stimulus (selecting one tells the server which stimulus to play under the finger), a touch pad,
and the answer buttons (or the bump/hole toggles of a scene trial); between blocks a rest
screen; at the end a thank-you screen. Answers go to ``POST /api/answer`` with the response
time measured in the page (from showing the trial to the click) and are logged by the
:class:`~surfhap.lab.session.SessionRunner` before the reply is sent.

Live stimuli (optional): with a :class:`StimulusPlayer`, pointer events on the pad stream over
``/ws`` (the message format of the live touch page: ``move`` / ``up``) into the live engine,
and selecting a stimulus swaps the engine's renderer to that stimulus (built outside the audio
callback). Stimuli that cannot be rendered on this display (a real sample, a visual-only scene,
a force-feedback effect) mute the output.

Security: binds 127.0.0.1 by default; requests whose ``Host`` is not the bound loopback name
are refused (DNS rebinding); the WebSocket accepts only the page's own origin; every message
is size-checked, rate-limited and parsed as JSON, never evaluated.
"""

# no "from __future__ import annotations": FastAPI must see the real WebSocket annotation
import json
import logging
import math
from importlib import resources

from surfhap.lab.stimuli import StimulusPlayer, scene_picture

__all__ = ["create_page_app", "PageServer", "StimulusPlayer", "scene_picture"]

log = logging.getLogger("surfhap.lab")
STATIC = {"study.html": "text/html; charset=utf-8", "study.js": "text/javascript; charset=utf-8",
          "study.css": "text/css; charset=utf-8"}
LOOPBACK = ("127.0.0.1", "localhost", "::1", "[::1]")
MAX_MESSAGE = 2048


def _num(v, lo, hi):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not lo <= v <= hi:
        return None
    return float(v)


def create_page_app(runner, player: StimulusPlayer | None = None, allowed_hosts: tuple[str, ...] = LOOPBACK,
                    markers=None):
    """The FastAPI app of the participant page over ``runner`` (a SessionRunner); ``markers``
    (:mod:`surfhap.lab.markers`) receives stimulus, touch and answer events."""
    from surfhap.lab.markers import NullMarkers

    markers = markers or NullMarkers()
    playing: dict[str, str | None] = {"trial": None}
    from fastapi import Body, FastAPI, Request, WebSocket, WebSocketDisconnect
    from fastapi.responses import JSONResponse, Response

    app = FastAPI(title="surfhap study", docs_url=None, redoc_url=None, openapi_url=None)
    files = resources.files("surfhap.lab") / "static"

    def host_ok(h: str | None) -> bool:
        if not h:
            return False
        host = h.rsplit(":", 1)[0] if not h.startswith("[") else h.split("]")[0] + "]"
        return "*" in allowed_hosts or host in allowed_hosts

    @app.middleware("http")
    async def check_host(request: Request, call_next):
        if not host_ok(request.headers.get("host")):
            return JSONResponse({"error": "host not allowed"}, status_code=400)
        return await call_next(request)

    @app.get("/")
    def index():
        return Response((files / "study.html").read_bytes(), media_type=STATIC["study.html"])

    @app.get("/static/{name}")
    def static(name: str):
        if name not in STATIC:
            return JSONResponse({"error": "not found"}, status_code=404)
        return Response((files / name).read_bytes(), media_type=STATIC[name],
                        headers={"Cache-Control": "no-store"})

    @app.get("/api/state")
    def state():
        return runner.state()

    pictures: dict[str, bytes] = {}

    @app.get("/api/image/{trial_id}")
    def image(trial_id: str):
        """The picture of the current trial's scene (visual tasks and the touch pad)."""
        t = runner.current() if hasattr(runner, "current") else None
        name = None
        if t is not None and t.id == trial_id:
            name = next((st.render.get("scene") or st.render.get("mesh") for st in t.stimuli
                         if st.render.get("scene") or st.render.get("mesh")), None)
        if not name:
            return JSONResponse({"error": "no picture for this trial"}, status_code=404)
        if name not in pictures:
            from surfhap.live.sources import TouchSpace

            sp = player.session.space if player is not None else TouchSpace()
            try:
                pictures[name] = scene_picture(name, (sp.width, sp.height))
            except ValueError as exc:
                return JSONResponse({"error": str(exc)}, status_code=404)
        return Response(pictures[name], media_type="image/png", headers={"Cache-Control": "no-store"})

    @app.post("/api/stimulus")
    def stimulus(body: dict = Body(...)):
        tid, idx = body.get("trial_id"), body.get("index")
        if not isinstance(tid, str) or not isinstance(idx, int) or isinstance(idx, bool):
            return JSONResponse({"error": "need trial_id (string) and index (int)"}, status_code=400)
        stim = runner.stimulus(tid, idx)
        if stim is None:
            return JSONResponse({"ok": False})
        played = player.select(stim.render) if player is not None else "not rendered (no live output)"
        markers.push("stimulus_on", trial=tid, index=idx, label=stim.label, muted=played == "muted")
        playing["trial"] = tid
        # never the render spec: it names the material and condition (blinding)
        return {"ok": True, "label": stim.label, "playing": "muted" if played == "muted" else
                ("on" if player is not None else "not rendered")}

    @app.post("/api/answer")
    def answer(body: dict = Body(...)):
        tid, ans = body.get("trial_id"), body.get("answer")
        rt = _num(body.get("rt_ms"), 0.0, 86_400_000.0)
        if not isinstance(tid, str) or not isinstance(ans, str) or len(ans) > 500:
            return JSONResponse({"error": "need trial_id and answer (strings)"}, status_code=400)
        try:
            st = runner.answer(tid, ans, None if rt is None else rt / 1000.0)
        except ValueError as exc:
            return JSONResponse({"error": str(exc)}, status_code=400)
        if player is not None:
            player.mute()
        if st.get("accepted"):
            if playing["trial"] == tid:
                markers.push("stimulus_off", trial=tid)
                playing["trial"] = None
            markers.push("answer", trial=tid, answer=ans, rt_s=None if rt is None else rt / 1000.0)
            if st["status"] in ("rest", "done"):
                markers.push("rest" if st["status"] == "rest" else "end")
        return st

    @app.post("/api/resume")
    def resume():
        runner.resume()
        return runner.state()

    @app.websocket("/ws")
    async def ws(sock: WebSocket):
        origin = sock.headers.get("origin")
        host = sock.headers.get("host")
        if not host_ok(host) or origin not in (f"http://{host}",):
            await sock.close(code=1008)
            return
        await sock.accept()
        client = id(sock) & 0x7FFF
        w_px, h_px = 800.0, 400.0
        touching = False
        from surfhap.live.sources import RateLimiter

        limiter = RateLimiter(rate=1000.0, burst=200.0)  # a pointer stream is ~60-240 events/s
        try:
            while True:
                text = await sock.receive_text()
                if (player is None and not markers.enabled) or len(text) > MAX_MESSAGE or not limiter.allow():
                    continue
                try:
                    msg = json.loads(text)
                except ValueError:
                    continue
                if not isinstance(msg, dict):
                    continue
                kind = msg.get("type")
                if kind == "hello":
                    w_px = _num(msg.get("w"), 10.0, 20000.0) or w_px
                    h_px = _num(msg.get("h"), 10.0, 20000.0) or h_px
                elif kind == "move":
                    t, x, y = _num(msg.get("t"), 0, 1e12), _num(msg.get("x"), -0.05, 1.05), _num(msg.get("y"), -0.05, 1.05)
                    p = _num(msg.get("p", 0.5), 0.0, 1.0)
                    if None not in (t, x, y, p):
                        if player is not None:
                            player.touch(client, min(max(x, 0.0), 1.0), min(max(y, 0.0), 1.0), p, t, w_px, h_px)
                        if not touching:
                            touching = True
                            markers.push("touch_down")
                elif kind == "up":
                    t = _num(msg.get("t"), 0, 1e12)
                    if t is not None:
                        if player is not None:
                            player.lift(client, t)
                        if touching:
                            touching = False
                            markers.push("touch_up")
        except WebSocketDisconnect:
            if player is not None:
                player.lift(client, 0.0)

    return app


class PageServer:
    """Run the page app with uvicorn in a background thread."""

    def __init__(self, runner, host: str = "127.0.0.1", port: int = 8780, player: StimulusPlayer | None = None,
                 markers=None):
        from surfhap.live.serverthread import ServerThread

        hosts = LOOPBACK if host in ("127.0.0.1", "::1", "localhost") else ("*",)
        self.thread = ServerThread(create_page_app(runner, player, hosts, markers=markers), host=host, port=port,
                                   max_message_bytes=MAX_MESSAGE)

    @property
    def url(self) -> str:
        h = self.thread.host
        return f"http://{'[' + h + ']' if ':' in h else h}:{self.thread.port}"

    def start(self) -> "PageServer":
        self.thread.start()
        return self

    def stop(self) -> None:
        self.thread.stop()
