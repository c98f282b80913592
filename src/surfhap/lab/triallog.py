"""Append-only trial logs that lose nothing (JSON lines, one file per participant).

Every record is one JSON object on one line, written with a single ``write`` on a file opened
for appending, then flushed and ``fsync``-ed before the call returns: once :meth:`TrialLog.append`
returns, the record survives a crash or ``kill -9``. A session that is killed while writing can
leave at most one partial last line; opening the log again cuts it off (that trial was never
acknowledged, so it is run again). A trial id is written at most once: the log refuses a second
record for an id it already holds. One session at a time: the log takes an exclusive lock
(``flock``) on ``<log>.lock`` while open. A session record is written with the session's first
trial or event, so a start that fails before (a busy port, a missing output) leaves no session.

Records::

    {"type": "session", "session": 1, "started": ISO time, "software_version": ..., "config": {...}}
    {"type": "trial", "participant": "P01", "trial_id": "P01-0003", "index": 3, "block": 0, "answer": "2",
     "correct": "2", "is_correct": true, "rt_s": 4.2, "answered_at": ISO time, "session": 1, ...}
    {"type": "event", "event": "rest" | "resume" | "end", "session": 1, "at": ISO time, ...}
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

from surfhap.errors import StudyFormatError

__all__ = ["TrialLog", "read_log", "LogContents", "now_iso"]


def now_iso() -> str:
    return datetime.now(timezone.utc).isoformat(timespec="milliseconds")


@dataclass
class LogContents:
    """Parsed log: ``sessions`` (session records), ``trials`` (trial records, file order),
    ``events``, ``dropped_tail`` (bytes of a partial last line, not counted). Every trial record
    holds ``participant`` (a log written before it was logged: the session's participant)."""

    sessions: list[dict]
    trials: list[dict]
    events: list[dict]
    dropped_tail: int


def _parse(path: Path, data: bytes) -> tuple[LogContents, int]:
    """Parse the complete lines of ``data``; returns the contents and the length of the
    complete part (a partial last line, without its newline, is excluded)."""
    end = data.rfind(b"\n") + 1
    sessions, trials, events = [], [], []
    participant = path.stem
    for no, line in enumerate(data[:end].splitlines(), start=1):
        if not line.strip():
            continue
        try:
            rec = json.loads(line)
        except json.JSONDecodeError:
            raise StudyFormatError(f"line {no} is not JSON", source=str(path), field="log") from None
        kind = rec.get("type") if isinstance(rec, dict) else None
        if kind == "session":
            sessions.append(rec)
            participant = str((rec.get("config") or {}).get("participant") or participant)
        elif kind == "trial":
            if not isinstance(rec.get("trial_id"), str):
                raise StudyFormatError(f"line {no}: trial record without trial_id", source=str(path), field="trial_id")
            trials.append({"participant": participant, **rec})
        elif kind == "event":
            events.append(rec)
        else:
            raise StudyFormatError(f"line {no}: unknown record type {kind!r}", source=str(path), field="type")
    return LogContents(sessions, trials, events, len(data) - end), end


def read_log(path: str | Path) -> LogContents:
    """Read a log without changing it (a partial last line is ignored and reported)."""
    p = Path(path)
    if not p.exists():
        return LogContents([], [], [], 0)
    return _parse(p, p.read_bytes())[0]


class TrialLog:
    """An open, locked, append-only trial log. Use as a context manager.

    ``participant`` goes into every trial record; ``config`` is the snapshot written at the start
    of every session (study file hash, participant, gain, safety limit, host, ...),
    ``software_version`` the surfhap version (default: the installed one).
    """

    def __init__(self, path: str | Path, *, participant: str, config: dict, software_version: str | None = None):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._lock_fd = os.open(str(self.path) + ".lock", os.O_RDWR | os.O_CREAT, 0o644)
        import fcntl

        try:
            fcntl.flock(self._lock_fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(self._lock_fd)
            raise StudyFormatError("another session is writing this log", source=str(self.path),
                                   field="participant") from None
        self._fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_APPEND, 0o644)
        data = self.path.read_bytes()
        try:
            contents, good = _parse(self.path, data)
        except StudyFormatError:
            self.close()
            raise
        if good < len(data):  # cut a partial last line left by a killed session
            os.ftruncate(self._fd, good)
            os.fsync(self._fd)
        self.contents = contents
        self._ids = {t["trial_id"] for t in contents.trials}
        self.session = len(contents.sessions) + 1
        self.participant = participant
        if software_version is None:
            from surfhap import __version__ as software_version
        # written before the session's first record: a start that fails before leaves no session
        self._head: list[dict] | None = [{"type": "session", "session": self.session, "started": now_iso(),
                                          "software_version": software_version, "config": config,
                                          "resumed_after": len(self._ids)}]

    def _write(self, record: dict) -> None:
        head, self._head = self._head, None
        for rec in head or ():
            self._line(rec)
        self._line(record)

    def _line(self, record: dict) -> None:
        line = (json.dumps(record, separators=(",", ":"), allow_nan=False) + "\n").encode("utf-8")
        n = os.write(self._fd, line)  # O_APPEND: one write, at the end
        if n != len(line):  # pragma: no cover - a short write on a regular file means a full disk
            raise OSError(f"{self.path}: short write ({n} of {len(line)} bytes)")
        os.fsync(self._fd)

    @property
    def completed(self) -> set[str]:
        """Ids of the trials already in the log."""
        return set(self._ids)

    def append_trial(self, record: dict) -> bool:
        """Append one completed trial (must hold ``trial_id``); returns False, writing nothing,
        if that trial is already logged."""
        tid = record["trial_id"]
        if tid in self._ids:
            return False
        self._write({"type": "trial", "participant": self.participant, **record, "session": self.session})
        self._ids.add(tid)
        return True

    def event(self, name: str, *, deferred: bool = False, **fields) -> None:
        """Log an event; ``deferred``: part of the session's start (e.g. "resume"), written with
        the session record, i.e. not at all if nothing else is logged in this session."""
        rec = {"type": "event", "event": name, "session": self.session, "at": now_iso(), **fields}
        if deferred and self._head is not None:
            self._head.append(rec)
        else:
            self._write(rec)

    def close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
            import fcntl

            fcntl.flock(self._lock_fd, fcntl.LOCK_UN)
            os.close(self._lock_fd)

    def __enter__(self) -> "TrialLog":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
