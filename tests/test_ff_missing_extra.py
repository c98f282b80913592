"""A plain install (no ``live`` extra): ``ff run`` names the missing extra in one line and
exits 2 before it starts anything (it used to wait 30 s for a page process that could not
import fastapi and print two tracebacks).

The missing modules are simulated in a child interpreter: a ``sitecustomize`` on its
PYTHONPATH puts a finder first on ``sys.meta_path`` that reports the live extra's modules
as not installed (also inherited by any process the command would spawn)."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

BLOCKER = '''
import sys
_MISSING = {"fastapi", "starlette", "uvicorn", "websockets", "pythonosc", "sounddevice"}


class _NotInstalled:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in _MISSING:
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return None


sys.meta_path.insert(0, _NotInstalled())
'''


@pytest.fixture()
def plain_env(tmp_path):
    site = tmp_path / "site"
    site.mkdir()
    (site / "sitecustomize.py").write_text(BLOCKER)
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([str(site), *filter(None, [env.get("PYTHONPATH")])])
    env["COLUMNS"] = "200"
    return env


def run(env, *args):
    return subprocess.run([sys.executable, "-m", "surfhap", *args], env=env, capture_output=True, text=True,
                          timeout=120)


def test_the_blocker_really_hides_the_extra(plain_env):
    r = subprocess.run([sys.executable, "-c", "import fastapi"], env=plain_env, capture_output=True, text=True,
                       timeout=60)
    assert r.returncode != 0 and "fastapi" in r.stderr


@pytest.mark.parametrize("args", [
    ["ff", "run", "buttons", "--touch", "web", "--duration", "1"],
    ["ff", "run", "buttons", "--touch", "osc://127.0.0.1:0", "--duration", "1"],
    ["ff", "run", "buttons", "--touch", "trajectory:none.csv", "--device", "osc://127.0.0.1:9", "--duration", "1"],
    ["ff", "run", "buttons", "--touch", "trajectory:none.csv", "--feedback", "osc://127.0.0.1:9", "--duration", "1"],
])
def test_ff_run_without_the_live_extra_is_one_line_and_exit_2(plain_env, tmp_path, args):
    r = run(plain_env, *args)
    lines = [ln for ln in r.stderr.splitlines() if ln.strip()]
    assert r.returncode == 2, r.stdout + r.stderr
    assert len(lines) == 1, r.stderr
    assert "pip install 'surfhap[live]'" in lines[0]
    assert "Traceback" not in r.stdout + r.stderr
