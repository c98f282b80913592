"""``--help`` that reads well at any width, and the click command tree the CLI runs.

typer's rich help puts each option's help in a table column whose overflow is an ellipsis,
so a value format longer than the column ('speed=M/S,load=N,duration=S[,length=M...') was cut
to 'speed=M/S,load=N,du…', and it labels flags ``<bool>``. This formatter writes plain text
wrapped to the terminal (long words are broken, never cut), names every option with its
metavar (none for flags), default and range, and lists each sub-command's whole first
paragraph. It imports neither ``typer.rich_utils`` nor pydantic, so ``--help`` starts fast.

``-h`` is accepted beside ``--help`` by every command (the root's context setting).
"""

from __future__ import annotations

import inspect
import shutil
import textwrap

import typer
from rich.text import Text
from typer.core import TyperArgument, TyperGroup, TyperOption

__all__ = ["command_tree"]

HELP_OPTION_NAMES = ["-h", "--help"]


def _plain(text: str | None) -> str:
    """Help text as plain words: rich markup (``\\[`` escapes) resolved, paragraphs kept."""
    paragraphs = inspect.cleandoc(text or "").partition("\f")[0].split("\n\n")
    return "\n\n".join(" ".join(Text.from_markup(p).plain.split()) for p in paragraphs if p.strip())


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
    if isinstance(self, TyperGroup):
        cmds = [(n, c) for n in self.list_commands(ctx) if (c := self.get_command(ctx, n)) and not c.hidden]
        lines += _section("Commands", [(n, _plain(c.help).split("\n\n")[0]) for n, c in cmds], width)
    formatter.write("\n".join(lines) + "\n")


def _get_help_option(self, ctx):
    """``get_help_option``: the help flag defaults to False, not None (typer coerces a non-bool
    flag value through a pydantic TypeAdapter: 0.15 s of start-up for every command)."""
    option = super(type(self), self).get_help_option(ctx)
    if option is not None and option.default is None:
        option.default = False
    return option


_classes: dict[type, type] = {}


def _with_help(command) -> None:
    """Give ``command`` and its sub-commands the two methods above (the class becomes a subclass
    holding them; typer builds the commands, so this is the one place all of them pass)."""
    cls = type(command)
    if cls not in _classes.values():
        methods = {"format_help": _format_help, "get_help_option": _get_help_option}
        command.__class__ = _classes.setdefault(cls, type(cls.__name__, (cls,), methods))
    if isinstance(command, TyperGroup):
        for sub in command.commands.values():
            _with_help(sub)


def command_tree(app: typer.Typer, argv: list[str] = ()):
    """The click command of ``app`` with the help above and ``-h`` beside ``--help`` everywhere.
    Only the command ``argv`` names is built when it names one (building all of them is a
    third of the start-up); the whole tree otherwise (the root's help, an unknown name)."""
    name = next((a for a in argv if not a.startswith("-")), None)
    commands = [c for c in app.registered_commands if c.name == name]
    groups = [g for g in app.registered_groups if g.name == name]
    if commands or groups:
        trimmed = typer.Typer(add_completion=False)
        trimmed.info, trimmed.registered_callback = app.info, app.registered_callback
        trimmed.registered_commands, trimmed.registered_groups = commands, groups
        app = trimmed
    command = typer.main.get_command(app)
    command.context_settings = {**command.context_settings, "help_option_names": HELP_OPTION_NAMES}
    _with_help(command)
    return command
