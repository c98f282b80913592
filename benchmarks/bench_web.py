"""Page server message validation, measured in one run (one JSON line; ratio >= 1 passes).

web_message_validation: per-message time to turn one page message (JSON text) into a
validated message, for the pydantic discriminated union of :mod:`surfhap.live.protocol`
(``parse_message``) and for the hand-written checks it replaced (``json.loads`` and
:func:`surfhap.live.sources.finite_in_range` per field, kept below as the reference).
A realistic mix: 90 % ``move``, 5 % ``up``, 5 % ``hello``. Best of 7 runs of 20 000
messages each. Target: the models at least 2x faster than the old checks (ratio = speed-up / 2).
"""

import json

from _common import best_time, log, report, run

from surfhap.live.protocol import parse_message
from surfhap.live.sources import finite_in_range as _num


def old_check(text: str):
    """The checks of the hand-written validator before pydantic (reference only): the
    message's fields, or None when rejected."""
    try:
        msg = json.loads(text)
    except (ValueError, RecursionError):
        return None
    if not isinstance(msg, dict):
        return None
    kind = msg.get("type")
    if kind == "move":
        seq = msg.get("seq")
        t = _num(msg.get("t"), 0.0, 1e12)
        x = _num(msg.get("x"), -0.05, 1.05)
        y = _num(msg.get("y"), -0.05, 1.05)
        p = _num(msg.get("p", 0.5), 0.0, 1.0)
        if not isinstance(seq, int) or isinstance(seq, bool) or not 0 <= seq < 2**53 or None in (t, x, y, p):
            return None
        return (kind, seq, t, x, y, p)
    if kind == "up":
        seq = msg.get("seq")
        t = _num(msg.get("t"), 0.0, 1e12)
        if not isinstance(seq, int) or isinstance(seq, bool) or not 0 <= seq < 2**53 or t is None:
            return None
        return (kind, seq, t)
    if kind == "hello":
        w = _num(msg.get("w"), 10.0, 20000.0)
        h = _num(msg.get("h"), 10.0, 20000.0)
        if w is None or h is None:
            return None
        return (kind, w, h)
    return None


def messages(n: int) -> list[str]:
    out = []
    for i in range(n):
        if i % 20 == 0:
            out.append(json.dumps({"type": "hello", "w": 1280 + i % 7, "h": 720}))
        elif i % 20 == 10:
            out.append(json.dumps({"type": "up", "seq": i, "t": 16.7 * i}))
        else:
            out.append(json.dumps({"type": "move", "seq": i, "t": 16.7 * i, "x": (i % 97) / 97.0,
                                   "y": (i % 89) / 89.0, "p": 0.5}))
    return out


def main():
    msgs = messages(20000)
    # the same verdicts first: both accept every message of the mix
    assert all(old_check(m) is not None for m in msgs) and not any(isinstance(parse_message(m), str) for m in msgs)

    def new():
        for m in msgs:
            parse_message(m)

    def old():
        for m in msgs:
            old_check(m)

    t_new = best_time(new, 7) / len(msgs)
    t_old = best_time(old, 7) / len(msgs)
    speedup = t_old / t_new
    log(f"pydantic {t_new * 1e6:.2f} us, old checks {t_old * 1e6:.2f} us per message")
    report("web_message_validation", {"pydantic_us": round(t_new * 1e6, 3), "old_checks_us": round(t_old * 1e6, 3),
                                      "speedup": round(speedup, 2)}, speedup / 2.0, "pydantic >= 2x faster", speedup >= 2.0)


if __name__ == "__main__":
    run(main)
