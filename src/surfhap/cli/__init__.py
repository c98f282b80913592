"""The ``surfhap`` command line (typer). One module per command group.

Every command turns :class:`surfhap.errors.InputError` (and other ``ValueError`` /
``OSError`` raised by bad input) and every usage error into one line on stderr and exit
code 2. A command's module is imported only when that command runs or shows its help: the
root's help and an unknown name are answered from :data:`COMMANDS` alone, and command modules
import nothing heavy at module level (numpy, scipy, pydantic models, matplotlib, rich, ... are
imported inside the command functions), so ``--help`` and usage errors start quickly.
"""

from __future__ import annotations

import sys
from importlib import import_module

import typer

from surfhap.cli._common import run_guarded

__all__ = ["app", "main", "COMMANDS", "root_command"]

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

        typer.echo(f"surfhap {surfhap.__version__}")
        raise typer.Exit(0)


@app.callback()
def _root(
    version: bool = typer.Option(False, "--version", help="Print surfhap's version and exit.",
                                 is_eager=True, callback=_print_version),
) -> None:
    """Make flat touchscreens feel like materials and shapes."""


# Every top-level command, in --help order: name -> (its module under surfhap.cli, which has
# ``register(app)``; the first paragraph of its help). tests/test_cli_startup.py checks this
# table against the commands the modules register.
COMMANDS: dict[str, tuple[str, str]] = {
    "materials": ("materials", "List the built-in materials, their friction laws, texture models and sources."),
    "calibrate-texture": ("materials", "Set the strength of MATERIAL_FILE's texture so its voltage ratio is RATIO at "
                                       "every load and speed."),
    "render": ("render", "Render MATERIAL along a virtual or recorded finger trajectory on the simulated display."),
    "demo": ("demo", "Render every built-in material at 0.26/0.5/0.96 N and 50/100/150 mm/s; write an HTML report "
                     "with the gain plans and the fidelity table."),
    "scenes": ("shape", "List the 20 scenes of Kim et al.'s summative study (2 profiles x 2 lights x 5 "
                        "configurations)."),
    "serve": ("live", "Serve the touch page: drag on it and the drive is rendered live to the chosen output."),
    "devices": ("live", "List the sound devices PortAudio can output to (use the index with --output sound:N)."),
    "play": ("live", "Play a scripted scan of MATERIAL live, to check the sound card and amplifier chain."),
    "compare": ("compare", "Overlay friction-law curves, texture spectra and voltage histograms of MATERIALS."),
    "fit": ("fit", "Fit material models from real recordings."),
    "import": ("importers", "Import material models from other toolkits."),
    "shape": ("shape", "Feel 3-D meshes on the (simulated) electrovibration display: gradient rendering with edge "
                       "emphasis (Kim et al. 2017). 'surfhap shape MESH --scan ... --out DIR' renders a scan; "
                       "'surfhap shape calibrate MESH' measures the force range."),
    "ff": ("ff", "Force-feedback touchscreen (a 3-DoF impedance device moving the tablet, KinesTouch): stiffness, "
                 "shape, roughness and sliding effects over a scene."),
    "calibrate": ("calibrate", "Calibrate a display: intensity or voltage -> friction force from tribometer "
                               "recordings (Kim et al. 2017 Sec. 2.2), written as a display file."),
    "study": ("study", "Perception studies: generate a counterbalanced design, run participants on a touch page "
                       "with a loss-free log, analyse the results as in the papers."),
    "record": ("record", "Record a rig's sensors (ATI Net F/T over RDT)."),
}


def _load(name: str):
    """The click command ``name``: its module imported and registered on a bare root, only
    ``name`` built (building a command costs start-up too)."""
    holder = typer.Typer(add_completion=False)
    holder.registered_callback = app.registered_callback  # a root with a callback: a group, even for one command
    import_module(f"surfhap.cli.{COMMANDS[name][0]}").register(holder)
    holder.registered_commands = [c for c in holder.registered_commands if c.name == name]
    holder.registered_groups = [g for g in holder.registered_groups if g.name == name]
    return typer.main.get_command(holder).commands[name]


def root_command():
    """The click command of the whole CLI; each command is built when it is first looked up."""
    from surfhap.cli._help import LazyCommands, command_tree

    return command_tree(app, LazyCommands({name: summary for name, (_, summary) in COMMANDS.items()}, _load))


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``surfhap`` script."""
    return run_guarded(root_command(), list(argv if argv is not None else sys.argv[1:]))
