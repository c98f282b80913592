"""docs/first-day.md runs top to bottom, and its pictures are the ones its commands draw (issue 21, item 6).

Every command of the walkthrough's ``sh`` blocks runs in order, as written, with the cwd a
temporary folder standing for the repository's; the only substitutions keep each command's
structure (the same as tests/test_readme_commands.py):

* ``.venv/bin/surfhap`` becomes this interpreter's ``-m surfhap``; ``../shared/data`` the shared data
  folder (tests/conftest.py finds it);
* ``serve`` (it runs until Ctrl-C) gets ``--duration 1`` and a free ``--port``;
* ``make`` lines are not run here: ``make demo`` is the demo run of tests/test_cli.py.

The pictures the walkthrough shows (``docs/images/first-day/*.png``) must be the ones these
commands drew: each is compared pixel by pixel with the fresh figure. After a deliberate change
to a figure, rewrite them with ``SURFHAP_WRITE_FIRST_DAY=1 pytest tests/test_first_day.py``.
"""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import socket
import subprocess
import sys
from pathlib import Path

import matplotlib.image as mpimg
import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
DOC = REPO / "docs" / "first-day.md"
IMAGES = REPO / "docs" / "images" / "first-day"
TIMEOUT = 600  # s per command: a failure guard, not a speed target
# each picture of the walkthrough and the file its commands write
PICTURES = {
    "render.png": "first-day/render/figure.png",
    "compare.png": "first-day/compare.png",
    "identification.png": "first-day/report/identification_friction_texture_bars.png",
}


def walkthrough_commands() -> list[str]:
    """The command lines of the walkthrough's sh blocks, in order, comments stripped."""
    lines = []
    for block in re.findall(r"```sh\n(.*?)```", DOC.read_text(encoding="utf-8"), flags=re.S):
        for line in block.splitlines():
            line = re.sub(r"\s+#.*$", "", line.strip())
            if line and not line.startswith("make "):
                lines.append(line)
    return lines


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def _args(cmd: str, shared_data: Path) -> list[str]:
    args = [a.replace("../shared/data", str(shared_data)) for a in shlex.split(cmd)]
    if args[0] not in (".venv/bin/surfhap", "surfhap"):
        return args
    args = [sys.executable, "-m", "surfhap", *args[1:]]
    if args[3] == "serve":
        args += ["--duration", "1", "--port", str(_free_port())]
    return args


@pytest.fixture(scope="module")
def walked(tmp_path_factory, shared_data) -> Path:
    """Run the walkthrough; the folder it ran in (each command's failure names it)."""
    d = tmp_path_factory.mktemp("first-day")
    env = {**os.environ, "MPLBACKEND": "Agg", "HOME": str(d),
           "PYTHONPATH": str(REPO / "src") + os.pathsep + os.environ.get("PYTHONPATH", "")}
    for cmd in walkthrough_commands():
        res = subprocess.run(_args(cmd, shared_data), cwd=d, env=env, capture_output=True, text=True, timeout=TIMEOUT)
        assert res.returncode == 0, f"{cmd}\n{res.stdout[-3000:]}{res.stderr[-3000:]}"
    return d


def test_the_walkthrough_covers_the_day():
    """Recording -> fit -> render -> live page -> pilot study -> analysis, in that order."""
    joined = "\n".join(walkthrough_commands())
    steps = ["hapmat-imu", "fit imu", "calibrate-texture", "render ", "serve ", "study new", "--simulate", "study analyze"]
    where = [joined.find(s) for s in steps]
    assert all(w >= 0 for w in where) and where == sorted(where), dict(zip(steps, where))
    assert (REPO / "README.md").read_text(encoding="utf-8").find("docs/first-day.md") < 2000, "linked first from the README"


@pytest.mark.slow
def test_every_step_runs_and_writes_what_the_doc_says(walked):
    material = walked / "first-day" / "my-denim.json"
    texture = json.loads(material.read_text(encoding="utf-8"))["texture"]
    assert texture["provenance"]["recording"].endswith("fabric_1.csv")
    assert texture["models"][0]["order_selection"].startswith("aic")  # no --order: AIC chose
    assert texture["calibration"]["target_voltage_ratio"] == 0.6
    for name in ("drive.wav", "render.npz", "summary.json", "figure.png"):
        assert (walked / "first-day" / "render" / name).is_file(), name
    assert (walked / "first-day" / "report" / "results.json").is_file()


@pytest.mark.slow
@pytest.mark.parametrize("picture", sorted(PICTURES))
def test_the_pictures_are_the_ones_the_commands_drew(walked, picture):
    fresh = walked / PICTURES[picture]
    shown = IMAGES / picture
    assert f"images/first-day/{picture}" in DOC.read_text(encoding="utf-8")
    if os.environ.get("SURFHAP_WRITE_FIRST_DAY") == "1":
        IMAGES.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(fresh, shown)
    a, b = mpimg.imread(fresh), mpimg.imread(shown)
    assert a.shape == b.shape, f"{picture}: {a.shape} drawn, {b.shape} shown; rewrite with SURFHAP_WRITE_FIRST_DAY=1"
    differing = np.mean(np.any(np.abs(a - b) > 0.1, axis=-1))
    assert differing < 0.005, f"{picture}: {differing:.1%} of the pixels differ; rewrite with SURFHAP_WRITE_FIRST_DAY=1"
