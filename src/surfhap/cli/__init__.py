"""The ``surfhap`` command line (typer). One module per command group.

Every command turns :class:`surfhap.errors.InputError` (and other ``ValueError`` /
``OSError`` raised by bad input) and every usage error into one line on stderr and exit
code 2. Command modules import nothing heavy at module level (numba, scipy, matplotlib,
trimesh, fastapi, ... are imported inside the command functions), so ``surfhap --help``
starts quickly.
"""

from __future__ import annotations

import sys

import typer

from surfhap.cli._common import run_guarded, stdout

__all__ = ["app", "main"]

app = typer.Typer(
    name="surfhap",
    help="Make flat touchscreens feel like materials and shapes: render textures and meshes "
    "on an electrostatic friction display (or the built-in simulated one), fit material models, "
    "calibrate displays.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


def _print_version(value: bool) -> None:
    if value:
        import surfhap

        stdout.print(f"surfhap {surfhap.__version__}")
        raise typer.Exit(0)


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", help="Print surfhap's version and exit.",
                                 is_eager=True, callback=_print_version),
) -> None:
    """Make flat touchscreens feel like materials and shapes."""


# Command modules, in --help order. Each has ``register(app)``; a module that is not
# present in this installation is skipped.
COMMAND_MODULES = ("materials", "render", "demo", "fit", "fit_recordings", "importers", "shape", "live", "ff", "calibrate",
                   "study", "compare", "record")

# The modules of a command whose name is not its module's (the others: the module of that name).
# Only a hint for a quick start: ``surfhap NAME ...`` imports just these; any other word, all.
MODULES_OF = {"calibrate-texture": ("materials",), "scenes": ("shape",), "serve": ("live",), "devices": ("live",),
              "play": ("live",), "fit": ("fit", "fit_recordings"), "import": ("importers",)}

_registered: set[str] = set()


def _register(command: str | None = None) -> None:
    """Register the command modules: all, or only those of ``command`` when it is known."""
    from importlib import import_module

    names = MODULES_OF.get(command, (command,))
    for name in names if set(names) <= set(COMMAND_MODULES) else COMMAND_MODULES:
        full = f"surfhap.cli.{name}"
        if name in _registered:
            continue
        try:
            mod = import_module(full)
        except ModuleNotFoundError as exc:
            if exc.name == full:
                continue
            raise
        mod.register(app)
        _registered.add(name)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``surfhap`` script."""
    argv = list(argv if argv is not None else sys.argv[1:])
    _register(next((a for a in argv if not a.startswith("-")), None))
    return run_guarded(app, argv)
