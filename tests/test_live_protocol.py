"""The page's message models (pydantic, surfhap.web.messages) against the hand-written
range rule they replace (surfhap.live.sources.finite_in_range), and the trace encoding."""

from __future__ import annotations

import json

import pytest
from hypothesis import given
from hypothesis import strategies as st

from pydantic import ValidationError

from surfhap.live.sources import TouchSpace, finite_in_range
from surfhap.web.messages import (CSS_PX_M, Hello, Move, Up, encode, page_to_surface, reason,
                                  trace_message)
from surfhap.web.messages import parse_message as _parse_or_raise


def parse_message(text):
    """The message, or the one-line reason the page server logs (any other exception fails)."""
    try:
        return _parse_or_raise(text)
    except ValidationError as exc:
        return reason(exc.errors(include_url=False, include_input=False))

HUGE = "1" + "0" * 400
VALID = {"hello": {"type": "hello", "w": 800, "h": 600},
         "move": {"type": "move", "seq": 1, "t": 0.0, "x": 0.5, "y": 0.5, "p": 0.5},
         "up": {"type": "up", "seq": 2, "t": 1.0}}
RANGES = {("hello", "w"): (10.0, 20000.0), ("hello", "h"): (10.0, 20000.0), ("move", "t"): (0.0, 1e12),
          ("move", "x"): (-0.05, 1.05), ("move", "y"): (-0.05, 1.05), ("move", "p"): (0.0, 1.0),
          ("up", "t"): (0.0, 1e12)}
# JSON literals and the Python value json.loads gives for each (the reference's input)
LITERALS = ["0", "0.5", "1", "-0.05", "1.05", "-0.0501", "1.0501", "10", "9.99", "20000", "20000.5", "1e12",
            "1.0000001e12", "-1", "1e308", "-1e308", "1e400", "-1e400", HUGE, "-" + HUGE, "NaN", "Infinity",
            "-Infinity", '"0.5"', "true", "false", "null", "[0.5]", "{}", "800"]


def _message(kind: str, field: str, literal: str) -> str:
    return json.dumps(dict(VALID[kind], **{field: "@@"})).replace('"@@"', literal)


def _python(literal: str):
    try:
        return json.loads(literal)
    except ValueError:
        return None


@pytest.mark.parametrize("kind,field", sorted(RANGES))
def test_numeric_fields_follow_the_finite_in_range_rule(kind, field):
    lo, hi = RANGES[(kind, field)]
    for literal in LITERALS:
        expected = finite_in_range(_python(literal), lo, hi)
        msg = parse_message(_message(kind, field, literal))
        if expected is None:
            assert isinstance(msg, str), f"{kind}.{field}={literal[:12]} accepted"
        else:
            assert not isinstance(msg, str), f"{kind}.{field}={literal[:12]} rejected: {msg}"
            assert getattr(msg, field) == expected


@pytest.mark.parametrize("kind", ["move", "up"])
def test_seq_must_be_an_exact_non_negative_integer(kind):
    for literal, ok in (("0", True), ("7", True), (str(2**53 - 1), True), (str(2**53), False), ("-1", False),
                        ("1.0", False), ("1.5", False), ("true", False), ('"1"', False), ("null", False),
                        (HUGE, False), ("1e400", False), ("NaN", False)):
        msg = parse_message(_message(kind, "seq", literal))
        assert isinstance(msg, str) != ok, (kind, literal, msg)


def test_message_kinds_and_garbage():
    assert isinstance(parse_message(json.dumps(VALID["hello"])), Hello)
    m = parse_message(json.dumps({k: v for k, v in VALID["move"].items() if k != "p"}))
    assert isinstance(m, Move) and m.p == 0.5  # pressure is optional
    assert isinstance(parse_message(json.dumps(dict(VALID["up"], extra=[1, 2]))), Up)  # unknown keys ignored
    for bad in ("not json", "[1,2,3]", '"move"', "{}", '{"type":"move"}', '{"type":"__import__(\'os\')"}',
                '{"type":1}', '{"type":"up","seq":1}', "[" * 600 + "]" * 600, '{"type":"hello","w":800}', ""):
        reason = parse_message(bad)
        assert isinstance(reason, str) and reason and "\n" not in reason, bad


@given(st.one_of(st.text(max_size=300), st.binary(max_size=300),
                 st.recursive(st.none() | st.booleans() | st.floats() | st.integers() | st.text(max_size=8),
                              lambda c: st.lists(c, max_size=4) | st.dictionaries(
                                  st.sampled_from(["type", "seq", "t", "x", "y", "p", "w", "h"]) | st.text(max_size=4),
                                  c, max_size=6), max_leaves=20).map(lambda v: json.dumps(v))))
def test_any_input_gives_a_message_or_a_reason_never_an_exception(text):
    out = parse_message(text)
    assert isinstance(out, (str, Hello, Move, Up))


def test_page_positions_map_to_metres_and_load():
    space = TouchSpace(width=0.2, height=0.1, max_load=2.0)
    m = Move(type="move", seq=0, t=0.0, x=0.25, y=1.05, p=0.0)
    x, y, load = page_to_surface(m, 800.0, 600.0, space, surface=False)
    assert x == pytest.approx(0.25 * 800 * CSS_PX_M) and y == pytest.approx(600 * CSS_PX_M)  # clipped to the page
    assert load == pytest.approx(1.0)  # pressure 0 (unknown) counts as 0.5
    x, y, load = page_to_surface(Move(type="move", seq=0, t=0.0, x=-0.05, y=0.5, p=1.0), 800.0, 600.0, space,
                                 surface=True)
    assert (x, y, load) == (0.0, pytest.approx(0.05), pytest.approx(2.0))


def test_trace_message_is_json_with_the_client_counters_frame_and_status():
    import numpy as np

    frame = {"t": [0.1, 0.2], "v": [1.0, 2.0], "f": [0.0, 0.1], "target": [0.0, 0.1], "speed": [0.0, 0.01]}
    status = {"counters": {"blocks": np.int64(3)}, "lat": np.float32(0.5), "note": 'a "quoted" } name'}
    m = json.loads(trace_message(5, 123.5, 6, 1, encode(frame), encode({"status": status})))
    assert m == {"type": "trace", "ack": 5, "ack_t": 123.5, "received": 6, "rejected": 1, **frame,
                 "status": {"counters": {"blocks": 3}, "lat": 0.5, "note": 'a "quoted" } name'}}
    assert json.loads(trace_message(5, 0.0, 6, 1, encode(frame))) == {
        "type": "trace", "ack": 5, "ack_t": 0.0, "received": 6, "rejected": 1, **frame}
    assert json.loads(trace_message(0, 1e12, 0, 0, "{}", encode({"a": [1]}))) == {
        "type": "trace", "ack": 0, "ack_t": 1e12, "received": 0, "rejected": 0, "a": [1]}
