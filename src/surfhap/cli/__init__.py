"""The ``surfhap`` command line (typer). One module per command group.

Every command turns :class:`surfhap.errors.InputError` (and other ``ValueError`` /
``OSError`` raised by bad input) into one line on stderr and exit code 2.
"""

from __future__ import annotations

import sys

import typer

from surfhap.cli._common import run_guarded

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


# Command modules, in --help order. Each has ``register(app)``; a module that is not
# present in this installation is skipped.
COMMAND_MODULES = ("materials", "render", "demo", "fit", "fit_recordings", "importers", "shape", "live")

_registered = False


def _register() -> None:
    global _registered
    if _registered:
        return
    from importlib import import_module

    for name in COMMAND_MODULES:
        full = f"surfhap.cli.{name}"
        try:
            mod = import_module(full)
        except ModuleNotFoundError as exc:
            if exc.name == full:
                continue
            raise
        mod.register(app)
    _registered = True


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``surfhap`` script."""
    _register()
    return run_guarded(app, argv if argv is not None else sys.argv[1:])
