"""rtree is a test/benchmark dependency only (the dev extra): nothing surfhap runs needs it.

trimesh uses rtree for its own ray and proximity queries, which surfhap does not call (its
top-surface index is its own). This runs the mesh paths of the command line with rtree made
unimportable and checks that they work.
"""

import subprocess
import sys
import tomllib
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]

_BLOCK = """
import sys
class _NoRtree:
    def find_spec(self, name, path=None, target=None):
        if name == "rtree" or name.startswith("rtree."):
            raise ImportError("rtree blocked by the test")
sys.meta_path.insert(0, _NoRtree())
from surfhap.cli import main
raise SystemExit(main(sys.argv[1:]))
"""


def test_rtree_is_only_a_dev_dependency():
    project = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]
    assert not any(r.lower().startswith("rtree") for r in project["dependencies"])
    assert any(r.lower().startswith("rtree") for r in project["optional-dependencies"]["dev"])


def test_mesh_commands_run_without_rtree(tmp_path):
    mesh = tmp_path / "suz.obj"
    mesh.write_bytes((REPO / "src" / "surfhap" / "data" / "suzanne.obj").read_bytes())

    def run(*args):
        res = subprocess.run([sys.executable, "-c", _BLOCK, *args], capture_output=True, text=True, timeout=600)
        assert res.returncode == 0, res.stderr
        return res

    run("shape", "calibrate", str(mesh), "--directions", "4", "--speeds", "2", "--size", "0.1")
    out = tmp_path / "o"
    run("shape", str(mesh), "--size", "0.1", "--scan", "-0.04,0,0.04,0,0.05", "--out", str(out),
        "--no-figure")
    assert (out / "summary.json").exists()
    probe = subprocess.run([sys.executable, "-c", _BLOCK.replace("from surfhap.cli import main", "import rtree")],
                           capture_output=True, text=True, timeout=60)
    assert probe.returncode != 0 and "rtree blocked" in probe.stderr  # the blocker works
