"""Trial logs out (``surfhap study export``): one tidy row per trial, as CSV or as a BIDS ``beh``
dataset, both read by pandas with no further work.

Columns: ``participant``, ``session`` (run of the log: 1, then +1 per resumed run), ``block``,
``block_label``, ``trial_id``, ``trial_index``, ``task``, one ``cond_<key>`` per condition
key of the design, ``stimulus`` (the render spec of every stimulus, ``key=value`` pairs, stimuli
separated by `` | ``), ``answer`` (choice id), ``correct_answer``, ``is_correct``, ``score``,
``response_time`` and ``response_time_server`` (s), ``answered_at``, then any other scalar
field of the trial records (e.g. a comfort staircase's ``level_V``).

BIDS (specification 1.10, "Behavioral experiments"): ``dataset_description.json``,
``participants.tsv`` and per participant and task
``sub-<label>/[ses-<label>/]beh/sub-<label>[_ses-<label>]_task-<label>_beh.tsv`` (missing values
``n/a``) with a ``_beh.json`` sidecar describing every column (LongName, Description, Units,
Levels). Sessions appear (``ses-<n>``) when a participant's log holds more than one.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pandas as pd

from surfhap.errors import ConfigError, StudyFormatError
from surfhap.lab.triallog import LogContents, read_log

__all__ = ["FORMATS", "log_files", "trial_table", "write_bids", "export_logs"]

FORMATS = ("csv", "bids")
BIDS_VERSION = "1.10.0"
#: column -> (LongName, Description, Units); cond_* and other record fields are described generically
COLUMNS: dict[str, tuple[str, str, str | None]] = {
    "participant": ("Participant", "Participant id of the study", None),
    "session": ("Session", "Run of the participant's log: 1, then +1 for every resumed or later run", None),
    "block": ("Block", "Block of the participant's trial list, from 0", None),
    "block_label": ("Block label", "Condition or part of the study of the block", None),
    "trial_id": ("Trial id", "Id of the trial in the study file", None),
    "trial_index": ("Trial index", "Position of the trial in the participant's planned list, from 0", None),
    "task": ("Task", "Task of the trial", None),
    "practice": ("Practice", "A practice trial (true): logged but left out of the analysis", None),
    "stimulus": ("Stimuli", "Render spec of every stimulus of the trial (key=value pairs; stimuli in the order of "
                            "the page's buttons, separated by ' | ')", None),
    "answer": ("Answer", "Choice id answered (toggles: position=choice id for every position)", None),
    "correct_answer": ("Correct answer", "The right answer (n/a when there is none: preferences, ratings)", None),
    "is_correct": ("Correct", "Whether the answer is the right one (n/a when there is none)", None),
    "score": ("Score", "1 or 0 for a choice, the fraction of right positions for toggles", None),
    "response_time": ("Response time", "From the trial shown to the answer, measured in the page", "s"),
    "response_time_server": ("Response time (server)", "From the trial served to the answer logged", "s"),
    "answered_at": ("Answered at", "Time of the answer (ISO 8601, UTC)", None),
}
_FIELDS = {"participant": "participant", "session": "session", "block": "block", "block_label": "block_label",
           "trial_id": "trial_id", "trial_index": "index", "task": "task"}
_ANSWER = {"answer": "answer", "correct_answer": "correct", "is_correct": "is_correct", "score": "score",
           "response_time": "rt_s", "response_time_server": "rt_server_s", "answered_at": "answered_at"}
_NOT_SCALAR = {"type", "condition", "key", "stimuli_touched"}


def log_files(source: str | Path) -> list[Path]:
    """The participants' logs of ``source``: a log file, or a study folder (its ``logs/``;
    the comfort staircases' logs are left out). StudyFormatError when there is none."""
    p = Path(source)
    if p.is_file():
        return [p]
    folder = p / "logs" if (p / "logs").is_dir() else p
    found = sorted(f for f in folder.glob("*.jsonl") if not f.stem.endswith("-comfort")) if p.is_dir() else []
    if not found:
        raise StudyFormatError("no such trial log (a logs/P01.jsonl file or a study folder)" if not p.is_dir() else
                               "holds no trial log (*.jsonl)", source=str(p), field="LOG")
    return found


def _row(rec: dict) -> dict:
    row = {col: rec.get(field) for col, field in _FIELDS.items()}
    row["practice"] = bool(rec.get("practice", False))
    row.update({f"cond_{k}": v for k, v in (rec.get("condition") or {}).items()})
    renders = (rec.get("key") or {}).get("stimuli")  # None: a log written before the render specs were logged
    row["stimulus"] = None if renders is None else " | ".join(",".join(f"{k}={v}" for k, v in r.items())
                                                              for r in renders)
    row.update({col: rec.get(field) for col, field in _ANSWER.items()})
    used = set(_FIELDS.values()) | set(_ANSWER.values()) | _NOT_SCALAR | {"practice"}
    row.update({k: v for k, v in rec.items() if k not in used and (v is None or isinstance(v, (str, int, float)))})
    return row


def trial_table(logs: list[LogContents]) -> pd.DataFrame:
    """One row per logged trial of ``logs`` (columns: module doc)."""
    rows = [_row(rec) for log in logs for rec in log.trials]
    return pd.DataFrame(rows, columns=None if rows else [*_FIELDS, "practice", "stimulus", *_ANSWER])


def _label(value: str, what: str) -> str:
    label = re.sub(r"[^A-Za-z0-9]", "", str(value))
    if not label:
        raise StudyFormatError(f"{what} {value!r} has no letter or digit for a BIDS label", field=what)
    return label


def _sidecar(table: pd.DataFrame, task: str, name: str) -> dict:
    side: dict = {"TaskName": task, "TaskDescription": name}
    for col in table.columns:
        long, desc, units = COLUMNS.get(col, (col, f"Field '{col}' of the trial records", None))
        entry = {"LongName": long, "Description": desc}
        if col.startswith("cond_"):
            entry = {"LongName": f"Condition: {col[5:]}", "Description": f"'{col[5:]}' of the trial's condition in "
                                                                          "the study design"}
            if not pd.api.types.is_numeric_dtype(table[col]):
                entry["Levels"] = {str(v): f"{col[5:]} = {v}" for v in sorted(table[col].dropna().unique(), key=str)}
        if col == "is_correct":
            entry["Levels"] = {"True": "the right answer", "False": "a wrong answer"}
        if units or col.endswith("_V"):
            entry["Units"] = units or "V"
        side[col] = entry
    return side


def write_bids(table: pd.DataFrame, out: Path, name: str, groups: dict[str, str],
               info: dict[str, dict] | None = None) -> list[Path]:
    """Write ``table`` as a BIDS ``beh`` dataset into ``out``; returns the files written.
    ``info``: participant -> the participant-information answers (columns of participants.tsv)."""
    from surfhap import __version__

    out.mkdir(parents=True, exist_ok=True)
    subs = {pid: _label(pid, "participant") for pid in table["participant"].unique()}
    if len(set(subs.values())) < len(subs):
        raise StudyFormatError("participant ids that differ only in punctuation share a BIDS label",
                               source=str(out), field="participant")
    written = [out / "dataset_description.json", out / "participants.tsv"]
    written[0].write_text(json.dumps({"Name": name, "BIDSVersion": BIDS_VERSION, "DatasetType": "raw",
                                      "GeneratedBy": [{"Name": "surfhap", "Version": __version__}]}, indent=1))
    people = pd.DataFrame({"participant_id": [f"sub-{s}" for s in subs.values()],
                           "group": [groups.get(p) or None for p in subs]})
    answers = pd.DataFrame([(info or {}).get(p, {}) for p in subs]).replace(r"[\t\r\n]", " ", regex=True)
    pd.concat([people, answers], axis=1).to_csv(written[1], sep="\t", na_rep="n/a", index=False)
    with_ses = bool((table.groupby("participant")["session"].nunique() > 1).any())
    tasks = table["task"].fillna("study")
    clean = table.replace(r"[\t\r\n]", " ", regex=True)  # a BIDS TSV value holds no tab or line break
    for (pid, ses, task), rows in clean.groupby([table["participant"], table["session"], tasks], sort=True):
        ent = f"sub-{subs[pid]}" + (f"_ses-{int(ses)}" if with_ses else "")
        folder = out / f"sub-{subs[pid]}" / (f"ses-{int(ses)}" if with_ses else "") / "beh"
        folder.mkdir(parents=True, exist_ok=True)
        stem = folder / f"{ent}_task-{_label(task, 'task')}_beh"
        rows = rows.dropna(axis=1, how="all")  # e.g. the other task's condition keys
        rows.to_csv(stem.with_suffix(".tsv"), sep="\t", na_rep="n/a", index=False)
        stem.with_suffix(".json").write_text(json.dumps(_sidecar(rows, task, name), indent=1))
        written += [stem.with_suffix(".tsv"), stem.with_suffix(".json")]
    return written


def export_logs(source: str | Path, fmt: str, out: str | Path) -> list[Path]:
    """``study export``: the trials of ``source`` (:func:`log_files`) to ``out`` as ``fmt``
    ("csv": one file; "bids": a dataset folder). Returns the files written."""
    if fmt not in FORMATS:
        raise ConfigError(f"unknown format {fmt!r} ({' | '.join(FORMATS)})", source="--format", field="format")
    logs = [read_log(p) for p in log_files(source)]
    table = trial_table(logs)
    out = Path(out)
    if fmt == "csv":
        out.parent.mkdir(parents=True, exist_ok=True)
        table.to_csv(out, index=False)
        return [out]
    if out.exists() and not out.is_dir():
        raise ConfigError("is a file; a BIDS dataset is a folder", source=str(out), field="out")
    configs = [s.get("config") or {} for log in logs for s in log.sessions]
    name = next((str(c["design"]) for c in configs if c.get("design")), "surfhap study")
    groups = {str(c.get("participant")): str(c.get("group") or "") for c in configs}
    info = {str(log.sessions[0]["config"].get("participant")): e["answers"] for log in logs for e in log.events
            if e["event"] == "participant-info" and log.sessions}
    return write_bids(table, out, name, groups, info)
