"""``surfhap import``: convert third-party model files into surfhap material files.

``surfhap import hatt FOLDER --out DIR`` converts every ``Models_*.xml`` of a user-supplied
Penn Haptic Texture Toolkit folder (HaTT files may not be redistributed; surfhap ships
none). A single ``Models_*.xml`` can also be given directly wherever a material is accepted.
"""

from __future__ import annotations

from pathlib import Path

import typer

from surfhap.cli._common import check_out, stdout
from surfhap.cli._options import OverwriteOption

__all__ = ["import_app", "register"]

import_app = typer.Typer(help="Import material models from other toolkits.", no_args_is_help=True)


@import_app.command("hatt")
def import_hatt_cmd(
    folder: Path = typer.Argument(..., help="HaTT folder holding Models_*.xml (searched recursively), or one such file."),
    out: Path = typer.Option(..., "--out", help="Folder for the material JSON files."),
    overwrite: OverwriteOption = False,
) -> None:
    """Convert HaTT model sets (interpolated ARMA acceleration textures + Coulomb mu)."""
    from surfhap.exchange.hatt import import_hatt_folder

    check_out(out, "--out", overwrite)
    written = import_hatt_folder(folder, out)
    for path in written:
        stdout().print(str(path))
    stdout().print(f"{len(written)} material(s) written to {out}")


def register(app: typer.Typer) -> None:
    # HaTT ``Models_*.xml`` is accepted wherever the CLI takes a material:
    # surfhap.exchange.materials.load_material imports the reader when it meets a .xml file.
    app.add_typer(import_app, name="import")
