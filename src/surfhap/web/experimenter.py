"""The experimenter's page of ``surfhap study run`` (docs/lab.md), beside the participant's.

``GET /experimenter?token=T`` serves the page; its API (``/experimenter/api/...``) wants the
same random token in the ``X-Experimenter-Token`` header (the query string and headers never
reach the request guard's log lines, which name the path only). A wrong or missing token is
403, compared in constant time (:func:`hmac.compare_digest`). The token is printed once to the
experimenter's terminal; the participant's page, its API, the markers and the trial log never
hold it.

The page shows :meth:`~surfhap.lab.session.SessionRunner.experimenter_state` (participant,
block, trial n of N, elapsed time, the condition unless ``session.blind_experimenter``) and
has four controls: pause (the participant's page shows a neutral "paused" screen; the output
is muted through the engine's safety stage, its gain ramp), resume, skip the current trial
(logged as skipped, never analysed as an answer) and notes (timestamped log events).
"""

# no "from __future__ import annotations": FastAPI reads the endpoints' annotations at run time
import hmac
from importlib import resources

from surfhap.lab.markers import NullMarkers
from surfhap.web.messages import NoteRequest, SkipRequest

__all__ = ["experimenter_router"]


def experimenter_router(page, token: str):
    """The routes of the experimenter's page of ``page`` (a StudyPage), guarded by ``token``."""
    from fastapi import APIRouter, Depends, Header, HTTPException
    from fastapi.responses import Response

    runner, player, markers = page.runner, page.player, page.markers or NullMarkers()
    html = resources.files("surfhap.web") / "static" / "study" / "experimenter.html"
    want = token.encode()

    def check(given: str) -> None:
        if not hmac.compare_digest(given.encode(), want):
            raise HTTPException(403, "wrong or missing experimenter token")

    def guarded(x_experimenter_token: str = Header("")) -> None:
        check(x_experimenter_token)

    router = APIRouter()
    api = APIRouter(prefix="/experimenter/api", dependencies=[Depends(guarded)])

    @router.get("/experimenter")
    def index(token: str = ""):
        check(token)
        return Response(html.read_bytes(), media_type="text/html; charset=utf-8",
                        headers={"Cache-Control": "no-store", "Referrer-Policy": "no-referrer"})

    @api.get("/state")
    def state():
        return runner.experimenter_state()

    def pause(on: bool) -> dict:
        if runner.pause(on):
            markers.push("pause" if on else "pause-end")
            if on and player is not None:
                player.mute()  # SetGain(0) / no force effect: through the output's safety stage
        return runner.experimenter_state()

    api.add_api_route("/pause", lambda: pause(True), methods=["POST"])
    api.add_api_route("/resume", lambda: pause(False), methods=["POST"])

    @api.post("/skip")
    def skip(req: SkipRequest):
        if runner.skip(req.trial_id):
            if player is not None:
                player.mute()
            markers.push("skip", trial=req.trial_id)
        return runner.experimenter_state()

    @api.post("/note")
    def note(req: NoteRequest):
        runner.note(req.text)
        return runner.experimenter_state()

    router.include_router(api)
    return router
