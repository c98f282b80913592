"""Every command and sub-command of the ``surfhap`` CLI, for the tests that check them all."""

from __future__ import annotations


def _walk(command, path=()):
    yield path, command
    for name, sub in sorted(getattr(command, "commands", {}).items()):
        yield from _walk(sub, (*path, name))


def all_commands() -> list:
    """``[(path, click command), ...]``: the root as ``()``, then every (sub-)command by name."""
    from surfhap.cli import root_command

    return list(_walk(root_command()))
