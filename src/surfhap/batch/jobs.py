"""One-job functions: one render into one folder, one IMU texture fit into one material file.

``surfhap render`` and ``surfhap fit imu`` call these for a single input and, through
:func:`surfhap.batch.schedulers.run_jobs`, for many. Each ``run_*_job`` takes one picklable
job spec and returns a small dict of summary figures (the big arrays stay on disk).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from surfhap.errors import ConfigError

__all__ = ["RENDER_JOB_MODULES", "FIT_IMU_JOB_MODULES", "NPZ_MAX_SECONDS", "choose_format", "RenderJob", "render_to_folder", "run_render_job", "FitImuJob", "fit_imu_to_file", "run_fit_imu_job"]


# The modules each job function imports as it runs (lazily, so the CLI starts fast); local
# worker processes import them once, before the first job (schedulers.prestart / preload).
RENDER_JOB_MODULES = ("surfhap.runtime.offline", "surfhap.render.chain", "surfhap.exchange.render_store",
                      "surfhap.exchange.render_files", "surfhap.report.figures", "matplotlib.backends.backend_agg")
FIT_IMU_JOB_MODULES = ("surfhap.fit.imu", "surfhap.exchange.imu_csv", "surfhap.exchange.material_json", "surfhap.models.material")

NPZ_MAX_SECONDS = 60.0  # --format auto: render.npz up to this duration, render.h5 above


def choose_format(fmt: str, duration: float) -> str:
    """"npz" or "h5" for ``--format`` ``fmt`` ("auto", "npz" or "h5") and a duration in s."""
    if fmt not in ("auto", "npz", "h5"):
        raise ConfigError(f"must be auto, npz or h5, got {fmt!r}", source="--format")
    if fmt == "auto":
        return "npz" if duration <= NPZ_MAX_SECONDS else "h5"
    return fmt


def render_to_folder(material, trajectory, config, out: Path, *, fmt: str = "auto", amp_gain: float | None = None,
                  figure: bool = True, progress=None, stop=None, block_seconds: float = 1.0):
    """One render job into one folder, streamed: drive.wav, render.npz or render.h5, summary.json
    and figure.png, in memory independent of the duration (except render.npz, kept until the end).

    ``material`` a Material, ``trajectory`` a Trajectory, ``config`` a ChainConfig; ``stop()``
    polled between blocks ends the render early with valid files and ``"interrupted": true`` in
    the summary. Returns (RenderResult, paths dict with keys wav, render, summary[, figure]).
    """
    from surfhap.exchange.render_files import render_file_attrs, render_file_spec, write_summary
    from surfhap.exchange.render_store import open_render_writer
    from surfhap.exchange.wav import DriveWavWriter
    from surfhap.render.chain import TextureChain
    from surfhap.runtime.offline import stream_render

    fmt = choose_format(fmt, trajectory.duration)
    out = Path(out)
    probe = TextureChain(material, config)  # validates the settings before any file is created
    out.mkdir(parents=True, exist_ok=True)
    gain = float(amp_gain) if amp_gain is not None else float(probe.config.limits.v_max)
    wav = DriveWavWriter(out / "drive.wav", probe.drive_rate, gain)
    quantity = material.texture.quantity if probe.law.uses_texture else None
    writer = open_render_writer(out, fmt, render_file_spec(probe.control_rate, probe.drive_rate, quantity))

    def sink(channel, block):
        writer(channel, block)
        if channel == "drive":
            wav(block)

    try:
        result = stream_render(material, trajectory, config, sink, block_seconds=block_seconds, progress=progress, stop=stop)
    except BaseException:
        writer.abort()
        wav.abort()
        raise
    wav.close()
    writer.close(render_file_attrs(result))
    paths = {"wav": wav.path, "render": writer.path, "summary": write_summary(out / "summary.json", result.summary(), gain)}
    if figure and result.n_model:
        paths["figure"] = out / "figure.png"
        result.plot().savefig(paths["figure"], dpi=110)
    return result, paths


@dataclass(frozen=True)
class RenderJob:
    """One point of a render grid: name (its folder's name and index row), material (Material),
    trajectory (Trajectory), config (ChainConfig), out (folder), amp_gain (V per DAC full scale
    or None), figure, ``params`` (the material and grid values of this point, for the index)
    and fmt (render file format)."""

    name: str
    material: Any
    trajectory: Any
    config: Any
    out: Path
    amp_gain: float | None = None
    figure: bool = True
    params: dict = field(default_factory=dict)
    fmt: str = "auto"


RENDER_FIGURES = ("max_abs_voltage", "clipped_fraction", "saturated_fraction", "alpha_v_per_sqrt_n", "rendering_gain", "method")


def run_render_job(job: RenderJob) -> dict:
    """Render one grid point into ``job.out``; returns the summary figures for the index
    (plus ``warning``: the saturation and texture-share warnings, or "")."""
    result, _ = render_to_folder(job.material, job.trajectory, job.config, job.out, fmt=job.fmt, amp_gain=job.amp_gain,
                                 figure=job.figure)
    fault = result.fault_error()
    if fault is not None:  # the job failed: listed in the index, exit code 1 (files kept for diagnosis)
        from surfhap.render.offline import RenderFaultError

        raise RenderFaultError(fault)
    s = result.summary()
    row = {k: s[k] for k in RENDER_FIGURES if k in s}
    row["warning"] = "; ".join(w for w in (result.saturation_warning(), result.texture_warning()) if w)
    return row


@dataclass(frozen=True)
class FitImuJob:
    """One IMU recording to fit: name (index row), recording (CSV), into (base material JSON),
    target (material JSON written, in the job's folder ``out``), order (fixed AR order or None), max_order, cutoff (Hz), unit_scale
    (m/s^2 per file unit), note, and ``command``: the command that reproduces this one fit,
    stored in the texture's provenance (the CLI writes it; the library never builds CLI text)."""

    name: str
    recording: Path
    into: Path
    target: Path
    order: int | None = None
    max_order: int = 60
    cutoff: float = 3.5
    unit_scale: float = 1.0
    note: str | None = None
    command: str = ""

    @property
    def out(self) -> Path:
        return Path(self.target).parent

    @property
    def params(self) -> dict:
        return {"recording": str(self.recording)}


def fit_imu_to_file(job: FitImuJob) -> dict:
    """Fit the acceleration texture of ``job.recording`` (DFT321, high band, AR) and write the
    base material with that texture to ``job.target``. Returns order, aic_order, bic_order,
    variance, sample_rate (Hz), name and the AIC note."""
    from surfhap.exchange.imu_csv import read_imu_csv
    from surfhap.exchange.material_json import read_material_json, write_material_json
    from surfhap.fit.imu import fit_imu_texture
    from surfhap.models.material import ARModelSpec, MaterialFile, Provenance, TextureSpec

    order, max_order, cutoff, unit_scale, note = job.order, job.max_order, job.cutoff, job.unit_scale, job.note
    rec = read_imu_csv(job.recording, unit_scale=unit_scale)
    fit = fit_imu_texture(rec.accel, rec.sample_rate, cutoff=cutoff, order=order, max_order=max_order)
    base = read_material_json(job.into)
    how = f"fixed at {order}" if order is not None else f"aic over 1..{max_order}"
    aic_note = (f"AIC over 1..{max(max_order, order or 0)} chooses {fit.selection.aic_order} (BIC {fit.selection.bic_order}; "
                f"edge-trimmed, tapered, notch below {2 * cutoff:g} Hz continued flat)")
    recording = Path(job.recording)
    recording_label = f"{recording.parent.name}/{rec.name}" if recording.parent.name else rec.name
    texture = TextureSpec(
        quantity="acceleration",
        sample_rate=rec.sample_rate,
        models=[ARModelSpec(coefficients=[float(c) for c in fit.coefficients], variance=fit.variance,
                            reference_speed=None, order_selection=f"{how}; {aic_note}")],
        provenance=Provenance(source="recording", recording=recording_label, sha256=rec.sha256,
                              command=job.command or None, note=note),
    )
    spec = base.spec.model_copy(update={"texture": texture})
    write_material_json(MaterialFile.model_validate(spec.model_dump()), job.target)
    return {"name": rec.name, "order": int(fit.order), "aic_order": int(fit.selection.aic_order),
            "bic_order": int(fit.selection.bic_order), "variance": float(fit.variance),
            "sample_rate": float(rec.sample_rate), "aic_note": aic_note}


run_fit_imu_job = fit_imu_to_file  # the batch's one-job function: write_material_json creates the job's folder
