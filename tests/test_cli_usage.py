"""The command line as a new user meets it: usage errors, --help of every command, --version,
``python -m surfhap``, missing extras, and a start-up that imports nothing heavy."""

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
import typer
from rich.text import Text

import surfhap
from live_support.cli_commands import all_commands
from surfhap.cli import main

REPO = Path(__file__).resolve().parents[1]
HEAVY = ("numba", "scipy", "matplotlib", "trimesh", "statsmodels", "fastapi", "uvicorn", "PIL", "joblib")


def run(capsys, *args):
    code = main(list(args))
    out = capsys.readouterr()
    return code, out.out, out.err


def run_python(code: str, *args: str, timeout: float = 300.0) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(REPO / "src"), COLUMNS="100")
    return subprocess.run([sys.executable, *args, "-c", code] if code else [sys.executable, *args], env=env,
                          capture_output=True, text=True, timeout=timeout)


def one_error_line(err: str) -> str:
    lines = [ln for ln in err.splitlines() if ln.strip()]
    assert len(lines) == 1, err
    assert "Traceback" not in err
    return lines[0]


@pytest.mark.parametrize("args,words", [
    (["render"], "Missing argument"),
    (["render", "cork", "--no-such-option"], "No such option: --no-such-option"),
    (["--no-such-option"], "No such option"),
    (["no-such-command"], "No such command 'no-such-command'"),
    (["demo", "--duration", "0"], "--duration"),
    (["render", "cork", "--drive-rate", "abc"], "--drive-rate"),
    (["render", "cork", "--scan"], "--scan"),
    (["shape", "calibrate"], "Missing argument"),
    (["fit", "friction"], "Missing argument"),
    (["fit", "no-such-fit"], "No such command"),
    (["import", "hatt", "--out"], "--out"),
    (["serve", "--port", "eighty"], "--port"),
    (["play"], "Missing argument"),
])
def test_usage_errors_are_one_line_and_exit_2(capsys, args, words):
    code, _, err = run(capsys, *args)
    assert code == 2, err
    line = one_error_line(err)
    assert line.startswith("error: ") and words in line


def test_bare_group_shows_help_and_exits_2(capsys):
    code, out, err = run(capsys, "fit")
    assert code == 2
    assert "friction" in out + err and "Traceback" not in out + err


def test_typer_exit_code_is_returned(capsys, monkeypatch):
    """A command that exits with typer.Exit(n) gives n, not 0 (typer returns it when not standalone)."""
    from surfhap.cli._common import fail

    probe = typer.Typer()

    @probe.command()
    def bad() -> None:
        fail("a [bracketed] message\nover two lines")

    @probe.command()
    def good() -> None:
        pass

    from surfhap.cli._common import run_guarded
    from surfhap.cli._help import command_tree

    assert run_guarded(command_tree(probe), ["good"]) == 0
    assert run_guarded(command_tree(probe), ["bad"]) == 2
    line = one_error_line(capsys.readouterr().err)
    assert line == "error: a [bracketed] message over two lines"


def test_the_walk_finds_every_command_group():
    paths = {" ".join(p) for p, _ in all_commands()}
    for expected in ("", "render", "materials", "demo", "fit friction", "fit accel", "fit imu", "import hatt",
                     "shape", "scenes", "serve", "devices", "play"):
        assert expected in paths, sorted(paths)


@pytest.mark.parametrize("path", [" ".join(p) for p, _ in all_commands()])
def test_help_of_every_command(capsys, path):
    code, out, err = run(capsys, *path.split(), "--help")
    assert code == 0, err
    assert "Usage:" in out and "Traceback" not in out + err
    assert len(out.strip().splitlines()) >= 3


def test_help_texts_survive_rich_markup():
    """Help strings are rendered as rich markup: a '[/...]' or '[word]' would crash or vanish.
    Every text must come out as written (``\\[`` is the escape for a literal bracket)."""
    garbled = []
    for path, command in all_commands():
        texts = [command.help or ""] + [getattr(p, "help", None) or "" for p in command.params]
        garbled += [(" ".join(path), text) for text in texts
                    if Text.from_markup(text).plain != text.replace("\\[", "[")]
    assert not garbled


def test_version_and_python_m():
    version = run_python("", "-m", "surfhap", "--version")
    assert version.returncode == 0, version.stderr
    assert version.stdout.strip() == f"surfhap {surfhap.__version__}"
    assert surfhap.__version__[0].isdigit()
    helped = run_python("", "-m", "surfhap", "--help")
    assert helped.returncode == 0 and "materials" in helped.stdout, helped.stderr
    bad = run_python("", "-m", "surfhap", "render")
    assert bad.returncode == 2
    assert one_error_line(bad.stderr).startswith("error: Missing argument")


def test_version_matches_the_installed_distribution():
    from importlib.metadata import version

    assert surfhap.__version__ == version("surfhap")


@pytest.mark.parametrize("args", [["--help"], ["materials"], ["serve", "--help"], ["render", "--help"]])
def test_startup_imports_nothing_heavy(args):
    """Commands register without importing numba, scipy, matplotlib, ... (a correctness check of
    lazy imports; the time it buys is measured by benchmarks/bench_cli_startup.py)."""
    code = textwrap.dedent(f"""
        import sys
        from surfhap.cli import main
        code = main({args!r})
        heavy = sorted({{m.split('.')[0] for m in sys.modules}} & set({HEAVY!r}))
        print("HEAVY=" + ",".join(heavy), file=sys.stderr)
        sys.exit(code)
    """)
    proc = run_python(code)
    assert proc.returncode == 0, proc.stderr
    assert "HEAVY=\n" in proc.stderr, proc.stderr


def test_import_surfhap_is_lazy_but_complete():
    proc = run_python(textwrap.dedent(f"""
        import sys
        import surfhap as sh
        loaded = sorted({{m.split('.')[0] for m in sys.modules}} & set({HEAVY!r}))
        assert not loaded, loaded
        import surfhap.render.chain
        # no public name shadows a subpackage: sh.render is the package, the renderer is sh.texture.render
        assert sh.render is sys.modules["surfhap.render"]
        assert sh.texture.render.__module__ == "surfhap.runtime.offline"
        for ns in (sh, sh.texture, sh.io, sh.lab):
            for name in ns.__all__:
                getattr(ns, name)
            assert set(ns.__all__) <= set(dir(ns))
        subpackages = {{m.split(".")[1] for m in sys.modules if m.startswith("surfhap.")}}
        assert not subpackages & set(sh.__all__), subpackages & set(sh.__all__)
        print("ok")
    """))
    assert proc.returncode == 0 and proc.stdout.strip() == "ok", proc.stderr


BLOCK_EXTRAS = textwrap.dedent("""
    import sys
    class Block:
        def find_spec(self, name, path=None, target=None):
            if name.split(".")[0] in {blocked!r}:
                raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
    sys.meta_path.insert(0, Block())
    from surfhap.cli import main
    sys.exit(main({args!r}))
""")


@pytest.mark.parametrize("args,extra", [
    (["serve", "--duration", "0.1"], "live"),
    (["devices"], "live"),
    (["play", "cork", "--output", "sound", "--scan", "speed=0.1,load=0.3,duration=0.1"], "live"),
    (["play", "cork", "--output", "osc://127.0.0.1:9", "--scan", "speed=0.1,load=0.3,duration=0.1"], "live"),
])
def test_missing_live_extra_is_one_line_exit_2(args, extra):
    blocked = ["fastapi", "starlette", "uvicorn", "websockets", "pythonosc", "sounddevice"]
    proc = run_python(BLOCK_EXTRAS.format(blocked=blocked, args=args))
    assert proc.returncode == 2, proc.stderr
    line = one_error_line(proc.stderr)
    assert f"pip install 'surfhap[{extra}]'" in line


def test_a_pydantic_validation_error_from_a_parameter_type_is_one_line(capsys):
    """A parameter type validated by pydantic and built straight from an option (here the grain
    parameters of a shape render, through a bad edge gain) reports its first error as one
    ``field: message`` line, exit 2, not pydantic's multi-line dump."""
    from pydantic import BaseModel, ValidationError, field_validator

    from surfhap.cli._common import _error_text

    class P(BaseModel):
        x: float

        @field_validator("x")
        @classmethod
        def positive(cls, v):
            if v <= 0:
                raise ValueError("must be > 0")
            return v

    try:
        P(x=-1)
    except ValidationError as exc:
        line = _error_text(exc)
    assert line == "x: must be > 0"
