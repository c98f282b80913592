"""The import layers of docs/architecture.md: the contracts exist, hold, and catch a break.

``make test`` runs ``lint-imports`` before pytest; these tests check the same contracts from
inside the suite, that a deliberately broken copy of the package fails them, and the one
exception they allow (the lazy ``.plot()`` delegates into report/).
"""

import ast
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SRC = REPO / "src" / "surfhap"
LINT = Path(sys.executable).parent / "lint-imports"

# top to bottom, as in pyproject.toml and docs/architecture.md
LAYERS = ["cli | texture | io", "web", "report", "lab | (batch)", "fit | live", "sim", "runtime", "render | ff", "shape", "exchange", "models", "signal"]


def _contracts() -> dict[str, dict]:
    cfg = tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["importlinter"]
    return {c["id"]: c for c in cfg["contracts"]}


def _lint(config: Path, src: Path) -> subprocess.CompletedProcess:
    env = {"PYTHONPATH": str(src), "PATH": str(Path(sys.executable).parent)}
    return subprocess.run([str(LINT), "--config", str(config), "--no-cache"], cwd=config.parent, env=env,
                          capture_output=True, text=True, timeout=300)


def test_the_contracts_are_the_documented_ones():
    contracts = _contracts()
    assert contracts["layers"]["layers"] == LAYERS
    assert contracts["layers"]["exhaustive"] is True
    assert set(contracts["report-reads"]["forbidden_modules"]) >= {"surfhap.fit", "surfhap.sim", "surfhap.live",
                                                                    "surfhap.lab"}
    doc = (REPO / "docs" / "architecture.md").read_text()
    for layer in LAYERS:  # "(batch)": an optional layer, for the batch package of issue 12 item 2
        assert layer.replace(" | ", "|").replace("(", "").replace(")", "") in doc.replace(" | ", "|"), layer


def test_the_package_keeps_its_contracts():
    res = _lint(REPO / "pyproject.toml", REPO / "src")
    assert res.returncode == 0, res.stdout + res.stderr
    assert "0 broken" in res.stdout


def _broken_copy(tmp_path: Path, module: str, line: str) -> subprocess.CompletedProcess:
    shutil.copytree(SRC, tmp_path / "src" / "surfhap", ignore=shutil.ignore_patterns("__pycache__", "builtin",
                                                                                       "static", "data"))
    shutil.copy(REPO / "pyproject.toml", tmp_path / "pyproject.toml")
    target = tmp_path / "src" / "surfhap" / module
    target.write_text(target.read_text() + f"\n\ndef _layer_break():\n    {line}\n")
    return _lint(tmp_path / "pyproject.toml", tmp_path / "src")


def test_an_upward_import_breaks_the_layers(tmp_path):
    # a lazy import counts: the models layer may not reach up to the renderer
    res = _broken_copy(tmp_path, "models/texture.py", "from surfhap.render.chain import TextureChain")
    assert res.returncode == 1, res.stdout + res.stderr
    assert "surfhap.models.texture -> surfhap.render.chain" in res.stdout


def test_the_renderers_below_the_runtime_cannot_import_it(tmp_path):
    # issue 20: the runtime sits above render|ff; nothing below it imports it
    res = _broken_copy(tmp_path, "render/chain.py", "from surfhap.runtime.loop import run")
    assert res.returncode == 1, res.stdout + res.stderr
    assert "surfhap.render.chain -> surfhap.runtime.loop" in res.stdout


def test_report_importing_a_fit_breaks_its_contract(tmp_path):
    res = _broken_copy(tmp_path, "report/fit_report.py", "from surfhap.fit.accel import AccelFit")
    assert res.returncode == 1, res.stdout + res.stderr
    assert "report/ reads results" in res.stdout.split("Broken contracts")[1]


def test_a_backend_importing_the_registry_breaks_it(tmp_path):
    res = _broken_copy(tmp_path, "live/backends/sim.py", "from surfhap.live.backends.output import open_backend")
    assert res.returncode == 1, res.stdout + res.stderr
    assert "surfhap.live.backends.sim -> surfhap.live.backends.output" in res.stdout


def _report_imports():
    """(file, enclosing function names) of every import of surfhap.report outside report/ and cli/."""
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC)
        if rel.parts[0] in ("report", "cli"):
            continue
        tree = ast.parse(path.read_text(), filename=str(path))
        stack: list[str] = []

        def visit(node):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                stack.append(node.name)
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("surfhap.report"):
                yield str(rel), tuple(stack)
            if isinstance(node, ast.Import) and any(a.name.startswith("surfhap.report") for a in node.names):
                yield str(rel), tuple(stack)
            for child in ast.iter_child_nodes(node):
                yield from visit(child)
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                stack.pop()

        yield from visit(tree)


def test_only_plot_methods_reach_up_into_report():
    """The contracts ignore imports into report/; each one must be the lazy body of a
    ``plot`` method (computing and plotting are separate calls), never a module-level import."""
    found = list(_report_imports())
    assert len(found) >= 10  # the delegates exist: the check looks at real imports
    bad = [(f, fn) for f, fn in found if not fn or fn[-1] != "plot"]
    assert not bad, f"imports of surfhap.report outside a plot() method: {bad}"
