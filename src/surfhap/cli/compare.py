"""``surfhap compare A B ...``: friction laws, texture spectra and drive-voltage histograms of
materials (built-in names, fitted material files, HaTT model files) in one figure and a table."""

from __future__ import annotations

from pathlib import Path
from typing import Optional

import typer

from surfhap.cli._common import check_out, figure_path, print_table, report, save_figure, stdout
from surfhap.cli._options import JsonOption, OverwriteOption, SeedOption

__all__ = ["register"]


def compare(
    materials: list[str] = typer.Argument(..., help="Materials: built-in names (see 'surfhap materials'), material "
                                                    "files (.json) or HaTT model files (.xml)."),
    out: Optional[Path] = typer.Option(None, "--out", help="Figure to write (PNG/PDF/SVG)."),
    speed_mm_s: float = typer.Option(100.0, "--speed-mm-s", help="Stroke speed of the comparison render (mm/s)."),
    load: float = typer.Option(0.5, "--load", help="Finger load of the comparison render (N)."),
    duration: float = typer.Option(4.0, "--duration", help="Seconds rendered per material."),
    seed: SeedOption = 0,
    overwrite: OverwriteOption = False,
    as_json: JsonOption = False,
) -> None:
    """Overlay friction-law curves, texture spectra and voltage histograms of MATERIALS."""
    from surfhap.errors import ConfigError
    from surfhap.lab.compare import MaterialComparison, compare_materials

    if not 1.0 <= speed_mm_s <= 2000.0:
        raise ConfigError("must be within 1-2000 mm/s", source="--speed-mm-s", field="speed")
    out = figure_path(out, "--out")
    if out is not None:
        check_out(out, "--out", overwrite)
    comp = compare_materials(materials, speed=speed_mm_s * 1e-3, load=load, duration=duration, seed=seed)
    if out is not None:
        save_figure(comp.plot(), out, dpi=120)
    if as_json:
        return report({"speed_m_s": comp.speed, "load_n": comp.load, "duration_s": comp.duration,
                       "table": [dict(zip(MaterialComparison.header, r)) for r in comp.rows()],
                       "renders": [p.summary for p in comp.profiles], "figure": out and str(out)}, [], True)
    print_table(MaterialComparison.header, comp.rows())
    if out is not None:
        stdout().print(f"wrote {out}")


def register(app: typer.Typer) -> None:
    app.command("compare")(compare)
