"""Running one participant's session: the trial sequence, answers, rests, resume.

:class:`SessionRunner` is the state machine behind both the touch page and the simulated
responder (``surfhap study run --simulate``). It is thread-safe (the page server calls it
from worker threads). Completed trials come from the :class:`~surfhap.lab.triallog.TrialLog`,
so a runner opened on a killed session continues with the first trial not yet logged.

Gain: ``gain`` multiplies the drive laws' alpha for this participant (Otake et al. 2022 adjust
it per participant near preset values) and ``v_max`` is the session's safety limit, the
smaller of the design's (<= 250 V) and the participant's comfort voltage (e.g. a staircase
threshold, Zhao et al.). Whatever the gain, the safety stage clamps every sample to v_max.

Sessions on different days: a run covers the trials of one study session (``Trial.session``)
and is then ``finished``; the next study session is refused on a calendar day on which the
previous one ran, unless ``allow_same_day`` (``study run --allow-same-day``). Each session
record of the log holds its ``date`` and ``study_session``.
"""

from __future__ import annotations

import hashlib
import platform
import threading
import time
from datetime import date
from pathlib import Path

from typing import TYPE_CHECKING

from surfhap.errors import ConfigError, StudyFormatError
from surfhap.lab.blinding import choice_key
from surfhap.lab.schema import InfoField, Study, Trial, load_study
from surfhap.lab.triallog import TrialLog, now_iso

if TYPE_CHECKING:
    from surfhap.models.panel import DisplayModel

__all__ = ["SessionRunner", "check_answer", "check_info", "local_today", "SAFETY_V_MAX", "MAX_GAIN", "TEXT_MAX"]

SAFETY_V_MAX = 250.0  # V, Otake et al. 2022 Sec. IV-D
TEXT_MAX = 500  # characters of a free-text answer (the page's request allows no more)
MAX_GAIN = 4.0  # largest per-participant multiplier of alpha (design choice: beyond it the safety clamp dominates)


def local_today() -> date:
    """The calendar day of the lab (local time): sessions on different days are compared by it."""
    return date.today()


def check_answer(trial: Trial, answer: str) -> tuple[str, float | None]:
    """Normalise and validate ``answer``; returns (answer, score) where score is 1/0 for a
    choice with a correct answer, the fraction of correct positions for toggles, None when the
    trial has no correct answer. Raises ConfigError for an answer the trial does not offer.
    A free-text answer is kept verbatim: 1 to TEXT_MAX characters, not only white space."""
    if trial.response == "text":
        if not answer.strip() or len(answer) > TEXT_MAX:
            raise ConfigError(f"a text answer needs 1-{TEXT_MAX} characters", field="answer")
        return answer, None
    ids = [c.id for c in trial.choices]
    if trial.response == "choice":
        if answer not in ids:
            raise ConfigError(f"answer {answer!r} is not one of {ids}", field="answer")
        return answer, (None if trial.correct is None else float(answer == trial.correct))
    parts = {}
    for item in str(answer).split(","):
        if "=" not in item:
            raise ConfigError(f"toggle answer {item!r} is not position=value", field="answer")
        k, v = (x.strip() for x in item.split("=", 1))
        if k not in trial.toggles or v not in ids:
            raise ConfigError(f"toggle answer {item!r}: position must be one of {trial.toggles}, value one of {ids}",
                              field="answer")
        parts[k] = v
    if set(parts) != set(trial.toggles):
        raise ConfigError(f"toggle answer needs every position {trial.toggles}", field="answer")
    norm = ",".join(f"{k}={parts[k]}" for k in trial.toggles)
    if trial.correct is None:
        return norm, None
    want = dict(item.split("=", 1) for item in trial.correct.split(","))
    return norm, sum(parts[k] == want[k] for k in trial.toggles) / len(trial.toggles)


def check_info(fields: list[InfoField], answers: dict[str, str | float]) -> dict[str, str | float]:
    """The participant-information ``answers`` checked against the design's ``fields`` (every
    field answered, nothing else); ConfigError naming the field."""
    extra = sorted(set(answers) - {f.id for f in fields})
    if extra:
        raise ConfigError(f"{extra[0]!r} is not a field of the form", field="participant_info")
    out: dict[str, str | float] = {}
    for f in fields:
        v, where = answers.get(f.id), f"participant_info.{f.id}"
        if f.kind == "number":
            try:
                x = float(v)  # the page's number input may send text
            except (TypeError, ValueError):
                raise ConfigError(f"{v!r} is not a number", field=where) from None
            if not (x == x and (f.min is None or x >= f.min) and (f.max is None or x <= f.max)):
                raise ConfigError(f"{x:g} is outside {f.min}..{f.max}", field=where)
            out[f.id] = x
        elif not isinstance(v, str) or not v.strip() or len(v) > 200 or (f.kind == "choice" and v not in f.choices):
            raise ConfigError("missing or not one of the offered answers" if f.kind == "choice"
                              else "must be text of 1-200 characters", field=where)
        else:
            out[f.id] = v.strip()
    return out


class SessionRunner:
    """One participant's session over ``study_dir`` (holding ``study.json``)."""

    def __init__(self, study_dir: str | Path, participant: str, *, gain: float | None = None,
                 comfort_voltage: float | None = None, mode: str = "page", extra_config: dict | None = None,
                 display: DisplayModel | None = None, today: date | None = None, allow_same_day: bool = False):
        self.dir = Path(study_dir)
        self.study: Study = load_study(self.dir)
        self.plan = self.study.participant(participant)
        sess = self.study.design.session
        self.gain = float(sess.gain if gain is None else gain)
        if not (0 < self.gain <= MAX_GAIN):
            raise ConfigError(f"must be in (0, {MAX_GAIN:g}]", source="--gain", field="gain")
        v_max = min(float(sess.v_max), SAFETY_V_MAX)
        if comfort_voltage is not None:
            if not (0 < comfort_voltage <= SAFETY_V_MAX):
                raise ConfigError(f"must be in (0, {SAFETY_V_MAX:g}] V (the safety limit)", source="--comfort-voltage",
                                  field="v_max")
            v_max = min(v_max, float(comfort_voltage))
        self.v_max = v_max
        self.limit_s = sess.stimulus_limit_s  # each stimulus's play time from its first touch (None: no limit)
        self.display = display  # the panel the stimuli are rendered for (--display; None: the assumptions)
        study_file = self.dir / "study.json" if self.dir.is_dir() else self.dir
        config = {"study": str(study_file), "study_sha256": hashlib.sha256(study_file.read_bytes()).hexdigest(),
                  "design": self.study.design.name, "kind": self.study.design.kind, "participant": self.plan.id,
                  "group": self.plan.group, "gain": self.gain, "v_max": self.v_max, "mode": mode,
                  "display": None if display is None else display.describe(),
                  "host": platform.node(), "python": platform.python_version(), **(extra_config or {})}
        self.log = TrialLog(self.dir / "logs" / f"{self.plan.id}.jsonl", participant=self.plan.id, config=config)
        self._lock = threading.Lock()
        self._shown_at: dict[str, float] = {}
        self._stimulus_log: dict[str, list] = {}
        done = self.log.completed
        unknown = done - {t.id for t in self.plan.trials}
        if unknown:
            self.log.close()
            raise StudyFormatError(f"log holds trials that are not in the study ({sorted(unknown)[:3]})",
                                   source=str(self.log.path), field="trial_id")
        todo = [t for t in self.plan.trials if t.id not in done]
        self.study_session = todo[0].session if todo else max(t.session for t in self.plan.trials)
        self._pending = [t for t in todo if t.session == self.study_session]
        self.later = len(todo) - len(self._pending)  # trials of the sessions still to come (other days)
        day = (today or local_today()).isoformat()
        prev_days = {s["config"].get("date") for s in self.log.contents.sessions
                     if s["config"].get("study_session") == self.study_session - 1}
        if self._pending and day in prev_days and not allow_same_day:
            self.log.close()
            raise ConfigError(f"session {self.study_session} of {self.plan.id} on the day of session "
                              f"{self.study_session - 1} ({day}): come back another day (or --allow-same-day)",
                              source="--participant", field="session")
        config.update(date=day, study_session=self.study_session)  # the session record, written with its first line
        # the participant-information form: answered once, before the first trial
        self._info = self.study.design.participant_info
        self._info_needed = bool(self._info) and not any(e["event"] == "participant-info"
                                                         for e in self.log.contents.events)
        self._resting = False
        self.paused = False  # the experimenter paused the session (the page shows a neutral screen)
        self._started = time.monotonic()
        self.last_record: dict | None = None
        if done and self._pending:
            self._resting = True  # resuming: start on the rest screen
            self.log.event("resume", deferred=True, next_trial=self._pending[0].id, completed=len(done))

    # -------------------------------------------------------------- state
    @property
    def total(self) -> int:
        return len(self.plan.trials)

    @property
    def n_done(self) -> int:
        return self.total - len(self._pending) - self.later

    @property
    def finished(self) -> bool:
        """Nothing more to run now: the study, or this session of it (``later`` > 0), is done."""
        return not self._pending

    def current(self) -> Trial | None:
        return self._pending[0] if self._pending else None

    def state(self) -> dict:
        """What the page shows now: {"status": "trial" | "rest" | "done", ...}."""
        with self._lock:
            base = {"done": self.n_done, "total": self.total, "participant": self.plan.id}
            t = self.current()
            if t is None:  # next_session: come back another day
                return {**base, "status": "done", **({"next_session": self.study_session + 1} if self.later else {})}
            if self.paused:
                return {**base, "status": "paused"}
            if self._info_needed:
                return {**base, "status": "info", "info": [f.model_dump() for f in self._info]}
            # block_label (the condition) is for the experimenter; the page shows only numbers (blinding)
            base.update(self._block_numbers(t))
            if self._resting:
                return {**base, "status": "rest", "next_block": t.block_label}
            self._shown_at.setdefault(t.id, time.monotonic())
            sess = self.study.design.session
            return {**base, "status": "trial", "block_label": t.block_label,
                    "trial": {"id": t.id, "prompt": t.prompt, "response": t.response, "practice": t.practice,
                              "limit_s": sess.stimulus_limit_s, "blank": sess.blank_until_release,
                              "stimuli": [s.label for s in t.stimuli],
                              "real": [s.render.get("real") for s in t.stimuli],
                              "choices": [c.model_dump() for c in t.choices], "toggles": t.toggles,
                              "image": any(s.render.get("scene") or s.render.get("mesh") not in (None, "flat")
                                           for s in t.stimuli),
                              "touch": any(s.render.get("haptic", True) and "real" not in s.render
                                           for s in t.stimuli)}}

    def _block_numbers(self, t: Trial) -> dict:
        blocks = sorted({x.block for x in self.plan.trials})
        return {"block_number": blocks.index(t.block) + 1, "blocks": len(blocks)}

    def resume(self) -> None:
        """Leave the rest screen."""
        with self._lock:
            if self._resting:
                self._resting = False
                t = self.current()
                self.log.event("rest-end", next_block=t.block_label if t else None)

    def info(self, answers: dict[str, str | float]) -> dict:
        """Record the participant-information form (:func:`check_info`) once; returns the new
        state plus ``"accepted"`` (False: already recorded, nothing written)."""
        with self._lock:
            accepted = self._info_needed
            if accepted:
                self.log.event("participant-info", answers=check_info(self._info, answers))
                self._info_needed = False
        return {**self.state(), "accepted": accepted}

    def stimulus(self, trial_id: str, index: int):
        """The participant selected stimulus ``index`` of the current trial; returns its
        Stimulus (to render), or None if ``trial_id`` is not the current trial."""
        with self._lock:
            t = self.current()
            if t is None or t.id != trial_id or self._blocked() or not 0 <= index < len(t.stimuli):
                return None
            self._stimulus_log.setdefault(trial_id, []).append(
                [index, round(time.monotonic() - self._shown_at.get(trial_id, time.monotonic()), 4)])
            return t.stimuli[index]

    def answer(self, trial_id: str, answer: str, rt_client_s: float | None = None) -> dict:
        """Record the answer to the current trial. Returns the new state plus ``"accepted"``:
        False (nothing written) when ``trial_id`` is not the current trial, e.g. a repeated
        click or a page left open from before a restart."""
        with self._lock:
            t = self.current()
            feedback = None
            if t is None or t.id != trial_id or self._blocked():
                accepted = False
            else:
                norm, score = check_answer(t, answer)
                shown = self._shown_at.pop(t.id, None)
                accepted = self._log_trial(t, answer=norm, is_correct=None if score is None else bool(score == 1.0),
                                           score=score, rt_s=None if rt_client_s is None else round(float(rt_client_s), 4),
                                           rt_server_s=None if shown is None else round(time.monotonic() - shown, 4))
                if t.training:  # the page shows it before the next trial (Trial.training)
                    label = {c.id: c.label for c in t.choices}
                    feedback = {"correct": score == 1.0, "answer": ", ".join(
                        f"{q}: {label[v]}" if q else label[v]
                        for q, _, v in (x.rpartition("=") for x in t.correct.split(",")))}
        return {**self.state(), "accepted": accepted, **({"feedback": feedback} if feedback else {})}

    def _blocked(self) -> bool:
        return self._resting or self._info_needed or self.paused

    def _log_trial(self, t: Trial, **answer) -> bool:
        """Log the current trial ``t`` with the ``answer`` fields and move on (lock held)."""
        rec = {"trial_id": t.id, "index": t.index, "block": t.block, "block_label": t.block_label,
               "task": t.task, "correct": t.correct, **answer,
               "stimuli_touched": self._stimulus_log.pop(t.id, []), "condition": t.condition,
               "answered_at": now_iso(), **({"practice": True} if t.practice else {}),
               **({"training": True} if t.training else {}),
               # the page's opaque ids -> choices, stimulus index -> render:
               "key": {"choices": choice_key([c.id for c in t.choices]),
                       "stimuli": [s.render for s in t.stimuli]}}
        accepted = self.log.append_trial(rec)
        self.last_record = rec
        self._pending.pop(0)
        nxt = self.current()
        if nxt is None:
            self.log.event("end" if not self.later else "session-end", completed=self.n_done,
                           study_session=self.study_session)
        elif nxt.block != t.block and self.study.design.session.rest_between_blocks:
            self._resting = True
            self.log.event("rest", after_block=t.block_label, next_block=nxt.block_label)
        return accepted

    # -------------------------------------------------------------- the experimenter's controls
    def pause(self, on: bool) -> bool:
        """Pause (``on``) or resume the session; logged as events "pause" / "pause-end" with
        the current trial. Returns False when nothing changed."""
        with self._lock:
            if on == self.paused or (on and self.current() is None):
                return False
            self.paused = on
            t = self.current()
            self.log.event("pause" if on else "pause-end", trial_id=t.id if t else None)
            return True

    def skip(self, trial_id: str) -> bool:
        """Skip the current trial ``trial_id``: logged with ``"skipped": true`` and no answer,
        never analysed as one. False (nothing written) when it is not the current trial."""
        with self._lock:
            t = self.current()
            if t is None or t.id != trial_id or self._info_needed:
                return False
            self._shown_at.pop(t.id, None)
            return self._log_trial(t, answer=None, is_correct=None, score=None, rt_s=None, rt_server_s=None,
                                   skipped=True)

    def note(self, text: str) -> None:
        """The experimenter's free-text note: a timestamped event with the participant and trial."""
        with self._lock:
            t = self.current()
            self.log.event("note", participant=self.plan.id, trial_id=t.id if t else None, text=text)

    def experimenter_state(self) -> dict:
        """What the experimenter's page shows: participant, block, trial n of N, elapsed time,
        pause, and the condition unless the design blinds the experimenter to it."""
        st = self.state()
        with self._lock:
            t = self.current()
            out = {"participant": self.plan.id, "status": st["status"], "paused": self.paused,
                   "trial_id": t.id if t else None, "trial": min(self.n_done + 1, self.total), "total": self.total,
                   **(self._block_numbers(t) if t else {}),
                   "elapsed_s": round(time.monotonic() - self._started, 1), "practice": bool(t and t.practice)}
            if t is not None and not self.study.design.session.blind_experimenter:
                out["condition"] = {"block": t.block_label, **t.condition}
        return out

    def renders(self) -> list[dict]:
        """The render specs of the stimuli still to run in this session."""
        return [s.render for t in self._pending for s in t.stimuli]

    def close(self) -> None:
        self.log.close()
