"""Helpers shared by the CLI command modules: error handling, progress, option parsing."""

from __future__ import annotations

import re
import sys
import warnings
from contextlib import contextmanager
from functools import cache
from typing import TYPE_CHECKING

import typer

from surfhap.errors import ConfigError, InputWarning, SurfhapError

__all__ = ["run_guarded", "fail", "error_line", "warning_line", "progress_bar", "status_line", "stderr", "stdout",
           "OPTIONAL_MODULES", "require_modules", "parse_numbers", "command_line", "figure_path", "save_figure",
           "report", "print_table", "check_out"]

if TYPE_CHECKING:
    from rich.console import Console
    from typer.core import TyperCommand, TyperGroup


# The two rich consoles, made on first use: rich costs a tenth of a second of start-up that
# --help and a usage error never need (their lines are written by typer.echo).
@cache
def stderr() -> Console:
    from rich.console import Console

    return Console(stderr=True, highlight=False)


@cache
def stdout() -> Console:
    """Result lines: never hard-wrapped (a pipe gets one line per result, grep-able) and no markup
    interpreted in them (a '[...]' in a name or path prints as written)."""
    from rich.console import Console

    return Console(highlight=False, soft_wrap=True, markup=False)

# Third-party modules that only an optional extra installs: import name -> extra.
OPTIONAL_MODULES = {
    "fastapi": "live",
    "starlette": "live",
    "uvicorn": "live",
    "websockets": "live",
    "pythonosc": "live",
    "sounddevice": "live",
    "dask": "dask",
    "distributed": "dask",
}


def require_modules(*names: str) -> None:
    """Raise ``ModuleNotFoundError`` (which :func:`run_guarded` turns into "install the
    extra") unless every module is importable. Cheap: finds, does not import."""
    from importlib.util import find_spec

    for name in names:
        if find_spec(name) is None:
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)


FIGURE_FORMATS = (".png", ".pdf", ".svg")


def parse_numbers(text: str, option: str, what: str = "comma-separated numbers", count: int | None = None,
                  kind: type = float) -> tuple:
    """``"0.1,0.5"`` -> (0.1, 0.5): one or more numbers of type ``kind`` (exactly ``count`` when
    given); other text is one ConfigError naming ``option``: "expected {what}, got '...'"."""
    try:
        values = tuple(kind(v) for v in text.split(",") if v.strip())
    except ValueError:
        values = ()
    if not values or len(values) != (count or len(values)):
        raise ConfigError(f"expected {what}, got {text!r}", source=option)
    return values


def command_line(*args, **options) -> str:
    """The ``surfhap`` command a provenance record stores: ``args``, then ``--name value`` per option
    in the order given (``step_seconds`` -> ``--step-seconds``; numbers as ``:g``; a list repeats the
    option; True is a bare flag; None and False are left out)."""
    import shlex

    words = ["surfhap", *map(str, args)]
    for name, value in options.items():
        flag = "--" + name.replace("_", "-")
        if value is True:
            words.append(flag)
        elif value is not None and value is not False:
            for v in value if isinstance(value, list) else [value]:
                words += [flag, f"{v:g}" if isinstance(v, (int, float)) else str(v)]
    return shlex.join(words)


def figure_path(path, option: str):
    """The file a figure option (``--out``, ``--plot``, ``--figure``) writes: PNG when the name
    has no suffix (so the "wrote" line names the real file). Any other suffix than .png, .pdf and
    .svg is bad input: a ConfigError naming the option, raised before any work is done."""
    from pathlib import Path

    if path is None:
        return None
    path = Path(path)
    if not path.suffix:
        return path.with_suffix(".png")
    if path.suffix.lower() not in FIGURE_FORMATS:
        raise ConfigError(f"a figure is written as {', '.join(FIGURE_FORMATS)}, not {path.suffix!r}", source=option,
                          field="suffix")
    return path


def save_figure(fig, path, dpi: int = 110) -> None:
    """Write a matplotlib figure to ``path`` (its folder made); an OSError names the file (exit 2)."""
    from pathlib import Path

    from surfhap.errors import writing

    Path(path).parent.mkdir(parents=True, exist_ok=True)
    with writing(path):
        fig.savefig(path, dpi=dpi)


def _line(label: str, colour: str, message: str) -> None:
    """``label: message`` as exactly one line on stderr, the label bold and coloured on a terminal."""
    flat = re.sub(r"\s+", " ", str(message)).strip()
    typer.echo(f"{typer.style(label, fg=colour, bold=True)} {flat}", err=True)


def error_line(message: str) -> None:
    """Print ``error: message`` as exactly one line on stderr (no markup is interpreted)."""
    _line("error:", "red", message)


def warning_line(message: str) -> None:
    """Print ``warning: message`` as exactly one line on stderr (no markup is interpreted)."""
    _line("warning:", "yellow", message)


@contextmanager
def input_warnings_as_lines():
    """Inside: every :class:`~surfhap.errors.InputWarning` the library issues (a mesh in
    millimetres, ...) is printed as one ``warning:`` line, each time; other warnings as usual."""
    with warnings.catch_warnings():
        warnings.simplefilter("always", InputWarning)
        shown = warnings.showwarning

        def _show(message, category, filename, lineno, file=None, line=None):
            if issubclass(category, InputWarning):
                warning_line(str(message))
            else:
                shown(message, category, filename, lineno, file, line)

        warnings.showwarning = _show
        yield


def fail(message: str, code: int = 2) -> None:
    """Print one error line and exit with ``code``: 2 bad input, 3 a failed backend or real-time
    loop (after the drive or force ramped to zero), 1 a failed render or batch job, 130 an
    interrupted batch."""
    error_line(message)
    raise typer.Exit(code)


def _error_text(exc: BaseException) -> str:
    """The one line of an input error; a pydantic ``ValidationError`` (a ``ValueError``, raised
    by a parameter type built directly from options) is its first error's ``field: message``."""
    pydantic = sys.modules.get("pydantic")  # not imported: the error cannot be pydantic's
    if pydantic is not None and isinstance(exc, pydantic.ValidationError):
        from surfhap.checked import first_error

        return ": ".join(first_error(exc))
    return str(exc)


def run_guarded(command: TyperCommand | TyperGroup, argv: list[str]) -> int:
    """Run a click command built by typer (:func:`surfhap.cli._help.command_tree`) and return its exit code.

    Usage errors (missing or unknown argument, option or command, bad option value) and bad
    input (:class:`~surfhap.errors.SurfhapError`, ``ValueError``, ``OSError``) become one line
    on stderr and exit code 2; a command that needs a missing optional extra says which one
    to install (exit 2). A group called without a command prints its help (exit 2).
    """
    try:
        with input_warnings_as_lines():
            code = command.main(args=argv, prog_name="surfhap", standalone_mode=False)
    except typer.Abort:
        error_line("aborted")
        return 130
    except typer.TyperException as exc:  # typer's own usage errors (vendored click classes)
        ctx = getattr(exc, "ctx", None)
        if type(exc).__name__ == "NoArgsIsHelpError" and ctx is not None:
            exc.show()  # a bare group: its help
        else:
            error_line(exc.format_message() + ("" if ctx is None else f" (try '{ctx.command_path} --help')"))
        return 2
    except ModuleNotFoundError as exc:
        extra = OPTIONAL_MODULES.get((exc.name or "").split(".")[0])
        if extra is None:
            raise
        error_line(f"this command needs the optional '{extra}' extra (missing module {exc.name!r}): "
                   f"pip install 'surfhap[{extra}]'")
        return 2
    except (SurfhapError, ValueError, OSError) as exc:
        error_line(_error_text(exc))
        return 2
    # standalone_mode=False: typer returns the code of a typer.Exit, or the command's value
    return code if isinstance(code, int) and not isinstance(code, bool) else 0


def report(data: dict, lines, as_json: bool) -> None:
    """A command's result: its human summary ``lines`` or, with ``--json``, ``data`` as one
    JSON object on one line of stdout (for scripts; numpy values as numbers, non-finite ones as
    null, paths as text)."""
    import json

    if as_json:
        from surfhap.results import jsonable

        typer.echo(json.dumps(jsonable(data), default=str))
        return
    for line in [lines] if isinstance(lines, str) else lines:
        stdout().print(line)


def print_table(header, rows, title: str | None = None) -> None:
    """A table on stdout: on a terminal a rich table whose cells wrap (a name is never cut to
    'otake20…'); piped, one tab-separated line per row after the header line."""
    if not stdout().is_terminal:
        for row in [header, *rows]:
            typer.echo("\t".join(" ".join(str(c).split()) if "\n" not in str(c) else "; ".join(str(c).splitlines())
                                  for c in row))
        return
    from rich.table import Table
    from rich.text import Text

    table = Table(title=title)
    for col in header:
        table.add_column(col, overflow="fold")
    for row in rows:
        table.add_row(*(c if isinstance(c, Text) else Text(str(c)) for c in row))
    stdout().print(table)


def check_out(path, option: str, overwrite: bool):
    """The one guard of every command that writes ``--out`` (a folder or a file): an existing
    non-empty one is refused (a ConfigError naming the option and the path: exit 2) unless
    ``--overwrite``. Returns ``path``."""
    from pathlib import Path

    p = Path(path)
    if not overwrite and (p.is_file() and p.stat().st_size > 0 or p.is_dir() and any(p.iterdir())):
        raise ConfigError(f"{p} exists and is not empty; give --overwrite to replace what is in it", source=option)
    return path


@contextmanager
def status_line(description: str):
    """Work of unknown length (a fit, a first index build, writing figures): a spinner on a
    terminal's stderr. Nothing when stderr is not a terminal: a log holds results and errors
    only, and bad input found during the work stays the one error line."""
    if not stderr().is_terminal:
        yield
        return
    with stderr().status(f"{description} ...", spinner="dots"):
        yield


@contextmanager
def progress_bar(description: str, enabled: bool = True, total: int | None = None):
    """A rich progress bar on a terminal's stderr (nothing otherwise, as :func:`status_line`);
    yields ``update(fraction)``, or with ``total`` items ``update(done, note="")`` (the bar
    counts done/total and shows the note)."""
    if not enabled or not stderr().is_terminal:
        yield lambda *args: None
        return
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

    count = MofNCompleteColumn() if total else TextColumn("{task.percentage:>3.0f}%")
    with Progress(TextColumn("{task.description}"), BarColumn(), count, TextColumn("{task.fields[note]}"),
                  TimeElapsedColumn(), TimeRemainingColumn(), console=stderr(), transient=True) as prog:
        task = prog.add_task(description, total=total or 1.0, note="")
        yield lambda done, note="": prog.update(task, completed=done, note=note)
