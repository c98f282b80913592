"""``surfhap shape`` (render / calibrate) and ``surfhap scenes``: 3-D shapes (Kim et al. 2017).

::

    surfhap shape MESH (--scan x0,y0,x1,y1,speed | --trajectory FILE) [--calibration FILE] --out DIR
    surfhap shape calibrate MESH [--out FILE]
    surfhap scenes [--out DIR]

MESH is a mesh file (OBJ, STL, PLY, glTF/GLB, OFF), a greyscale image used as a height map
(needs --pixel-size and --height), or a built-in name: suzanne, gaussian-bump, gaussian-hole,
frustum-bump, frustum-hole, or one of the 20 study scenes (see ``surfhap scenes``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer
from typer.core import TyperGroup

from surfhap.cli._common import check_out, figure_path, parse_numbers, progress_bar, report, save_figure, status_line, stdout
from surfhap.cli._display_options import resolve_display
from surfhap.cli._options import (ConfigOption, DisplayOption, FigureOption, JsonOption, OverwriteOption,
                                  TrajectoryOption)
from surfhap.errors import ConfigError

__all__ = ["register"]


class _ShapeGroup(TyperGroup):
    """``surfhap shape MESH ...`` runs the hidden ``render`` command; ``surfhap shape calibrate``
    and the other subcommands run as usual."""

    def parse_args(self, ctx, args):
        if args and args[0] not in self.commands and args[0] not in ("--help", "-h"):
            args = ["render", *args]
        return super().parse_args(ctx, args)


shape_app = typer.Typer(cls=_ShapeGroup, no_args_is_help=True, add_completion=False, pretty_exceptions_enable=False,
                        help="Feel 3-D meshes on the (simulated) electrovibration display: gradient rendering with edge "
                             "emphasis (Kim et al. 2017). 'surfhap shape MESH --scan ... --out DIR' renders a scan; "
                             "'surfhap shape calibrate MESH' measures the force range.")


# the options that place a mesh (render and calibrate take the same)
FzOption = Annotated[float, typer.Option("--fz", help="Assumed normal force of eq. 7, N.")]
UpOption = Annotated[str, typer.Option("--up", help="Mesh axis pointing out of the screen: x, y, z, -x, -y, -z.")]
ScaleOption = Annotated[float, typer.Option("--scale", help="Mesh units -> metres factor (0.01 for a mesh in cm).")]
SizeOption = Annotated[Optional[float], typer.Option("--size", help="Rescale and centre the mesh so its larger xy side is SIZE m.")]
ResolutionOption = Annotated[Optional[float], typer.Option("--resolution", help="Grid step (m) of built-in Gaussian shapes (default 0.0005, scenes 0.001).")]
PixelSizeOption = Annotated[Optional[float], typer.Option("--pixel-size", help="Height maps: m per pixel.")]
HeightOption = Annotated[Optional[float], typer.Option("--height", help="Height maps: height (m) of white.")]
_MESH_HELP = "Mesh file (OBJ/STL/PLY/glTF/OFF), greyscale image (height map), or built-in name (suzanne, gaussian-bump, frustum-hole, a scene...)."


@shape_app.command("render")
def render_cmd(
    mesh: str = typer.Argument(..., help=_MESH_HELP),
    out: Path = typer.Option(..., "--out", help="Output folder: shape.npz, summary.json, figure.png."),
    scan: Optional[str] = typer.Option(None, "--scan", help="Straight scan 'x0,y0,x1,y1,speed' in m and m/s (mesh coordinates)."),
    trajectory: TrajectoryOption = None,
    calibration: Optional[Path] = typer.Option(None, "--calibration", help="Calibration JSON from 'surfhap shape calibrate' (default: MESH.calibration.json next to the mesh if present, else calibrate now)."),
    rate: float = typer.Option(60.0, "--rate", help="Touch sampling rate of --scan, Hz (Kim et al.: 60)."),
    load: float = typer.Option(1.0, "--load", help="Finger load of --scan, N."),
    grain: str = typer.Option("area-even", "--grain", help="Area grain: area-even (smooth) | area-grainy (rough); edge-soft = area-even."),
    edges: bool = typer.Option(True, "--edges/--no-edges", help="Edge emphasis ticks (Sec. 4.3)."),
    edge_threshold: float = typer.Option(135.0, "--edge-threshold", help="Convex edges up to this dihedral angle (deg) tick; 180 = every convex edge."),
    edge_walk: bool = typer.Option(False, "--edge-walk", help="Also find edges crossed between touch samples (narrow steps, height maps)."),
    fz: FzOption = 1.0,
    up: UpOption = "z",
    scale: ScaleOption = 1.0,
    size: SizeOption = None,
    resolution: ResolutionOption = None,
    pixel_size: PixelSizeOption = None,
    height: HeightOption = None,
    drive_rate: int = typer.Option(20000, "--drive-rate", help="DAC rate, Hz (2000-48000)."),
    carrier: float = typer.Option(2000.0, "--carrier", help="Polarity carrier, Hz (2000-20000; 0 = off)."),
    seed: int = typer.Option(0, "--seed", help="Seed of the grainy grain."),
    display: DisplayOption = None,
    config: ConfigOption = None,
    figure: FigureOption = True,
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
) -> None:
    """Render a scan over MESH on the simulated display (also: surfhap shape MESH ...)."""
    from surfhap.exchange.shape_files import default_calibration_path, read_calibration, write_shape
    from surfhap.exchange.trajectory_csv import read_trajectory_csv
    from surfhap.render.shape_chain import render_shape
    from surfhap.render.shape_renderer import ShapeConfig
    from surfhap.shape.scan import parse_scan
    from surfhap.shape.surfaces import load_surface

    check_out(out, "--out", overwrite)
    if (scan is None) == (trajectory is None):
        raise ConfigError("give exactly one of --scan or --trajectory", source="--scan/--trajectory")
    cfg = ShapeConfig(fz=fz, grain=grain, edges=edges, edge_threshold_deg=edge_threshold, edge_walk=edge_walk, drive_rate=drive_rate,
                      carrier=carrier, seed=seed, display=resolve_display(display, config))
    traj = parse_scan(scan, rate=rate, load=load) if scan is not None else read_trajectory_csv(trajectory)
    with status_line(f"loading {mesh}"):  # a first run compiles the mesh kernels: seconds
        surf = load_surface(mesh, up=up, scale=scale, size=size, resolution=resolution, pixel_size=pixel_size,
                            height=height)
    if calibration is None and Path(mesh).is_file() and default_calibration_path(mesh).is_file():
        calibration = default_calibration_path(mesh)  # saved by 'surfhap shape calibrate MESH'
    cal = read_calibration(calibration) if calibration is not None else None
    what = f"rendering {surf.name}" + ("" if cal is not None else " (calibrating it first)")
    with progress_bar(what) if traj.duration > 5.0 else status_line(what) as update:
        result = render_shape(surf, traj, cal, cfg, progress=update)
    paths = write_shape(result, out)
    if figure:
        save_figure(result.plot(), Path(out) / "figure.png")
    s = result.summary()
    report({**s, "mesh": surf.name, "out": str(paths["npz"].parent)},
           f"{surf.name}: {s['samples']} touch samples, {s['on_mesh_fraction']:.0%} on the mesh, "
           f"force {s['force_range_n'][0]:+.3g}..{s['force_range_n'][1]:+.3g} N, {s['ticks']} edge ticks, "
           f"Fsq range [{result.calibration.fmin:+.3g}, {result.calibration.fmax:+.3g}] "
           f"({'from ' + str(calibration) if calibration is not None else 'calibrated now'}) -> {paths['npz'].parent}",
           as_json)


@shape_app.command("calibrate")
def calibrate_cmd(
    mesh: str = typer.Argument(..., help=_MESH_HELP),
    out: Optional[Path] = typer.Option(None, "--out", help="Calibration JSON (default: MESH.calibration.json next to a mesh file)."),
    directions: int = typer.Option(36, "--directions", help="Scan headings, evenly spaced all around."),
    speeds: int = typer.Option(5, "--speeds", help="Number of scan speeds, evenly spaced over --v-min..--v-max."),
    v_min: float = typer.Option(0.02, "--v-min", help="Slowest scan, m/s."),
    v_max: float = typer.Option(0.20, "--v-max", help="Fastest scan, m/s."),
    rate: float = typer.Option(60.0, "--rate", help="Touch sampling rate, Hz (60-100 on the paper's tablet)."),
    lines: int = typer.Option(16, "--lines", help="Parallel scan lines per heading."),
    method: str = typer.Option("sd", "--method", help="sd: mean -/+ k sd (the paper, k = 2) | percentile."),
    k: float = typer.Option(2.0, "--k", help="Number of standard deviations for --method sd."),
    percentiles: str = typer.Option("2.5,97.5", "--percentiles", help="LOWER,UPPER for --method percentile."),
    fz: FzOption = 1.0,
    up: UpOption = "z",
    scale: ScaleOption = 1.0,
    size: SizeOption = None,
    resolution: ResolutionOption = None,
    pixel_size: PixelSizeOption = None,
    height: HeightOption = None,
    figure: Optional[Path] = typer.Option(None, "--figure", help="Also write the Fsq histogram (PNG/PDF/SVG)."),
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
) -> None:
    """Measure the Fsq range of MESH by simulated scans (Kim et al. Sec. 4.2) and save it as JSON."""
    from surfhap.exchange.shape_files import default_calibration_path, write_calibration
    from surfhap.shape.calibration import ScanPlan, calibrate
    from surfhap.shape.surfaces import load_surface

    figure = figure_path(figure, "--figure")
    if not (0 < v_min <= v_max <= 2.0):
        raise ConfigError("need 0 < --v-min <= --v-max <= 2 m/s", source="--v-min/--v-max")
    plan = ScanPlan.evenly(directions, speeds, v_min, v_max, sensor_rate=rate, lines=lines)
    surf = load_surface(mesh, up=up, scale=scale, size=size, resolution=resolution, pixel_size=pixel_size, height=height)
    if out is None:
        if not Path(mesh).exists():
            raise ConfigError("give --out FILE for a built-in shape", source="--out")
        out = default_calibration_path(mesh)
    check_out(out, "--out", overwrite)
    with status_line(f"calibrating {surf.name} by {directions * speeds * lines} simulated scans"):
        cal = calibrate(surf, plan, method=method, k=k, percentiles=parse_numbers(percentiles, "--percentiles", "LOWER,UPPER (e.g. 2.5,97.5)", 2), fz=fz)
    path = write_calibration(cal, out)
    if figure is not None:
        save_figure(cal.plot(), figure)
    report({**cal.to_dict(), "mesh": surf.name, "out": str(path)},
           f"{surf.name}: Fsq range [{cal.fmin:+.4g}, {cal.fmax:+.4g}] sqrt(N) ({cal.method}, "
           f"{cal.n_samples} samples, theta_min {cal.theta_min_deg:.1f} deg) -> {path}", as_json)


@shape_app.command("profile")
def profile_cmd(
    shape: str = typer.Argument("bump", help="bump | hole"),
    out: Path = typer.Option(..., "--out", help="Output folder: profile.npz, figure.png."),
    mapping: str = typer.Option("IP0.5", "--mapping", help="IP0.5 | IP0.7 (Kim et al. Sec. 3.1.2)."),
    piecewise: bool = typer.Option(False, "--piecewise", help="Piecewise-linear intensity profile (Fig. 6b, d)."),
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
) -> None:
    """Write a 1-D profile of the formative study: geometry, force and intensity along the track."""
    import numpy as np

    from surfhap.shape.profiles import formative_profile

    check_out(out, "--out", overwrite)
    prof = formative_profile(shape, mapping, piecewise=piecewise)
    out.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(out / "profile.npz", x=prof.x, height=prof.height, force=prof.force, intensity=prof.intensity)
    prof.plot().savefig(out / "figure.png", dpi=110)
    report({**prof.summary(), "out": str(out)}, f"{prof.name}: force {prof.force.min():+.3f}..{prof.force.max():+.3f} N, "
           f"intensity {prof.intensity.min():.2f}..{prof.intensity.max():.2f} -> {out}", as_json)


def scenes_cmd(
    out: Optional[Path] = typer.Option(None, "--out", help="Write each scene as OBJ plus a top-view PNG into this folder."),
    resolution: float = typer.Option(0.001, "--resolution", help="Grid step (m) of the Gaussian scenes."),
    overwrite: OverwriteOption = False,
) -> None:
    """List the 20 scenes of Kim et al.'s summative study (2 profiles x 2 lights x 5 configurations)."""
    from surfhap.shape.scenes import all_scenes

    scenes = all_scenes()
    if out is not None:
        check_out(out, "--out", overwrite)
        import trimesh

        from surfhap.report.shape_figures import plot_scene

        out.mkdir(parents=True, exist_ok=True)
    with progress_bar("writing scenes", enabled=out is not None) as update:
        for i, sc in enumerate(scenes):
            lay = " ".join(f"{p}:{k}" for p, k in sc.layout.items())
            stdout().print(f"{sc.name:28s} {lay}")
            if out is not None:
                v, f = sc.mesh(resolution)
                trimesh.Trimesh(v, f, process=False).export(out / f"{sc.name}.obj")
                plot_scene(sc, resolution=resolution).savefig(out / f"{sc.name}.png", dpi=90)
                update((i + 1) / len(scenes))


def register(app: typer.Typer) -> None:
    app.add_typer(shape_app, name="shape")
    app.command("scenes")(scenes_cmd)
