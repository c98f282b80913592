"""Bad files and bad address options, through the real CLI: one line naming the file or the
option, exit code 2, never a traceback (issue 17 item 14).

Each case writes its bad input into a temporary folder and runs ``python -m surfhap ...`` in a
subprocess, as a user would. The readers share one conversion of OS / decoding / archive errors
(:func:`surfhap.errors.reading`, :func:`surfhap.errors.writing`), so the table also covers the
readers of every format a command takes.
"""

from __future__ import annotations

import subprocess
import sys
import tracemalloc
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

from surfhap.errors import ConfigError, InputError, OutputError, RecordingFormatError
from surfhap.exchange.files import npz_number
from surfhap.exchange.recordings import read_recording
from surfhap.live.netaddr import check_host, parse_host_port, parse_osc_address

N = 400
T = np.arange(N) / 1000.0


def _recording_npz(path: Path, **override) -> Path:
    arrays = {"time": T, "normal_force": np.full(N, 0.5), "shear_force": np.full(N, 0.2), "speed": np.full(N, 0.1)}
    arrays.update(override)
    np.savez(path, **{k: v for k, v in arrays.items() if v is not None}, allow_pickle=True)
    return path


def _tribometer_npz(path: Path, **override) -> Path:
    level = np.r_[np.zeros(N // 2), np.full(N - N // 2, 0.5)]
    arrays = {"time": T, "lateral_force": np.full(N, 0.3), "normal_force": np.full(N, 0.5), "level": level,
              "input": np.array("intensity")}
    arrays.update(override)
    np.savez(path, **{k: v for k, v in arrays.items() if v is not None}, allow_pickle=True)
    return path


def _truncate(path: Path) -> Path:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    return path


def _undecodable(path: Path, head: bytes) -> Path:
    path.write_bytes(head + b"\xff\xfe\xfa not UTF-8 \x81\n")
    return path


def _fit(path: Path, out: Path) -> list[str]:
    return ["fit", "friction", str(path), "--material", "x", "--out", str(out / "x.json")]


def _tribo(path: Path, out: Path) -> list[str]:
    return ["calibrate", "tribometer", str(path), "--out", str(out / "cal.json")]


SCAN = ["--scan", "speed=0.1,load=0.5,duration=0.2"]

# name -> (make(tmp) -> argv, what the line must name)
CASES = {
    "truncated recording npz": (lambda d: _fit(_truncate(_recording_npz(d / "rec.npz")), d), "rec.npz"),
    "truncated tribometer npz": (lambda d: _tribo(_truncate(_tribometer_npz(d / "tri.npz")), d), "tri.npz"),
    "array sample_rate (recording)": (
        lambda d: _fit(_recording_npz(d / "rec.npz", time=None, sample_rate=np.array([1e3, 2e3])), d), "rec.npz"),
    "array sample_rate (tribometer)": (
        lambda d: _tribo(_tribometer_npz(d / "tri.npz", time=None, sample_rate=np.array([1e3, 2e3])), d), "tri.npz"),
    "object array (recording)": (
        lambda d: _fit(_recording_npz(d / "rec.npz", speed=np.array([{"v": 1}] * N, dtype=object)), d), "rec.npz"),
    "object array (tribometer)": (
        lambda d: _tribo(_tribometer_npz(d / "tri.npz", lateral_force=np.array([None] * N, dtype=object)), d),
        "tri.npz"),
    "string array (recording)": (
        lambda d: _fit(_recording_npz(d / "rec.npz", speed=np.array(["fast"] * N)), d), "rec.npz"),
    "undecodable recording csv": (lambda d: _fit(_undecodable(d / "rec.csv", b"time,normal_force\n0,"), d), "rec.csv"),
    "undecodable tribometer csv": (lambda d: _tribo(_undecodable(d / "tri.csv", b"# input: intensity\n"), d),
                                   "tri.csv"),
    "undecodable material json": (
        lambda d: ["render", str(_undecodable(d / "mat.json", b'{"name": "')), *SCAN, "--out", str(d / "r")],
        "mat.json"),
    "undecodable display json": (
        lambda d: ["render", "cork", "--display", str(_undecodable(d / "disp.json", b'{"k": "')), *SCAN,
                   "--out", str(d / "r")], "disp.json"),
    "undecodable shape calibration": (
        lambda d: ["shape", "gaussian-bump", "--calibration", str(_undecodable(d / "c.json", b'{"fmin": "')),
                   "--scan", "0,0,0.01,0,0.1", "--out", str(d / "s"), "--no-figure"], "c.json"),
    "unreadable stl": (
        lambda d: ["shape", "calibrate", str(_undecodable(d / "part.stl", b"solid x\nfacet \x00\x01")),
                   "--out", str(d / "c.json")], "part.stl"),
    "osc output host that is no address": (
        lambda d: ["serve", "--output", "osc://999.1.1.1:5", "--duration", "1"], "--output"),
    "osc output port out of range": (
        lambda d: ["serve", "--output", "osc://127.0.0.1:70000", "--duration", "1"], "--output"),
    "osc output port 0": (lambda d: ["serve", "--output", "osc://127.0.0.1:0", "--duration", "1"], "--output"),
    "osc-in host that is no address": (lambda d: ["serve", "--osc-in", "999.1.1.1:5", "--duration", "1"], "--osc-in"),
    "ff device host that is no address": (
        lambda d: ["ff", "run", "buttons", "--device", "osc://999.1.1.1:5", "--duration", "1"], "--device"),
    "ff device port out of range": (
        lambda d: ["ff", "run", "buttons", "--device", "osc://127.0.0.1:65536", "--duration", "1"], "--device"),
    "ff feedback port out of range": (
        lambda d: ["ff", "run", "buttons", "--device", "sim", "--feedback", "osc://127.0.0.1:99999",
                   "--duration", "1"], "--feedback"),
}


def _run(argv: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "surfhap", *argv], cwd=cwd, capture_output=True, text=True,
                          timeout=600)


@pytest.fixture(scope="module")
def cli_runs(tmp_path_factory):
    """Every case's CLI run, started at once a few at a time (each run is mostly interpreter and
    import start-up); a test waits for its own."""
    pool = ThreadPoolExecutor(max_workers=3)
    runs = {}
    for i, (name, (make, _)) in enumerate(CASES.items()):
        folder = tmp_path_factory.mktemp(f"case{i}")
        runs[name] = pool.submit(_run, make(folder), folder)
    yield runs
    pool.shutdown(wait=True)


@pytest.mark.parametrize("name", list(CASES))
def test_bad_input_is_one_line_naming_it(name, cli_runs):
    _, named = CASES[name]
    res = cli_runs[name].result()
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert "Traceback" not in res.stderr and "No module named" not in res.stderr, res.stderr
    assert res.returncode == 2, (res.returncode, res.stderr)
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith("error: ") and named in lines[0], lines[0]


@pytest.mark.skipif(not Path("/dev/full").exists(), reason="needs Linux's /dev/full (every write: ENOSPC)")
def test_no_space_left_names_the_output(tmp_path):
    """A write that fails with ENOSPC names the file it was writing (/dev/full fails every write)."""
    res = _run(["shape", "calibrate", "gaussian-bump", "--directions", "2", "--speeds", "1", "--lines", "1",
                "--out", "/dev/full"], tmp_path)
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert res.returncode == 2 and len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
    assert "/dev/full" in lines[0] and "no space left" in lines[0], lines[0]


def test_enospc_in_process_names_the_path(tmp_path, monkeypatch):
    """The same for a writer whose target is a regular file: a monkeypatched write fails with ENOSPC."""
    import errno

    from surfhap.exchange.recordings import write_recording_csv

    rec = read_recording(_recording_npz(tmp_path / "rec.npz"))

    def full(self, *args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(Path, "write_text", full)
    with pytest.raises(OutputError, match=r"out\.csv: cannot write file \(no space left"):
        write_recording_csv(rec, tmp_path / "out.csv")


def test_large_csv_memory_is_bounded_by_its_columns(tmp_path):
    """A CSV is streamed: the peak memory of reading it is a small multiple of the columns it
    yields (8 bytes per used cell), not of its text (the whole-text reader took ~17x the file)."""
    n = 100_000
    rng = np.random.default_rng(1)
    p = tmp_path / "big.csv"
    with p.open("w") as fh:
        fh.write("# participant: P1\ntime,normal_force,shear_force,speed,unused_a,unused_b\n")
        np.savetxt(fh, np.column_stack([np.arange(n) / 1e3, 0.5 + 0.01 * rng.random(n), 0.2 + 0.01 * rng.random(n),
                                        0.1 + 1e-3 * rng.random(n), rng.random(n), rng.random(n)]),
                   delimiter=",", fmt="%.9g")
    columns_bytes = 4 * n * 8
    tracemalloc.start()
    try:
        rec = read_recording(p)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert rec.n == n and np.allclose(rec.time, np.arange(n) / 1e3)
    assert peak < 4 * columns_bytes, f"peak {peak / 1e6:.1f} MB for {columns_bytes / 1e6:.1f} MB of columns"


def test_streamed_csv_still_locates_bad_cells(tmp_path):
    """The cell-by-cell path (after the fast reader gave up) names the row and the column."""
    p = tmp_path / "r.csv"
    rows = "".join(f"{i / 1e3},0.5,0.2,0.1\n" for i in range(40))
    p.write_text("time,normal_force,shear_force,speed\n" + rows + "0.04,0.5,abc,0.1\n")
    with pytest.raises(RecordingFormatError, match=r"r\.csv: shear_force: row 41: 'abc' is not a number"):
        read_recording(p)


@pytest.mark.parametrize("good, host", [("localhost", "localhost"), ("lab-pc.example.org", "lab-pc.example.org"),
                                        ("10.0.0.7", "10.0.0.7"), ("[::1]", "::1"), ("::1", "::1")])
def test_hosts_accepted_without_lookup(good, host, monkeypatch):
    import socket

    def no_dns(*args, **kwargs):
        raise AssertionError("parsing an address must not resolve it")

    monkeypatch.setattr(socket, "getaddrinfo", no_dns)
    monkeypatch.setattr(socket, "gethostbyname", no_dns)
    assert check_host(good, "--x") == host


@pytest.mark.parametrize("bad", ["999.1.1.1", "1.2.3", "256.0.0.1", "bad_host", "-lead.example", "a..b", "[10.0.0.1]",
                                 "x" * 64 + ".org", "example.123"])
def test_hosts_refused_without_lookup(bad):
    with pytest.raises(ConfigError, match="--x: host"):
        check_host(bad, "--x")


def test_ports_and_paths():
    assert parse_osc_address("osc://[::1]:9000/drive", "--output") == ("::1", 9000, "drive")
    assert parse_osc_address("osc://127.0.0.1:0", "--touch", listen=True) == ("127.0.0.1", 0, "")
    assert parse_host_port("0.0.0.0:9000", "--osc-in", listen=True) == ("0.0.0.0", 9000)
    for bad in ("127.0.0.1:0", "127.0.0.1:65536", "127.0.0.1:", "127.0.0.1:-1", "127.0.0.1:9x", "127.0.0.1"):
        with pytest.raises(ConfigError, match="--device"):
            parse_host_port(bad, "--device")


def test_npz_number_wants_one_number():
    assert npz_number(np.array(2000.0), "f.npz", "sample_rate") == 2000.0
    assert npz_number(np.array([2000]), "f.npz", "sample_rate") == 2000.0
    for bad in (np.array([1.0, 2.0]), np.array("fast"), np.zeros((0,))):
        with pytest.raises(InputError, match="f.npz: sample_rate"):
            npz_number(bad, "f.npz", "sample_rate")

