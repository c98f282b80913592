"""The papers' study designs, generated per participant from a seed with their counterbalancing.

================== ============================================================================ =======
kind               trials per participant (defaults)                                            paper
================== ============================================================================ =======
nafc               per condition: C(4, 2) = 6 material pairs x 4 repetitions = 24 trials; one    001
                   material shown twice, the other once; which one is the odd one alternates
                   over the repetitions, its position is balanced over the 3 intervals;
                   condition order alternates between participants (Latin square)
realism            4 materials x 2 rounds (a break between them) = 8 two-alternative trials:    003
                   friction+texture vs friction-only; each material gets both presentation
                   orders over the two rounds
identification     per condition: 4 materials x 2 = 8 trials, answer = one of the 4 materials;  003
                   condition order alternates between participants; the template opens with
                   8 training trials with feedback (each material once per condition)
ratings            block 1: 10 materials x (real, virtual) x (roughness, stickiness) on 7-point  000
                   scales; block 2: similarity (7 points) of each real material with its
                   data-driven rendering and with a constant-amplitude square wave (30-300 Hz)
shape-choice       10 electrovibration conditions of Table 1 (bump/hole x IP0.5/IP0.7 x two     002
                   grains, flat x two grains), once each, random order; answer bump / hole /
                   flat / none of these; groups G1 / G2 alternate
scene-recognition  20 scenes x 2 sessions (V, V+H): G1 does V+H first, G2 V first; scene order   002
                   random per session; answer: bump or hole at each of the four positions
sliding-pairs      4 blocks (V0F0, V0F1, V1F0, V1F1) in balanced-Latin-square order, 2 blocks    004
                   per session; each block 6 ordered pairs of REVERSE / FOLLOW / STATIC x 10 = 60;
                   2 practice trials (not analysed) open each session; 3.5 s per stimulus
================== ============================================================================ =======

Every generator reads its parameters from ``design.params`` through a strict pydantic model,
so an unknown or out-of-range parameter is a :class:`~surfhap.errors.StudyFormatError` naming
``params.<field>``. The random stream of participant ``i`` is ``default_rng([seed, i])``.
"""

from __future__ import annotations

from itertools import combinations, permutations, product
from typing import Callable, Literal

import numpy as np
from pydantic import Field, ValidationError

from surfhap.errors import StudyFormatError
from surfhap.lab.counterbalance import balanced_assignment, balanced_latin_square, participant_rng
from surfhap.checked import Checked, first_error, within
from surfhap.lab.schema import Choice, DesignSpec, ParticipantPlan, Stimulus, Study, Trial

__all__ = ["build_study", "TEMPLATES", "template", "study_template", "ZHAO_MATERIALS", "square_frequencies",
           "analysis_params"]

OTAKE2021_MATERIALS = ["leather", "cork", "denim", "drawing-paper"]  # 001 Sec. III
OTAKE2022_MATERIALS = ["leather", "cork", "denim", "wood"]  # 003 Sec. II
# 000 Sec. 3: ten HaTT materials (names of the user's HaTT models; HaTT is not redistributed)
ZHAO_MATERIALS = ["masking-tape", "playing-card", "sandpaper-220", "frosted-acrylic", "nylon-bag", "nylon-mesh",
                  "scouring-pad", "aluminum", "whiteboard", "cork"]
SLIDING_EFFECTS = ["reverse", "follow", "static"]  # 004 Sec. 5.2
SLIDING_BLOCKS = ["V0F0", "V0F1", "V1F0", "V1F1"]  # 004 Sec. 5.2
SCALE = [Choice(id=str(i), label=str(i)) for i in range(1, 8)]  # 7-point scales of 000


Alternative = Literal["two-sided", "greater", "less"]


def _conditions(method: str, **bounds):
    """The conditions field: the drive law ``method`` against friction only (condition -> law)."""
    return Field(default_factory=lambda: {"friction+texture": method, "friction-only": "friction-only"}, **bounds)


class NafcParams(Checked):
    materials: list[str] = Field(default_factory=lambda: list(OTAKE2021_MATERIALS), min_length=2)
    conditions: dict[str, str] = _conditions("otake2021", min_length=1)
    repetitions: int = Field(4, ge=1, le=100)
    alternatives: int = Field(3, ge=3, le=6)
    # 001 Sec. V: t = 0.63, p = 0.27 is a one-sided Student t test between the conditions'
    # participant proportions (independent: it matches all five t values the paper prints)
    alternative: Alternative = "greater"
    paired: bool = False


class RealismParams(Checked):
    materials: list[str] = Field(default_factory=lambda: list(OTAKE2022_MATERIALS), min_length=1)
    conditions: dict[str, str] = _conditions("otake2022", min_length=2, max_length=2)  # a comparison of two
    rounds: int = Field(2, ge=1, le=20)
    alternative: Alternative = "greater"  # 003 Table II: "greater than the chance level"


class IdentificationParams(Checked):
    materials: list[str] = Field(default_factory=lambda: list(OTAKE2022_MATERIALS), min_length=2)
    conditions: dict[str, str] = _conditions("otake2022", min_length=1)
    repetitions: int = Field(2, ge=1, le=100)
    # 003 Table IV: two-sided unpooled (Wald) z per material, Bonferroni (p = .04 / .04)
    alternative: Alternative = "two-sided"
    pooled: bool = False
    # training with feedback before the first block: presentations of each material per
    # condition (003 Sec. III-B: "a few minutes in a training session with feedback", no count
    # given; the template's 1 shows every answer once under each condition); 0: none
    training: int = Field(0, ge=0, le=20)


class RatingsParams(Checked):
    materials: list[str] = Field(default_factory=lambda: list(ZHAO_MATERIALS), min_length=2)
    method: str = "zhao"
    adjectives: dict[str, tuple[str, str]] = Field(default_factory=lambda: {"roughness": ("smooth", "rough"),
                                                                            "stickiness": ("slippery", "sticky")})
    square_frequencies: dict[str, within(30.0, 300.0, "outside 30-300 Hz")] | None = None
    # 000 Sec. 4: F(1, 260) is a between-subjects method x material ANOVA over all 280 ratings
    anova: Literal["between", "repeated"] = "between"


class ShapeChoiceParams(Checked):
    repetitions: int = Field(1, ge=1, le=20)
    descriptions: bool = False  # 002 Sec. 4 Part 1: first a free-text description of each stimulus
    grains: dict[str, str] = Field(default_factory=lambda: {"HG1": "edge-soft", "HG2": "area-grainy"})  # 002 Sec. 3.1.2


class SceneParams(Checked):
    anova: Literal["repeated", "between"] = "repeated"  # 002 Table 2: four-way within-subject ANOVA
    scenes: list[str] | None = Field(None, min_length=1)  # a subset of the built-in scenes (None: all 20, 002)


class SlidingParams(Checked):
    repetitions: int = Field(10, ge=1, le=100)
    blocks_per_session: int = Field(2, ge=1, le=4)
    practice_trials: int = Field(2, ge=0, le=20)  # at the start of each session (004 Sec. 5.2), not analysed
    anova: Literal["art", "repeated"] = "art"  # 004 Sec. 5.3: aligned rank transform, then the ANOVA


def _params(model: type[Checked], design: DesignSpec) -> Checked:
    try:
        return model.model_validate(design.params)
    except ValidationError as exc:
        field, msg = first_error(exc)
        raise StudyFormatError(msg, field=f"params.{field}") from None


def analysis_params(study: Study) -> Checked:
    """The validated parameters of a study's design (a bad one: StudyFormatError naming ``params.<field>``)."""
    return _params(_GENERATORS[study.design.kind][0], study.design)


def square_frequencies(materials: list[str]) -> dict[str, float]:
    """Default baseline square-wave frequency per material: log-spaced over 30-300 Hz in the
    listed order. Zhao et al. give only the range (after Bau et al.), not the frequency of each
    material; this spreads them evenly so that each material has its own baseline."""
    f = np.geomspace(30.0, 300.0, len(materials))
    return {m: float(round(x, 1)) for m, x in zip(materials, f)}


def _trial(pid, trials, **kw) -> None:
    trials.append(Trial(id=f"{pid}-{len(trials):04d}", index=len(trials), **kw))


def _nafc(design: DesignSpec, p: NafcParams, i: int, pid: str) -> tuple[str, list[Trial]]:
    rng = participant_rng(design.seed, i)
    conds = list(p.conditions)
    order = balanced_latin_square(len(conds))[i % len(conds)]
    n = p.alternatives
    trials: list[Trial] = []
    for b, ci in enumerate(order):
        cond = conds[ci]
        items = []
        for a, c in combinations(p.materials, 2):
            first_odd = rng.integers(2)
            for r in range(p.repetitions):
                odd, twice = (a, c) if (r + first_odd) % 2 == 0 else (c, a)
                items.append((a, c, odd, twice))
        positions = balanced_assignment(len(items), n, rng)
        for k in rng.permutation(len(items)):
            a, c, odd, twice = items[k]
            pos = int(positions[k])
            stim = [Stimulus(label=str(j + 1), render={"material": odd if j == pos else twice,
                                                        "method": p.conditions[cond]}) for j in range(n)]
            _trial(pid, trials, block=b, block_label=cond, task="nafc",
                   prompt=f"Which of the {n} surfaces is different from the others?", stimuli=stim,
                   choices=[Choice(id=str(j + 1), label=str(j + 1)) for j in range(n)], correct=str(pos + 1),
                   condition={"condition": cond, "pair": "|".join(sorted((a, c))), "odd": odd, "twice": twice,
                              "odd_position": pos + 1})
    return f"order-{''.join(str(int(x)) for x in order)}", trials


def _realism(design: DesignSpec, p: RealismParams, i: int, pid: str) -> tuple[str, list[Trial]]:
    rng = participant_rng(design.seed, i)
    conds = list(p.conditions)
    first = {m: int(rng.integers(2)) for m in p.materials}
    trials: list[Trial] = []
    for r in range(p.rounds):
        for m in rng.permutation(p.materials):
            m = str(m)
            a = (first[m] + r) % 2  # the order alternates over rounds: both orders for every material
            pair = [conds[a], conds[1 - a]]
            _trial(pid, trials, block=r, block_label=f"round {r + 1}", task="realism",
                   prompt="Touch the real sample. Which of the two feels more like it?",  # not its name: blinding
                   stimuli=[Stimulus(label=lab, render={"material": m, "method": p.conditions[c]})
                            for lab, c in zip("AB", pair)],
                   choices=[Choice(id=c, label=lab) for lab, c in zip("AB", pair)],
                   condition={"material": m, "first": pair[0], "round": r + 1})
    return "", trials


def _identification(design: DesignSpec, p: IdentificationParams, i: int, pid: str) -> tuple[str, list[Trial]]:
    rng = participant_rng(design.seed, i)
    conds = list(p.conditions)
    order = balanced_latin_square(len(conds))[i % len(conds)]
    trials: list[Trial] = []
    training_rng = np.random.default_rng([design.seed, i, 1])  # its own stream: the trials' stay as they were
    blocks = [(True, [(conds[ci], int(k)) for ci in order
                      for k in training_rng.permutation(np.repeat(np.arange(len(p.materials)), p.training))])]
    blocks = (blocks if p.training else []) + [
        (False, [(conds[ci], int(k)) for k in rng.permutation(np.repeat(np.arange(len(p.materials)), p.repetitions))])
        for ci in order]
    for b, (training, items) in enumerate(blocks):
        for cond, k in items:
            m = p.materials[k]
            _trial(pid, trials, block=b, block_label=cond, task="identification", practice=training, training=training,
                   prompt="Which real material does this surface feel like?" + (" (training)" if training else ""),
                   stimuli=[Stimulus(label="touch", render={"material": m, "method": p.conditions[cond]})],
                   choices=[Choice(id=x, label=x) for x in p.materials], correct=m,
                   condition={"condition": cond, "material": m})
    return f"order-{''.join(str(int(x)) for x in order)}", trials


def _ratings(design: DesignSpec, p: RatingsParams, i: int, pid: str) -> tuple[str, list[Trial]]:
    rng = participant_rng(design.seed, i)
    freqs = p.square_frequencies or square_frequencies(p.materials)
    missing = [m for m in p.materials if m not in freqs]
    if missing:
        raise StudyFormatError(f"no baseline frequency for {missing[0]!r}", field="params.square_frequencies")
    trials: list[Trial] = []
    items = [(m, src, adj) for m in p.materials for src in ("real", "virtual") for adj in p.adjectives]
    for k in rng.permutation(len(items)):
        m, src, adj = items[k]
        lo, hi = p.adjectives[adj]
        render = {"real": m} if src == "real" else {"material": m, "method": p.method}
        _trial(pid, trials, block=0, block_label="adjective ratings", task="rating",
               prompt=f"How {hi} is this surface? (1 = {lo}, 7 = {hi})",
               stimuli=[Stimulus(label="touch", render=render)], choices=SCALE,
               condition={"material": m, "source": src, "adjective": adj})
    methods = {"data-driven": {"method": p.method}, "square-wave": {"method": "square"}}
    items2 = [(m, meth) for m in p.materials for meth in methods]
    for k in rng.permutation(len(items2)):
        m, meth = items2[k]
        render = {"material": m, **methods[meth]}
        if meth == "square-wave":
            render["square_frequency"] = freqs[m]
        _trial(pid, trials, block=1, block_label="similarity ratings", task="similarity",
               prompt="How similar are the two surfaces? (1 = not at all, 7 = identical)",
               stimuli=[Stimulus(label="real", render={"real": m}), Stimulus(label="virtual", render=render)],
               choices=SCALE,
               condition={"material": m, "method": meth})
    return "", trials


def _shape_choice(design: DesignSpec, p: ShapeChoiceParams, i: int, pid: str) -> tuple[str, list[Trial]]:
    rng = participant_rng(design.seed, i)
    # Kim et al. Table 1, electrovibration conditions 1-10
    conds = sorted(product(("bump", "hole"), ("IP0.5", "IP0.7"), p.grains), key=lambda c: (c[0] != "bump", c[2], c[1]))
    conds += [("flat", "", g) for g in p.grains]
    # the formative 1-D profiles (Sec. 3.1); the flat surface has no intensity profile in
    # Table 1: it is played with IP0.5's offset (zero force -> intensity 0.5)
    renders = {c: {"profile1d": c[0], "mapping": c[1] or "IP0.5", "grain": p.grains[c[2]]} for c in conds}
    items = [c for c in conds for _ in range(p.repetitions)]
    trials: list[Trial] = []
    if p.descriptions:  # Part 1 before Part 2 (after a short break: the rest screen); own stream
        for k in np.random.default_rng([design.seed, i, 2]).permutation(len(conds)):
            shape, prof, grain = conds[int(k)]
            _trial(pid, trials, block=0, block_label="open description", task="description", response="text",
                   prompt="Describe what you felt, in your own words.",
                   stimuli=[Stimulus(label="touch", render=renders[shape, prof, grain])],
                   condition={"shape": shape, "profile": prof or "-", "grain": grain})
    for k in rng.permutation(len(items)):
        shape, prof, grain = items[k]
        _trial(pid, trials, block=int(p.descriptions), block_label="closed choice", task="shape",
               prompt="Which shape did you feel?", stimuli=[Stimulus(label="touch", render=renders[items[k]])],
               choices=[Choice(id=x, label=lab) for x, lab in (("bump", "bump"), ("hole", "hole"),
                                                                ("flat", "flat surface"), ("none", "none of these"))],
               correct=shape, condition={"shape": shape, "profile": prof or "-", "grain": grain})
    return ("G1" if i % 2 == 0 else "G2"), trials


def _scenes(design: DesignSpec, p: SceneParams, i: int, pid: str) -> tuple[str, list[Trial]]:
    from surfhap.shape.scenes import all_scenes

    rng = participant_rng(design.seed, i)
    group = "G1" if i % 2 == 0 else "G2"
    tasks = ["V+H", "V"] if group == "G1" else ["V", "V+H"]  # 002 Sec. 5.1.3
    scenes = [s for s in all_scenes() if p.scenes is None or s.name in p.scenes]
    unknown = sorted(set(p.scenes or ()) - {s.name for s in scenes})
    if unknown:
        raise StudyFormatError(f"unknown scene {unknown[0]!r} (see 'surfhap scenes')", field="params.scenes")
    trials: list[Trial] = []
    for b, task in enumerate(tasks):
        for k in rng.permutation(len(scenes)):
            s = scenes[int(k)]
            layout = s.layout
            _trial(pid, trials, block=b, block_label=task, task="scene",
                   prompt="Is each object a bump or a hole?" + (" Touch them, then answer." if task == "V+H" else
                                                                 " Look only; do not touch."),
                   stimuli=[Stimulus(label="scene", render={"scene": s.name, "haptic": task == "V+H"})],
                   response="toggles", toggles=["TL", "TR", "BL", "BR"],
                   choices=[Choice(id="bump", label="bump"), Choice(id="hole", label="hole")],
                   correct=",".join(f"{q}={layout[q]}" for q in ("TL", "TR", "BL", "BR")),
                   condition={"task": task, "profile": s.profile, "light": s.light,
                              "configuration": s.configuration, "scene": s.name})
    return group, trials


def _sliding(design: DesignSpec, p: SlidingParams, i: int, pid: str) -> tuple[str, list[Trial]]:
    rng = participant_rng(design.seed, i)
    order = balanced_latin_square(len(SLIDING_BLOCKS))[i % len(SLIDING_BLOCKS)]
    pairs = list(permutations(SLIDING_EFFECTS, 2))  # 6 ordered pairs (the inverse comparisons too)
    practice_rng = np.random.default_rng([design.seed, i, 1])  # its own stream: the trials' stay as they were
    trials: list[Trial] = []
    for b, bi in enumerate(order):
        block = SLIDING_BLOCKS[int(bi)]
        items = [pr for pr in pairs for _ in range(p.repetitions)]
        first_of_session = b % p.blocks_per_session == 0
        practice = [pairs[int(k)] for k in practice_rng.integers(len(pairs), size=p.practice_trials)]
        for k in [-1 - j for j in range(len(practice) if first_of_session else 0)] + list(rng.permutation(len(items))):
            a, c = practice[k] if k < 0 else items[k]
            _trial(pid, trials, block=b, block_label=block, task="sliding", practice=k < 0,
                   session=b // p.blocks_per_session + 1,
                   prompt="On which one did you feel more sliding?" + (" (practice)" if k < 0 else ""),
                   stimuli=[Stimulus(label="1st", render={"effect": a}), Stimulus(label="2nd", render={"effect": c})],
                   choices=[Choice(id=a, label="1st"), Choice(id=c, label="2nd")],
                   condition={"block": block, "visual": block[:2], "tactile": block[2:],
                              "comparison": " vs ".join(sorted((a, c))), "first": a, "second": c,
                              "session": b // p.blocks_per_session + 1})
    return "latin-row-" + "".join(str(int(x)) for x in order), trials


_GENERATORS: dict[str, tuple[type[Checked], Callable]] = {
    "nafc": (NafcParams, _nafc),
    "realism": (RealismParams, _realism),
    "identification": (IdentificationParams, _identification),
    "ratings": (RatingsParams, _ratings),
    "shape-choice": (ShapeChoiceParams, _shape_choice),
    "scene-recognition": (SceneParams, _scenes),
    "sliding-pairs": (SlidingParams, _sliding),
}


def build_study(design: DesignSpec, software_version: str = "") -> Study:
    """Generate every participant's trial list (participants P01, P02, ...)."""
    model, gen = _GENERATORS[design.kind]
    params = _params(model, design)
    width = max(2, len(str(design.participants)))
    plans = []
    for i in range(design.participants):
        pid = f"P{i + 1:0{width}d}"
        group, trials = gen(design, params, i, pid)
        plans.append(ParticipantPlan(id=pid, group=group, trials=trials))
    if not software_version:
        from surfhap import __version__ as software_version
    return Study(design=design, params=params.model_dump(mode="json"), software_version=software_version,
                 participants=plans)


#: built-in designs with the papers' defaults (participants as in each paper)
TEMPLATES: dict[str, dict] = {
    "otake2021-3afc": {"kind": "nafc", "name": "Otake et al. 2021: 3AFC discrimination", "participants": 6},
    "otake2022-realism": {"kind": "realism", "name": "Otake et al. 2022 Task 1: realism", "participants": 14},
    "otake2022-identification": {"kind": "identification", "name": "Otake et al. 2022 Task 2: identification",
                                 "participants": 14, "params": {"training": 1}},  # 003 Sec. III-B: training first
    "zhao-ratings": {"kind": "ratings", "name": "Zhao et al.: adjective and similarity ratings", "participants": 14},
    "kim-shapes": {"kind": "shape-choice", "name": "Kim et al. 2017: bump / hole / flat closed choice",
                   "participants": 12},
    "kim-scenes": {"kind": "scene-recognition", "name": "Kim et al. 2017: 20 scenes, V vs V+H", "participants": 20},
    "kinestouch-sliding": {"kind": "sliding-pairs", "name": "KinesTouch: sliding pairwise comparisons",
                           "participants": 18,  # 004 Sec. 5.2: 3.5 s per stimulus, black until release
                           "session": {"stimulus_limit_s": 3.5, "blank_until_release": True}},
}


def template(name: str, seed: int = 0, participants: int | None = None) -> DesignSpec:
    """A built-in design by name (see :data:`TEMPLATES`)."""
    if name not in TEMPLATES:
        raise StudyFormatError(f"unknown design template {name!r} (built in: {', '.join(TEMPLATES)})", field="design")
    d = dict(TEMPLATES[name], seed=seed)
    if participants is not None:
        d["participants"] = participants
    return DesignSpec.model_validate(d)


#: the public name of :func:`template`
study_template = template
