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

Security (docs/lab.md, "Threat model: study page"): binds 127.0.0.1 by default; every request
passes the same request guard as ``surfhap serve``'s page (:mod:`surfhap.live.webguard`):
``Host`` allow list (DNS rebinding), ``Origin`` check on every state-changing request and on
the WebSocket (CSRF), a body cap enforced while the body is read, one throttled log line per
refusal. Request bodies and WebSocket messages are validated by pydantic models with finite,
bounded numbers (:func:`surfhap.live.protocol.parse_json`): invalid input is a 422 with a short
reason, never a 500 with a traceback.
"""

# no "from __future__ import annotations": FastAPI must see the real WebSocket annotation
import logging
from importlib import resources
from typing import Annotated, Optional

from pydantic import BaseModel, ConfigDict, Field, TypeAdapter

from surfhap.lab.stimuli import StimulusPlayer, scene_picture
from surfhap.live.hosts import OriginRule, WILDCARD_HOSTS, host_allow_list
from surfhap.live.protocol import Hello, Move, number, parse_json, parse_message
from surfhap.live.webguard import RequestGuard

__all__ = ["create_page_app", "PageServer", "StimulusPlayer", "scene_picture", "StimulusRequest", "AnswerRequest"]

log = logging.getLogger("surfhap.lab")
STATIC = {"study.html": "text/html; charset=utf-8", "study.js": "text/javascript; charset=utf-8",
          "study.css": "text/css; charset=utf-8"}
LOOPBACK = ("127.0.0.1", "localhost", "::1", "[::1]")
MAX_MESSAGE = 2048
MAX_BODY = 4096  # an answer is a few dozen bytes; a toggles answer stays under 500 characters


class _Request(BaseModel):
    model_config = ConfigDict(frozen=True, extra="ignore")


TrialId = Annotated[str, Field(max_length=200, strict=True)]


class StimulusRequest(_Request):
    """``POST /api/stimulus``: play stimulus ``index`` of trial ``trial_id``."""

    trial_id: TrialId
    index: Annotated[int, Field(ge=0, le=1000, strict=True)]


class AnswerRequest(_Request):
    """``POST /api/answer``: ``answer`` to ``trial_id``, ``rt_ms`` measured in the page
    (trial shown -> click, ms, at most a day)."""

    trial_id: TrialId
    answer: Annotated[str, Field(max_length=500, strict=True)]
    rt_ms: Optional[number(0.0, 86_400_000.0)] = None


_STIMULUS = TypeAdapter(StimulusRequest)
_ANSWER = TypeAdapter(AnswerRequest)


def create_page_app(runner, player: StimulusPlayer | None = None,
                    allowed_hosts: tuple[str, ...] = host_allow_list("127.0.0.1"), markers=None,
                    ip_literals: bool = False):
    """The FastAPI app of the participant page over ``runner`` (a SessionRunner); ``markers``
    (:mod:`surfhap.lab.markers`) receives stimulus, touch and answer events.
    ``allowed_hosts`` / ``ip_literals``: the ``Host`` rule of the request guard."""
    from surfhap.lab.markers import NullMarkers

    markers = markers or NullMarkers()
    playing: dict[str, str | None] = {"trial": None}
    from fastapi import FastAPI, Request, WebSocket, WebSocketDisconnect
    from fastapi.responses import JSONResponse, Response
    from starlette.concurrency import run_in_threadpool

    app = FastAPI(title="surfhap study", docs_url=None, redoc_url=None, openapi_url=None)
    guard = RequestGuard(allowed_hosts, OriginRule(), max_body_bytes=MAX_BODY, ip_literals=ip_literals,
                         logger=log).install(app)
    files = resources.files("surfhap.lab") / "static"

    async def parsed(request: Request, adapter: TypeAdapter):
        """The request's body validated by ``adapter``, or the 422 response."""
        msg = parse_json(adapter, await request.body())
        if isinstance(msg, str):
            return JSONResponse(guard.invalid(request.scope, msg), status_code=422)
        return msg

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

    def play(req: StimulusRequest):
        stim = runner.stimulus(req.trial_id, req.index)
        if stim is None:
            return {"ok": False}
        played = player.select(stim.render) if player is not None else "not rendered (no live output)"
        markers.push("stimulus_on", trial=req.trial_id, index=req.index, label=stim.label, muted=played == "muted")
        playing["trial"] = req.trial_id
        # never the render spec: it names the material and condition (blinding)
        return {"ok": True, "label": stim.label, "playing": "muted" if played == "muted" else
                ("on" if player is not None else "not rendered")}

    @app.post("/api/stimulus")
    async def stimulus(request: Request):
        req = await parsed(request, _STIMULUS)
        return req if isinstance(req, Response) else await run_in_threadpool(play, req)

    def log_answer(req: AnswerRequest):
        tid, ans = req.trial_id, req.answer
        rt_s = None if req.rt_ms is None else req.rt_ms / 1000.0
        try:
            st = runner.answer(tid, ans, rt_s)
        except ValueError as exc:
            return JSONResponse({"error": str(exc)}, status_code=400)
        if player is not None:
            player.mute()
        if st.get("accepted"):
            if playing["trial"] == tid:
                markers.push("stimulus_off", trial=tid)
                playing["trial"] = None
            markers.push("answer", trial=tid, answer=ans, rt_s=rt_s)
            if st["status"] in ("rest", "done"):
                markers.push("rest" if st["status"] == "rest" else "end")
        return st

    @app.post("/api/answer")
    async def answer(request: Request):
        req = await parsed(request, _ANSWER)
        return req if isinstance(req, Response) else await run_in_threadpool(log_answer, req)

    @app.post("/api/resume")
    def resume():
        runner.resume()
        return runner.state()

    @app.websocket("/ws")
    async def ws(sock: WebSocket):
        # host and origin: checked by the request guard before the handshake gets here
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
                msg = parse_message(text)  # the live page's messages: finite, bounded numbers
                if isinstance(msg, str):
                    continue
                if isinstance(msg, Hello):
                    w_px, h_px = msg.w, msg.h
                elif isinstance(msg, Move):
                    if player is not None:
                        player.touch(client, min(max(msg.x, 0.0), 1.0), min(max(msg.y, 0.0), 1.0), msg.p, msg.t,
                                     w_px, h_px)
                    if not touching:
                        touching = True
                        markers.push("touch_down")
                else:  # Up
                    if player is not None:
                        player.lift(client, msg.t)
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

        # the Host rule of 'surfhap serve': loopback names and the bound address; bound to every
        # interface, also any IP literal (a tablet opening http://192.168.1.20:8780; a DNS
        # rebinding attack always names the attacker's domain)
        app = create_page_app(runner, player, host_allow_list(host), markers=markers,
                              ip_literals=host in WILDCARD_HOSTS)
        self.thread = ServerThread(app, host=host, port=port, max_message_bytes=MAX_MESSAGE)

    @property
    def url(self) -> str:
        h = self.thread.host
        return f"http://{'[' + h + ']' if ':' in h else h}:{self.thread.port}"

    def start(self) -> "PageServer":
        self.thread.start()
        return self

    def stop(self) -> None:
        self.thread.stop()
