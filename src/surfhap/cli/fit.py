"""``surfhap fit``: build material models from real recordings.

This module defines the ``fit`` group (``fit_app``) and its ``imu`` command; other command
modules add their fitting commands to ``fit_app``.
"""

from __future__ import annotations

import shlex
from pathlib import Path
from typing import Optional

import typer

from surfhap.cli._common import stdout
from surfhap.errors import ConfigError

__all__ = ["fit_app", "register"]

fit_app = typer.Typer(help="Fit material models from real recordings.", no_args_is_help=True)


@fit_app.command("imu")
def fit_imu(
    recording: Path = typer.Argument(..., help="IMU CSV (time, accel_x, accel_y, accel_z), e.g. HapMat's leather_1.csv."),
    into: Optional[Path] = typer.Option(None, "--into", help="Material JSON whose 'texture' section is replaced (written back unless --out is given)."),
    out: Optional[Path] = typer.Option(None, "--out", help="Where to write the material (default: the --into file)."),
    order: Optional[int] = typer.Option(None, "--order", min=1, max=400, help="Fixed AR order (e.g. from a paper's table); default: chosen by AIC."),
    max_order: int = typer.Option(60, "--max-order", min=1, max=400, help="Largest order AIC considers."),
    cutoff: float = typer.Option(3.5, "--cutoff", help="Band-split cut-off, Hz (Otake et al. 2022: 3.5)."),
    unit_scale: float = typer.Option(1.0, "--unit-scale", help="m/s^2 per file unit (HapMat does not state its unit; 1 takes m/s^2)."),
    note: Optional[str] = typer.Option(None, "--note", help="Text stored in the texture provenance (e.g. how the recording matches the material)."),
) -> None:
    """Fit an acceleration texture (DFT321, high band, AR by AIC) from an IMU recording."""
    from surfhap.exchange.imu_csv import read_imu_csv
    from surfhap.exchange.material_json import read_material_json, write_material_json
    from surfhap.fit.imu import fit_imu_texture
    from surfhap.models.material import ARModelSpec, Provenance, TextureSpec

    if into is None:
        raise ConfigError("give the material file to update", source="--into")
    target = out or into
    rec = read_imu_csv(recording, unit_scale=unit_scale)
    fit = fit_imu_texture(rec.accel, rec.sample_rate, cutoff=cutoff, order=order, max_order=max_order)
    base = read_material_json(into)
    how = f"fixed at {order}" if order is not None else f"aic over 1..{max_order}"
    aic_note = (f"AIC over 1..{max(max_order, order or 0)} chooses {fit.selection.aic_order} (BIC {fit.selection.bic_order}; "
                f"edge-trimmed, tapered, notch below {2 * cutoff:g} Hz continued flat)")
    command = ["surfhap", "fit", "imu", str(recording), "--into", str(into)]
    if out is not None:
        command += ["--out", str(out)]
    if order is not None:
        command += ["--order", str(order)]
    command += ["--max-order", str(max_order), "--cutoff", f"{cutoff:g}", "--unit-scale", f"{unit_scale:g}"]
    if note:
        command += ["--note", note]
    recording_label = f"{Path(recording).parent.name}/{rec.name}" if Path(recording).parent.name else rec.name
    texture = TextureSpec(
        quantity="acceleration",
        sample_rate=rec.sample_rate,
        models=[ARModelSpec(coefficients=[float(c) for c in fit.coefficients], variance=fit.variance,
                            reference_speed=None, order_selection=f"{how}; {aic_note}")],
        provenance=Provenance(source="recording", recording=recording_label, sha256=rec.sha256,
                              command=shlex.join(command), note=note),
    )
    spec = base.spec.model_copy(update={"texture": texture})
    from surfhap.models.material import MaterialFile

    write_material_json(MaterialFile.model_validate(spec.model_dump()), target)
    stdout.print(f"{target}: texture AR({fit.order}) at {rec.sample_rate:g} Hz from {rec.name} ({aic_note})")


def register(app: typer.Typer) -> None:
    app.add_typer(fit_app, name="fit")
