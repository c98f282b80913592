"""What the commands print and write (issue 21 items 1-3): piped result lines are whole,
unstyled lines and ``--json`` is one JSON object; an existing non-empty ``--out`` is refused
unless ``--overwrite`` (the one guard, on every command that has ``--out``); built-in shape
names work for ``serve --mesh``; ``--help`` imports nothing heavy."""

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from surfhap.cli import main, root_command
from surfhap.exchange.trajectory_csv import write_trajectory_csv
from surfhap.models.trajectory import Trajectory

REPO = Path(__file__).resolve().parents[1]
SCAN = "speed=0.1,load=0.5,duration=0.3"


def _run(capsys, args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    assert code == 0, err
    return out


# each report command, and two pieces of its summary that must sit on one line (not hard-wrapped)
REPORTS = {
    "play": (["play", "cork", "--clock", "sim", "--scan", SCAN], ("cork", "underruns")),
    "render": (["render", "cork", "--scan", SCAN, "--out", "{tmp}/r", "--no-figure"], ("cork", "saturated")),
    "ff simulate": (["ff", "simulate", "follow", "--out", "{tmp}/ff", "--no-figures"], ("|Fx|", "effect switches")),
    "shape": (["shape", "gaussian-bump", "--scan=-0.02,0,0.02,0,0.1", "--out", "{tmp}/s", "--no-figure"],
              ("gaussian-bump", "edge ticks")),
    "compare": (["compare", "cork", "wood", "--duration", "1"], ("cork", "otake")),
    "materials": (["materials"], ("leather", "otake")),
    "shape profile": (["shape", "profile", "bump", "--out", "{tmp}/p"], ("force", "intensity")),
}


@pytest.mark.parametrize("name", REPORTS)
def test_piped_results_are_whole_plain_lines_and_json(tmp_path, capsys, monkeypatch, name):
    monkeypatch.setenv("COLUMNS", "40")  # narrower than every summary: a hard wrap would show
    args, (a, b) = REPORTS[name]
    out = _run(capsys, [str(x).format(tmp=tmp_path / "plain") for x in args])
    assert "\x1b[" not in out and "…" not in out
    assert any(a in line and b in line for line in out.splitlines()), out
    assert max(len(line) for line in out.splitlines()) > 40
    doc = json.loads(_run(capsys, [str(x).format(tmp=tmp_path / "json") for x in args] + ["--json"]))
    assert isinstance(doc, dict) and doc


def test_play_and_ff_simulate_say_what_happened_in_words(tmp_path, capsys):
    play = _run(capsys, ["play", "cork", "--clock", "sim", "--scan", SCAN])
    assert not play.lstrip().startswith("{") and "samples" in play and "clamped" in play
    ff = _run(capsys, ["ff", "simulate", "follow", "--out", tmp_path / "ff", "--no-figures"])
    assert "[" not in ff and "|Fz|" in ff  # not 'max |F| [1.5503212684627685, ...]'
    summary = json.loads((tmp_path / "ff" / "summary.json").read_text())
    assert f"|Fx| {summary['force_abs_max_N'][0]:.2f}" in ff


def test_compare_table_keeps_whole_names(capsys, monkeypatch):
    monkeypatch.setenv("COLUMNS", "40")
    out = _run(capsys, ["compare", "cork", "leather", "wood", "--duration", "1"]).splitlines()
    rows = [line.split("\t") for line in out[1:] if "\t" in line]
    assert [r[0] for r in rows] == ["cork", "leather", "wood"]
    assert all(r[1].startswith(("otake20", "zhao", "friction", "square")) and "…" not in r[1] for r in rows)


def _commands_with_out():
    def walk(cmd, path=()):
        yield path, cmd
        for n, sub in getattr(cmd, "commands", {}).items():
            yield from walk(sub, (*path, n))

    return [(" ".join(p), c) for p, c in walk(root_command())
            if any("--out" in prm.opts for prm in c.params)]


def test_every_command_with_out_takes_overwrite():
    """One guard: every command that writes --out offers --overwrite (study new refuses a study
    folder itself; fit imu's --out defaults to its --into, which it updates by design)."""
    found = _commands_with_out()
    assert len(found) >= 12
    lacking = [p for p, c in found if not any("--overwrite" in prm.opts for prm in c.params)]
    assert lacking == ["study new"], lacking


@pytest.mark.parametrize("kind", ["folder", "file"])
def test_existing_out_is_refused_with_one_line_unless_overwrite(tmp_path, capsys, kind):
    if kind == "folder":
        target = tmp_path / "r"
        target.mkdir()
        (target / "keep.txt").write_text("mine")
        args = ["render", "cork", "--scan", SCAN, "--out", target, "--no-figure"]
    else:
        target = tmp_path / "cmp.png"
        target.write_bytes(b"mine")
        args = ["compare", "cork", "--duration", "1", "--out", target]
    assert main([str(a) for a in args]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert len(err) == 1 and "--out" in err[0] and str(target) in err[0] and "--overwrite" in err[0], err
    assert (target / "keep.txt").read_text() == "mine" if kind == "folder" else target.read_bytes() == b"mine"
    _run(capsys, [*args, "--overwrite"])
    assert (target / "summary.json").is_file() if kind == "folder" else target.read_bytes() != b"mine"
    empty = tmp_path / "empty"
    empty.mkdir()  # an existing but empty folder is fine
    _run(capsys, ["render", "cork", "--scan", SCAN, "--out", empty, "--no-figure"])


def test_serve_takes_a_built_in_shape_name_as_shape_does(tmp_path, capsys):
    t = np.arange(0.0, 0.5, 1 / 125)
    csv = write_trajectory_csv(Trajectory(t, 0.05 + 0.02 * t, np.full(t.size, 0.03), np.full(t.size, 0.5)),
                               tmp_path / "t.csv")
    out = _run(capsys, ["serve", "--mesh", "gaussian-bump", "--clock", "sim", "--trajectory", csv, "--json"])
    assert "gaussian-bump" in json.loads(out)["material"]
    assert main(["serve", "--mesh", "no-such-mesh", "--clock", "sim", "--trajectory", str(csv)]) == 2
    assert "not a built-in shape" in capsys.readouterr().err


def test_fit_imu_takes_a_built_in_material_as_its_base_but_never_writes_it_back(capsys):
    assert main(["fit", "imu", "x.csv", "--into", "cork"]) == 2
    assert "--out" in capsys.readouterr().err


@pytest.mark.parametrize("args", [["--help"], ["render", "--help"], ["shape", "-h"], ["fit", "friction", "-h"],
                                  ["study", "run", "-h"], ["render", "cork", "--no-such-option"]])
def test_help_and_usage_errors_import_nothing_heavy(args):
    """Start-up is measured by benchmarks/bench_cli_startup.py; this checks its cause: --help and a
    usage error import no numpy, scipy, numba, matplotlib, pydantic or typer's rich help."""
    code = textwrap.dedent(f"""
        import sys
        from surfhap.cli import main
        main({args!r})
        heavy = {{"numpy", "scipy", "numba", "matplotlib", "pydantic", "typer.rich_utils"}}
        print("HEAVY=" + ",".join(sorted(m for m in heavy if m in sys.modules)), file=sys.stderr)
    """)
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"))
    proc = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert "HEAVY=\n" in proc.stderr, proc.stderr


def test_progress_and_status_show_on_a_terminal_only(capsys, monkeypatch):
    """A bar or spinner on a terminal's stderr; piped, nothing at all (the demo printed blank
    lines from a bar drawn into a pipe)."""
    import io

    from rich.console import Console

    from surfhap.cli import _common

    with _common.progress_bar("rendering") as update, _common.status_line("writing figures"):
        update(0.5)
    assert capsys.readouterr().err == ""
    term = io.StringIO()
    monkeypatch.setattr(_common, "stderr", lambda: Console(file=term, force_terminal=True, width=80))
    with _common.progress_bar("rendering") as update:
        update(0.5)
    with _common.status_line("writing figures"):
        pass
    assert "rendering" in term.getvalue() and "writing figures" in term.getvalue()


def test_json_output_is_strict_json_for_numpy_and_non_finite_values(capsys):
    """``--json`` goes through surfhap.results.jsonable: numpy scalars and arrays are numbers,
    a non-finite value is null (Python's json would write NaN, which no strict parser reads),
    a path is its text."""
    from surfhap.cli._common import report

    report({"a": np.float32(1.5), "b": np.arange(2), "c": float("nan"), "d": np.inf, "p": Path("x/y")}, [], True)
    line = capsys.readouterr().out

    def refuse(token):
        raise ValueError(token)

    assert json.loads(line, parse_constant=refuse) == {"a": 1.5, "b": [0, 1], "c": None, "d": None, "p": "x/y"}
