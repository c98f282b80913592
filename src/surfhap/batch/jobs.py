"""One-job functions: one render into one folder, one IMU texture fit into one material file.

``surfhap render`` and ``surfhap fit imu`` call these for a single input and, through
:func:`surfhap.batch.schedulers.run_jobs`, for many. Each ``run_*_job`` takes one picklable
job spec and returns a small dict of summary figures (the big arrays stay on disk).
"""

from __future__ import annotations

import shlex
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

__all__ = ["RenderJob", "render_to_folder", "run_render_job", "FitImuJob", "fit_imu_to_file", "run_fit_imu_job"]


def render_to_folder(material, trajectory, config, out: str | Path, amp_gain: float | None = None, figure: bool = True,
                     progress: Callable[[float], None] | None = None):
    """Render ``material`` (Material) along ``trajectory`` (Trajectory) with ``config``
    (ChainConfig) and write drive.wav, render.npz, summary.json (and figure.png) into ``out``.
    Returns (RenderResult, dict of written paths)."""
    from surfhap.exchange.render_files import write_render
    from surfhap.render.offline import render

    result = render(material, trajectory, config, progress=progress)
    paths = write_render(result, out, amp_gain=amp_gain)
    if figure:
        fig = result.plot()
        paths["figure"] = Path(out) / "figure.png"
        fig.savefig(paths["figure"], dpi=110)
    return result, paths


@dataclass(frozen=True)
class RenderJob:
    """One point of a render grid: material (Material), trajectory (Trajectory), config
    (ChainConfig), out (folder), amp_gain (V per DAC full scale or None), figure, and
    ``params`` (the grid values of this point, for the index)."""

    material: Any
    trajectory: Any
    config: Any
    out: Path
    amp_gain: float | None = None
    figure: bool = True
    params: dict = field(default_factory=dict)


RENDER_FIGURES = ("max_abs_voltage", "clipped_fraction", "saturated_fraction", "alpha_v_per_sqrt_n", "rendering_gain", "method")


def run_render_job(job: RenderJob) -> dict:
    """Render one grid point into ``job.out``; returns the summary figures for the index
    (plus ``warning``: the saturation warning or "")."""
    result, _ = render_to_folder(job.material, job.trajectory, job.config, job.out, amp_gain=job.amp_gain, figure=job.figure)
    s = result.summary()
    row = {k: s[k] for k in RENDER_FIGURES if k in s}
    row["warning"] = result.saturation_warning() or ""
    return row


@dataclass(frozen=True)
class FitImuJob:
    """One IMU recording to fit: recording (CSV), into (base material JSON), target (material
    JSON written), order (fixed AR order or None), max_order, cutoff (Hz), unit_scale
    (m/s^2 per file unit), note, and ``out_given`` (whether --out was given, for the
    provenance command)."""

    recording: Path
    into: Path
    target: Path
    order: int | None = None
    max_order: int = 60
    cutoff: float = 3.5
    unit_scale: float = 1.0
    note: str | None = None
    out_given: bool = True


def fit_imu_to_file(job: FitImuJob) -> dict:
    """Fit the acceleration texture of ``job.recording`` (DFT321, high band, AR) and write the
    base material with that texture to ``job.target``. Returns order, aic_order, bic_order,
    variance, sample_rate (Hz), name and the AIC note."""
    from surfhap.exchange.imu_csv import read_imu_csv
    from surfhap.exchange.materials import read_material_json, write_material_json
    from surfhap.models.from_imu import fit_imu_texture
    from surfhap.models.material import ARModelSpec, MaterialFile, Provenance, TextureSpec

    order, max_order, cutoff, unit_scale, note = job.order, job.max_order, job.cutoff, job.unit_scale, job.note
    rec = read_imu_csv(job.recording, unit_scale=unit_scale)
    fit = fit_imu_texture(rec.accel, rec.sample_rate, cutoff=cutoff, order=order, max_order=max_order)
    base = read_material_json(job.into)
    how = f"fixed at {order}" if order is not None else f"aic over 1..{max_order}"
    aic_note = (f"AIC over 1..{max(max_order, order or 0)} chooses {fit.selection.aic_order} (BIC {fit.selection.bic_order}; "
                f"edge-trimmed, tapered, notch below {2 * cutoff:g} Hz continued flat)")
    command = ["surfhap", "fit", "imu", str(job.recording), "--into", str(job.into)]
    if job.out_given:
        command += ["--out", str(job.target)]
    if order is not None:
        command += ["--order", str(order)]
    command += ["--max-order", str(max_order), "--cutoff", f"{cutoff:g}", "--unit-scale", f"{unit_scale:g}"]
    if note:
        command += ["--note", note]
    recording = Path(job.recording)
    recording_label = f"{recording.parent.name}/{rec.name}" if recording.parent.name else rec.name
    texture = TextureSpec(
        quantity="acceleration",
        sample_rate=rec.sample_rate,
        models=[ARModelSpec(coefficients=[float(c) for c in fit.coefficients], variance=fit.variance,
                            reference_speed=None, order_selection=f"{how}; {aic_note}")],
        provenance=Provenance(source="recording", recording=recording_label, sha256=rec.sha256,
                              command=shlex.join(command), note=note),
    )
    spec = base.spec.model_copy(update={"texture": texture})
    write_material_json(MaterialFile.model_validate(spec.model_dump()), job.target)
    return {"name": rec.name, "order": int(fit.order), "aic_order": int(fit.selection.aic_order),
            "bic_order": int(fit.selection.bic_order), "variance": float(fit.variance),
            "sample_rate": float(rec.sample_rate), "aic_note": aic_note}


def run_fit_imu_job(job: FitImuJob) -> dict:
    """:func:`fit_imu_to_file`, creating the target's folder first (one folder per recording)."""
    Path(job.target).parent.mkdir(parents=True, exist_ok=True)
    return fit_imu_to_file(job)
