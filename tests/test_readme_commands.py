"""Every ``surfhap`` command of README.md runs (issue 17, item 15: the Dask example failed).

The commands are extracted from README.md's ``sh`` code blocks (``make`` and ``pip`` lines are
out of scope) and run as written (globs and ``~`` expanded as a shell would), with cwd and HOME
a temporary folder, three at a time; the ``study`` commands in README order, since each uses the
study the one before wrote. Documented substitutions, each keeping the command's structure:

* placeholders become small files in the right schema, written by :func:`write_placeholders`:
  ``my_material.json`` (a built-in material file), ``finger.csv`` (a trajectory), ``my_panel.json``
  (a ``surfhap-display`` file), ``my_mesh.obj`` / ``my_mesh.stl`` (Suzanne), ``P*.csv`` (synthetic
  friction recordings), ``scan*.npz`` (a synthetic tool scan), ``~/HaTT`` (a HaTT model set),
  ``rec/*.csv`` (synthetic tribometer runs);
* ``.venv/bin/surfhap`` and ``surfhap`` become this interpreter's ``-m surfhap``;
* ``duration=N`` in ``--scan`` becomes ``duration=0.2`` (time, not structure);
* ``--output sound:3`` becomes ``--output file:sound3.wav`` (CI has no sound card);
* fixed TCP/UDP ports (the pages' 8765 / 8780, OSC 9100, the bridge's listen port 9101) become
  free ones (``:0``, or a free port the test picks where a command needs a number), since other
  test processes may hold them;
* long-running commands stop by themselves: ``serve`` and ``ff run`` get ``--duration 1``;
  ``study run`` (a participant page) is interrupted with SIGINT once it serves, and must
  stop in order: "paused" and exit 0 (a study is paused, to be resumed) or 130 (interrupted
  before its page loop), never a traceback;
* before ``study analyze``, one simulated participant answers (``study run s/ -p P02 --simulate 1``,
  the documented dry run): the page run was interrupted before any answer.
"""

from __future__ import annotations

import glob
import json
import os
import re
import shlex
import signal
import socket
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
SRC = Path(__file__).resolve().parents[1] / "src"
TIMEOUT = 240  # s, a failure guard per command, not a speed target


def readme_commands() -> list[str]:
    """The surfhap command lines of README.md's sh blocks, comments stripped."""
    text = README.read_text(encoding="utf-8")
    commands = []
    for block in re.findall(r"```sh\n(.*?)```", text, flags=re.S):
        for line in block.splitlines():
            line = line.strip()
            if not re.match(r"^(\.venv/bin/)?surfhap\b", line):
                continue
            commands.append(re.sub(r"\s+#.*$", "", line))
    return commands


COMMANDS = readme_commands()
INTERRUPTED = ("study run",)  # run until stopped: SIGINT once serving, an orderly exit (0 "paused" or 130)


def free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def substitute(cmd: str, home: Path) -> list[str]:
    """The documented substitutions of the module docstring; ``~`` and globs expand as a shell
    would (relative to ``home``, the cwd), an unmatched glob stays as written."""
    args = shlex.split(cmd)
    out = [sys.executable, "-m", "surfhap"]
    for a in args[1:]:
        a = re.sub(r"duration=[0-9.]+", "duration=0.2", a)
        a = a.replace("sound:3", "file:sound3.wav")
        a = re.sub(r"^osc://127\.0\.0\.1:9100$", "osc://127.0.0.1:0", a)
        if a.startswith("~"):
            a = str(home) + a[1:]
        matches = sorted(glob.glob(a, root_dir=home)) if re.search(r"[*?\[]", a) else []
        out += matches or [a]
    head = " ".join(out[3:5])
    if out[3] == "serve" or head == "ff run":
        out += ["--duration", "1"]
    if out[3] == "serve" or (head == "ff run" and "web" in out):
        out += ["--port", str(free_port())]
    if head == "study run":
        out += ["--port", "0"]
    if head == "ff run" and "--device" in out and out[out.index("--device") + 1].startswith("osc://"):
        out += ["--device-listen", f"127.0.0.1:{free_port()}"]
    return out


# ---------------------------------------------------------------- placeholder files


def _hatt_bank(seed: int = 0):
    """A small HaTT-like interpolated ARMA bank over a 3 x 3 (speed, force) grid."""
    from surfhap.models.interpolated import InterpolatedARMABank
    from surfhap.signal.lsf import poly_to_lsf

    rng = np.random.default_rng(seed)

    def stable(p, rmax):
        r, th = rng.uniform(0.3, rmax, p // 2), rng.uniform(0.1, 3.0, p // 2)
        return np.real(np.poly(np.r_[r * np.exp(1j * th), r * np.exp(-1j * th)]))

    sp, fo = np.meshgrid([0.0, 0.1, 0.2], [0.0, 1.0, 2.0])
    speeds, forces = sp.ravel(), fo.ravel()
    ar = np.array([poly_to_lsf(stable(6, 0.9)) for _ in range(9)])
    ma = np.array([poly_to_lsf(stable(4, 0.7)) for _ in range(9)])
    var = np.where((speeds == 0) | (forces == 0), 0.0, rng.uniform(0.005, 0.02, 9))
    return InterpolatedARMABank.from_models("acceleration", 1000.0, speeds, forces, ar, var, ma, rng.uniform(1, 5, 9))


def write_placeholders(d: Path) -> None:
    import surfhap
    from surfhap.exchange.hatt import bank_to_hatt, write_hatt_xml
    from surfhap.exchange.recordings import write_recording_csv, write_recording_npz
    from surfhap.exchange.trajectory_csv import write_trajectory_csv
    from surfhap.exchange.tribometer import write_tribometer_csv
    from surfhap.fit.synthetic import synthetic_accel_recording, synthetic_friction_recordings
    from surfhap.lab.tribometer_synth import synthetic_tribometer
    from surfhap.models.friction import QuasiStaticLaw
    from surfhap.models.trajectory import strokes

    pkg = Path(surfhap.__file__).parent
    (d / "my_material.json").write_bytes((pkg / "models" / "builtin" / "cork.json").read_bytes())
    write_trajectory_csv(strokes(0.1, 0.4, 1.0, length=0.05), d / "finger.csv")
    (d / "my_panel.json").write_text(json.dumps({
        "format": "surfhap-display", "version": 1, "k": 8e-6, "mu_panel": 0.4, "area": 1.5e-4,
        "provenance": {"source": "assumed", "command": "written by tests/test_readme_commands.py"}}))
    suzanne = (pkg / "data" / "suzanne.obj").read_bytes()
    (d / "my_mesh.obj").write_bytes(suzanne)
    import trimesh

    mesh = trimesh.load(d / "my_mesh.obj", force="mesh")
    mesh.apply_scale(0.1 / max(mesh.extents))  # 10 cm across, in metres
    mesh.export(d / "my_mesh.stl")
    tex = {0.05: (np.array([0.5]), 1e-6), 0.1: (np.array([-0.3]), 1e-6)}
    recs = synthetic_friction_recordings(QuasiStaticLaw(0.4, 0.3, 1.0, 1.0, 0.5), tex, participants=2, duration=4.0, seed=0)
    for i, r in enumerate(recs, 1):
        write_recording_csv(r, d / f"P{i}.csv")
    pieces = [(np.array([1.4, -0.8]), 1.0, 1500, 0.05, 0.5), (np.array([-0.5]), 2.0, 1500, 0.15, 1.0)]
    write_recording_npz(synthetic_accel_recording(pieces, seed=3), d / "scan1.npz")
    (d / "HaTT").mkdir()
    write_hatt_xml(bank_to_hatt(_hatt_bank(), "Cork", 0.55), d / "HaTT" / "Models_Cork.xml")
    (d / "rec").mkdir()
    for i, v in enumerate([60.0, 120.0, 180.0, 240.0]):
        rec = synthetic_tribometer(v, "voltage", k=5e-6, mu_panel=0.5, duration=2.0, sample_rate=4000.0, seed=i)
        write_tribometer_csv(rec, d / "rec" / f"v{i}.csv")


def _env(d: Path) -> dict:
    return {**os.environ, "HOME": str(d), "PYTHONPATH": str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""),
            "MPLBACKEND": "Agg"}


def _run(cmd: str, d: Path) -> tuple[int, str]:
    """Run one README command in ``d``: exit code and its output (for the failure message)."""
    args = substitute(cmd, d)
    shown = f"{cmd}\n-> {shlex.join(args)}\n"
    if " ".join(args[3:5]) in INTERRUPTED:
        proc = subprocess.Popen(args, cwd=d, env=_env(d), stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        seen = []
        try:
            for line in proc.stdout:  # wait until the page serves, then Ctrl-C
                seen.append(line)
                if "http://" in line:
                    break
            proc.send_signal(signal.SIGINT)
            rest, _ = proc.communicate(timeout=TIMEOUT)
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.communicate()
        return proc.returncode, shown + "".join(seen) + (rest or "")
    res = subprocess.run(args, cwd=d, env=_env(d), capture_output=True, text=True, timeout=TIMEOUT)
    return res.returncode, shown + res.stdout[-3000:] + res.stderr[-3000:]


@pytest.fixture(scope="module")
def results(tmp_path_factory) -> dict[str, tuple[int, str]]:
    """Every README command's (exit code, output). They run three at a time (most of their time
    is interpreter start-up, imports and figure drawing); the study commands in README order
    in one chain, since each uses the study the one before wrote."""
    d = tmp_path_factory.mktemp("readme")
    write_placeholders(d)
    chain = [c for c in COMMANDS if re.search(r"surfhap study ", c)]
    alone = sorted((c for c in COMMANDS if c not in chain), key=lambda c: not re.search(r"--grid|scenes", c))  # longest first

    def run_chain() -> dict:
        done = {}
        for c in chain:
            if "study analyze" in c:  # a participant's answers to analyse: the documented dry run (no page)
                done["setup"] = _run("surfhap study run s/ -p P02 --simulate 1", d)
            done[c] = _run(c, d)
        return done

    with ThreadPoolExecutor(3) as pool:
        chained = pool.submit(run_chain)
        singles = {c: pool.submit(_run, c, d) for c in alone}
        out = {c: f.result() for c, f in singles.items()} | chained.result()
    code, text = out.pop("setup")
    assert code == 0, text
    return out


def test_the_readme_has_the_commands_it_documents():
    """The extraction finds every documented command group (a README edit cannot hide them)."""
    joined = "\n".join(COMMANDS)
    assert len(COMMANDS) >= 30
    for needle in ("render leather,cork", "--scheduler local:2", "shape calibrate", "fit friction", "import hatt", "serve",
                   "ff run", "study run", "study analyze", "calibrate tribometer", "--version"):
        assert needle in joined, needle


@pytest.mark.slow  # still runs in `make test` (it runs every test); the time is ~35 interpreter start-ups
@pytest.mark.parametrize("cmd", COMMANDS, ids=[f"{i:02d}" for i in range(len(COMMANDS))])
def test_readme_command_runs(results, cmd):
    code, text = results[cmd]
    if any(f"surfhap {c} " in cmd for c in INTERRUPTED):
        # an orderly stop: "paused" and exit 0 when Ctrl-C reaches the page loop (a study pauses, to be
        # resumed), 130 when it comes first (as every interrupted command); never a traceback
        assert code in (0, 130) and "Traceback" not in text, text
        assert code == 130 or "paused" in text, text
    else:
        assert code == 0, text


def test_readme_python_blocks_run(tmp_path):
    """README.md's ``python`` blocks run as written (in a fresh interpreter, cwd a temporary
    folder): the namespaces they show (``sh.texture.render``, ``sh.io.write_render`` /
    ``read_render``) exist and round-trip."""
    text = README.read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, flags=re.S)
    assert blocks, "README.md has no python block"
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(SRC), os.environ.get("PYTHONPATH", "")]), MPLBACKEND="Agg")
    for block in blocks:
        proc = subprocess.run([sys.executable, "-c", block], cwd=tmp_path, env=env, capture_output=True, text=True,
                              timeout=TIMEOUT)
        assert proc.returncode == 0, f"README python block failed:\n{block}\n{proc.stderr[-2000:]}"
