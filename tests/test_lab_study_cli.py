"""``surfhap study`` commands: new / run --simulate / analyze, and malformed files (exit 2)."""

import json

import pytest

from surfhap.cli import main
from surfhap.lab.analyze_study import analyze_study, sliding_scores

TEMPLATES = ["otake2021-3afc", "otake2022-realism", "otake2022-identification", "zhao-ratings", "kim-shapes",
             "kim-scenes", "kinestouch-sliding"]


@pytest.mark.parametrize("name", TEMPLATES)
def test_new_run_analyze_every_template(tmp_path, name, capsys):
    study = tmp_path / "s"
    assert main(["study", "new", name, "--out", str(study), "--participants", "3", "--seed", "4"]) == 0
    for p in ("P01", "P02", "P03"):  # 004's two sessions (another day each): both today, by override
        for _ in range(2 if name == "kinestouch-sliding" else 1):
            assert main(["study", "run", str(study), "-p", p, "--simulate", "7", "--p-correct", "0.9",
                         "--allow-same-day"]) == 0
    assert main(["study", "analyze", str(study), "--report", str(tmp_path / "rep")]) == 0
    html = (tmp_path / "rep" / "index.html").read_text()
    assert "<table" in html or "<img" in html
    tests = json.loads((tmp_path / "rep" / "results.json").read_text(), parse_constant=pytest.fail)["tests"]
    assert tests and all(set(t) >= {"name", "groups", "statistic", "df", "p", "p_adjusted", "alternative", "method",
                                    "effect_size"} for t in tests)
    res = analyze_study(study)
    assert res.participants == ["P01", "P02", "P03"] and not res.incomplete


def test_identification_analysis_counts(tmp_path):
    study = tmp_path / "s"
    assert main(["study", "new", "otake2022-identification", "--out", str(study), "--participants", "2"]) == 0
    for p in ("P01", "P02"):
        assert main(["study", "run", str(study), "-p", p, "--simulate", "1", "--p-correct", "1.0"]) == 0
    res = analyze_study(study)
    text = " ".join(t for s in res.sections for t in s.text)
    assert "overall 1.00 correct" in text  # a perfect simulated participant


def test_sliding_scores_follow_table_3():
    recs = []
    for i in range(10):  # 8 of 10 choose "reverse" over "static" -> p = 0.8 -> score 0.6
        recs.append({"participant": "P1", "answer": "reverse" if i < 8 else "static",
                     "condition": {"comparison": "reverse vs static", "visual": "V1", "tactile": "F0"}})
    (s,) = sliding_scores(recs)
    assert s["score"] == pytest.approx(0.6) and s["n"] == 10


def _design(tmp_path, **over):
    d = {"format": "surfhap-study-design", "version": 1, "kind": "nafc", "name": "t", "participants": 2}
    d.update(over)
    p = tmp_path / "design.json"
    p.write_text(json.dumps(d))
    return p


@pytest.mark.parametrize("over,field", [({"participants": 0}, "participants"), ({"kind": "nope"}, "kind"),
                                        ({"params": {"repetitions": -1}}, "params.repetitions"),
                                        ({"session": {"v_max": 400}}, "session.v_max"),
                                        ({"colour": 1}, "colour")])
def test_malformed_design_one_line_exit_2(tmp_path, capsys, over, field):
    p = _design(tmp_path, **over)
    assert main(["study", "new", str(p), "--out", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err.strip()
    assert "design.json" in err and field in err and "Traceback" not in err
    assert len(err.splitlines()) == 1


def test_malformed_study_and_json(tmp_path, capsys):
    bad = tmp_path / "s"
    bad.mkdir()
    (bad / "study.json").write_text("{not json")
    assert main(["study", "run", str(bad), "-p", "P01", "--simulate", "1"]) == 2
    assert "study.json" in capsys.readouterr().err
    (bad / "study.json").write_text(json.dumps({"format": "surfhap-study", "version": 1}))
    assert main(["study", "analyze", str(bad), "--report", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert "study.json" in err and "design" in err and "Traceback" not in err
    assert main(["study", "new", "no-such-template", "--out", str(tmp_path / "x")]) == 2


def test_design_file_round_trip(tmp_path):
    p = _design(tmp_path, params={"materials": ["a", "b", "c"], "repetitions": 2})
    assert main(["study", "new", str(p), "--out", str(tmp_path / "s")]) == 0
    st = json.loads((tmp_path / "s" / "study.json").read_text())
    assert len(st["participants"][0]["trials"]) == 2 * 3 * 2  # conditions x pairs x repetitions
    assert main(["study", "new", str(p), "--out", str(tmp_path / "s")]) == 2  # never overwrite a study


def test_corrupt_log_line_is_one_clear_error(tmp_path, capsys):
    study = tmp_path / "s"
    assert main(["study", "new", "kim-shapes", "--out", str(study), "--participants", "1"]) == 0
    assert main(["study", "run", str(study), "-p", "P01", "--simulate", "1"]) == 0
    log = study / "logs" / "P01.jsonl"
    lines = log.read_text().splitlines()
    lines[3] = "garbage"
    log.write_text("\n".join(lines) + "\n")
    assert main(["study", "analyze", str(study), "--report", str(tmp_path / "r")]) == 2
    err = capsys.readouterr().err
    assert "P01.jsonl" in err and "line 4" in err and "Traceback" not in err
    assert main(["study", "run", str(study), "-p", "P01", "--simulate", "1"]) == 2


def test_edited_study_file_is_flagged(tmp_path):
    study = tmp_path / "s"
    assert main(["study", "new", "kim-shapes", "--out", str(study), "--participants", "1"]) == 0
    assert main(["study", "run", str(study), "-p", "P01", "--simulate", "1"]) == 0
    assert analyze_study(study).warnings == []
    doc = json.loads((study / "study.json").read_text())
    doc["design"]["note"] = "edited"
    (study / "study.json").write_text(json.dumps(doc))
    assert any("different study.json" in w for w in analyze_study(study).warnings)


def test_status_lists_progress(tmp_path, capsys):
    study = tmp_path / "s"
    assert main(["study", "new", "kim-shapes", "--out", str(study), "--participants", "2"]) == 0
    assert main(["study", "run", str(study), "-p", "P02", "--simulate", "1"]) == 0
    capsys.readouterr()
    assert main(["study", "status", str(study)]) == 0
    out = capsys.readouterr().out
    assert "0/10" in out and "10/10" in out
