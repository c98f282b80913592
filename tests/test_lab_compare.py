"""``surfhap compare``: profiles of materials agree with their laws; figure and table written."""

import json

import numpy as np
import pytest

from surfhap.cli import main
from surfhap.exchange.materials import load_material
from surfhap.lab.compare import compare_materials
from live_support.figures import assert_png_drawn


def test_profiles_follow_the_material_laws():
    comp = compare_materials(["cork", "wood"], duration=1.5)
    assert [p.name for p in comp.profiles] == ["cork", "wood"]
    for p in comp.profiles:
        law = load_material(p.name).low_frequency_law
        assert np.allclose(p.mu_speed, law.coefficient(np.full(p.speeds.size, 0.5), p.speeds))
        assert np.allclose(p.force_load, law.coefficient(p.loads, np.full(p.loads.size, 0.1)) * p.loads)
        assert p.v_hist.sum() == pytest.approx(1.0, abs=1e-9)  # every driven sample in a bin
        assert 0 < p.v_mean <= p.v_p95 <= p.v_max <= 250.0
        assert p.psd.shape == p.freqs.shape and np.all(p.psd >= 0)


def test_cli_compare_writes_figure_and_json(tmp_path, capsys):
    fig = tmp_path / "cmp.png"
    assert main(["compare", "cork", "leather", "--duration", "1", "--out", str(fig), "--json"]) == 0
    assert_png_drawn(fig)
    doc = json.loads(capsys.readouterr().out)  # --json: the table and render summaries as one JSON object
    assert [r["material"] for r in doc["table"]] == ["cork", "leather"] and doc["figure"] == str(fig)
    assert main(["compare", "no-such-material"]) == 2
    assert "no-such-material" in capsys.readouterr().err


def test_cli_figure_paths_name_the_file_written(tmp_path, capsys):
    """A figure path without a suffix becomes PNG and the 'wrote' line names that file; a
    suffix matplotlib cannot write is bad input (one line naming --out, exit 2) before any work."""
    assert main(["compare", "cork", "--duration", "1", "--out", str(tmp_path / "cmp")]) == 0
    assert_png_drawn(tmp_path / "cmp.png")
    out = capsys.readouterr().out.replace("\n", "")  # rich may fold a long path over lines
    assert "wrote " in out and out.rstrip().endswith("cmp.png")
    assert main(["compare", "cork", "--out", str(tmp_path / "cmp.jpgx")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--out" in err[0] and ".jpgx" in err[0]
    assert not list(tmp_path.glob("cmp.jpgx*"))
