"""``surfhap render``: render a material along a finger trajectory on the simulated display."""

from __future__ import annotations

from pathlib import Path
from typing import List, Optional

import typer

from surfhap.batch.jobs import NPZ_MAX_SECONDS, choose_format
from surfhap.cli._batch import GRID_HELP, render_batch, split_inputs
from surfhap.cli._common import check_out, fail, parse_numbers, progress_bar, report, warning_line
from surfhap.cli._display_options import resolve_display_and_range
from surfhap.cli._scan import trajectory_from_options
from surfhap.cli._signals import StopSignals
from surfhap.cli._options import (ConfigOption, DisplayOption, FigureOption, JobsOption, JsonOption, LoadRangeOption,
                                  OverwriteOption, SchedulerOption, SeedOption, SpeedRangeOption, TrajectoryOption)
from surfhap.errors import ConfigError

__all__ = ["register"]


def render_cmd(
    material: List[str] = typer.Argument(..., help="Built-in material name (see 'surfhap materials') or a material file; several (or comma-separated) make a batch."),
    out: Path = typer.Option(..., "--out", help="Output folder: drive.wav, render.npz or render.h5, summary.json, figure.png (a batch: one such folder per job, and index.csv/index.json)."),
    fmt: str = typer.Option("auto", "--format", help=f"Render file: npz | h5 | auto (render.npz up to {NPZ_MAX_SECONDS:g} s, render.h5 above; see docs/outputs.md)."),
    scan: Optional[str] = typer.Option(None, "--scan", help="Virtual finger: 'speed=M/S,load=N,duration=S[,length=M for back-and-forth strokes][,rate=HZ sensor rate]'."),
    trajectory: TrajectoryOption = None,
    method: str = typer.Option("auto", "--method", help="otake2022 | otake2021 | zhao | friction-only | square (auto: otake2022 when the material has the quasi-static law)."),
    drive_rate: int = typer.Option(20000, "--drive-rate", help="DAC rate, Hz (2000-48000)."),
    carrier: Optional[float] = typer.Option(None, "--carrier", help="Polarity carrier, Hz (2000-20000; 0 = off). Default: the method's paper (otake2021: 20 kHz, capped at half the drive rate; else 2 kHz)."),
    seed: SeedOption = 0,
    alpha: Optional[float] = typer.Option(None, "--alpha", help="Gain V/sqrt(N), overriding the gain plan (default: planned so the operating range does not saturate)."),
    beta: float = typer.Option(1.8, "--beta", help="Gain of the textural component (Otake et al. 2021: 1.8; used for 2022 too, see docs/texture.md)."),
    square_frequency: float = typer.Option(100.0, "--square-frequency", help="Baseline square wave, Hz (30-300)."),
    square_reference: str = typer.Option("0.5,0.1", "--square-reference", help="Square baseline: 'LOAD,SPEED' (N, m/s) at which its mean equals the friction-only mean."),
    display: DisplayOption = None,
    load_range: LoadRangeOption = None,
    speed_range: SpeedRangeOption = None,
    config: ConfigOption = None,
    v_max: float = typer.Option(250.0, "--v-max", help="Safety limit on |V| (V)."),
    amp_gain: Optional[float] = typer.Option(None, "--amp-gain", help="Amplifier gain, V per DAC full scale, for drive.wav (default: --v-max)."),
    figure: FigureOption = True,
    grid: List[str] = typer.Option([], "--grid", metavar="KEY=V1,V2,...", help=GRID_HELP),
    jobs: JobsOption = 1,
    scheduler: SchedulerOption = None,
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
) -> None:
    """Render MATERIAL along a virtual or recorded finger trajectory on the simulated display."""
    materials = split_inputs(material)
    check_out(out, "--out", overwrite)
    batch = len(materials) > 1 or bool(grid) or jobs != 1 or scheduler is not None
    if batch:  # local workers start importing now, while this process sets up the jobs
        from surfhap.batch.jobs import RENDER_JOB_MODULES
        from surfhap.batch.schedulers import parse_scheduler, prestart

        prestart(parse_scheduler(scheduler, jobs), RENDER_JOB_MODULES)
    from surfhap.batch.jobs import render_to_folder
    from surfhap.exchange.materials import load_material
    from surfhap.render.chain import ChainConfig
    from surfhap.render.safety import SafetyLimits

    disp, rng = resolve_display_and_range(display, load_range, speed_range, config)
    sq_load, sq_speed = parse_numbers(square_reference, "--square-reference", "LOAD,SPEED (two numbers)", 2)
    mat = load_material(materials[0])
    traj = None if batch else trajectory_from_options(scan, trajectory)
    if not batch:
        choose_format(fmt, traj.duration)
    if not (v_max > 0 and v_max <= 1000):
        raise ConfigError("must be within (0, 1000] V", source="--v-max")
    cfg = ChainConfig(method=method, drive_rate=drive_rate, carrier=carrier, seed=seed, alpha=alpha, beta=beta,
                      square_frequency=square_frequency, square_reference_load=sq_load, square_reference_speed=sq_speed,
                      operating_range=rng, display=disp, limits=SafetyLimits(v_max=v_max, rise_rate=v_max * 1e4))
    if batch:
        return render_batch(materials, scan, trajectory, grid, cfg, out, amp_gain, figure, jobs, scheduler, fmt=fmt)
    with StopSignals() as guard, progress_bar(f"rendering {mat.name}", enabled=traj.duration > 2.0) as update:
        result, paths = render_to_folder(mat, traj, cfg, out, fmt=fmt, amp_gain=amp_gain, figure=figure, progress=update, stop=guard)
    s = result.summary()
    report({**s, "material": mat.name, "files": {k: str(v) for k, v in paths.items()}}, f"{mat.name} ({s['method']}): alpha {s['alpha_v_per_sqrt_n']:.1f} V/sqrt(N) ({s['alpha_source']}, "
                 f"rendering gain {s['rendering_gain']:.3f}), max |V| {s['max_abs_voltage']:.1f} V, clipped {s['clipped_fraction']:.1%}, "
                 f"saturated {s['saturated_fraction']:.1%} -> {paths['render']}", as_json)
    for warning in (result.saturation_warning(), result.texture_warning()):
        if warning is not None:
            warning_line(warning)
    guard.finish(f"wrote the first {s['rendered_s']:g} s of {s['requested_s']:g} s to {paths['render']}" if result.interrupted
                 else f"after the render was complete ({paths['render']})")
    fault = result.fault_error()
    if fault is not None:  # a failed render, like a failed batch job (docs/outputs.md)
        fail(fault, 1)


def register(app: typer.Typer) -> None:
    app.command("render")(render_cmd)
