"""What the participant may see of a session: opaque ids only (blinding by construction).

The runners' ``state()`` is the experimenter's view (block labels name the condition, choice
ids may be condition names, e.g. the realism study's ``"friction+texture"``). The participant's
page, its API and the LSL markers get :func:`participant_state` instead: built field by field
from :data:`STATE_FIELDS` / :data:`TRIAL_FIELDS` (a new field is hidden until listed here), with
every choice id replaced by its position ``"1"``, ``"2"``, ... and a real sample's name by
``true``. The mapping from positions to choice ids (:func:`choice_key`) is written into every
trial record of the log, with the render spec of every stimulus (stimulus ``index`` of the
markers), so analysis needs nothing else.
"""

from __future__ import annotations

from surfhap.errors import ConfigError

__all__ = ["STATE_FIELDS", "TRIAL_FIELDS", "choice_key", "participant_state", "real_answer"]

#: fields of a runner's state the page receives (not: block_label, next_block, participant)
STATE_FIELDS = ("status", "done", "total", "block_number", "blocks", "accepted", "next_session",
                "info",  # info: the participant-information form (labels and answers offered, no condition)
                "feedback")  # a training trial's: right or not, the right answer's label (shown on its button)
#: fields of the current trial the page receives (choices and real samples made opaque)
TRIAL_FIELDS = ("id", "prompt", "response", "stimuli", "toggles", "image", "touch", "limit_s", "blank")


def choice_key(choice_ids: list[str]) -> dict[str, str]:
    """Opaque id (position from 1) -> choice id."""
    return {str(k): cid for k, cid in enumerate(choice_ids, start=1)}


def participant_state(state: dict) -> dict:
    """The participant's view of a runner's ``state()`` (see module doc)."""
    out = {k: state[k] for k in STATE_FIELDS if k in state}
    t = state.get("trial")
    if t is not None:
        view = {k: t[k] for k in TRIAL_FIELDS if k in t}
        view["real"] = [bool(r) for r in t.get("real", [])]
        view["choices"] = [{"id": str(k), "label": c["label"]} for k, c in enumerate(t["choices"], start=1)]
        out["trial"] = view
    return out


def real_answer(key: dict[str, str], answer: str, toggles: bool) -> str:
    """The choice id(s) of an opaque ``answer`` ("2", or "TL=1,TR=2" for toggles); ConfigError
    naming only opaque ids for one the trial does not offer."""
    values = [answer] if not toggles else [item.partition("=")[2].strip() for item in answer.split(",")]
    bad = next((v for v in values if v not in key), None)
    if bad is not None:
        raise ConfigError(f"answer {bad!r} is not one of {list(key)}", field="answer")
    if not toggles:
        return key[answer]
    return ",".join(f"{item.partition('=')[0].strip()}={key[v]}" for item, v in zip(answer.split(","), values))
