"""``surfhap fit``: build material models from real recordings.

This module defines the ``fit`` group (``fit_app``) and its ``imu`` command; ``friction`` and
``accel`` come from :mod:`surfhap.cli.fit_recordings`.
"""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from surfhap.cli._batch import fit_imu_batch, fit_imu_command
from surfhap.cli._common import check_out, report, status_line
from surfhap.cli._options import JobsOption, JsonOption, OverwriteOption, SchedulerOption
from surfhap.cli.fit_recordings import fit_accel_cmd, fit_friction_cmd
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
    report({**row, "out": str(target)},
           f"{target}: texture AR({row['order']}) at {row['sample_rate']:g} Hz from {row['name']} ({row['aic_note']})", as_json)


fit_app.command("friction")(fit_friction_cmd)
fit_app.command("accel")(fit_accel_cmd)


def register(app: typer.Typer) -> None:
    app.add_typer(fit_app, name="fit")
