"""``surfhap ff bridge-check`` against two loopback reference bridges written with python-osc
(tests/live_support/ff_bridges.py): one that follows the bridge contract passes every row;
one that holds its last force forever (issue 17 #7: 5.8 N after ``ff run`` was killed)
fails the watchdog row and only that one.

Timing: the 20 ms watchdog is measured where the positions arrive; on a loaded CI machine
the delivery can take longer, so these runs add a generous ``--tolerance-ms``; the holding
bridge never reaches zero, whatever the tolerance."""

from __future__ import annotations

import math
import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from surfhap.live.ff_bridge_check import BridgeCheck, BridgeSettings

sys.path.insert(0, str(Path(__file__).parent))
from live_support.ff_bridges import ReferenceBridge  # noqa: E402

ROWS = ["reply", "rate", "sequence", "units", "axes", "nonfinite", "watchdog"]
TOLERANCE_MS = "300"


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def bridge_check(*args):
    env = dict(os.environ, COLUMNS="200")
    return subprocess.run([sys.executable, "-m", "surfhap", "ff", "bridge-check", *args], env=env,
                          capture_output=True, text=True, timeout=120)


def table(stdout: str) -> dict:
    """The plain lines of a piped run: 'PASS name detail' -> {name: passed}."""
    rows = {}
    for ln in stdout.splitlines():
        word, name = ln.split()[:2]
        assert word in ("PASS", "FAIL"), ln
        rows[name] = word == "PASS"
    return rows


@pytest.mark.parametrize("watchdog", [True, False], ids=["compliant", "holds-last-force"])
def test_bridge_check_passes_a_compliant_bridge_and_fails_one_that_holds_its_force(watchdog):
    listen = free_udp_port()
    with ReferenceBridge(("127.0.0.1", listen), watchdog=watchdog) as bridge:
        r = bridge_check(f"osc://127.0.0.1:{bridge.port}", "--listen", f"127.0.0.1:{listen}",
                         "--tolerance-ms", TOLERANCE_MS, "--clamp")
        assert bridge.forces > 0
    rows = table(r.stdout)
    assert list(rows) == ROWS[:-1] + ["clamp", "watchdog"], r.stdout + r.stderr
    if watchdog:
        assert r.returncode == 0 and all(rows.values()), r.stdout + r.stderr
    else:
        assert r.returncode == 1, r.stdout + r.stderr
        assert [n for n, ok in rows.items() if not ok] == ["watchdog"], r.stdout


@pytest.mark.parametrize("kw,failing", [
    ({"position": (0.5, 0.0, 0.0)}, "units"),  # not metres relative to X0
    ({"limit": 1e9}, "clamp"),  # passes 1e6 device units through
])
def test_bridge_check_names_the_broken_contract_item(kw, failing):
    listen = free_udp_port()
    with ReferenceBridge(("127.0.0.1", listen), **kw) as bridge:
        rows = BridgeCheck("127.0.0.1", bridge.port, BridgeSettings(tolerance_ms=300, trials=1, full_scale=True),
                           listen=("127.0.0.1", listen)).run()
    assert [r.name for r in rows] == ROWS[:-1] + ["clamp", "watchdog"]
    assert failing in [r.name for r in rows if not r.passed], rows


def test_bridge_check_without_a_bridge_fails_the_reply_row():
    listen = free_udp_port()
    r = bridge_check(f"osc://127.0.0.1:{free_udp_port()}", "--listen", f"127.0.0.1:{listen}")
    assert r.returncode == 1
    assert table(r.stdout) == {"reply": False}


@pytest.mark.parametrize("args,option", [
    (["http://127.0.0.1:9000"], "URL"),
    (["osc://127.0.0.1:0"], "URL"),
    (["osc://127.0.0.1:9000", "--listen", "nowhere"], "--listen"),
    (["osc://127.0.0.1:9000", "--force", "50"], "--force"),
    (["osc://127.0.0.1:9000", "--tolerance-ms", "-1"], "--tolerance-ms"),
    (["osc://127.0.0.1:9000", "--trials", "0"], "--trials"),
    (["osc://127.0.0.1:9000", "--gain", "0.05"], "--gain"),
    (["osc://127.0.0.1:9000", "--limit", "0"], "--limit"),
])
def test_bridge_check_bad_input_is_one_line_exit_2(args, option):
    r = bridge_check(*args)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert r.returncode == 2, r.stdout + r.stderr
    assert len(lines) == 1 and option in lines[0], r.stderr


def test_bridge_settings_are_checked_where_they_are_built():
    """Issue 20: the settings are one pydantic type (no hand-written range checks in the CLI):
    a bad value is one ConfigError naming the field, for a library caller too."""
    from surfhap.errors import ConfigError

    for kw, field in (({"force": 5.0}, "force"), ({"trials": 21}, "trials"), ({"tolerance_ms": -1.0}, "tolerance_ms"),
                      ({"gain": math.nan}, "gain")):
        with pytest.raises(ConfigError) as e:
            BridgeSettings(**kw)
        assert e.value.field == field


def test_bridge_check_drives_full_scale_only_when_asked():
    """Without --clamp no force above the check's small --force reaches the bridge (a device
    under a hand never gets the full-scale step); the table has no clamp row."""
    listen = free_udp_port()
    with ReferenceBridge(("127.0.0.1", listen), limit=1e9) as bridge:  # passes any force through
        rows = BridgeCheck("127.0.0.1", bridge.port, BridgeSettings(tolerance_ms=300, trials=1),
                           listen=("127.0.0.1", listen)).run()
        with bridge.lock:
            commands = list(bridge.commands)
    assert [r.name for r in rows] == ROWS
    finite = [abs(v) for c in commands for v in c if math.isfinite(v)]
    assert commands and max(finite) <= 1.0 * 4.5 + 1e-9, max(finite)  # --force 1 N x gain 4.5
