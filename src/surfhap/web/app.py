"""The one web app of surfhap: :func:`create_app` builds a FastAPI app with the request guard
(:mod:`surfhap.web.guard`) and the router of the page it serves: the touch page of ``surfhap
serve`` (:mod:`surfhap.web.touch`), the force-feedback page of ``surfhap ff run --touch web``
(the touch page over :func:`surfhap.web.ff.build_ff_session`) or the study page of ``surfhap
study run`` (:mod:`surfhap.web.study`). Serve it with :class:`surfhap.web.server.ServerThread`
or, apart from the real-time engine, :class:`surfhap.web.process.WebProcess`.
"""

from __future__ import annotations

import asyncio
from contextlib import asynccontextmanager

from surfhap.live.config import ServerConfig
from surfhap.web.guard import WILDCARD_HOSTS, RequestGuard

__all__ = ["create_app"]


def _static_files(page: str):
    """The assets of ``page`` ("touch" or "study", ``surfhap.web/static/<page>``), never cached
    by the browser."""
    from starlette.staticfiles import StaticFiles

    class NoStoreStaticFiles(StaticFiles):
        def file_response(self, *args, **kwargs):
            response = super().file_response(*args, **kwargs)
            response.headers["Cache-Control"] = "no-store"
            return response

    return NoStoreStaticFiles(packages=[("surfhap.web", f"static/{page}")])


def create_app(cfg: ServerConfig | None = None, *, touch=None, study=None):
    """The FastAPI app serving ``touch`` (an :class:`~surfhap.web.link.EngineLink` or a live
    session: the touch or force-feedback page) or ``study`` (a
    :class:`~surfhap.web.study.StudyPage`), one of them, with the limits of ``cfg``.

    A study page bound to every interface (``cfg.host`` 0.0.0.0 or ::) also accepts IP address
    literals as ``Host`` (a tablet opening http://192.168.1.20:8780; a DNS rebinding attack
    always names the attacker's domain)."""
    from fastapi import FastAPI

    cfg = cfg or ServerConfig()
    if (touch is None) == (study is None):
        raise ValueError("create_app serves one page: give touch or study")
    if study is not None:
        from surfhap.web.study import MAX_BODY, log as study_log, study_router

        app = FastAPI(title="surfhap study", docs_url=None, redoc_url=None, openapi_url=None)
        RequestGuard.for_page(cfg, ip_literals=cfg.host in WILDCARD_HOSTS, max_body_bytes=MAX_BODY,
                              logger=study_log).install(app)
        app.mount("/static", _static_files("study"), name="static")
        app.include_router(study_router(study, cfg))
        return app

    from surfhap.web.link import as_link
    from surfhap.web.touch import Hub, touch_router

    link = as_link(touch, cfg)
    hub = Hub(cfg.send_timeout)

    @asynccontextmanager
    async def lifespan(_app):
        task = asyncio.get_running_loop().create_task(link.stream(hub.publish))
        try:
            yield
        finally:
            task.cancel()

    def refused() -> None:
        hub.refused += 1

    app = FastAPI(title="surfhap live", docs_url=None, redoc_url=None, openapi_url=None, lifespan=lifespan)
    app.state.hub = hub
    RequestGuard.for_page(cfg, on_refused=refused).install(app)
    app.mount("/static", _static_files("touch"), name="static")
    app.include_router(touch_router(link, hub, cfg))
    return app
