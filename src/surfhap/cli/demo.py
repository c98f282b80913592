"""``surfhap demo``: every built-in material at three speeds on the simulated display."""

from __future__ import annotations

from pathlib import Path

import typer

from surfhap.cli._common import progress_bar, stdout

__all__ = ["register"]


def demo(out: Path = typer.Option(Path("demo"), "--out", help="Folder for report.html and figures."),
         duration: float = typer.Option(10.0, "--duration", min=1.0, max=60.0, help="Seconds per render."),
         seed: int = typer.Option(0, "--seed", help="Seed of the texture noise.")) -> None:
    """Render every built-in material at 50, 100 and 150 mm/s and write an HTML report."""
    from surfhap.report.demo_report import DemoSettings, run_demo, write_demo_report

    settings = DemoSettings(duration=duration, seed=seed)
    with progress_bar("rendering built-in materials") as update:
        results = run_demo(settings, progress=update)
    with progress_bar("writing figures") as _:
        path = write_demo_report(results, out, settings)
    stdout.print(f"demo report: {path.resolve()}")


def register(app: typer.Typer) -> None:
    app.command("demo")(demo)
