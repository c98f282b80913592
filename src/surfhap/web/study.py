"""The study page router: the participant's page of ``surfhap study run`` (docs/lab.md).

The page polls ``GET /api/state``, shows the current trial (prompt, one button per stimulus,
a touch pad, the answers; a rest screen between blocks), asks for a stimulus with ``POST
/api/stimulus`` and answers with ``POST /api/answer`` (response time measured in the page),
logged by the :class:`~surfhap.lab.session.SessionRunner` before the reply. A design's
participant-information form is shown first (status "info") and sent with ``POST /api/info``. With a
:class:`~surfhap.lab.stimuli.StimulusPlayer`, the pad's pointer events (``/ws``, the touch
page's messages and checks) drive the live engine and a stimulus swaps its renderer.
Request bodies are pydantic models (:mod:`surfhap.web.messages`); the app's request guard
does the rest. Blinding: every reply and marker carries the participant's view only
(:mod:`surfhap.lab.blinding`: opaque choice ids, no block label, no render spec); an answer's
opaque id is mapped back to the choice id before the runner logs it. A training trial's answer
returns ``feedback`` (right or not, the right answer's label), shown before the next trial; a
paused session (:mod:`surfhap.web.experimenter`) has status "paused".
"""

# no "from __future__ import annotations": FastAPI reads the endpoints' annotations at run time
import logging
import secrets
from dataclasses import dataclass, field
from importlib import resources

from surfhap.errors import InputError
from surfhap.lab.blinding import choice_key, participant_state, real_answer
from surfhap.lab.markers import NullMarkers
from surfhap.lab.stimuli import FFStimulusPlayer, StimulusPlayer, scene_picture
from surfhap.live.config import ServerConfig
from surfhap.live.sources import RateLimiter, RejectLog
from surfhap.web.experimenter import experimenter_router
from surfhap.web.messages import AnswerRequest, InfoRequest, StimulusRequest
from surfhap.web.touch import Client, pointer_messages

__all__ = ["StudyPage", "study_router", "start_player"]

log = logging.getLogger("surfhap.lab")
MAX_BODY = 4096  # an answer is a few dozen bytes; a toggles answer stays under 500 characters


@dataclass
class StudyPage:
    """What the study page serves (with the experimenter's page beside it): ``runner`` (a
    SessionRunner), the live ``player`` (or None: nothing rendered) and the ``markers`` (:mod:`surfhap.lab.markers`) that receive
    stimulus, touch and answer events."""

    runner: object
    player: StimulusPlayer | FFStimulusPlayer | None = None
    markers: object = field(default_factory=NullMarkers)
    #: the experimenter page's secret (:mod:`surfhap.web.experimenter`), printed once by ``study run``
    experimenter_token: str = field(default_factory=lambda: secrets.token_urlsafe(24), repr=False)


def start_player(runner, output=None, amp_gain: float = 250.0, ff: bool = False, ff_backend=None):
    """The started live player of ``runner``'s session (``study run``), muted: on the
    force-feedback loop (``ff``; on ``ff_backend``, a force device, default the simulated one), on ``output`` (an Output of
    :mod:`surfhap.live.backends.output`, every stimulus prepared before the engine starts,
    :meth:`StimulusPlayer.prepare`), or None (answers only). Stop it with ``player.session.stop()``."""
    if ff:
        from surfhap.lab.stimuli import FFStudySession

        player = FFStimulusPlayer(FFStudySession(backend=ff_backend), limit_s=runner.limit_s)
    elif output is not None:
        from surfhap.live.session import build_session

        first = next((str(s.render["material"]) for t in runner.plan.trials for s in t.stimuli if "material" in s.render),
                     "cork")
        session = build_session(first, output, amp_gain=amp_gain, display=runner.display)
        player = StimulusPlayer(session, gain=runner.gain, v_max=runner.v_max, display=runner.display,
                                limit_s=runner.limit_s)
        player.prepare(runner.renders())
    else:
        return None
    player.mute()
    player.session.start()
    return player


def study_router(page: StudyPage, cfg: ServerConfig):
    """The routes of the study page (see module doc)."""
    from fastapi import APIRouter, WebSocket
    from fastapi.responses import JSONResponse, Response

    runner, player, markers = page.runner, page.player, page.markers or NullMarkers()
    playing: dict[str, str | None] = {"trial": None}
    rejects = RejectLog(log)
    router = APIRouter()
    index_html = resources.files("surfhap.web") / "static" / "study" / "study.html"

    @router.get("/")
    def index():
        return Response(index_html.read_bytes(), media_type="text/html; charset=utf-8")

    @router.get("/api/state")
    def state():
        return participant_state(runner.state())

    pictures: dict[str, bytes] = {}

    @router.get("/api/image/{trial_id}")
    def image(trial_id: str):
        """The picture of the current trial's scene (visual tasks and the touch pad)."""
        t = runner.current()
        stimuli = t.stimuli if t is not None and t.id == trial_id else ()
        name = next(filter(None, (st.render.get("scene") or st.render.get("mesh") for st in stimuli)), None)
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

    @router.post("/api/stimulus")
    def stimulus(req: StimulusRequest):
        stim = runner.stimulus(req.trial_id, req.index)
        if stim is None:
            return {"ok": False}
        played = player.select(stim.render) if player is not None else "not rendered (no live output)"
        markers.push("stimulus_on", trial=req.trial_id, index=req.index, label=stim.label, muted=played == "muted")
        playing["trial"] = req.trial_id
        # never the render spec: it names the material and condition (blinding)
        return {"ok": True, "label": stim.label, "playing": "muted" if played == "muted" else
                ("on" if player is not None else "not rendered")}

    @router.post("/api/answer")
    def answer(req: AnswerRequest):
        tid, ans = req.trial_id, req.answer  # ans: the opaque id(s) of participant_state
        rt_s = None if req.rt_ms is None else req.rt_ms / 1000.0
        t = runner.state().get("trial")
        if t is None or t["id"] != tid:  # not the current trial: nothing to log
            return {**participant_state(runner.state()), "accepted": False}
        try:
            key = choice_key([c["id"] for c in t["choices"]])
            real = ans if t["response"] == "text" else real_answer(key, ans, t["response"] == "toggles")
            st = runner.answer(tid, real, rt_s)
        except InputError as exc:  # the runner's message may name choice ids: the page gets the field
            log.warning("study page: answer %r to %s refused: %s", ans, tid, exc)
            return JSONResponse({"error": f"invalid answer ({exc.field})"}, status_code=400)
        if player is not None:
            player.mute()
        if st.get("accepted"):
            if playing["trial"] == tid:
                markers.push("stimulus_off", trial=tid)
                playing["trial"] = None
            markers.push("answer", trial=tid, answer=ans, rt_s=rt_s)
            if st["status"] in ("rest", "done"):
                markers.push("rest" if st["status"] == "rest" else "end")
        return participant_state(st)

    @router.post("/api/info")
    def info(req: InfoRequest):
        if runner.state()["status"] != "info":  # answered already (or a runner without a form)
            return {**participant_state(runner.state()), "accepted": False}
        try:
            st = runner.info(req.answers)
        except InputError as exc:  # names the form's field only (no condition in the form)
            return JSONResponse({"error": f"{exc.field}: {exc.message}"}, status_code=400)
        return participant_state(st)

    @router.post("/api/resume")
    def resume():
        runner.resume()
        return participant_state(runner.state())

    @router.websocket("/ws")
    async def ws(sock: WebSocket):
        # host and origin: checked by the request guard before the handshake gets here
        await sock.accept()
        peer = f"ws {sock.client.host}:{sock.client.port}" if sock.client else "ws ?"
        client = Client(id(sock) & 0x7FFF, peer, RateLimiter(cfg.max_rate, cfg.burst, t=0.0), height_px=400.0)
        live = player is not None

        def handle(msg) -> None:
            down = msg.type == "move"
            if live and down:
                player.touch(client.id, min(max(msg.x, 0.0), 1.0), min(max(msg.y, 0.0), 1.0), msg.p, msg.t,
                             client.width_px, client.height_px)
            elif live:
                player.lift(client.id, msg.t)
            if down != client.down:
                client.down = down
                markers.push("touch_down" if down else "touch_up")

        try:
            await pointer_messages(sock, cfg, client, rejects, handle)
        finally:
            if live:
                player.lift(client.id, 0.0)

    router.include_router(experimenter_router(page, page.experimenter_token))
    return router
