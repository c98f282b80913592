"""'study export' (issue 18): the trials of logs written by real sessions of the study runner
round-trip through pandas, as one CSV and as a BIDS 'beh' dataset, compared with the study file
and the raw log lines read here independently."""

from __future__ import annotations

import json

import pandas as pd
import pytest

from surfhap.cli import main
from surfhap.lab.session import SessionRunner

INT, FLOAT = "int64", "float64"


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    """003 identification, two participants: P01 answers 5 trials, stops and resumes (two log
    sessions); P02 runs in one go (the simulated participant of 'study run')."""
    folder = tmp_path_factory.mktemp("export") / "study"
    design = folder.parent / "design.json"  # the template without its training trials (test_lab_experimenter)
    design.write_text(json.dumps({"format": "surfhap-study-design", "version": 1, "kind": "identification",
                                  "name": "Otake et al. 2022 Task 2: identification", "participants": 2}))
    assert main(["study", "new", str(design), "--out", str(folder)]) == 0
    r = SessionRunner(folder, "P01", mode="test")
    for k in range(5):
        t = r.current()
        r.answer(t.id, t.correct if k % 2 else t.choices[-1].id, rt_client_s=0.5 + k)
    r.close()
    for pid in ("P01", "P02"):
        assert main(["study", "run", str(folder), "-p", pid, "--simulate", "4"]) == 0
    return folder


def _expected(study) -> pd.DataFrame:
    """The trial rows from study.json and the raw JSON lines (no surfhap reader)."""
    plan = json.loads((study / "study.json").read_text())["participants"]
    rows = []
    for p in plan:
        trials = {t["id"]: t for t in p["trials"]}
        for line in (study / "logs" / f"{p['id']}.jsonl").read_text().splitlines():
            rec = json.loads(line)
            if rec["type"] != "trial":
                continue
            t = trials[rec["trial_id"]]
            mat, method = t["condition"]["material"], t["stimuli"][0]["render"]["method"]
            rows.append({"participant": p["id"], "session": rec["session"], "block": t["block"],
                         "trial_index": t["index"], "cond_condition": t["condition"]["condition"],
                         "cond_material": mat, "stimulus": f"material={mat},method={method}",
                         "answer": rec["answer"], "correct_answer": t["correct"],
                         "is_correct": rec["answer"] == t["correct"], "response_time": rec["rt_s"]})
    return pd.DataFrame(rows)


def _check(table: pd.DataFrame, want: pd.DataFrame) -> None:
    assert {c: str(table[c].dtype) for c in ("session", "block", "trial_index", "response_time")} == {
        "session": INT, "block": INT, "trial_index": INT, "response_time": FLOAT}
    assert table["is_correct"].dtype == bool and table["practice"].dtype == bool and not table["practice"].any()
    for c in ("participant", "cond_condition", "cond_material", "answer", "stimulus"):
        assert pd.api.types.is_string_dtype(table[c]), c
    got = table[list(want.columns)].reset_index(drop=True)
    pd.testing.assert_frame_equal(got, want, check_dtype=False)


def test_csv_round_trips_through_pandas(study, tmp_path):
    out = tmp_path / "trials.csv"
    assert main(["study", "export", str(study), "--format", "csv", "--out", str(out)]) == 0
    table = pd.read_csv(out)
    want = _expected(study)
    assert len(table) == 32 and sorted(set(want["session"])) == [1, 2]
    _check(table, want)


def test_bids_beh_round_trips_through_pandas(study, tmp_path):
    out = tmp_path / "bids"
    assert main(["study", "export", str(study), "--format", "bids", "--out", str(out)]) == 0
    desc = json.loads((out / "dataset_description.json").read_text())
    assert desc["BIDSVersion"].startswith("1.") and desc["Name"] == "Otake et al. 2022 Task 2: identification"
    assert list(pd.read_csv(out / "participants.tsv", sep="\t")["participant_id"]) == ["sub-P01", "sub-P02"]
    files = sorted(p.relative_to(out).as_posix() for p in out.rglob("*_beh.tsv"))
    assert files == ["sub-P01/ses-1/beh/sub-P01_ses-1_task-identification_beh.tsv",
                     "sub-P01/ses-2/beh/sub-P01_ses-2_task-identification_beh.tsv",
                     "sub-P02/ses-1/beh/sub-P02_ses-1_task-identification_beh.tsv"]
    tables = [pd.read_csv(out / f, sep="\t") for f in files]
    assert [len(t) for t in tables] == [5, 11, 16]
    _check(pd.concat(tables, ignore_index=True), _expected(study))
    side = json.loads((out / files[0].replace(".tsv", ".json")).read_text())
    assert side["TaskName"] == "identification" and set(tables[0].columns) <= set(side)
    assert all(side[c]["Description"] for c in tables[0].columns)
    assert side["response_time"]["Units"] == "s"
    assert set(side["cond_material"]["Levels"]) == set(tables[0]["cond_material"])
    assert set(side["is_correct"]["Levels"]) == {"True", "False"}
    # one log, one session: no ses- level
    one = tmp_path / "one"
    assert main(["study", "export", str(study / "logs" / "P02.jsonl"), "--format", "bids", "--out", str(one)]) == 0
    assert [p.relative_to(one).as_posix() for p in one.rglob("*_beh.tsv")] == [
        "sub-P02/beh/sub-P02_task-identification_beh.tsv"]


def test_two_tasks_of_a_design_two_bids_files(tmp_path):
    """000's ratings: adjective ratings and similarity are two tasks, each with its own columns;
    the 7-point answers read back as integers, no correctness (n/a)."""
    study = tmp_path / "study"
    assert main(["study", "new", "zhao-ratings", "--out", str(study), "--participants", "1"]) == 0
    assert main(["study", "run", str(study), "-p", "P01", "--simulate", "2"]) == 0
    assert main(["study", "export", str(study), "--format", "bids", "--out", str(tmp_path / "b")]) == 0
    beh = tmp_path / "b" / "sub-P01" / "beh"
    rating = pd.read_csv(beh / "sub-P01_task-rating_beh.tsv", sep="\t")
    sim = pd.read_csv(beh / "sub-P01_task-similarity_beh.tsv", sep="\t")
    assert (len(rating), len(sim)) == (40, 20)
    assert "cond_adjective" in rating and "cond_adjective" not in sim and "cond_method" in sim
    assert str(rating["answer"].dtype) == INT and rating["answer"].between(1, 7).all()
    assert "is_correct" not in rating  # no right answer: the empty column is left out


@pytest.mark.parametrize("args, needle", [
    (["missing.jsonl", "--out", "x.csv"], "missing.jsonl"),
    (["{study}", "--format", "xlsx", "--out", "x.csv"], "--format"),
    (["{bad}", "--out", "x.csv"], "line 2"),
])
def test_bad_input_one_line_exit_2(tmp_path, capsys, study, args, needle):
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"type":"session","session":1}\nnot json\n')
    argv = [a.format(study=study, bad=bad) for a in args]
    argv = [str(tmp_path / a) if a in ("missing.jsonl", "x.csv") else a for a in argv]
    capsys.readouterr()
    assert main(["study", "export", *argv]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and needle in err[0], err
