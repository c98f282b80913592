"""CLI start-up (issue 21 item 2): the root's help and usage errors are answered without
importing the command modules that are not involved, numpy, pydantic or rich; the static
command table agrees with the commands; the shortcuts taken for speed give what the slow path
gave (the time itself is measured by benchmarks/bench_cli_startup.py, not here)."""

import json
import os
import subprocess
import sys
import textwrap
from importlib import import_module
from pathlib import Path

import pytest
import typer
from typer._click import Context
from typer._click.exceptions import MissingParameter

from live_support.cli_commands import all_commands
from surfhap.cli import COMMANDS, root_command
from surfhap.cli._help import _plain

REPO = Path(__file__).resolve().parents[1]
HEAVY = ("numpy", "scipy", "numba", "pydantic", "rich", "matplotlib", "typer.rich_utils", "typer._adapters")
COMMAND_MODULES = sorted({module for module, _ in COMMANDS.values()} | {"ff_bridge"})


def test_the_table_lists_every_command_with_its_real_summary():
    registered = {}
    for module in sorted({module for module, _ in COMMANDS.values()}):
        holder = typer.Typer()
        import_module(f"surfhap.cli.{module}").register(holder)
        for info in [*holder.registered_commands, *holder.registered_groups]:
            registered[info.name] = module
    assert registered == {name: module for name, (module, _) in COMMANDS.items()}
    root = root_command()
    for name, (_, summary) in COMMANDS.items():
        assert _plain(root.commands[name].help).split("\n\n")[0] == summary, name


@pytest.mark.parametrize("args,modules", [
    (["--help"], []), ([], []), (["--version"], []), (["rendr"], []), (["render"], ["render"]),
    (["render", "cork", "--no-such-option"], ["render"]), (["render", "--help"], ["render"]),
    (["play", "cork", "--no-such-option"], ["live"]), (["fit", "friction"], ["fit"]),
    (["study", "run", "-h"], ["study"]), (["ff", "simulate", "-h"], ["ff", "ff_bridge"]),
])
def test_help_and_usage_errors_import_only_their_command(args, modules):
    """The root's help, --version and an unknown name import no command module; a command's help
    or usage error imports its own module only; none imports numpy, pydantic or rich."""
    code = textwrap.dedent(f"""
        import sys
        from surfhap.cli import main
        code = main({args!r})
        loaded = [m for m in {HEAVY!r} if m in sys.modules]
        loaded += sorted(m.rpartition(".")[2] for m in sys.modules if m.rpartition(".")[2] in {COMMAND_MODULES!r})
        print("LOADED=" + ",".join(loaded), file=sys.stderr)
        sys.exit(code)
    """)
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"))
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert proc.returncode in (0, 2) and "Traceback" not in proc.stderr, proc.stderr
    assert f"LOADED={','.join(modules)}\n" in proc.stderr, proc.stderr


def test_a_missing_value_gives_what_typers_coercion_gives():
    """Every parameter of every command: its process_value with no value (None, or nothing given
    to a required one) returns or raises what typer's own process_value does."""
    checked = 0
    for path, command in all_commands():
        ctx = Context(command, info_name=" ".join(path) or "surfhap")
        for param in command.params:
            typer_cls = type(param).__mro__[1]
            for value in (None, ()) if param.nargs == -1 or param.multiple else (None,):
                outcomes = []
                for process in (param.process_value, lambda c, v: typer_cls.process_value(param, c, v)):
                    try:
                        outcomes.append(("value", process(ctx, value)))
                    except MissingParameter as exc:
                        outcomes.append(("missing", exc.format_message()))
                assert outcomes[0] == outcomes[1], (path, param.name, value, outcomes)
                checked += 1
    assert checked > 200


@pytest.mark.parametrize("name", sorted(p.stem for p in (REPO / "src/surfhap/models/builtin").glob("*.json")))
def test_the_material_list_reads_the_files_as_the_materials_do(name):
    """``surfhap materials`` reads the built-in files as written; each row equals the one made
    from the loaded, validated Material (its laws, texture_text, default_method, provenance)."""
    from surfhap.cli.materials import _builtin_specs, _row
    from surfhap.exchange.materials import builtin_names, load_material
    from surfhap.render.drive import default_method

    assert [n for n, _ in _builtin_specs()] == builtin_names()
    m = load_material(name)
    laws = ([f"mu_p: a={m.quasi_static.a:g} b={m.quasi_static.b:g} c={m.quasi_static.c:g} d={m.quasi_static.d:g} "
             f"q={m.quasi_static.q:g}"] if m.quasi_static else []) + ([f"mu0={m.coulomb.mu0:g}"] if m.coulomb else [])
    spec = m.spec
    sources = [p.provenance.reference.split(",")[0].split(" (")[0] if p.provenance.source == "paper"
               else f"fit of {p.provenance.recording}"
               for p in (spec.friction.quasi_static, spec.friction.coulomb, spec.texture) if p is not None]
    expected = (name, "\n".join(laws), m.texture_text(), default_method(m), "\n".join(dict.fromkeys(sources)))
    raw = json.loads((REPO / "src/surfhap/models/builtin" / f"{name}.json").read_text())
    assert _row(name, raw) == expected
