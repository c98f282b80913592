"""``make bench`` contract: each benchmark prints only JSON lines on stdout, each with a
boolean "pass", and exits non-zero when a figure misses its target (the figures themselves
are timing and are not judged here)."""

import ast
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
BENCH = REPO / "benchmarks"
SCRIPTS = sorted(BENCH.glob("bench_*.py"))


def run_script(path: Path, *args: str, timeout: float = 600.0) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(BENCH), str(REPO / "src")]))
    return subprocess.run([sys.executable, str(path), *args], env=env, capture_output=True, text=True,
                          timeout=timeout, cwd=BENCH)


def json_lines(stdout: str) -> list[dict]:
    lines = stdout.splitlines()
    rows = [json.loads(ln) for ln in lines]  # every stdout line is JSON, or this raises
    assert all(isinstance(r.get("pass"), bool) for r in rows), rows
    return rows


FAKE = """
from _common import emit, report, run

def main():
    print("progress: this must go to stderr")
    for i, ok in enumerate({verdicts!r}):
        report(f"fake{{i}}", {{"value": i}}, 1.0 if ok else 0.5, "a target", ok)
    if {extra_row}:
        emit({{"figure": "row", "pass": True}})
    if {crash}:
        raise RuntimeError("the benchmark broke")

run(main)
"""


@pytest.mark.parametrize("verdicts,extra_row,crash,code", [
    ([True, True], True, False, 0),
    ([True, False], True, False, 1),
    ([False], False, False, 1),
    ([], False, False, 1),  # a benchmark that reported nothing did not meet its target
    ([True], False, True, 1),
])
def test_exit_code_and_stdout_of_the_common_runner(tmp_path, verdicts, extra_row, crash, code):
    script = tmp_path / "bench_fake.py"
    script.write_text(FAKE.format(verdicts=verdicts, extra_row=extra_row, crash=crash))
    r = run_script(script)
    assert r.returncode == code, r.stderr
    rows = json_lines(r.stdout)
    assert [row["pass"] for row in rows] == verdicts + ([True] if extra_row else [])
    assert "progress: this must go to stderr" in r.stderr
    if code and not crash and verdicts:
        assert "missed target" in r.stderr


def test_a_row_without_a_verdict_is_refused(tmp_path):
    script = tmp_path / "bench_fake.py"
    script.write_text("from _common import emit, run\nrun(lambda: emit({'figure': 'x'}))\n")
    r = run_script(script)
    assert r.returncode != 0 and r.stdout == ""


@pytest.mark.parametrize("path", SCRIPTS, ids=[p.name for p in SCRIPTS])
def test_every_benchmark_reports_through_the_common_runner(path):
    """Each script's entry point is ``run(main)`` and nothing else prints to stdout."""
    tree = ast.parse(path.read_text())
    guard = [n for n in tree.body if isinstance(n, ast.If) and "__main__" in ast.unparse(n.test)]
    assert guard and any(ast.unparse(s) == "run(main)" for s in guard[0].body), path.name
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and getattr(node.func, "id", None) == "print":
            assert any(k.arg == "file" for k in node.keywords), f"{path.name}: print to stdout"


def test_cli_startup_benchmark_exit_matches_its_verdict():
    r = run_script(BENCH / "bench_cli_startup.py", "--runs", "2")
    rows = json_lines(r.stdout)
    assert len(rows) == 1 and rows[0]["benchmark"] == "cli_startup", r.stderr
    row = rows[0]
    assert row["help_s"] > 0 and row["materials_s"] > 0 and row["python_pass_s"] > 0
    assert r.returncode == (0 if row["pass"] else 1), r.stderr
    quick = [v for k, v in row.items() if k.endswith("_s") and k not in ("materials_s", "python_pass_s", "help_target_s", "target_s")]
    assert len(quick) >= 8 and "usage_missing_argument_s" in row and "render_help_s" in row
    assert row["pass"] == (max(quick) <= row["help_target_s"] and row["materials_s"] <= row["target_s"])
