"""The index of a batch: one row per job (its name, parameters, status, error, wall time,
output folder and summary figures), written as index.csv and index.json into the batch folder."""

from __future__ import annotations

import csv
import json
from collections.abc import Sequence
from pathlib import Path

from surfhap.batch.schedulers import JobOutcome

__all__ = ["index_rows", "write_index"]


def index_rows(jobs: Sequence, outcomes: Sequence[JobOutcome], root: Path) -> list[dict]:
    """Rows of the jobs (each with ``name``, ``params`` and ``out``, see :mod:`surfhap.batch.jobs`):
    job, the job's parameters, status ("ok" | "failed"), error, seconds, out (relative to
    ``root``) and the job's summary figures (empty on failure)."""
    rows = []
    for job, o in zip(jobs, outcomes):
        out = job.out
        row = {"job": job.name, **job.params, "status": "ok" if o.ok else "failed", "error": o.error or "",
               "seconds": round(o.seconds, 3), "out": str(Path(out).relative_to(root)) if Path(out).is_relative_to(root) else str(out)}
        if o.ok and isinstance(o.value, dict):
            row.update(o.value)
        rows.append(row)
    return rows


def write_index(rows: list[dict], root: str | Path, scheduler: str) -> dict[str, Path]:
    """Write ``index.csv`` (columns: the union of the rows' keys, in first-seen order) and
    ``index.json`` ({"scheduler", "jobs", "failed", "rows"}) into ``root``; returns the paths."""
    root = Path(root)
    root.mkdir(parents=True, exist_ok=True)
    columns = list(dict.fromkeys(k for row in rows for k in row))
    paths = {"csv": root / "index.csv", "json": root / "index.json"}
    with paths["csv"].open("w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=columns, restval="")
        writer.writeheader()
        writer.writerows(rows)
    doc = {"scheduler": scheduler, "jobs": len(rows), "failed": sum(r["status"] != "ok" for r in rows), "rows": rows}
    paths["json"].write_text(json.dumps(doc, indent=2, default=float) + "\n", encoding="utf-8")
    return paths
