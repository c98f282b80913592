"""``surfhap serve`` / ``play`` / ``devices`` from the command line, as a user runs them."""

from __future__ import annotations

import json
import os
import selectors
import signal
import socket
import subprocess
import sys
import time
import urllib.request

import numpy as np
import pytest

from surfhap.cli import main

SURFHAP = [sys.executable, "-c", "import sys; from surfhap.cli import main; sys.exit(main())"]


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_play_to_file_writes_the_scan(tmp_path, capsys):
    out = tmp_path / "drive.npz"
    code = main(["play", "cork", "--json", "--output", f"file:{out}", "--scan", "speed=0.1,load=0.5,duration=0.5,length=0.04"])
    res = capsys.readouterr()
    assert code == 0, res.err
    summary = json.loads(res.out.strip().splitlines()[-1])
    assert summary["touches"] > 50 and summary["counters"]["errors"] == 0
    z = np.load(out)
    assert z["drive"].size > 0.4 * 20000 and np.abs(z["drive"]).max() > 50


@pytest.mark.parametrize("args,message", [
    (["serve", "--output", "pigeon"], "unknown output"),
    (["serve", "--output", "file:x.txt"], ".wav or .npz"),
    (["serve", "--mesh", "x.obj", "--material", "cork"], "not both"),
    (["serve", "--osc-in", "nonsense"], "HOST:PORT"),
    (["serve", "--port", "0"], "1-65535"),
    (["serve", "--material", "no-such-material"], "unknown material"),
    (["serve", "--touch-latency-ms", "900"], "0-200 ms"),
    (["serve", "--block-ms", "500"], "block_seconds: must be within 0.2-100 ms"),
    (["play", "cork", "--scan", "speed=0.1"], "missing"),
    (["play", "cork", "--channels", "0"], "only applies to sound"),
    (["play", "cork", "--output", "sound", "--channels", "a,b"], "channel numbers"),
])
def test_bad_options_give_one_line_and_exit_2(capsys, args, message):
    code = main(args)
    err = capsys.readouterr().err
    assert code == 2
    assert message in err and "Traceback" not in err


def test_devices_lists_or_says_none(capsys):
    code = main(["devices"])
    out = capsys.readouterr()
    assert code in (0, 2)
    if code == 0:
        assert out.out.strip()
    else:
        assert "PortAudio" in out.err


def test_serve_runs_the_page_from_the_command_line(tmp_path):
    port = free_port()
    env = dict(os.environ)
    p = subprocess.Popen([*SURFHAP, "serve", "--json", "--material", "cork", "--port", str(port), "--duration", "60"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        sel = selectors.DefaultSelector()
        sel.register(p.stdout, selectors.EVENT_READ)
        first = ""
        end = time.monotonic() + 300  # generous: start-up compiles the renderer (numba) on a loaded machine
        while "open http" not in first and time.monotonic() < end and p.poll() is None:  # bounded
            if sel.select(timeout=0.5):
                first += p.stdout.readline()
        assert f"http://127.0.0.1:{port}/" in first
        page = None
        for _ in range(100):  # bounded
            try:
                page = urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=2).read().decode()
                break
            except OSError:
                time.sleep(0.1)
        assert page is not None and "surfhap live" in page
        info = json.loads(urllib.request.urlopen(f"http://127.0.0.1:{port}/api/info", timeout=60).read())
        assert info["title"].startswith("cork") and info["drive_rate"] == 20000
        p.send_signal(signal.SIGINT)  # Ctrl-C: ramped stop, status line, exit 130
        out, err = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            p.kill()
            p.wait(5)
    assert p.returncode == 130, err
    assert json.loads(out.strip().splitlines()[-1])["stopped"] is True


@pytest.mark.parametrize("host", ["0.0.0.0", "192.168.1.20", "::"])
def test_non_loopback_host_without_allow_host_exits_2_with_one_line(capsys, host):
    code = main(["serve", "--host", host])
    err = capsys.readouterr().err
    assert code == 2
    assert "--allow-host" in err and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("value", ["*", "http://lab.example", "a b", "lab.*.example"])
def test_allow_host_rejects_what_is_not_a_host_name(capsys, value):
    code = main(["serve", "--host", "0.0.0.0", "--allow-host", value])
    err = capsys.readouterr().err
    assert code == 2 and "--allow-host" in err and "Traceback" not in err


def test_allow_host_is_repeatable_and_comma_separated():
    from surfhap.cli.live import _allowed_hosts

    assert _allowed_hosts("0.0.0.0", ["Lab-PC.local,192.168.1.20", " *.rig.example "]) == (
        "lab-pc.local", "192.168.1.20", "*.rig.example")
    assert _allowed_hosts("127.0.0.1", []) == ()  # loopback needs no flag


def test_non_loopback_binds_warn_and_loopback_binds_do_not(capsys):
    # the options are checked (and warned about) before anything is bound: the unknown
    # material then stops the command, so nothing listens on a public address in this test
    code = main(["serve", "--host", "0.0.0.0", "--allow-host", "lab.example", "--osc-in", "0.0.0.0:9000",
                 "--material", "no-such-material"])
    err = capsys.readouterr().err
    assert code == 2 and "unknown material" in err and "--allow-host" not in err
    assert "warning: binding 0.0.0.0" in err
    assert "warning: --osc-in binds 0.0.0.0" in err
    code = main(["serve", "--osc-in", "[::]:9000", "--material", "no-such-material"])
    err = capsys.readouterr().err
    assert code == 2 and "warning: --osc-in binds ::" in err and "warning: binding" not in err
    code = main(["serve", "--osc-in", "127.0.0.1:9000", "--material", "no-such-material"])
    err = capsys.readouterr().err
    assert code == 2 and "warning" not in err
