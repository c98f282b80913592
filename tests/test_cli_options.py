"""Options shared by several commands are defined once (cli/_options.py) and read the same everywhere."""

import re
from pathlib import Path

from surfhap.cli import root_command

CLI = Path(__file__).resolve().parents[1] / "src" / "surfhap" / "cli"
SHARED = ("--display", "--load-range", "--speed-range", "--config", "--jobs", "--scheduler")


def _commands(group, path=()):
    if hasattr(group, "commands"):  # a group (typer vendors click)
        for name, cmd in group.commands.items():
            yield from _commands(cmd, (*path, name))
    else:
        yield path, group


def test_shared_options_have_one_help_text():
    helps: dict[str, dict[str, tuple]] = {}
    for path, cmd in _commands(root_command()):
        for p in cmd.params:
            for opt in p.opts:
                if opt in SHARED:
                    helps.setdefault(opt, {}).setdefault(p.help, path)
    assert set(helps) >= {"--display", "--load-range", "--speed-range", "--config"}
    assert {opt: list(by_help.values()) for opt, by_help in helps.items() if len(by_help) > 1} == {}
    assert len([1 for _, cmd in _commands(root_command())
                if any("--display" in p.opts for p in cmd.params)]) >= 4


def test_shared_options_are_declared_only_in_the_aliases():
    """A command module that spells out typer.Option(..., "--display", ...) again duplicates it."""
    pattern = re.compile(r'typer\.Option\([^)]*"(' + "|".join(map(re.escape, SHARED)) + r')"')
    dupes = [(f.name, m.group(1)) for f in sorted(CLI.glob("*.py")) if f.name != "_options.py"
             for m in pattern.finditer(f.read_text())]
    assert dupes == []
