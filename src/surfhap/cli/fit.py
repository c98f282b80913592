"""``surfhap fit``: build material models from real recordings (``imu``, ``friction``, ``accel``)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import List, Optional

import typer

from surfhap.cli._batch import fit_imu_batch, fit_imu_command
from surfhap.cli._common import check_out, command_line, parse_numbers, status_line
from surfhap.cli._common import report as print_result  # 'report' is the --report option
from surfhap.cli._options import JobsOption, JsonOption, OverwriteOption, SchedulerOption
from surfhap.cli._signals import StopSignals
from surfhap.errors import ConfigError

__all__ = ["fit_app", "register"]

fit_app = typer.Typer(help="Fit material models from real recordings.", no_args_is_help=True)


@fit_app.command("imu")
def fit_imu(
    recording: List[Path] = typer.Argument(..., help="IMU CSV (time, accel_x, accel_y, accel_z), e.g. HapMat's leather_1.csv; several, or a folder of them, make a batch."),
    into: Optional[Path] = typer.Option(None, "--into", help="Material JSON (or built-in material name) whose 'texture' section is replaced (a file is written back unless --out is given)."),
    out: Optional[Path] = typer.Option(None, "--out", help="Where to write the material (default: the --into file); a batch: a folder, with OUT/<recording>/material.json per recording and index.csv/index.json."),
    order: Optional[int] = typer.Option(None, "--order", min=1, max=400, help="Fixed AR order (e.g. from a paper's table); default: chosen by AIC."),
    max_order: int = typer.Option(60, "--max-order", min=1, max=400, help="Largest order AIC considers."),
    cutoff: float = typer.Option(3.5, "--cutoff", help="Band-split cut-off, Hz (Otake et al. 2022: 3.5)."),
    unit_scale: float = typer.Option(1.0, "--unit-scale", help="m/s^2 per file unit (HapMat does not state its unit; 1 takes m/s^2)."),
    note: Optional[str] = typer.Option(None, "--note", help="Text stored in the texture provenance (e.g. how the recording matches the material)."),
    jobs: JobsOption = 1,
    scheduler: SchedulerOption = None,
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
) -> None:
    """Fit an acceleration texture (DFT321, high band, AR by AIC) from an IMU recording (or many)."""
    from surfhap.batch.jobs import FitImuJob, fit_imu_to_file
    from surfhap.exchange.materials import material_path

    if into is None:
        raise ConfigError("give the material file to update", source="--into")
    if material_path(into) != into:  # a built-in name: its file is read, never written back
        if out is None:
            raise ConfigError(f"{into} is a built-in material: give --out FILE for the fitted one", source="--into")
        into = material_path(into)
    if out is not None:
        check_out(out, "--out", overwrite)
    fit = dict(order=order, max_order=max_order, cutoff=cutoff, unit_scale=unit_scale, note=note)
    if len(recording) > 1 or recording[0].is_dir() or jobs != 1 or scheduler is not None:
        if out is None:
            raise ConfigError("give the folder to write the fitted materials into", source="--out")
        return fit_imu_batch(recording, into, out, jobs, scheduler, **fit)
    target = out or into
    with status_line(f"fitting {recording[0].name}"):
        row = fit_imu_to_file(FitImuJob(recording[0].stem, recording[0], into, target,
                                        command=fit_imu_command(recording[0], into, out, **fit), **fit))
    print_result({**row, "out": str(target)},
                 f"{target}: texture AR({row['order']}) at {row['sample_rate']:g} Hz from {row['name']} ({row['aic_note']})", as_json)


def _fit_and_write(fit_fn, write_report, lines_of, recordings: list[Path], columns: str | None, material: str,
                   out: Path, report: Path | None, jobs: int, scheduler: str | None, overwrite: bool, as_json: bool,
                   **params) -> None:
    """Read the recordings, run ``fit_fn`` (stoppable by Ctrl-C/SIGTERM, on the Dask cluster when
    given), write the material to ``out`` and, with ``--report``, ``write_report``'s HTML report;
    print ``lines_of(fit)`` (or the JSON summary)."""
    from surfhap.batch.schedulers import joblib_backend, parse_scheduler
    from surfhap.exchange.material_json import write_material_json
    from surfhap.exchange.recordings import parse_column_map, read_recordings

    check_out(out, "--out", overwrite)
    parse_scheduler(scheduler, jobs)  # one line for a bad --jobs or --scheduler, before any file is read
    n_jobs = -1 if scheduler and jobs == 1 else jobs  # on a cluster, let the scheduler spread the work
    recs = read_recordings(recordings, parse_column_map(columns))
    # the provenance: the command as typed (run as the surfhap script), else just its name
    command = command_line(*sys.argv[1:]) if sys.argv and Path(sys.argv[0]).name.startswith("surfhap") else "surfhap fit"
    with StopSignals() as guard, joblib_backend(scheduler), status_line(f"fitting {material} from {len(recs)} recordings"):
        fit = guard.call(fit_fn, recs, material, jobs=n_jobs, **params)
    guard.finish(f"the fit did not finish; {out} not written")
    write_material_json(fit.to_material(command=command), out)
    lines, data = lines_of(fit), {**fit.summary(), "out": str(out)}
    if report is not None:
        with status_line("writing the report"):
            data["report"] = str(write_report(fit, report, command))
        lines.append(f"report: {data['report']}")
    print_result(data, lines, as_json)


@fit_app.command("friction")
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
    from surfhap.report.fit_report import write_friction_report

    if estimator not in ESTIMATORS:
        raise ConfigError(f"must be one of {', '.join(ESTIMATORS)}", source="--estimator")
    if criterion.lower() not in ("aic", "bic"):
        raise ConfigError("must be aic or bic", source="--criterion")
    speeds = tuple(v / 1000.0 if v > 5 else v for v in parse_numbers(reference_velocities, "--reference-velocities"))

    def lines_of(fit) -> list[str]:
        qs = fit.quasi_static
        return [f"{out}: mu0 {fit.coulomb.mu0:.3f}; quasi-static a={qs.params['a']:.3f} b={qs.params['b']:.3f} "
                f"c={qs.params['c']:.3f} d={qs.params['d']:.3f} q={qs.params['q']:.3f} (R² {qs.r2:.2f}); "
                f"AR orders {', '.join(f'{t.reference_speed * 1e3:g} mm/s: {t.model.order} (AIC {t.selection.aic_order}, BIC {t.selection.bic_order})' for t in fit.textures) or 'none'}",
                *(f"note: {note}" for note in fit.notes)]

    _fit_and_write(fit_friction, write_friction_report, lines_of, recordings, columns, material, out, report, jobs,
                   scheduler, overwrite, as_json, cutoff=cutoff, reference_speeds=speeds, tolerance=tolerance / 1000.0,
                   min_span=min_span / 1000.0, max_order=max_order, criterion=criterion.lower(), estimator=estimator,
                   edge_trim=None if edge_trim is None else edge_trim / 1000.0)


@fit_app.command("accel")
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
    from surfhap.report.fit_report import write_accel_report

    _fit_and_write(fit_accel, write_accel_report,
                   lambda fit: [f"{out}: {len(fit.segments)} segments, AR({fit.order}) models (AIC {fit.aic_order}, "
                                f"BIC {fit.bic_order}) over (speed, force), {fit.bank.triangles.shape[0]} triangles; "
                                f"mu0 {fit.mu0:.3f}"],
                   recordings, columns, material, out, report, jobs, scheduler, overwrite, as_json,
                   texture_rate=texture_rate, highpass=highpass, max_order=max_order, criterion=criterion,
                   min_segment=min_segment / 1000.0, mu0=mu0, max_segment=max_segment or None)


def register(app: typer.Typer) -> None:
    app.add_typer(fit_app, name="fit")
