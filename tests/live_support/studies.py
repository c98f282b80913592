"""A small identification study (cork and denim) made through the CLI, for tests that run
the study page or the study runner."""

from __future__ import annotations

import json
from pathlib import Path

from surfhap.cli import main


def identification_study(tmp_path: Path, repetitions: int = 1, name: str = "test") -> Path:
    """``study new`` of a one-participant identification design in ``tmp_path / "study"``."""
    design = {"format": "surfhap-study-design", "version": 1, "kind": "identification", "name": name,
              "participants": 1, "seed": 3, "params": {"materials": ["cork", "denim"], "repetitions": repetitions}}
    p = tmp_path / "design.json"
    p.write_text(json.dumps(design))
    study = tmp_path / "study"
    assert main(["study", "new", str(p), "--out", str(study)]) == 0
    return study
