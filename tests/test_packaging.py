"""The package as pip installs it: every import is declared, and ``pip install surfhap``
without extras gives a command line that starts and renders."""

import ast
import os
import re
import shutil
import subprocess
import sys
import tomllib
from functools import cache
from importlib.metadata import packages_distributions
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SRC = REPO / "src" / "surfhap"


def _norm(name: str) -> str:
    return re.sub(r"[-_.]+", "-", name).lower()


def _requirement_names(reqs: list[str]) -> set[str]:
    return {_norm(re.match(r"[A-Za-z0-9._-]+", r).group(0)) for r in reqs}


def _declared() -> tuple[set[str], dict[str, set[str]]]:
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    extras = {k: _requirement_names(v) for k, v in project.get("optional-dependencies", {}).items()}
    return _requirement_names(project["dependencies"]), extras


def _distributions(import_name: str) -> set[str]:
    """Distribution names that provide a top-level import (the import name itself when the
    distribution is not installed here, e.g. an extra that `make test` does not install)."""
    return {_norm(d) for d in _installed().get(import_name, [import_name])}


@cache
def _installed() -> dict[str, list[str]]:
    """Top-level import -> distributions, read once: every installed file is walked, which took
    seconds per import checked."""
    return packages_distributions()


def _third_party_imports(root: Path):
    """(file, top-level import name, at module level?) for every absolute import under root
    that is neither the standard library, surfhap, nor a module of root itself."""
    local = {p.stem for p in root.rglob("*.py")} | {p.name for p in root.rglob("*") if p.is_dir()}
    for path in sorted(root.rglob("*.py")):
        tree = ast.parse(path.read_text(), filename=str(path))
        module_level = {id(n) for n in tree.body}
        for stmt in tree.body:  # module-level try/if blocks still run at import time
            if isinstance(stmt, (ast.Try, ast.If)):
                module_level |= {id(n) for n in ast.walk(stmt)}
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                names = [node.module]
            else:
                continue
            for name in names:
                top = name.split(".")[0]
                if top in sys.stdlib_module_names or top == "surfhap" or top in local:
                    continue
                yield path.relative_to(REPO), top, id(node) in module_level


def test_every_import_of_the_package_is_declared():
    core, extras = _declared()
    anywhere = core.union(*extras.values())
    undeclared = sorted({(str(f), name) for f, name, _ in _third_party_imports(SRC)
                         if not _distributions(name) & anywhere})
    assert not undeclared, f"imported but not in pyproject dependencies or extras: {undeclared}"


def test_module_level_imports_need_no_extra():
    """What runs on ``import`` must come with ``pip install surfhap``; an extra (live, dask)
    may only be imported inside the function that needs it (the live package may import its
    own extra: the CLI checks for it and names the extra to install)."""
    core, extras = _declared()
    bad = sorted({(str(f), name) for f, name, top_level in _third_party_imports(SRC)
                  if top_level and not _distributions(name) & core
                  and not (f.parts[2] == "live" and _distributions(name) & extras["live"])})
    assert not bad, f"module-level imports of optional or undeclared packages: {bad}"


def _make_test_extras(extras: dict) -> set:
    """Distributions of the extras the Makefile installs for `make test` (``-e ".[a,b]"``)."""
    found = re.search(r'-e "\.\[([^\]]+)\]"', (REPO / "Makefile").read_text())
    assert found, "the Makefile installs surfhap with its extras"
    names = [n.strip() for n in found.group(1).split(",")]
    assert {"dev", "live", "lsl", "dask"} <= set(names), names
    return set().union(*(extras[n] for n in names))


def test_tests_and_benchmarks_imports_are_declared():
    core, extras = _declared()
    allowed = core | _make_test_extras(extras)
    missing = sorted({(str(f), name) for root in (REPO / "tests", REPO / "benchmarks")
                      for f, name, _ in _third_party_imports(root) if not _distributions(name) & allowed})
    assert not missing, f"imported by tests/benchmarks but not in dependencies or the extras make test installs: {missing}"


def _copy_tree(dest: Path) -> Path:
    """The files a build needs, without caches or an in-tree egg-info (pip builds in place)."""
    dest.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy2(REPO / name, dest / name)
    shutil.copytree(REPO / "src", dest / "src",
                    ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.egg-info"))
    return dest


@pytest.mark.slow
@pytest.mark.install
def test_pip_install_without_extras_gives_a_working_cli(tmp_path):
    """A fresh virtual environment, ``pip install <tree>`` (not editable, no extras): the
    command line starts, lists and renders, and the live commands name the extra to install."""
    tree = _copy_tree(tmp_path / "tree")
    venv = tmp_path / "venv"
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV", "PYTHONHOME")}
    env.update(PIP_DISABLE_PIP_VERSION_CHECK="1", COLUMNS="100")
    subprocess.run([sys.executable, "-m", "venv", str(venv)], check=True, env=env, timeout=300)
    py, exe = venv / "bin" / "python", venv / "bin" / "surfhap"
    install = subprocess.run([str(py), "-m", "pip", "install", "--quiet", str(tree)], env=env,
                             capture_output=True, text=True, timeout=1800)
    assert install.returncode == 0, install.stdout[-3000:] + install.stderr[-3000:]

    def surfhap(*args, cmd=(str(exe),)):
        return subprocess.run([*cmd, *args], env=env, cwd=tmp_path, capture_output=True, text=True, timeout=600)

    # the installed copy is what runs, not the source tree
    where = subprocess.run([str(py), "-c", "import surfhap; print(surfhap.__file__)"], env=env, cwd=tmp_path,
                           capture_output=True, text=True, timeout=120)
    assert str(venv) in where.stdout, where.stdout + where.stderr

    helped = surfhap("--help")
    assert helped.returncode == 0 and "materials" in helped.stdout, helped.stderr
    version = surfhap("--version")
    expected = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["version"]
    assert version.returncode == 0 and version.stdout.strip() == f"surfhap {expected}", version.stderr
    listed = surfhap("materials")
    assert listed.returncode == 0 and "leather" in listed.stdout, listed.stderr
    via_m = surfhap("-m", "surfhap", "--help", cmd=(str(py),))
    assert via_m.returncode == 0 and "materials" in via_m.stdout, via_m.stderr
    rendered = surfhap("render", "cork", "--scan", "speed=0.1,load=0.3,duration=0.3", "--out", str(tmp_path / "r"))
    assert rendered.returncode == 0, rendered.stderr
    assert (tmp_path / "r" / "render.npz").is_file() and (tmp_path / "r" / "figure.png").is_file()

    for args in (["serve", "--duration", "0.1"], ["devices"]):
        live = surfhap(*args)
        assert live.returncode == 2, live.stdout + live.stderr
        lines = [ln for ln in live.stderr.splitlines() if ln.strip()]
        assert len(lines) == 1 and "surfhap[live]" in lines[0], live.stderr


def test_tests_do_not_skip_on_the_project_or_its_declared_dependencies():
    """``pytest.importorskip`` turns a broken import into a silent skip: allowed only for
    packages that `make test` does not install."""
    core, extras = _declared()
    installed_by_make_test = core | _make_test_extras(extras)
    offenders = []
    for path in sorted((REPO / "tests").rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.Call) and getattr(node.func, "attr", None) == "importorskip"
                    and node.args and isinstance(node.args[0], ast.Constant)):
                top = str(node.args[0].value).split(".")[0]
                if top == "surfhap" or _distributions(top) & installed_by_make_test:
                    offenders.append((path.name, node.args[0].value))
    assert not offenders, f"import these normally: {offenders}"
