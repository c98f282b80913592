"""Schemas (pydantic) of study designs, generated studies, and how they are read.

* a *design* (``surfhap-study-design``): which paper's study, its parameters, the number of
  participants and a seed; written by hand or taken from the built-in templates;
* a *study* (``surfhap-study``): the design plus, for every participant, the complete trial
  list generated from the seed with the paper's counterbalancing. ``surfhap study new`` writes
  it to ``STUDY/study.json``; ``study run`` and ``study analyze`` read it.

A malformed file raises :class:`~surfhap.errors.StudyFormatError` naming the file and the field
(``design.json: params.repetitions: Input should be greater than or equal to 1``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, model_validator

from surfhap.errors import StudyFormatError
from surfhap.exchange.files import read_model
from surfhap.lab.quest import QuestParams
from surfhap.lab.questplus import QuestPlusParams
from surfhap.lab.staircase import StaircaseParams

#: the adaptive method of a design's threshold procedures (the comfort run): one of the three
#: parameter types, chosen by ``method`` ("staircase" | "quest" | "questplus")
Adaptive = Annotated[StaircaseParams | QuestParams | QuestPlusParams, Field(discriminator="method")]

__all__ = ["Adaptive", "DESIGN_FORMAT", "STUDY_FORMAT", "KINDS", "Choice", "Stimulus", "Trial", "ParticipantPlan", "InfoField",
           "DesignSpec",
           "Session", "Study", "load_design", "load_study"]

DESIGN_FORMAT = "surfhap-study-design"
STUDY_FORMAT = "surfhap-study"
KINDS = ("nafc", "realism", "identification", "ratings", "shape-choice", "scene-recognition", "sliding-pairs")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class Choice(_Strict):
    """One answer button: ``id`` is logged, ``label`` is shown."""

    id: str = Field(min_length=1, max_length=64)
    label: str = Field(min_length=1, max_length=200)


class Stimulus(_Strict):
    """One stimulus of a trial. ``label`` is shown on its button; ``render`` says what to play:
    ``{"material": name, "method": drive law}``, ``{"material": name, "method": "square",
    "square_frequency": Hz}``, ``{"mesh": shape or scene name, "grain": ..., "profile": ...}``,
    ``{"effect": "follow"|"reverse"|"static"}`` (force feedback) or ``{"real": name}`` (a real
    sample handed over by the experimenter: nothing is rendered)."""

    label: str = Field(min_length=1, max_length=64)
    render: dict[str, Any]


class Trial(_Strict):
    """One trial: the stimuli, the question and its possible answers.

    response "choice": one of ``choices``; "toggles": each of ``toggles`` (e.g. scene
    positions) is set to one of ``choices`` and the answer is ``"TL=bump,TR=hole,..."``;
    "text": a free-text answer (no choices), logged verbatim (002 Part 1: open descriptions).
    ``correct`` is the right answer when there is one (None for preferences and ratings).
    ``session``: the study session (a separate day, from 1) the trial belongs to; a run stops
    at the end of a session's trials (e.g. 004: two blocks per session).
    """

    id: str
    index: int = Field(ge=0)
    block: int = Field(ge=0)
    block_label: str
    task: str
    prompt: str
    stimuli: list[Stimulus]
    response: Literal["choice", "toggles", "text"] = "choice"
    choices: list[Choice] = []
    toggles: list[str] = []
    correct: str | None = None
    condition: dict[str, str | int | float] = {}
    practice: bool = False  # a practice trial: logged with "practice": true, left out of the analysis
    # a training trial: a practice trial whose answer the page follows with feedback (right or
    # wrong, and the right answer); logged with "training": true as well (003 Sec. III-B)
    training: bool = False
    session: int = Field(1, ge=1)

    @model_validator(mode="after")
    def _choices(self) -> "Trial":
        if (self.response == "text") == (len(self.choices) >= 2):
            raise ValueError("choices: two or more for a choice or toggles answer, none for text")
        if self.training and not (self.practice and self.correct):
            raise ValueError("training: a training trial is a practice trial with a correct answer")
        return self


class ParticipantPlan(_Strict):
    id: str = Field(min_length=1, max_length=64, pattern=r"^[A-Za-z0-9_.-]+$")
    group: str = ""
    trials: list[Trial]


class Session(_Strict):
    """How a session runs. ``rest_between_blocks``: show the rest screen between blocks;
    ``gain``: default multiplier of the drive gain alpha (per participant, ``study run
    --gain``); ``v_max``: V, the safety limit of the session (never above 250 V, Otake et al.
    2022 Sec. IV-D; lowered per participant with ``--comfort-voltage``).
    ``stimulus_limit_s``: each stimulus plays for this long from the first touch, then stops
    (None: no limit); ``blank_until_release``: when it stops, the page turns black until the
    finger is lifted (004 Sec. 5.2: 3.5 s, then black until release).
    ``blind_experimenter``: the experimenter's page of ``study run`` hides the condition of
    the current trial (False: shows it, for designs not blinded to the experimenter)."""

    rest_between_blocks: bool = True
    gain: float = Field(1.0, gt=0, le=4.0)
    v_max: float = Field(250.0, gt=0, le=250.0)
    stimulus_limit_s: float | None = Field(None, gt=0, le=600.0)
    blank_until_release: bool = False
    blind_experimenter: bool = True


class InfoField(_Strict):
    """One question of the participant-information form, shown before the first trial:
    ``kind`` "number" (within ``min``..``max``), "choice" (one of ``choices``) or "text"
    (at most 200 characters). The answers are logged once (event ``participant-info``)."""

    id: str = Field(min_length=1, max_length=32, pattern=r"^[a-z][a-z0-9_]*$")
    label: str = Field(min_length=1, max_length=200)
    kind: Literal["number", "choice", "text"]
    choices: list[str] = []
    min: float | None = None
    max: float | None = None

    @model_validator(mode="after")
    def _choices(self) -> "InfoField":
        if (self.kind == "choice") != (len(self.choices) >= 2):
            raise ValueError("choices: a choice field needs two or more, other kinds none")
        return self


class DesignSpec(_Strict):
    format: Literal["surfhap-study-design"] = DESIGN_FORMAT
    version: Literal[1] = 1
    kind: Literal[KINDS]
    name: str = Field(min_length=1, max_length=200)
    seed: int = Field(0, ge=0)
    participants: int = Field(ge=1, le=1000)
    params: dict[str, Any] = {}
    session: Session = Session()
    participant_info: list[InfoField] = []  # e.g. age, handedness, gender
    note: str = ""
    adaptive: Adaptive | None = None  # the comfort run's method (None: its 3-up/1-down staircase)


class Study(_Strict):
    format: Literal["surfhap-study"] = STUDY_FORMAT
    version: Literal[1] = 1
    design: DesignSpec
    params: dict[str, Any]
    software_version: str
    participants: list[ParticipantPlan]

    def participant(self, pid: str) -> ParticipantPlan:
        for p in self.participants:
            if p.id == pid:
                return p
        raise StudyFormatError(f"unknown participant {pid!r} (study has {', '.join(p.id for p in self.participants[:8])}"
                               f"{' ...' if len(self.participants) > 8 else ''})", field="participant")


def load_design(path: str | Path) -> DesignSpec:
    """Read and validate a design file."""
    return read_model(path, DesignSpec, StudyFormatError)


def load_study(folder: str | Path) -> Study:
    """Read and validate ``STUDY/study.json`` (``folder`` may also be the file itself)."""
    p = Path(folder)
    return read_model(p / "study.json" if p.is_dir() else p, Study, StudyFormatError)
