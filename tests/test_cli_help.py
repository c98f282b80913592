"""Help at any width (issue 21 item 1): every command's and sub-command's help at 60 and 200
columns names every option with its whole help text (wrapped, never cut with '…'), shows no
``<bool>``-style type labels, and keeps within the width; ``-h`` works everywhere."""

import re

import pytest
from rich.text import Text

from live_support.cli_commands import all_commands
from surfhap.cli import main


def _squash(text: str) -> str:
    """Whitespace-free text: a help text wrapped over lines (even inside a word) still matches."""
    return "".join(text.split())


@pytest.mark.parametrize("columns,flag", [(60, "-h"), (200, "--help")])
@pytest.mark.parametrize("path,command", all_commands(), ids=lambda v: " ".join(v) if isinstance(v, tuple) else "")
def test_help_names_every_option_whole_at_any_width(capsys, monkeypatch, columns, flag, path, command):
    monkeypatch.setenv("COLUMNS", str(columns))
    code = main([*path, flag])
    out, err = capsys.readouterr()
    assert code == 0, err
    assert "…" not in out and "Traceback" not in out + err
    assert not re.search(r"<(bool|str|int|float|path|list\[\w+\])( range)?>", out), out  # typer's type labels
    assert max(len(line) for line in out.splitlines()) <= columns, out
    flat = _squash(out)
    for param in command.params:
        if param.hidden:
            continue
        for name in (*param.opts, *param.secondary_opts) if param.param_type_name == "option" else ():
            assert re.search(rf"(^|[\s,]){re.escape(name)}([\s,]|$)", out, re.M), (name, out)
        assert _squash(Text.from_markup(param.help or "").plain) in flat, (param.name, out)
    for name, sub in getattr(command, "commands", {}).items():  # a group lists each command's whole summary
        if not sub.hidden:
            assert name in out and _squash(Text.from_markup((sub.help or "").split("\n\n")[0]).plain) in flat


def test_the_old_truncation_is_gone(capsys, monkeypatch):
    """The issue's case: render's --scan format was cut to 'speed=M/S,load=N,du…' at 80 columns."""
    monkeypatch.setenv("COLUMNS", "80")
    assert main(["render", "--help"]) == 0
    flat = _squash(capsys.readouterr().out)
    assert "'speed=M/S,load=N,duration=S[,length=Mforback-and-forthstrokes][,rate=HZsensorrate]'" in flat
    assert "'k=N/V^2,mu_panel=..,area=m^2[,leakage=s]'" in flat
