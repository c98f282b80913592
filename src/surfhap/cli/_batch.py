"""Batch mode of ``surfhap render`` and ``surfhap fit imu``: parse the many inputs (materials,
``--grid``, a folder of recordings) and ``--jobs``/``--scheduler``, build the job list, and
delegate to :mod:`surfhap.batch` (which runs the jobs and writes the index)."""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import typer

from surfhap.cli._common import command_line, error_line, fail, progress_bar, stdout
from surfhap.cli._signals import EXIT_INTERRUPTED, StopSignals
from surfhap.errors import ConfigError

__all__ = ["GRID_HELP", "split_inputs", "parse_grid", "render_batch", "fit_imu_command", "fit_imu_batch"]

GRID_KEYS = ("load", "speed", "duration", "length", "rate")
GRID_HELP = ("Render a grid: 'KEY=V1,V2,...' with KEY one of load (N), speed (m/s), duration (s), length (m), rate (Hz); "
             "repeat for more keys (the grid is every combination, times the materials). Values override --scan's.")


def split_inputs(values: list[str]) -> list[str]:
    """Material arguments: each is a name or file; a comma-separated list is split (an existing
    file whose name has a comma is kept whole)."""
    out: list[str] = []
    for v in values:
        out += [v] if Path(v).exists() else [p.strip() for p in v.split(",") if p.strip()]
    return out


def parse_grid(grid: list[str]) -> dict[str, list[float]]:
    """``["load=0.26,0.5", "speed=0.1"]`` -> {"load": [0.26, 0.5], "speed": [0.1]} (keys in order given)."""
    axes: dict[str, list[float]] = {}
    for item in grid:
        key, sep, values = item.partition("=")
        key = key.strip()
        if not sep:
            raise ConfigError(f"expected KEY=V1,V2,..., got {item!r}", source="--grid")
        if key not in GRID_KEYS:
            raise ConfigError(f"unknown key {key!r} (known: {', '.join(GRID_KEYS)})", source="--grid")
        if key in axes:
            raise ConfigError("given twice", source="--grid", field=key)
        try:
            vals = [float(v) for v in values.split(",") if v.strip()]
        except ValueError:
            raise ConfigError(f"expected comma-separated numbers, got {values!r}", source="--grid", field=key) from None
        if not vals or len(set(vals)) != len(vals):
            raise ConfigError("give one or more distinct values", source="--grid", field=key)
        axes[key] = vals
    return axes


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9._+-]+", "-", text).strip("-") or "job"


def _run(fn, items, root: Path, spec, what: str, preload: tuple[str, ...] = ()) -> None:
    """Run the jobs with a progress bar on stderr, write the index, print one line; exits 1
    when a job failed, 130 when a signal stopped the batch."""
    from surfhap.batch.index import index_rows, write_index
    from surfhap.batch.schedulers import JobOutcome, run_jobs

    where = spec.describe()
    with progress_bar(f"{what} on {where}", total=len(items)) as update:
        finished: dict[int, JobOutcome] = {}

        def progress(outcome, done, total):
            finished[outcome.index] = outcome
            failed = sum(not o.ok for o in finished.values())
            update(done, f"{failed} failed" if failed else "")

        with StopSignals() as guard:  # Ctrl-C or SIGTERM: keep what finished, mark the rest, no traceback
            outcomes = guard.call(run_jobs, fn, items, spec, progress=progress, preload=preload)
    interrupted = outcomes is None
    if interrupted:
        outcomes = [finished.get(i, JobOutcome(i, False, None, "interrupted", 0.0)) for i in range(len(items))]
    rows = index_rows(items, outcomes, root)
    paths = write_index(rows, root, where)
    if interrupted:
        done = sum(o.ok for o in finished.values())
        fail(f"interrupted: {done} of {len(items)} jobs done; index -> {paths['csv']} ({guard.name})", EXIT_INTERRUPTED)
    bad = [r for r in rows if r["status"] != "ok"]
    for r in bad:
        error_line(f"{r['job']}: {r['error']}")
    stdout().print(f"{len(rows) - len(bad)} of {len(rows)} jobs done on {where}"
                   f"{f', {len(bad)} failed' if bad else ''} -> {paths['csv']}")
    if bad:
        raise typer.Exit(1)


def render_batch(materials: list[str], scan: str | None, trajectory: Path | None, grid: list[str], config, out: Path,
                 amp_gain: float | None, figure: bool, jobs: int, scheduler: str | None, *, fmt: str = "auto") -> None:
    """Render every material x grid point, one folder each under ``out`` (render file format ``fmt``);
    exits 1 when a job failed."""
    from surfhap.batch.jobs import RENDER_JOB_MODULES, RenderJob, run_render_job
    from surfhap.batch.schedulers import parse_scheduler
    from surfhap.cli._scan import SCAN_KEYS, scan_trajectory, trajectory_from_options
    from surfhap.exchange.files import parse_pairs
    from surfhap.exchange.materials import load_material

    spec = parse_scheduler(scheduler, jobs)
    axes = parse_grid(grid)
    if axes and trajectory is not None:
        raise ConfigError("a recorded trajectory cannot be varied; use --scan with --grid", source="--grid")
    if (trajectory is None and scan is None and not axes) or (trajectory is not None and scan is not None):
        raise ConfigError("give exactly one of --scan or --trajectory", source="--scan/--trajectory")
    mats = {m: load_material(m) for m in dict.fromkeys(materials)}
    base = {} if scan is None else parse_pairs(scan, "--scan", SCAN_KEYS, ConfigError, numbers=True)  # grid fills in
    recorded = trajectory_from_options(None, trajectory) if trajectory is not None else None
    items = []
    for m, point in itertools.product(mats, itertools.product(*axes.values())):
        p = dict(zip(axes, point))
        traj = recorded if recorded is not None else scan_trajectory({**base, **p})
        name = _slug(mats[m].name) + "".join(f"_{k}{v:g}" for k, v in p.items())
        if any(job.name == name for job in items):
            raise ConfigError(f"two jobs would write the folder {name!r}", source="MATERIAL")
        items.append(RenderJob(name, mats[m], traj, config, Path(out) / name, amp_gain=amp_gain, figure=figure,
                               params={"material": mats[m].name, **p}, fmt=fmt))
    _run(run_render_job, items, Path(out), spec, f"rendering {len(items)} jobs", RENDER_JOB_MODULES)


def fit_imu_command(recording: Path, into: Path, out: Path | None, order: int | None, max_order: int, cutoff: float,
                    unit_scale: float, note: str | None) -> str:
    """The ``surfhap fit imu`` command of one recording (the texture provenance; a batch job's too)."""
    return command_line("fit", "imu", recording, into=into, out=out, order=order, max_order=max_order, cutoff=cutoff,
                        unit_scale=unit_scale, note=note or None)


def recordings_in(paths: list[Path]) -> list[Path]:
    """Recording files: each path itself, or every *.csv in it when it is a folder (sorted)."""
    files: list[Path] = []
    for p in paths:
        if p.is_dir():
            found = sorted(f for f in p.iterdir() if f.suffix.lower() == ".csv" and f.is_file())
            if not found:
                raise ConfigError("no .csv recordings in this folder", source=str(p))
            files += found
        elif not p.exists():
            raise ConfigError("no such file or folder", source=str(p))
        else:
            files.append(p)
    return files


def fit_imu_batch(recordings: list[Path], into: Path, out: Path, jobs: int, scheduler: str | None, **fit) -> None:
    """Fit every recording into ``out/<recording stem>/material.json``; exits 1 when a job failed."""
    from surfhap.batch.jobs import FIT_IMU_JOB_MODULES, FitImuJob, run_fit_imu_job
    from surfhap.batch.schedulers import parse_scheduler

    spec = parse_scheduler(scheduler, jobs)
    if not Path(into).is_file():
        raise ConfigError("no such material file", source=str(into))
    files = recordings_in(recordings)
    names = [_slug(f.stem) for f in files]
    dupes = sorted({n for n in names if names.count(n) > 1})
    if dupes:
        raise ConfigError(f"two recordings would write the folder {dupes[0]!r}", source="RECORDING")
    targets = [Path(out) / n / "material.json" for n in names]
    items = [FitImuJob(n, f, into, t, command=fit_imu_command(f, into, t, **fit), **fit)
             for n, f, t in zip(names, files, targets)]
    _run(run_fit_imu_job, items, Path(out), spec, f"fitting {len(items)} recordings", FIT_IMU_JOB_MODULES)
