"""``--help`` that reads well at any width, and the click command tree the CLI runs.

typer's rich help puts each option's help in a table column whose overflow is an ellipsis,
so a value format longer than the column ('speed=M/S,load=N,duration=S[,length=M...') was cut
to 'speed=M/S,load=N,du…', and it labels flags ``<bool>``. This formatter writes plain text
wrapped to the terminal (long words are broken, never cut), names every option with its
metavar (none for flags), default and range, and lists each sub-command's whole first
paragraph. It imports neither ``typer.rich_utils`` nor pydantic, so ``--help`` starts fast.

``-h`` is accepted beside ``--help`` by every command (the root's context setting).

Start-up (issue 21): the root's commands are a :class:`LazyCommands` mapping, so a command's
module is imported only when that command runs or shows its help, and the root's help lists
the commands from their summaries alone; a parameter whose value is missing is not coerced
(typer builds a pydantic TypeAdapter to coerce: 0.15 s that a usage error never needs).
"""

from __future__ import annotations

import inspect
import shutil
import textwrap
from collections.abc import Callable, Iterator, Mapping

import typer
from typer._click.exceptions import MissingParameter
from typer.core import TyperArgument, TyperCommand, TyperGroup, TyperOption

__all__ = ["command_tree", "LazyCommands"]

HELP_OPTION_NAMES = ["-h", "--help"]


def _plain(text: str | None) -> str:
    """Help text as plain words: ``\\[`` escapes resolved (the only rich markup a help text may
    hold: tests/test_cli_usage.py checks every one), paragraphs kept."""
    paragraphs = inspect.cleandoc(text or "").partition("\f")[0].split("\n\n")
    return "\n\n".join(" ".join(p.replace("\\[", "[").split()) for p in paragraphs if p.strip())


class LazyCommands(Mapping):
    """A group's commands by name, each built by ``load(name)`` on first use; ``summaries`` holds
    every name (in help order) with the first paragraph of its help, which the group's help lists."""

    def __init__(self, summaries: Mapping[str, str], load: Callable[[str], TyperCommand | TyperGroup]):
        self.summaries, self._load = summaries, load
        self._built: dict[str, TyperCommand | TyperGroup] = {}

    def __getitem__(self, name: str) -> TyperCommand | TyperGroup:
        if name not in self.summaries:
            raise KeyError(name)
        if name not in self._built:
            self._built[name] = command = self._load(name)
            _with_help(command)
        return self._built[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self.summaries)

    def __len__(self) -> int:
        return len(self.summaries)


def _metavar(param, ctx) -> str:
    """What a parameter takes: its metavar, an argument's name, an option's type (nothing for a flag)."""
    if param.metavar is not None:
        return param.metavar
    if isinstance(param, TyperOption) and (param.is_flag or param.count):
        return ""
    if isinstance(param, TyperArgument):
        label = param.name.upper()
    else:
        label = param.display_type(ctx).strip("<>").removeprefix("list[").removesuffix("]").split()[0]
        label = {"str": "TEXT", "int": "INTEGER"}.get(label, label.upper())
    return label + ("..." if param.nargs == -1 else "")


def _extras(param, ctx) -> str:
    """``  [range: ..]  [required]`` or ``  [default: ..]`` after a parameter's help."""
    bits = []
    if isinstance(param, (TyperOption, TyperArgument)) and (param.min is not None or param.max is not None):
        bits.append(f"range: {'' if param.min is None else param.min}..{'' if param.max is None else param.max}")
    default = param.default
    if param.required:
        bits.append("required")
    elif isinstance(param, TyperOption) and param.is_flag and param.secondary_opts:
        bits.append(f"default: {(param.opts if default else param.secondary_opts)[0]}")
    elif (isinstance(param, TyperOption) and param.show_default is not False and not param.is_flag
          and default not in (None, "", [], ()) and not callable(default)):
        bits.append(f"default: {default}")
    return "".join(f"  [{b}]" for b in bits)


def _rows(params, ctx) -> list[tuple[str, str]]:
    rows = []
    for p in params:
        if p.hidden:
            continue
        names = ", ".join([*p.opts, *p.secondary_opts]) if isinstance(p, TyperOption) else ""
        mv = _metavar(p, ctx)
        rows.append((f"{names} {mv}".strip() if names else mv, (_plain(p.help) + _extras(p, ctx)).strip()))
    return rows


def _section(title: str, rows: list[tuple[str, str]], width: int) -> list[str]:
    """A definition list: names in the first column, the wrapped help beside or below them."""
    if not rows:
        return []
    first = min(max(len(n) for n, _ in rows) + 2, max(12, width // 3))
    lines = ["", f"{title}:"]
    wrap = dict(break_long_words=True, break_on_hyphens=False)
    for name, help_ in rows:
        body = textwrap.wrap(help_, max(width - first - 2, 20), **wrap) or [""]
        if len(name) + 2 <= first:
            lines.append(f"  {name:<{first}}{body[0]}".rstrip())
            body = body[1:]
        else:
            lines += textwrap.wrap(name, width - 2, initial_indent="  ", subsequent_indent="    ", **wrap)
        lines += [" " * (first + 2) + b for b in body]
    return lines


def _format_help(self, ctx, formatter) -> None:
    """``format_help`` of every command and group: the help described above."""
    width = max(40, min(shutil.get_terminal_size().columns, 100) - 1)
    params = self.get_params(ctx)
    pieces = ["[OPTIONS]", *(_metavar(p, ctx) for p in params if isinstance(p, TyperArgument))]
    if isinstance(self, TyperGroup):
        pieces.append("COMMAND [ARGS]...")
    lines = textwrap.wrap(f"Usage: {ctx.command_path} {' '.join(pieces)}", width, subsequent_indent="  ",
                          break_on_hyphens=False)
    for paragraph in _plain(self.help).split("\n\n"):
        lines += [""] + textwrap.wrap(paragraph, width - 2, initial_indent="  ", subsequent_indent="  ")
    lines += _section("Arguments", _rows([p for p in params if isinstance(p, TyperArgument)], ctx), width)
    lines += _section("Options", _rows([p for p in params if not isinstance(p, TyperArgument)], ctx), width)
    if isinstance(self, TyperGroup) and isinstance(self.commands, LazyCommands):  # no command is built
        lines += _section("Commands", list(self.commands.summaries.items()), width)
    elif isinstance(self, TyperGroup):
        cmds = [(n, c) for n in self.list_commands(ctx) if (c := self.get_command(ctx, n)) and not c.hidden]
        lines += _section("Commands", [(n, _plain(c.help).split("\n\n")[0]) for n, c in cmds], width)
    formatter.write("\n".join(lines) + "\n")


def _get_help_option(self, ctx):
    """``get_help_option``: the help flag defaults to False, not None (typer coerces a non-bool
    flag value through a pydantic TypeAdapter: 0.15 s of start-up for every command), and its
    names are in a fixed order (click takes them from a set: '--help, -h' or '-h, --help' by chance)."""
    option = super(type(self), self).get_help_option(ctx)
    if option is not None and option.default is None:
        option.default = False
        option.opts.sort(key=len)
    return option


def _list_commands(self, ctx) -> list[str]:
    """``list_commands`` of every group: the names, in order, without building a lazy command."""
    return list(self.commands)


def _process_value(self, ctx, value):
    """``process_value`` of every parameter: a missing value (None, or nothing given for a
    required one) skips typer's coercion, which builds a pydantic TypeAdapter first and then
    gives None (``()`` for many values) or the same MissingParameter."""
    if self.required and self.value_is_missing(value):
        raise MissingParameter(ctx=ctx, param=self)
    if value is not None:
        return super(type(self), self).process_value(ctx, value)
    value = () if self.multiple or self.nargs == -1 else None
    return value if self.callback is None else self.callback(ctx, self, value)


_classes: dict[type, type] = {}
_METHODS = {TyperCommand: {"format_help": _format_help, "get_help_option": _get_help_option},
            TyperGroup: {"format_help": _format_help, "get_help_option": _get_help_option,
                         "list_commands": _list_commands},
            TyperOption: {"process_value": _process_value}, TyperArgument: {"process_value": _process_value}}


def _subclass(obj) -> None:
    """Make ``obj``'s class the subclass holding the methods above for its kind (typer builds the
    commands and parameters, so this is the one place all of them pass)."""
    cls = type(obj)
    if cls not in _classes.values():
        methods = next(m for kind, m in _METHODS.items() if isinstance(obj, kind))
        obj.__class__ = _classes.setdefault(cls, type(cls.__name__, (cls,), methods))


def _with_help(command) -> None:
    """Give ``command``, its parameters and its built sub-commands the methods above."""
    _subclass(command)
    for param in command.params:
        if isinstance(param, (TyperOption, TyperArgument)):
            _subclass(param)
    if isinstance(command, TyperGroup) and not isinstance(command.commands, LazyCommands):
        for sub in command.commands.values():
            _with_help(sub)


def command_tree(app: typer.Typer, commands: LazyCommands | None = None):
    """The click command of ``app`` with the help above and ``-h`` beside ``--help`` everywhere;
    ``commands``, when given, are its (lazy) commands instead of those registered on ``app``."""
    command = typer.main.get_command(app)
    if commands is not None:
        command.commands = commands
    command.context_settings = {**command.context_settings, "help_option_names": HELP_OPTION_NAMES}
    _with_help(command)
    return command
