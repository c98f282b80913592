"""One request guard for every page of the web app (surfhap.web.guard): the study page of 'study run'
and the touch page of 'serve' (which also serves 'ff run --touch web'), each on a real uvicorn
server on loopback. Hostile requests: numbers too large for a float, a 300 MB body, cross-site
POSTs, a flood of invalid requests. See docs/lab.md, "Threat model: study page"."""

from __future__ import annotations

import http.client
import json
import logging
import socket
import threading

import pytest

from live_support.studies import identification_study

PATIENCE = 60.0  # s: bound of every wait for the server (generous: a loaded 2-core machine)
HUGE = "1" + "0" * 400  # 10**400 as a JSON integer: float() of it raises OverflowError
HUGE_BODY = 300 * 1024 * 1024  # what a cross-site fetch can send


@pytest.fixture
def page(tmp_path):
    """The study page of one participant on 127.0.0.1 (any free port)."""
    from surfhap.lab.session import SessionRunner
    from surfhap.live.config import ServerConfig
    from surfhap.web import create_app
    from surfhap.web.server import ServerThread
    from surfhap.web.study import StudyPage

    runner = SessionRunner(identification_study(tmp_path, name="guard test"), "P01", mode="page")
    server = ServerThread(create_app(ServerConfig(port=0), study=StudyPage(runner))).start()
    yield runner, server
    server.stop()
    runner.close()


@pytest.fixture
def live_page():
    """'surfhap serve''s touch page (simulated output) on 127.0.0.1 (any free port)."""
    from surfhap.web import create_app
    from surfhap.live.config import ServerConfig
    from surfhap.web.server import ServerThread
    from surfhap.live.session import build_session

    session = build_session("cork")
    session.start()
    srv = ServerThread(create_app(ServerConfig(port=0), touch=session), port=0).start()
    yield srv
    srv.stop()
    session.stop()


def _port(server) -> int:
    return server.port


def _request(port, method, path, body: bytes | None = None, headers=None):
    c = http.client.HTTPConnection("127.0.0.1", port, timeout=PATIENCE)
    try:
        h = {"Content-Type": "application/json", **(headers or {})}
        c.request(method, path, body=body, headers=h)
        r = c.getresponse()
        return r.status, r.read()
    finally:
        c.close()


def _answer_body(trial_id: str, answer: str, rt_literal: str) -> bytes:
    return json.dumps({"trial_id": trial_id, "answer": answer, "rt_ms": "@@"}).replace('"@@"', rt_literal).encode()


def _opaque(trial) -> str:
    """The page's id of the trial's correct choice: its position from 1 (blinding)."""
    return str([c.id for c in trial.choices].index(trial.correct) + 1)


def _records(caplog):
    return [r for r in caplog.records if r.levelno >= logging.WARNING]


def test_huge_numbers_are_a_422_with_one_short_log_line(page, caplog):
    runner, server = page
    caplog.set_level(logging.WARNING)
    port = _port(server)
    t = runner.current()
    bodies = [_answer_body(t.id, t.correct, lit) for lit in (HUGE, "-" + HUGE, "1e400", "NaN", "-Infinity")]
    bodies += [json.dumps({"trial_id": t.id, "index": "@@"}).replace('"@@"', HUGE).encode(),
               json.dumps({"trial_id": t.id, "index": "@@"}).replace('"@@"', "1e400").encode()]
    for k, body in enumerate(bodies):
        path = "/api/answer" if b"answer" in body else "/api/stimulus"
        caplog.clear()
        status, reply = _request(port, "POST", path, body)
        assert status == 422, (body[:60], status, reply[:200])
        assert len(reply) < 300 and HUGE.encode() not in reply  # a short reason, not the input echoed
        recs = _records(caplog)
        # one line for each of the first five rejections, then one per hundred
        assert len(recs) == (1 if k < 5 else 0), [r.getMessage()[:200] for r in recs]
        assert all(not r.exc_info and len(r.getMessage()) < 300 and "\n" not in r.getMessage() for r in recs)
    assert runner.n_done == 0  # nothing was logged as an answer
    assert server.app.state.guard.counts["invalid"] == len(bodies)
    # a valid answer still goes through
    status, reply = _request(port, "POST", "/api/answer", _answer_body(t.id, _opaque(t), "800"))
    assert status == 200 and json.loads(reply)["accepted"] and runner.n_done == 1


def test_a_flood_of_invalid_requests_leaves_a_few_log_lines(page, caplog):
    runner, server = page
    caplog.set_level(logging.INFO)
    t = runner.current()
    for k in range(300):
        status, _ = _request(_port(server), "POST", "/api/answer",
                             _answer_body(t.id, t.correct, HUGE if k % 2 else "1e400"))
        assert status == 422
    recs = _records(caplog)
    text = "\n".join(r.getMessage() for r in recs)
    # the first five rejections, then every 100th (with the count so far)
    assert len(recs) <= 5 + 3 and len(text) < 3000, text[:3000]
    assert not any(r.exc_info for r in recs)
    assert "(300 rejected so far)" in text
    assert runner.n_done == 0


def _push(port: int, path: str, total: int, chunked: bool) -> tuple[int, bytes]:
    """POST ``total`` bytes to ``path`` from a generator, stopping when the server answers or
    closes the connection; returns (bytes the server let us send, the response bytes)."""
    s = socket.create_connection(("127.0.0.1", port), timeout=PATIENCE)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_SNDBUF, 1 << 16)
    length = "Transfer-Encoding: chunked" if chunked else f"Content-Length: {total}"
    s.sendall(f"POST {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nContent-Type: application/json\r\n"
              f"{length}\r\n\r\n".encode())
    reply = bytearray()
    answered = threading.Event()

    def read():
        try:
            while True:
                data = s.recv(65536)
                if not data:
                    break
                reply.extend(data)
                if b"\r\n\r\n" in reply:
                    answered.set()
        except OSError:
            pass
        answered.set()

    reader = threading.Thread(target=read, daemon=True)
    reader.start()

    def pieces():
        chunk = b"7" * 65536
        for _ in range(total // len(chunk)):
            yield (b"10000\r\n" + chunk + b"\r\n") if chunked else chunk

    sent = 0
    try:
        for piece in pieces():
            if answered.is_set():
                break
            s.sendall(piece)
            sent += 65536
    except OSError:  # the server closed the connection
        pass
    reader.join(PATIENCE)
    s.close()
    return sent, bytes(reply)


@pytest.mark.parametrize("chunked", [False, True], ids=["content-length", "chunked"])
@pytest.mark.parametrize("app", ["study page", "serve page"])
def test_a_300_mb_body_is_refused_with_413_without_being_read(app, chunked, request):
    server = request.getfixturevalue("page")[1] if app == "study page" else request.getfixturevalue("live_page")
    sent, reply = _push(_port(server), "/api/answer" if app == "study page" else "/api/status", HUGE_BODY, chunked)
    assert reply.startswith(b"HTTP/1.1 413"), reply[:200]
    # at most the cap was read; the rest of what got through sits in the sockets' buffers
    assert sent < 16 * 1024 * 1024, f"{sent / 1e6:.0f} MB consumed"
    assert server.app.state.guard.counts["body"] == 1
    assert _request(_port(server), "GET", "/")[0] == 200  # and the page still answers


def test_cross_site_posts_to_every_state_changing_study_endpoint_are_403(page, caplog):
    runner, server = page
    caplog.set_level(logging.WARNING)
    port = _port(server)
    t = runner.current()
    calls = [("/api/resume", b"{}"), ("/api/stimulus", json.dumps({"trial_id": t.id, "index": 0}).encode()),
             ("/api/answer", _answer_body(t.id, _opaque(t), "500"))]
    cross = [{"Origin": "http://evil.example"}, {"Origin": "null"},  # an opaque origin (sandboxed frame, file)
             {"Origin": f"http://127.0.0.1:{port}.evil.example"},
             {"Sec-Fetch-Site": "cross-site"}]  # a browser that left Origin out
    for path, body in calls:
        for headers in cross:
            status, reply = _request(port, "POST", path, body, headers)
            assert status == 403, (path, headers, status, reply[:200])
    assert runner.n_done == 0 and runner.log.path.read_text().count('"trial_id"') == 0
    assert server.app.state.guard.counts["origin"] == len(calls) * len(cross)
    assert not any(r.exc_info for r in _records(caplog))
    # the page's own origin (what the browser sends for the page's fetch) is served
    own = {"Origin": f"http://127.0.0.1:{port}", "Sec-Fetch-Site": "same-origin"}
    for path, body in calls:
        status, reply = _request(port, "POST", path, body, own)
        assert status == 200, (path, status, reply[:200])
    assert runner.n_done == 1


def test_the_study_page_refuses_other_hosts_and_cross_site_websockets(page):
    from websockets.exceptions import InvalidStatus
    from websockets.sync.client import connect

    _, server = page
    port = _port(server)
    assert _request(port, "GET", "/api/state", headers={"Host": f"rebind.example:{port}"})[0] == 400
    with pytest.raises(InvalidStatus):
        connect(f"ws://127.0.0.1:{port}/ws", origin="http://evil.example", open_timeout=PATIENCE)
    with connect(f"ws://127.0.0.1:{port}/ws", origin=f"http://127.0.0.1:{port}", open_timeout=PATIENCE) as ws:
        ws.send(json.dumps({"type": "move", "seq": 0, "t": 1.0, "x": 0.5, "y": 0.5, "p": 0.5}))


def test_serve_page_refuses_cross_site_posts_with_the_same_guard(live_page):
    from surfhap.live.config import ServerConfig
    from surfhap.web import create_app
    from surfhap.web.guard import RequestGuard
    from surfhap.web.study import StudyPage

    port = live_page.port
    status, _ = _request(port, "POST", "/api/status", b"{}", {"Origin": "http://evil.example"})
    assert status == 403
    assert live_page.app.state.guard.counts["origin"] == 1
    assert type(live_page.app.state.guard) is RequestGuard
    study_app = create_app(ServerConfig(), study=StudyPage(None))
    assert type(study_app.state.guard) is RequestGuard  # the study page's: the same class


def test_a_wildcard_bound_study_page_takes_ip_literals_but_not_names(tmp_path):
    from surfhap.live.config import ServerConfig
    from surfhap.web import create_app
    from surfhap.web.guard import RequestGuard, host_allow_list
    from surfhap.web.study import StudyPage

    guard = create_app(ServerConfig(host="0.0.0.0"), study=StudyPage(None)).state.guard
    for host, ok in (("192.168.1.20:8780", True), ("[fe80::1]:8780", True), ("127.0.0.1", True),
                     ("localhost:8780", True), ("rebind.example:8780", False), ("192.168.1.20.evil.example", False),
                     ("", False)):
        assert guard.host_ok(host) is ok, host
    assert not RequestGuard(host_allow_list("0.0.0.0")).host_ok("192.168.1.20")  # serve's rule: names only


def test_a_flood_of_malformed_requests_leaves_a_few_log_lines(page, caplog, monkeypatch):
    """uvicorn logs one warning per malformed request ('Invalid HTTP request received.'); in
    'study run' nobody configured logging, so nothing but the server's own throttle bounds it."""
    from collections import OrderedDict

    from surfhap.live.logfilter import RateLimitFilter

    _, server = page
    caplog.set_level(logging.INFO)
    for f in logging.getLogger("uvicorn.error").filters:  # a frozen clock: the flood lasts "no time"
        if isinstance(f, RateLimitFilter):
            monkeypatch.setattr(f, "clock", lambda: 1e9)
            monkeypatch.setattr(f, "_kinds", OrderedDict())
    port = _port(server)
    for k in range(300):
        with socket.create_connection(("127.0.0.1", port), timeout=PATIENCE) as s:
            s.sendall(b"POST /api/answer HTTP/1.1\r\nHost: 127.0.0.1\r\nContent-Length: x%d\r\n\r\n" % k)
            s.settimeout(PATIENCE)
            assert s.recv(4096).startswith(b"HTTP/1.1 400")
    recs = _records(caplog)
    assert len(recs) == 1, len(recs)  # one line per kind per second
    assert not any(r.exc_info for r in recs)
    assert _request(port, "GET", "/api/state")[0] == 200


def test_an_exception_in_a_route_is_a_500_with_one_line_not_a_traceback(caplog):
    from fastapi import FastAPI

    from surfhap.web.guard import host_allow_list
    from surfhap.web.server import ServerThread
    from surfhap.web.guard import RequestGuard

    app = FastAPI()
    guard = RequestGuard(host_allow_list("127.0.0.1")).install(app)

    @app.get("/boom")
    def boom():
        raise RuntimeError("line one\nline two")

    caplog.set_level(logging.INFO)
    srv = ServerThread(app, port=0).start()
    try:
        status, reply = _request(srv.port, "GET", "/boom")
    finally:
        srv.stop()
    assert status == 500 and json.loads(reply) == {"error": "internal error"}
    recs = _records(caplog)
    assert len(recs) == 1 and not recs[0].exc_info and "\n" not in recs[0].getMessage(), recs
    assert "RuntimeError" in recs[0].getMessage() and guard.counts["error"] == 1
