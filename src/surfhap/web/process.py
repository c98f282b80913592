"""Run the web app in its own process, apart from the real-time engine (whose callback would
otherwise share the GIL with the web traffic), linked by two standard-library pipes
(``multiprocessing.Pipe``: OS pipes, reachable only by the two processes):

* touches, web -> engine: :class:`ProcessLink` keeps the newest sample of each client (only
  the newest position matters: samples of one client arriving within :data:`FLUSH_S` are
  coalesced, so nothing queues up when the web process falls behind) and :data:`FLUSH_S`
  after the first of them sends them as rows (source, source time, arrival time on the
  shared monotonic clock, x, y, load, samples coalesced into the row) in atomic messages of
  at most :data:`BATCH` rows while the pipe has room (else shortly after): the loop never
  waits on the pipe.
  :class:`EngineEnd`'s reader thread pushes the rows into the engine's non-blocking touch
  ring, whose arrival law applies to the stamps (a stale stamp stays stale);
* trace, engine -> web: :class:`EngineEnd` sends a frame at ``trace_hz`` (the engine status
  with every 5th). When the engine process ends, the web process exits.
"""

from __future__ import annotations

import asyncio
import gc
import logging
import math
import multiprocessing as mp
import os
import select
import struct
import threading
from itertools import chain, islice
from typing import Callable

import numpy as np

from surfhap.runtime.clock import now

__all__ = ["EngineEnd", "ProcessLink", "WebProcess", "describe"]

COLS = 7  # source, t_event, t_arrival, x, y, load, samples
# rows per message: with multiprocessing's 4-byte header, 73 rows stay within PIPE_BUF (4096
# bytes), so a message goes into a pipe that select() reports writable in one atomic write
BATCH = 73
# the touches of all clients go to the engine together, at most this long (s) after the first:
# one pipe write and one wake-up of the engine's reader per window instead of one per event
# (pages send <= 240 Hz, so a client's samples are 4 ms or more apart and none is coalesced)
FLUSH_S = 0.001


class EngineEnd:
    """Engine side of the link: touches from ``touch_in`` into ``session.engine``, trace
    frames from ``session`` to ``trace_out`` at ``hz``. ``received``: samples the web side
    took (coalesced ones included); ``dropped``: rows the engine's touch ring refused (full)."""

    def __init__(self, session, touch_in, trace_out, hz: float = 30.0, points: int = 64):
        from surfhap.web.link import trace_ticks

        self.engine = session.engine
        self.ticks = trace_ticks(session, points)
        self.touch_in, self.trace_out = touch_in, trace_out
        self.hz = float(hz)
        self.received = self.dropped = 0
        self._stop = threading.Event()
        self._threads = [threading.Thread(target=self._read, name="surfhap-touch-in", daemon=True),
                         threading.Thread(target=self._publish, name="surfhap-trace-out", daemon=True)]

    def start(self) -> "EngineEnd":
        for th in self._threads:
            th.start()
        return self

    def _read(self) -> None:
        push = self.engine.push_touch
        while not self._stop.is_set():
            try:
                rows = np.frombuffer(self.touch_in.recv_bytes(), dtype=np.float64).reshape(-1, COLS)
            except (EOFError, OSError, ValueError, TypeError):
                return  # the web process ended (or the link was closed: TypeError mid-read)
            for src, t_ev, t_arr, x, y, load, n in rows.tolist():
                # the web process's arrival stamp: push_touch applies the arrival law to it
                if not push(int(src), x, y, load, t_event=t_ev, t_arrival=t_arr):
                    self.dropped += 1
                self.received += int(n)

    def _publish(self) -> None:
        for tick in self.ticks:
            if self._stop.wait(1.0 / self.hz):
                return
            try:
                self.trace_out.send(tick)
            except (OSError, ValueError):
                return

    def stop(self) -> None:
        self._stop.set()
        for conn in (self.touch_in, self.trace_out):
            conn.close()
        for th in self._threads:
            th.join(1.0)


class ProcessLink:
    """Web side :class:`~surfhap.web.link.EngineLink` to the engine in the parent process:
    ``push_touch`` keeps the newest sample per source (``pending``, sent :data:`FLUSH_S` later;
    ``coalesced`` counts the samples it superseded), ``stream`` publishes the frames that
    arrive on ``trace_in``. ``about``: :func:`describe` of the session; ``on_engine_gone``:
    called (in the event loop) when the trace pipe ends."""

    def __init__(self, about: dict, touch_out, trace_in, on_engine_gone: Callable[[], None] = lambda: None):
        from surfhap.live.sources import TouchSpace

        self._info = about["info"]
        self.space = TouchSpace(*about["space"])
        self.positions = about["positions"]
        self.touch_out, self.trace_in = touch_out, trace_in
        self.on_engine_gone = on_engine_gone
        self.pending: dict[int, tuple] = {}
        self.coalesced = 0
        self._flush_due = False

    def info(self) -> dict:
        return dict(self._info)

    def push_touch(self, source: int, x: float, y: float, load: float, t_event: float = math.nan) -> bool:
        """Keep this sample as ``source``'s newest (event-loop thread); sent within
        :data:`FLUSH_S`."""
        old = self.pending.get(source)
        n = 1.0 if old is None else old[6] + 1.0
        self.coalesced += old is not None
        self.pending[source] = (float(source), t_event, now(), x, y, load, n)
        if not self._flush_due:
            self._flush_due = True
            asyncio.get_running_loop().call_later(FLUSH_S, self._flush)
        return True

    def _flush(self) -> None:
        """Send the pending rows if the pipe has room now, else try again shortly: the event
        loop never waits on a stalled engine process (meanwhile newer samples replace older)."""
        self._flush_due = False
        try:
            while self.pending and select.select([], [self.touch_out], [], 0)[1]:
                rows = [self.pending.pop(k) for k in list(islice(self.pending, BATCH))]
                # native float64s as EngineEnd reads them (struct: half the CPU of np.array(rows))
                self.touch_out.send_bytes(struct.pack(f"={COLS * len(rows)}d", *chain.from_iterable(rows)))
        except (OSError, ValueError):
            self.pending.clear()  # the engine side is gone
        if self.pending:
            self._flush_due = True
            asyncio.get_running_loop().call_later(0.005, self._flush)

    async def stream(self, publish) -> None:
        loop = asyncio.get_running_loop()

        def read():
            try:
                while True:
                    try:
                        frame, status = self.trace_in.recv()
                    except (EOFError, OSError):
                        loop.call_soon_threadsafe(self.on_engine_gone)
                        return
                    loop.call_soon_threadsafe(publish, frame, status)
            except RuntimeError:  # the event loop is closed: the server has stopped
                return

        threading.Thread(target=read, name="surfhap-trace-in", daemon=True).start()
        await asyncio.Event().wait()  # until cancelled


def describe(session) -> dict:
    """What the web process needs to know about ``session`` (picklable): the page info, the
    touch surface and how page positions map onto it."""
    from surfhap.live.session import page_info

    s = session.space
    return {"info": page_info(session), "positions": session.positions,
            "space": (s.width, s.height, s.max_load, s.default_load)}


def _web_main(cfg, about: dict, touch_out, trace_in, log_level: int) -> None:
    """Entry point of the web process: listen, report the port (or why not) on ``touch_out``
    (connections wait in the kernel from then on), then serve until the engine process ends."""
    logging.basicConfig(level=log_level, format="%(asctime)s %(levelname)s %(name)s[web]: %(message)s")
    import uvicorn

    from surfhap.live.logfilter import install_rate_limit
    from surfhap.web.app import create_app
    from surfhap.web.server import listen, uvicorn_config

    install_rate_limit()  # one line per kind per second, whatever a client provokes
    try:
        sock = listen(cfg.host, cfg.port, cfg.backlog)
    except OSError as exc:
        touch_out.send(("error", f"cannot listen on {cfg.host}:{cfg.port} ({exc.strerror or exc})"))
        return
    # the engine process is gone: never outlive it
    app = create_app(cfg, touch=ProcessLink(about, touch_out, trace_in, on_engine_gone=lambda: os._exit(0)))
    server = uvicorn.Server(uvicorn_config(app, cfg)[0])
    touch_out.send(("ok", sock.getsockname()[1]))
    # what exists now (~10^5 objects) is never scanned again by the cyclic collector: a full
    # collection over it paused the event loop for 0.1-0.5 s under load
    gc.freeze()
    server.run(sockets=[sock])


class WebProcess:
    """Serve the touch page of ``session`` from a separate (spawned) process."""

    def __init__(self, session, cfg):
        self.session, self.cfg = session, cfg
        self.end = self.proc = self.port = None

    @property
    def url(self) -> str:
        from surfhap.web.server import page_url

        return page_url(self.cfg.host, self.port)

    def start(self, timeout: float = 120.0) -> "WebProcess":
        """Spawn the web process and wait for its report (it listens) or its end; ``timeout``
        s only guards against a child that hangs (its start-up, seconds on a loaded machine,
        is not a deadline)."""
        from multiprocessing.connection import wait

        from surfhap.errors import ConfigError

        ctx = mp.get_context("spawn")
        touch_in, touch_out = ctx.Pipe(duplex=False)
        trace_in, trace_out = ctx.Pipe(duplex=False)
        self.proc = ctx.Process(target=_web_main, name="surfhap-web", daemon=True,
                                args=(self.cfg, describe(self.session), touch_out, trace_in,
                                      logging.getLogger("surfhap").getEffectiveLevel()))
        self.proc.start()
        touch_out.close()  # the child's ends: only the child holds them now
        trace_in.close()
        if not wait([touch_in, self.proc.sentinel], timeout):
            self.stop()
            raise RuntimeError(f"the web process did not start within {timeout:g} s")
        try:
            msg = touch_in.recv()
        except EOFError:  # it ended without a report
            self.stop()
            raise RuntimeError(f"the web process ended before it served (exit code {self.proc.exitcode})") from None
        if msg[0] != "ok":
            self.stop()
            raise ConfigError(msg[1], source="--port")
        self.port = msg[1]
        self.end = EngineEnd(self.session, touch_in, trace_out, self.cfg.trace_hz, self.cfg.trace_points).start()
        return self

    def stop(self) -> None:
        if self.end is not None:
            self.end.stop()
        if self.proc is not None:
            self.proc.terminate()
            self.proc.join(5.0)
            if self.proc.is_alive():
                self.proc.kill()
                self.proc.join(2.0)
