"""Batch renders and fits over a scheduler: the same numbers whichever scheduler runs them
(serial, local processes, a real Dask cluster), failures reported without losing the others,
and one-line errors for bad options."""

import csv
import json
import math
import shutil
import sys

import numpy as np
import pytest

from surfhap.batch.schedulers import SchedulerSpec, parse_scheduler, run_jobs
from surfhap.cli import main
from surfhap.errors import ConfigError

GRID = ["leather,cork", "--scan", "duration=0.2", "--grid", "load=0.26,0.96", "--grid", "speed=0.05,0.2", "--no-figure"]
NAMES = [f"{m}_load{ld}_speed{s}" for m in ("leather", "cork") for ld in ("0.26", "0.96") for s in ("0.05", "0.2")]


def run(capsys, *args):
    code = main([str(a) for a in args])
    out = capsys.readouterr()
    return code, out.out, out.err


@pytest.fixture(scope="module")
def cluster():
    """A real Dask cluster, started here: 2 single-threaded workers in this process (robust
    on a loaded 2-core machine), reached over TCP as a remote cluster would be."""
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, protocol="tcp", dashboard_address=":0") as c:
        yield c


@pytest.fixture(scope="module")
def serial_grid(tmp_path_factory):
    out = tmp_path_factory.mktemp("serial")
    assert main(["render", *GRID, "--out", str(out)]) == 0
    return out


def _assert_same_renders(a, b):
    for name in NAMES:
        ra, rb = np.load(a / name / "render.npz"), np.load(b / name / "render.npz")
        assert sorted(ra.files) == sorted(rb.files)
        for key in ra.files:
            assert np.array_equal(ra[key], rb[key]), (name, key)  # bitwise, drive included
        assert (a / name / "drive.wav").read_bytes() == (b / name / "drive.wav").read_bytes()
        assert json.loads((a / name / "summary.json").read_text()) == json.loads((b / name / "summary.json").read_text())


def test_serial_grid_writes_one_folder_per_point_and_an_index(serial_grid):
    rows = list(csv.DictReader((serial_grid / "index.csv").open()))
    assert [r["job"] for r in rows] == NAMES
    assert all(r["status"] == "ok" and r["error"] == "" for r in rows)
    for r in rows:
        summary = json.loads((serial_grid / r["out"] / "summary.json").read_text())
        assert summary["material"] == r["material"]
        assert float(r["max_abs_voltage"]) == summary["max_abs_voltage"]
        data = np.load(serial_grid / r["out"] / "render.npz")
        touch = data["load"] > 0
        assert np.allclose(data["load"][touch], float(r["load"]))
        assert np.isclose(data["speed"][touch][-1], float(r["speed"]), rtol=1e-3)  # at steady state
    doc = json.loads((serial_grid / "index.json").read_text())
    assert doc["jobs"] == 8 and doc["failed"] == 0 and doc["scheduler"] == "serial"
    # a heavier load needs more voltage: the grid point really changed the render
    by = {r["job"]: float(r["max_abs_voltage"]) for r in rows}
    assert by["leather_load0.96_speed0.05"] > by["leather_load0.26_speed0.05"]


def test_grid_point_equals_the_single_render(serial_grid, tmp_path, capsys):
    code, _, err = run(capsys, "render", "cork", "--scan", "speed=0.2,load=0.96,duration=0.2", "--no-figure", "--out", tmp_path / "one")
    assert code == 0, err
    one, point = np.load(tmp_path / "one" / "render.npz"), np.load(serial_grid / "cork_load0.96_speed0.2" / "render.npz")
    assert all(np.array_equal(one[k], point[k]) for k in one.files)


def test_local_processes_give_the_serial_numbers(serial_grid, tmp_path, capsys):
    code, stdout, err = run(capsys, "render", *GRID, "--jobs", "2", "--out", tmp_path)
    assert code == 0, err
    assert "8 of 8 jobs done on 2 processes" in stdout
    _assert_same_renders(serial_grid, tmp_path)


def test_dask_cluster_gives_the_serial_numbers(serial_grid, cluster, tmp_path, capsys):
    code, stdout, err = run(capsys, "render", *GRID, "--scheduler", cluster.scheduler_address, "--out", tmp_path)
    assert code == 0, err
    assert f"dask {cluster.scheduler_address}" in stdout
    _assert_same_renders(serial_grid, tmp_path)
    assert len(cluster.scheduler.workers) == 2 and "call" in cluster.scheduler.task_prefixes  # the jobs (_call) ran there


def test_a_local_dask_cluster_started_by_the_cli(serial_grid, tmp_path, capsys):
    code, stdout, err = run(capsys, "render", *GRID, "--scheduler", "local:2", "--out", tmp_path)
    assert code == 0, err
    assert "dask LocalCluster of 2" in stdout
    _assert_same_renders(serial_grid, tmp_path)


@pytest.mark.parametrize("kind", ["serial", "processes", "dask"])
def test_a_failing_job_is_reported_and_the_others_complete(kind, cluster):
    spec = {"serial": SchedulerSpec("serial"), "processes": SchedulerSpec("processes", workers=2),
            "dask": parse_scheduler(cluster.scheduler_address)}[kind]
    seen = []
    outcomes = run_jobs(math.sqrt, [4.0, -1.0, 9.0, 2.25], spec, progress=lambda o, done, total: seen.append((done, total)))
    assert [o.index for o in outcomes] == [0, 1, 2, 3]
    assert [o.ok for o in outcomes] == [True, False, True, True]
    assert [o.value for o in outcomes] == [2.0, None, 3.0, 1.5]
    assert outcomes[1].error.startswith("ValueError: math domain error")
    assert seen == [(1, 4), (2, 4), (3, 4), (4, 4)]


def test_fit_imu_folder_reports_a_bad_recording_and_fits_the_rest(shared_data, cluster, tmp_path, capsys):
    recs = tmp_path / "recs"
    recs.mkdir()
    for name in ("leather_1.csv", "wood_1.csv"):
        shutil.copy(shared_data / "hapmat-imu" / name, recs / name)
    (recs / "broken.csv").write_text("time,accel_x,accel_y,accel_z\n0,1,2\n")
    base = tmp_path / "base.json"
    shutil.copy(sys.modules["surfhap"].__path__[0] + "/models/builtin/leather.json", base)
    code, stdout, err = run(capsys, "fit", "imu", recs, "--into", base, "--out", tmp_path / "fits", "--order", "20",
                            "--scheduler", cluster.scheduler_address)
    assert code == 1
    assert "2 of 3 jobs done" in stdout
    assert len([ln for ln in err.splitlines() if ln.strip()]) == 1 and "broken" in err
    rows = {r["job"]: r for r in csv.DictReader((tmp_path / "fits" / "index.csv").open())}
    assert rows["broken"]["status"] == "failed" and "broken.csv" in rows["broken"]["error"]
    assert not (tmp_path / "fits" / "broken" / "material.json").exists()
    for job in ("leather_1", "wood_1"):
        assert rows[job]["status"] == "ok" and rows[job]["order"] == "20"
        batch = json.loads((tmp_path / "fits" / job / "material.json").read_text())
        # the same fit as the single command recorded in the material's provenance
        single = tmp_path / f"{job}.json"
        code, _, err = run(capsys, "fit", "imu", recs / f"{job}.csv", "--into", base, "--out", single, "--order", "20")
        assert code == 0, err
        ref = json.loads(single.read_text())
        assert batch["texture"]["models"] == ref["texture"]["models"]
        assert batch["texture"]["provenance"]["command"] == ref["texture"]["provenance"]["command"].replace(
            str(single), str(tmp_path / "fits" / job / "material.json"))


def test_fit_friction_on_a_dask_cluster_equals_serial(cluster, tmp_path, capsys):
    from surfhap.exchange.recordings import write_recording_npz
    from surfhap.fit.synthetic import synthetic_friction_recordings
    from surfhap.models.friction import QuasiStaticLaw

    tex = {0.05: (np.array([0.5]), 1e-6), 0.1: (np.array([-0.3]), 1e-6)}
    recs = synthetic_friction_recordings(QuasiStaticLaw(0.4, 0.3, 1.0, 1.0, 0.5), tex, participants=2, duration=3.0, seed=0)
    files = [write_recording_npz(r, tmp_path / f"r{i}.npz") for i, r in enumerate(recs)]
    args = ["fit", "friction", *files, "--material", "syn", "--reference-velocities", "50,100"]
    assert run(capsys, *args, "--out", tmp_path / "serial.json")[0] == 0
    code, _, err = run(capsys, *args, "--out", tmp_path / "dask.json", "--jobs", "2", "--scheduler", cluster.scheduler_address)
    assert code == 0, err
    assert any(p.startswith("batch_of_") for p in cluster.scheduler.task_prefixes)  # joblib's work ran on the cluster
    a, b = (json.loads((tmp_path / f).read_text()) for f in ("serial.json", "dask.json"))
    assert a["texture"]["models"] == b["texture"]["models"] and a["friction"]["quasi_static"]["a"] == b["friction"]["quasi_static"]["a"]


@pytest.mark.parametrize("value", ["tcp://host", "local:0", "udp://h:1", "local:x", "tcp://h:99999", "dask"])
def test_bad_scheduler_is_one_line_exit_2(value, tmp_path, capsys):
    for args in (["render", "leather", "--scan", "speed=0.1,load=0.3,duration=0.2"],
                 ["fit", "friction", tmp_path / "x.npz", "--material", "m"]):
        code, _, err = run(capsys, *args, "--scheduler", value, "--out", tmp_path / "o")
        assert code == 2
        lines = [ln for ln in err.splitlines() if ln.strip()]
        assert len(lines) == 1 and "--scheduler" in lines[0], err
    with pytest.raises(ConfigError):
        parse_scheduler(value)


@pytest.mark.parametrize("args,message", [
    (["--grid", "load=0.2,x"], "--grid: load"),
    (["--grid", "mass=1"], "unknown key 'mass'"),
    (["--grid", "load=0.2", "--grid", "load=0.3"], "given twice"),
    (["--jobs", "0"], "--jobs"),
])
def test_bad_grid_or_jobs_is_one_line_exit_2(args, message, tmp_path, capsys):
    code, _, err = run(capsys, "render", "leather", "--scan", "speed=0.1,duration=0.2", *args, "--out", tmp_path)
    assert code == 2
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and message in lines[0], err


def test_missing_dask_names_the_extra(monkeypatch, tmp_path, capsys):
    for mod in ("dask", "dask.distributed", "distributed"):
        monkeypatch.setitem(sys.modules, mod, None)
    code, _, err = run(capsys, "render", *GRID, "--scheduler", "local:2", "--out", tmp_path)
    assert code == 2
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1 and "surfhap[dask]" in lines[0], err
    assert not (tmp_path / "index.csv").exists()


@pytest.mark.parametrize("sig", ["SIGINT", "SIGTERM"])
def test_ctrl_c_keeps_the_finished_jobs_and_exits_130(tmp_path, sig):
    """Ctrl-C (SIGINT to the whole process group, as a terminal sends it) or SIGTERM during a
    batch on local processes: no traceback from the parent or the workers, one line, exit 130,
    and an index with every finished job 'ok' and the rest 'interrupted'. The child starts
    with SIGINT ignored, as a shell starts a background command: the CLI handles it anyway."""
    import os
    import signal
    import subprocess
    import time

    out = tmp_path / "grid"
    cmd = [sys.executable, "-c", "import sys; from surfhap.cli import main; sys.exit(main())", "render", "leather,cork",
           "--scan", "duration=20", "--grid", "load=0.26,0.5,0.96", "--grid", "speed=0.05,0.1,0.15,0.2",
           "--no-figure", "--jobs", "2", "--out", str(out)]
    p = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    try:
        end = time.monotonic() + 300
        while time.monotonic() < end and p.poll() is None and len(list(out.glob("*/summary.json"))) < 3:
            time.sleep(0.05)
        written = len(list(out.glob("*/summary.json")))  # a job's last file (no figure); its outcome may still be on the way
        assert p.poll() is None, "the batch ended before it could be interrupted"
        if sig == "SIGINT":  # the terminal's Ctrl-C reaches the whole process group
            os.killpg(p.pid, signal.SIGINT)
        else:  # kill PID
            os.kill(p.pid, signal.SIGTERM)
        stdout, stderr = p.communicate(timeout=120)
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait(10)
    assert p.returncode == 130, stderr
    assert "Traceback" not in stderr and "KeyboardInterrupt" not in stderr, stderr
    lines = [ln for ln in stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: interrupted:"), stderr
    with (out / "index.csv").open() as fh:
        rows = list(csv.DictReader(fh))
    assert len(rows) == 24
    done = [r for r in rows if r["status"] == "ok"]
    # at most one finished-but-unreported job per worker (2) may be counted as interrupted
    assert written - 2 <= len(done) < 24 and len(done) >= 1
    assert all(r["error"] == "interrupted" for r in rows if r["status"] != "ok")
    for r in done:  # a finished job's folder is complete
        assert json.loads((out / r["out"] / "summary.json").read_text())["material"] in ("leather", "cork")


@pytest.mark.parametrize("modules", ["RENDER_JOB_MODULES", "FIT_IMU_JOB_MODULES"])
def test_job_module_lists_name_real_modules(modules):
    """The fork server skips a preload module that does not import: a stale name would only
    make the workers slower, silently. Every listed module must import."""
    import importlib

    from surfhap.batch import jobs

    for name in getattr(jobs, modules):
        importlib.import_module(name)


@pytest.mark.parametrize("spec", ["SchedulerSpec('processes', workers=2)", "SchedulerSpec('dask', workers=2)"])
def test_local_workers_start_with_the_job_modules_loaded(tmp_path, spec):
    """prestart + run_jobs on local processes or a Dask LocalCluster: each worker has the
    preload modules before its first job (forked from the fork server that imported them),
    and a fresh interpreter's CLI alone does not import them (else the check proves nothing)."""
    import subprocess

    if "forkserver" not in __import__("multiprocessing").get_all_start_methods():
        pytest.skip("no fork server on this platform (spawned workers import as they go)")
    (tmp_path / "probe_jobs.py").write_text(
        "import sys\n\ndef loaded(name):\n    return name in sys.modules\n", encoding="utf-8")
    script = (
        "import sys, json\n"
        f"sys.path.insert(0, {str(tmp_path)!r})\n"
        "import surfhap.cli, probe_jobs\n"
        "from surfhap.batch.jobs import RENDER_JOB_MODULES as M\n"
        "from surfhap.batch.schedulers import SchedulerSpec, prestart, run_jobs\n"
        "before = [m in sys.modules for m in M]\n"
        f"spec = {spec}\n"
        "prestart(spec, M)\n"
        "out = run_jobs(probe_jobs.loaded, list(M) * 2, spec, preload=M)\n"
        "print(json.dumps({'parent': before, 'workers': [o.value for o in out]}))\n"
    )
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    seen = json.loads(r.stdout.strip().splitlines()[-1])
    assert not any(seen["parent"]), seen
    assert all(seen["workers"]), seen
