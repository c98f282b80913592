"""What the web pages send and receive: the pointer messages of the WebSocket (touch page,
force-feedback page, study pad), the study page's request bodies and the trace encoding.

Page -> server (JSON text, one per pointer event), one pydantic discriminated union on
``type`` (:func:`parse_message`) validated straight from the JSON text::

    {"type": "hello", "w": css_px, "h": css_px}
    {"type": "move", "seq": n, "t": ms, "x": 0..1, "y": 0..1, "p": 0..1}
    {"type": "up", "seq": n, "t": ms}

Numbers must be JSON numbers within their ranges; NaN, ±inf and numbers too large for a float
(``1e400``, ``10**400``) are invalid like any out-of-range value (the rule of
:func:`surfhap.live.sources.finite_in_range`); unknown keys are ignored. The study page's POST
bodies are :class:`StimulusRequest`, :class:`AnswerRequest` and :class:`InfoRequest`, the
experimenter page's :class:`SkipRequest` and :class:`NoteRequest`.

Server -> page at ``trace_hz`` (:func:`trace_message`): ``{"type": "trace", "ack": seq,
"ack_t": ms, "received": n, "rejected": n, "t": [...], "v": [...], "f": [...], "target": [...],
"speed": [...], "status": {...}}``: the newest acknowledged ``seq`` and its page time stamp
(the page shows the round trip), the trace rows since the last frame and, every few frames,
the engine's counters and latency.
"""

from __future__ import annotations

import json
from typing import Annotated, Literal, Optional, Union

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, TypeAdapter

__all__ = ["Hello", "Move", "Up", "ClientMessage", "parse_message", "reason", "number", "page_to_surface",
           "trace_message", "encode", "json_default", "CSS_PX_M", "StimulusRequest", "AnswerRequest",
           "InfoRequest", "SkipRequest", "NoteRequest"]

CSS_PX_M = 0.0254 / 96.0  # one CSS pixel in metres (CSS reference pixel: 1/96 inch)


def number(lo: float, hi: float):
    """A JSON number (int or float, not bool or str), finite, within [lo, hi]."""
    return Annotated[float, Field(ge=lo, le=hi, strict=True, allow_inf_nan=False)]


Seq = Annotated[int, Field(ge=0, lt=2**53, strict=True)]  # an exact integer in a JS number
TimeMs = number(0.0, 1e12)
Fraction = number(-0.05, 1.05)  # page position, a little beyond the edges
CssPx = number(10.0, 20000.0)


class _Message(BaseModel):  # also the study page's request bodies
    model_config = ConfigDict(frozen=True, extra="ignore")


class Hello(_Message):
    """The page's size in CSS pixels (sent on connect and on resize)."""

    type: Literal["hello"]
    w: CssPx
    h: CssPx


class Move(_Message):
    """Finger (or pointer) at ``x``, ``y`` (fractions of the page) with pressure ``p`` 0-1
    (0: unknown, taken as 0.5); ``t``: the page's time stamp (ms); ``seq``: event number."""

    type: Literal["move"]
    seq: Seq
    t: TimeMs
    x: Fraction
    y: Fraction
    p: number(0.0, 1.0) = 0.5


class Up(_Message):
    """Finger lifted at page time ``t`` (ms)."""

    type: Literal["up"]
    seq: Seq
    t: TimeMs


ClientMessage = Annotated[Union[Hello, Move, Up], Field(discriminator="type")]
# the compiled validator itself: TypeAdapter.validate_json's Python wrapper cost a third more
_VALIDATE_JSON = TypeAdapter(ClientMessage).validator.validate_json


def parse_message(text: str | bytes) -> Hello | Move | Up:
    """The validated message in ``text`` (JSON); raises pydantic's ``ValidationError``
    (:func:`reason` makes it one line) for anything else, also malformed JSON."""
    return _VALIDATE_JSON(text)


def reason(errors: list) -> str:
    """One line (at most ~120 characters, never the input itself) from pydantic's or
    FastAPI's list of validation errors: where and what."""
    err = errors[0] if errors else {}
    loc = ".".join(str(p) for p in err.get("loc", ()) if p != "body")[:40]
    return f"{loc + ': ' if loc else ''}{str(err.get('msg', 'invalid'))[:80]}"


TrialId = Annotated[str, Field(max_length=200, strict=True)]


class StimulusRequest(_Message):
    """Study page ``POST /api/stimulus``: play stimulus ``index`` of trial ``trial_id``."""

    trial_id: TrialId
    index: Annotated[int, Field(ge=0, le=1000, strict=True)]


class AnswerRequest(_Message):
    """Study page ``POST /api/answer``: ``answer`` to ``trial_id``, ``rt_ms`` measured in the
    page (trial shown -> click, ms, at most a day)."""

    trial_id: TrialId
    answer: Annotated[str, Field(max_length=500, strict=True)]
    rt_ms: Optional[number(0.0, 86_400_000.0)] = None


class InfoRequest(_Message):
    """Study page ``POST /api/info``: the participant-information form, field id -> answer."""

    answers: Annotated[dict[Annotated[str, Field(max_length=32)],
                            Union[Annotated[str, Field(max_length=200, strict=True)], number(-1e9, 1e9)]],
                       Field(max_length=50)]


class SkipRequest(_Message):
    """Experimenter page ``POST /experimenter/api/skip``: skip ``trial_id`` (the current trial)."""

    trial_id: TrialId


class NoteRequest(_Message):
    """Experimenter page ``POST /experimenter/api/note``: a free-text note for the log."""

    text: Annotated[str, Field(min_length=1, max_length=500, strict=True)]  # within the body cap


def page_to_surface(msg: Move, width_px: float, height_px: float, space, surface: bool) -> tuple[float, float, float]:
    """``(x, y, load)`` in metres and newtons for a move on a page of ``width_px`` x
    ``height_px`` CSS pixels: positions clipped to the page, then mapped through CSS pixels
    (``surface=False``: real finger speed) or onto the whole ``space`` (``surface=True``);
    load = pressure x ``space.max_load`` (pressure 0 counts as 0.5)."""
    x, y, p = msg.x, msg.y, msg.p  # comparisons, not min/max: this runs for every pointer event
    x = 0.0 if x < 0.0 else (1.0 if x > 1.0 else x)
    y = 0.0 if y < 0.0 else (1.0 if y > 1.0 else y)
    load = (p if p > 0 else 0.5) * space.max_load
    if surface:
        return x * space.width, y * space.height, load
    return x * width_px * CSS_PX_M, y * height_px * CSS_PX_M, load


def json_default(o):
    """JSON for numpy scalars (and ``str`` of anything else) in engine status dicts."""
    return o.item() if isinstance(o, (np.integer, np.floating)) else str(o)


def encode(obj) -> str:
    """Compact JSON of ``obj`` (numpy scalars as numbers, see :func:`json_default`)."""
    return json.dumps(obj, default=json_default, separators=(",", ":"))


def trace_message(ack: int, ack_t: float, received: int, rejected: int, *parts: str) -> str:
    """One server -> page message (see module doc): the client's counters and the members of
    ``parts``, JSON objects encoded by :func:`encode` (the trace frame of
    :meth:`surfhap.live.session.FrameBuilder.frame` and, when due, ``{"status": ...}``). A frame
    is encoded once for every client: only the counters are formatted per client."""
    head = (f'{{"type":"trace","ack":{int(ack)},"ack_t":{float(ack_t)!r},"received":{int(received)},'
            f'"rejected":{int(rejected)}')
    return head + "".join("," + p[1:-1] for p in parts if len(p) > 2) + "}"
