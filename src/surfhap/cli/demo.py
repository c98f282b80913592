"""``surfhap demo``: every built-in material at three speeds on the simulated display."""

from __future__ import annotations

from pathlib import Path

import typer

from surfhap.cli._common import check_out, progress_bar, report, status_line
from surfhap.cli._display_options import resolve_display_and_range
from surfhap.cli._options import ConfigOption, DisplayOption, JsonOption, OverwriteOption, SeedOption

__all__ = ["register"]


def demo(out: Path = typer.Option(Path("demo"), "--out", help="Folder for report.html and figures."),
         duration: float = typer.Option(10.0, "--duration", min=1.0, max=60.0, help="Seconds per render."),
         seed: SeedOption = 0,
         display: DisplayOption = None,
         config: ConfigOption = None,
         overwrite: OverwriteOption = False,
         as_json: JsonOption = False) -> None:
    """Render every built-in material at 0.26/0.5/0.96 N and 50/100/150 mm/s; write an HTML report
    with the gain plans and the fidelity table."""
    from surfhap.report.demo_report import write_demo_report
    from surfhap.sim.demo import DemoSettings, run_demo

    check_out(out, "--out", overwrite)
    disp, _ = resolve_display_and_range(display, None, None, config)
    settings = DemoSettings(duration=duration, seed=seed, display=disp)
    with progress_bar("rendering built-in materials") as update:
        results = run_demo(settings, progress=update)
    with status_line("writing the report and its figures"):  # no fraction to show: a spinner that moves
        path = write_demo_report(results, out)
    report({"report": str(path.resolve())}, f"demo report: {path.resolve()}", as_json)


def register(app: typer.Typer) -> None:
    app.command("demo")(demo)
