"""Schedulers: run one picklable function over many job specs, serially, in local processes
or on a Dask distributed cluster, and yield every job's outcome as it completes.

A job that raises is reported as a failed :class:`JobOutcome` (type and message of the
exception); the other jobs run on. The functions are pure with respect to the scheduler:
the same job gives the same numbers whichever scheduler runs it.

Scheduler specs (``--scheduler``): None (local processes, ``jobs`` of them; one job = serial),
``tcp://HOST:PORT`` (a running Dask scheduler) or ``local:N`` (a Dask ``LocalCluster`` of N
single-threaded worker processes started for the run). Dask is imported only when a Dask
spec is opened (the optional ``dask`` extra).
"""

from __future__ import annotations

import contextlib
import re
import time
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from surfhap.errors import ConfigError

__all__ = ["JobOutcome", "SchedulerSpec", "parse_scheduler", "prestart", "open_scheduler", "run_jobs", "joblib_backend"]

_TCP = re.compile(r"^tcp://[^\s:/]+:\d{1,5}$")
_LOCAL = re.compile(r"^local:(\d+)$")


@dataclass(frozen=True)
class JobOutcome:
    """What one job gave: ``index`` in the job list, ``ok``, the function's ``value`` (None on
    failure), ``error`` ("Type: message", None on success) and ``seconds`` of wall time in
    the worker."""

    index: int
    ok: bool
    value: Any
    error: str | None
    seconds: float


@dataclass(frozen=True)
class SchedulerSpec:
    """kind: "serial", "processes" or "dask"; workers: processes (or Dask local workers);
    address: the Dask scheduler address for a remote cluster, None for ``local:N``."""

    kind: str
    workers: int = 1
    address: str | None = None

    def describe(self) -> str:
        if self.kind == "dask":
            return f"dask {self.address}" if self.address else f"dask LocalCluster of {self.workers}"
        return "serial" if self.kind == "serial" else f"{self.workers} processes"


def parse_scheduler(spec: str | None, jobs: int = 1) -> SchedulerSpec:
    """Check ``--scheduler`` and ``--jobs`` (no import of dask). ``jobs`` -1 = all cores."""
    import os

    if jobs == 0 or jobs < -1:
        raise ConfigError("must be >= 1 (or -1 for all cores)", source="--jobs")
    if spec is None or spec == "":
        n = (os.cpu_count() or 1) if jobs == -1 else jobs
        return SchedulerSpec("serial") if n == 1 else SchedulerSpec("processes", workers=n)
    spec = spec.strip()
    m = _LOCAL.match(spec)
    if m:
        n = int(m.group(1))
        if not 1 <= n <= 256:
            raise ConfigError(f"local:N needs 1 <= N <= 256, got {n}", source="--scheduler")
        return SchedulerSpec("dask", workers=n)
    if _TCP.match(spec) and 0 < int(spec.rsplit(":", 1)[1]) < 65536:
        return SchedulerSpec("dask", address=spec)
    raise ConfigError(f"expected tcp://HOST:PORT or local:N, got {spec!r}", source="--scheduler")


def _call(fn: Callable, index: int, item: Any) -> JobOutcome:
    """Run one job where the scheduler put it, turning an exception into a failed outcome."""
    t0 = time.perf_counter()
    try:
        value = fn(item)
    except Exception as exc:  # noqa: BLE001 - a job's failure is data for the index
        last = traceback.extract_tb(exc.__traceback__)[-1:] if exc.__traceback__ else []
        where = f" ({last[0].filename.rsplit('/', 1)[-1]}:{last[0].lineno})" if last else ""
        return JobOutcome(index, False, None, f"{type(exc).__name__}: {exc}{where}", time.perf_counter() - t0)
    return JobOutcome(index, True, value, None, time.perf_counter() - t0)


class _Serial:
    def map(self, fn, items):
        for i, item in enumerate(items):
            yield _call(fn, i, item)


def _pool_context(preload: Sequence[str] = ()):
    """The start method of local worker processes. Never a fork of the caller, which runs
    threads (the progress bar): where the platform has it, a fork server, a single-threaded
    process that imports ``preload`` (module names) once and forks each worker from itself,
    so workers start with the job's modules loaded; elsewhere fresh (spawned) interpreters."""
    import multiprocessing

    if "forkserver" not in multiprocessing.get_all_start_methods():
        return multiprocessing.get_context("spawn")
    ctx = multiprocessing.get_context("forkserver")
    if preload:
        ctx.set_forkserver_preload(list(preload))  # takes effect when the server starts (once per process)
    return ctx


def prestart(spec: SchedulerSpec, preload: Sequence[str] = ()) -> bool:
    """Start the local workers' fork server now, importing ``preload`` (and ``distributed`` for a
    Dask ``local:N`` cluster) in the background, so that it overlaps the caller's own set-up
    (loading materials, building the jobs). True when a fork server runs; False, doing nothing,
    for the serial scheduler, a remote cluster, or where the platform has no fork server. The
    server lives until this process ends; a second call reuses it."""
    if spec.kind == "serial" or spec.address is not None:
        return False
    if _pool_context(("distributed", *preload) if spec.kind == "dask" else preload).get_start_method() != "forkserver":
        return False
    from multiprocessing import forkserver

    forkserver.ensure_running()
    return True


class _Pool:
    """Jobs on a :class:`concurrent.futures.Executor`: a pool of local worker processes or a
    Dask client's executor (see :func:`open_scheduler`)."""

    def __init__(self, executor):
        self._executor = executor

    def map(self, fn, items):
        from concurrent.futures import as_completed

        futures = {self._executor.submit(_call, fn, i, item): i for i, item in enumerate(items)}
        for fut in as_completed(futures):
            index, exc = futures.pop(fut), fut.exception()  # popped: a finished job's value is not kept
            if exc is not None:  # a worker died or was lost, or the result did not pickle (_call catches a job's own)
                yield JobOutcome(index, False, None, f"{type(exc).__name__}: {exc}", 0.0)
            else:
                yield fut.result()


def _ignore_sigint() -> None:
    """Worker start-up: Ctrl-C in the terminal reaches the whole process group; only the parent
    handles it (it ends the workers), so a worker never prints a KeyboardInterrupt traceback."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


# A LocalCluster started for one batch runs a few long, CPU-bound (and GIL-holding) jobs per
# worker. Its servers' housekeeping wakes their event loops often: the event-loop tick every
# 20 ms, the statistical profiler (a stack sample of the job every 10 ms), the memory monitor
# every 0.1 s, work stealing every 0.1 s, the system and GIL monitors. In a worker each wake-up
# takes the GIL from the running job; the scheduler and the nannies run in this process and
# take CPU from the workers. Measured on one worker, a render job ran 15-25 % slower than in
# a plain process with the defaults and as fast with these; the 60-render grid on 2 workers
# gained 1-2 s more from the memory monitor and stealing settings. Nobody watches this
# cluster's dashboard; the jobs are independent and queued on the scheduler until a worker
# is free, so stealing has nothing to balance. A cluster at tcp:// keeps its owner's settings.
_LOCAL_CLUSTER_CONFIG = {
    "distributed.admin.tick.interval": "1s",
    "distributed.admin.system-monitor.interval": "2s",
    "distributed.admin.system-monitor.gil.enabled": False,
    "distributed.worker.profile.enabled": False,
    "distributed.worker.memory.monitor-interval": "1s",
    "distributed.scheduler.work-stealing": False,
}


@contextlib.contextmanager
def _dask(spec: SchedulerSpec, preload: Sequence[str] = ()):
    """A Dask client, closed on exit: of a LocalCluster of ``spec.workers`` single-threaded worker
    processes (forked from the fork server with ``preload`` imported, where the platform has one;
    closed with the client), or of the scheduler at ``spec.address``."""
    import dask.config
    from dask.distributed import Client, LocalCluster  # the optional 'dask' extra

    if spec.address is not None:
        try:
            client = Client(spec.address, timeout="10s")
        except OSError as exc:
            raise ConfigError(f"cannot reach the Dask scheduler at {spec.address}: {exc}", source="--scheduler") from None
        with client:
            yield client
        return
    config = dict(_LOCAL_CLUSTER_CONFIG)
    if prestart(spec, preload):  # before the nannies: they would set their own preload
        config["distributed.worker.multiprocessing-method"] = "forkserver"
    with dask.config.set(config):  # the nannies pass it on to their workers
        cluster = LocalCluster(n_workers=spec.workers, threads_per_worker=1, processes=True, dashboard_address=":0")
    with cluster, Client(cluster) as client:
        yield client


@contextlib.contextmanager
def open_scheduler(spec: SchedulerSpec, preload: Sequence[str] = ()):
    """Start the scheduler's workers (a pool, a LocalCluster or a client of a running
    cluster) and shut them down on exit. Yields an object with ``map(fn, items)``.
    ``preload``: modules the jobs need, imported once by the local processes' fork server."""
    if spec.kind == "serial":
        yield _Serial()
        return
    if spec.kind == "dask":
        with _dask(spec, preload) as client:  # closing the client (and a local cluster) drops its jobs
            yield _Pool(client.get_executor(pure=False))
        return
    from concurrent.futures import ProcessPoolExecutor

    # local worker processes started by _pool_context (a fork server that preloaded the job's
    # modules, or spawned interpreters); workers ignore SIGINT
    pool = ProcessPoolExecutor(max_workers=spec.workers, mp_context=_pool_context(preload), initializer=_ignore_sigint)
    try:
        yield _Pool(pool)
    except BaseException:  # Ctrl-C or an error in the caller: drop the queued jobs and end the running ones
        procs = list((getattr(pool, "_processes", None) or {}).values())  # CPython's executor keeps its workers here
        pool.shutdown(wait=False, cancel_futures=True)
        for proc in procs:
            proc.terminate()
        raise
    pool.shutdown(wait=True, cancel_futures=True)


@contextlib.contextmanager
def joblib_backend(scheduler: str | None):
    """Context in which joblib's ``Parallel`` runs on the Dask cluster named by ``scheduler``
    (``tcp://HOST:PORT`` or ``local:N``), or joblib's default backend when None."""
    if not scheduler:
        yield None
        return
    spec = parse_scheduler(scheduler)
    import joblib

    with _dask(spec) as client, joblib.parallel_backend("dask"):
        yield client


def run_jobs(fn: Callable[[Any], Any], items: Sequence[Any], spec: SchedulerSpec,
             progress: Callable[[JobOutcome, int, int], None] | None = None, preload: Sequence[str] = ()) -> list[JobOutcome]:
    """Run ``fn(item)`` for every item on the scheduler ``spec``; ``fn`` must be a module-level
    (picklable) function. ``progress(outcome, done, total)`` is called as each job ends;
    ``preload`` names the modules ``fn`` needs (see :func:`open_scheduler`).
    Returns the outcomes in the order of ``items``."""
    outcomes: list[JobOutcome | None] = [None] * len(items)
    if not items:
        return []
    with open_scheduler(spec, preload) as sched:
        for done, outcome in enumerate(sched.map(fn, list(items)), 1):
            outcomes[outcome.index] = outcome
            if progress is not None:
                progress(outcome, done, len(items))
    return [o for o in outcomes if o is not None]
