"""``surfhap fit friction`` and ``surfhap fit accel``: material models from recordings.

Both commands are added to the ``fit`` group by :mod:`surfhap.cli.fit`.
"""

from __future__ import annotations

import shlex
import sys
from pathlib import Path
from typing import List, Optional

import typer

from surfhap.cli._common import check_out, status_line
from surfhap.cli._common import report as _report  # 'report' is the --report option
from surfhap.cli._signals import StopSignals
from surfhap.cli._options import JobsOption, JsonOption, OverwriteOption, SchedulerOption
from surfhap.errors import ConfigError

__all__ = ["fit_friction_cmd", "fit_accel_cmd"]


def _speeds_mm(text: str) -> tuple[float, ...]:
    try:
        vals = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise ConfigError(f"expected comma-separated numbers, got {text!r}", source="--reference-velocities") from None
    if not vals:
        raise ConfigError("give at least one velocity", source="--reference-velocities")
    return vals


def _command() -> str:
    return shlex.join(["surfhap", *sys.argv[1:]]) if sys.argv and Path(sys.argv[0]).name.startswith("surfhap") else "surfhap fit"


def _check_jobs(jobs: int, scheduler: str | None) -> int:
    from surfhap.batch.schedulers import parse_scheduler

    parse_scheduler(scheduler, jobs)  # one line for a bad --jobs or --scheduler, before any file is read
    return -1 if scheduler and jobs == 1 else jobs  # on a cluster, let the scheduler spread the work


def _fit_and_write(fit_fn, recordings: list[Path], columns: str | None, material: str, out: Path, jobs: int,
                   scheduler: str | None, **params):
    """Read the recordings, run ``fit_fn`` (stoppable by Ctrl-C/SIGTERM, on the Dask cluster when
    given), write the material to ``out``; returns the fit and the provenance command."""
    from surfhap.batch.schedulers import joblib_backend
    from surfhap.exchange.material_json import write_material_json
    from surfhap.exchange.recordings import parse_column_map, read_recordings

    n_jobs = _check_jobs(jobs, scheduler)
    recs = read_recordings(recordings, parse_column_map(columns))
    command = _command()
    with StopSignals() as guard, joblib_backend(scheduler), status_line(f"fitting {material} from {len(recs)} recordings"):
        fit = guard.call(fit_fn, recs, material, jobs=n_jobs, **params)
    guard.finish(f"the fit did not finish; {out} not written")
    write_material_json(fit.to_material(command=command), out)
    return fit, command


def fit_friction_cmd(
    recordings: List[Path] = typer.Argument(..., help="Friction recordings (CSV or NPZ): time, normal_force, shear_force or cof, speed or position."),
    material: str = typer.Option(..., "--material", help="Name of the material to write."),
    out: Path = typer.Option(..., "--out", help="Material JSON to write."),
    cutoff: float = typer.Option(3.5, "--cutoff", help="Band split, Hz (Otake et al. 2021: 2.5, 2022: 3.5)."),
    reference_velocities: str = typer.Option("0.05,0.075,0.1,0.125,0.15", "--reference-velocities",
                                             help="Reference velocities, m/s (values > 5 are read as mm/s)."),
    tolerance: float = typer.Option(20.0, "--tolerance", help="Speed window around each reference velocity, mm/s."),
    min_span: float = typer.Option(100.0, "--min-span", help="Shortest spliced span, ms."),
    max_order: int = typer.Option(60, "--max-order", min=1, max=400, help="Largest AR order considered."),
    criterion: str = typer.Option("aic", "--criterion", help="aic | bic."),
    estimator: str = typer.Option("yule-walker", "--estimator", help="yule-walker (averaged spectra, the paper's) | burg."),
    edge_trim: Optional[float] = typer.Option(None, "--edge-trim", min=0.0,
                                              help="Cut from both ends of every contact run before splicing, ms "
                                                   "(default: one cut-off period, where the band split is an extrapolation)."),
    columns: Optional[str] = typer.Option(None, "--columns", help="Map channels to columns: 'speed=v_x\\[mm/s],normal_force=Fz'."),
    report: Optional[Path] = typer.Option(None, "--report", help="Folder for an HTML report with figures."),
    jobs: JobsOption = 1,
    scheduler: SchedulerOption = None,
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
) -> None:
    """Fit Coulomb mu0, the quasi-static law and AR textures per reference velocity (Otake et al.)."""
    from surfhap.fit.material_fit import fit_friction
    from surfhap.fit.texture import ESTIMATORS

    if estimator not in ESTIMATORS:
        raise ConfigError(f"must be one of {', '.join(ESTIMATORS)}", source="--estimator")
    if criterion.lower() not in ("aic", "bic"):
        raise ConfigError("must be aic or bic", source="--criterion")
    speeds = tuple(v / 1000.0 if v > 5 else v for v in _speeds_mm(reference_velocities))
    check_out(out, "--out", overwrite)
    fit, command = _fit_and_write(fit_friction, recordings, columns, material, out, jobs, scheduler, cutoff=cutoff,
                                  reference_speeds=speeds, tolerance=tolerance / 1000.0, min_span=min_span / 1000.0,
                                  max_order=max_order, criterion=criterion.lower(), estimator=estimator,
                                  edge_trim=None if edge_trim is None else edge_trim / 1000.0)
    qs = fit.quasi_static
    lines = [f"{out}: mu0 {fit.coulomb.mu0:.3f}; quasi-static a={qs.params['a']:.3f} b={qs.params['b']:.3f} "
                 f"c={qs.params['c']:.3f} d={qs.params['d']:.3f} q={qs.params['q']:.3f} (R² {qs.r2:.2f}); "
                 f"AR orders {', '.join(f'{t.reference_speed * 1e3:g} mm/s: {t.model.order} (AIC {t.selection.aic_order}, BIC {t.selection.bic_order})' for t in fit.textures) or 'none'}"]
    lines += [f"note: {note}" for note in fit.notes]
    data = {**fit.summary(), "out": str(out)}
    if report is not None:
        from surfhap.report.fit_report import write_friction_report

        with status_line("writing the report"):
            data["report"] = str(write_friction_report(fit, report, command))
        lines.append(f"report: {data['report']}")
    _report(data, lines, as_json)


def fit_accel_cmd(
    recordings: List[Path] = typer.Argument(..., help="Tool-scan recordings (CSV or NPZ): time, acceleration, speed, normal_force[, shear_force]."),
    material: str = typer.Option(..., "--material", help="Name of the material to write."),
    out: Path = typer.Option(..., "--out", help="Material JSON to write."),
    texture_rate: float = typer.Option(1000.0, "--texture-rate", help="Rate of the models, Hz (HaTT: 1000)."),
    highpass: float = typer.Option(20.0, "--highpass", help="High-pass of the acceleration before fitting, Hz (0 = off)."),
    max_order: int = typer.Option(20, "--max-order", min=1, max=100, help="Largest AR order considered."),
    criterion: str = typer.Option("aic", "--criterion", help="aic | bic (the common order)."),
    min_segment: float = typer.Option(250.0, "--min-segment", help="Shortest stationary segment, ms."),
    max_segment: float = typer.Option(10.0, "--max-segment", help="Longest segment, s (0 = unlimited; the search grows quadratically)."),
    mu0: Optional[float] = typer.Option(None, "--mu0", help="Coulomb coefficient when the recordings have no shear force."),
    columns: Optional[str] = typer.Option(None, "--columns", help="Map channels to columns: 'acceleration=az\\[g],speed=v\\[mm/s]'."),
    report: Optional[Path] = typer.Option(None, "--report", help="Folder for an HTML report with figures."),
    jobs: JobsOption = 1,
    scheduler: SchedulerOption = None,
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
) -> None:
    """Segment, fit AR per segment and interpolate over (speed, force) (HaTT / Zhao et al.)."""
    from surfhap.fit.accel import fit_accel

    check_out(out, "--out", overwrite)
    fit, command = _fit_and_write(fit_accel, recordings, columns, material, out, jobs, scheduler,
                                  texture_rate=texture_rate, highpass=highpass, max_order=max_order, criterion=criterion,
                                  min_segment=min_segment / 1000.0, mu0=mu0, max_segment=max_segment or None)
    lines = [f"{out}: {len(fit.segments)} segments, AR({fit.order}) models (AIC {fit.aic_order}, BIC {fit.bic_order}) "
             f"over (speed, force), {fit.bank.triangles.shape[0]} triangles; mu0 {fit.mu0:.3f}"]
    data = {**fit.summary(), "out": str(out)}
    if report is not None:
        from surfhap.report.fit_report import write_accel_report

        with status_line("writing the report"):
            data["report"] = str(write_accel_report(fit, report, command))
        lines.append(f"report: {data['report']}")
    _report(data, lines, as_json)

