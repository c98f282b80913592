"""Helpers shared by the CLI command modules: error handling, progress, option parsing."""

from __future__ import annotations

import sys
from contextlib import contextmanager

import click
import typer
from rich.console import Console
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

from surfhap.errors import ConfigError, SurfhapError

__all__ = ["run_guarded", "fail", "progress_bar", "parse_key_values", "stderr", "stdout"]

stderr = Console(stderr=True, highlight=False)
stdout = Console(highlight=False)


def fail(message: str) -> None:
    """Print one error line and exit with code 2."""
    stderr.print(f"[bold red]error:[/] {message}", markup=True, soft_wrap=True)
    raise typer.Exit(2)


def run_guarded(app: typer.Typer, argv: list[str]) -> int:
    """Run the typer app; bad input becomes one line on stderr and exit code 2."""
    try:
        app(args=argv, prog_name="surfhap", standalone_mode=False)
    except click.exceptions.Exit as exc:
        return int(exc.exit_code or 0)
    except click.exceptions.Abort:
        stderr.print("aborted")
        return 130
    except click.ClickException as exc:  # usage errors: typer's own message
        exc.show(file=sys.stderr)
        return 2
    except (SurfhapError, ValueError, OSError) as exc:
        stderr.print(f"[bold red]error:[/] {exc}", markup=True, soft_wrap=True)
        return 2
    return 0


@contextmanager
def progress_bar(description: str, enabled: bool = True):
    """A rich progress bar; yields ``update(fraction)``. Silent when not enabled."""
    if not enabled:
        yield lambda fraction: None
        return
    with Progress(TextColumn("{task.description}"), BarColumn(), TextColumn("{task.percentage:>3.0f}%"),
                  TimeElapsedColumn(), TimeRemainingColumn(), console=stderr, transient=True) as prog:
        task = prog.add_task(description, total=1.0)
        yield lambda fraction: prog.update(task, completed=fraction)


def parse_key_values(text: str, option: str, keys: dict[str, float | None]) -> dict[str, float]:
    """Parse ``"speed=0.1,load=0.5"`` into floats; ``keys`` maps allowed keys to defaults
    (None = required)."""
    out: dict[str, float] = {}
    for part in filter(None, (p.strip() for p in text.split(","))):
        if "=" not in part:
            raise ConfigError(f"expected key=value, got {part!r}", source=option)
        key, value = (s.strip() for s in part.split("=", 1))
        if key not in keys:
            raise ConfigError(f"unknown key {key!r} (known: {', '.join(keys)})", source=option)
        try:
            out[key] = float(value)
        except ValueError:
            raise ConfigError(f"{value!r} is not a number", source=option, field=key) from None
    for key, default in keys.items():
        if key not in out:
            if default is None:
                raise ConfigError("missing (required)", source=option, field=key)
            out[key] = default
    return out
