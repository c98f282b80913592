"""Study designs: the papers' trial counts and counterbalancing, reproducible from the seed."""

from collections import Counter

import pytest

from surfhap.errors import StudyFormatError
from surfhap.lab.counterbalance import balanced_latin_square
from surfhap.lab.designs import TEMPLATES, build_study, template
from surfhap.lab.schema import DesignSpec


def test_nafc_otake2021_counts_and_balance():
    study = build_study(template("otake2021-3afc", seed=5))
    assert len(study.participants) == 6
    orders = set()
    for plan in study.participants:
        by_cond = Counter(t.condition["condition"] for t in plan.trials)
        assert by_cond == {"friction+texture": 24, "friction-only": 24}  # 6 pairs x 4 repetitions
        for cond in by_cond:
            ts = [t for t in plan.trials if t.condition["condition"] == cond]
            pairs = Counter(t.condition["pair"] for t in ts)
            assert len(pairs) == 6 and set(pairs.values()) == {4}
            for pair in pairs:  # each material of a pair is the odd one twice
                odd = Counter(t.condition["odd"] for t in ts if t.condition["pair"] == pair)
                assert sorted(odd.values()) == [2, 2]
            pos = Counter(t.correct for t in ts)
            assert sorted(pos.values()) == [8, 8, 8]  # odd position balanced over 3 intervals
            for t in ts:  # one material twice, the other once; the odd one where 'correct' says
                mats = [s.render["material"] for s in t.stimuli]
                assert mats[int(t.correct) - 1] == t.condition["odd"] and mats.count(t.condition["twice"]) == 2
        orders.add(plan.group)
    assert orders == {"order-01", "order-10"}  # condition order counterbalanced


def test_realism_and_identification_otake2022():
    real = build_study(template("otake2022-realism", seed=1))
    for plan in real.participants:
        assert len(plan.trials) == 8
        for m in ("leather", "cork", "denim", "wood"):
            firsts = [t.condition["first"] for t in plan.trials if t.condition["material"] == m]
            assert sorted(firsts) == ["friction+texture", "friction-only"]  # both orders
    ident = build_study(template("otake2022-identification", seed=1))
    for plan in ident.participants:
        c = Counter((t.condition["condition"], t.correct) for t in plan.trials if not t.training)
        assert len(c) == 8 and set(c.values()) == {2}  # each material twice per condition
    assert Counter(p.group for p in ident.participants) == {"order-01": 7, "order-10": 7}


def test_ratings_zhao():
    plan = build_study(template("zhao-ratings")).participants[0]
    adj = [t for t in plan.trials if t.task == "rating"]
    sim = [t for t in plan.trials if t.task == "similarity"]
    assert len(adj) == 40 and len(sim) == 20
    assert all(len(t.choices) == 7 for t in plan.trials)
    freqs = [t.stimuli[1].render["square_frequency"] for t in sim if t.condition["method"] == "square-wave"]
    assert len(freqs) == 10 and min(freqs) == 30.0 and max(freqs) == 300.0


def test_kim_shapes_and_scenes():
    shapes = build_study(template("kim-shapes"))
    plan = shapes.participants[0]
    assert len(plan.trials) == 10
    assert Counter(t.correct for t in plan.trials) == {"bump": 4, "hole": 4, "flat": 2}
    assert Counter(p.group for p in shapes.participants) == {"G1": 6, "G2": 6}
    scenes = build_study(template("kim-scenes", seed=2))
    for plan in scenes.participants:
        assert len(plan.trials) == 40
        first = plan.trials[0].condition["task"]
        assert first == ("V+H" if plan.group == "G1" else "V")
        for task in ("V", "V+H"):
            names = [t.condition["scene"] for t in plan.trials if t.condition["task"] == task]
            assert len(set(names)) == 20
    orders = {tuple(t.condition["scene"] for t in p.trials[:20]) for p in scenes.participants}
    assert len(orders) > 15  # randomised per participant


def test_kinestouch_latin_square():
    study = build_study(template("kinestouch-sliding", seed=3))
    plan = study.participants[0]
    assert len(plan.trials) == 240 + 4  # and 2 practice trials opening each of the 2 sessions
    for block in ("V0F0", "V0F1", "V1F0", "V1F1"):
        ts = [t for t in plan.trials if t.block_label == block and not t.practice]
        assert len(ts) == 60
        assert set(Counter((t.condition["first"], t.condition["second"]) for t in ts).values()) == {10}
    # block order: a balanced Latin square over participants (positions and neighbour pairs)
    rows = [[lab for lab in dict.fromkeys(t.block_label for t in p.trials)] for p in study.participants[:4]]
    for pos in range(4):
        assert len({r[pos] for r in rows}) == 4
    neighbours = Counter((r[j], r[j + 1]) for r in rows for j in range(3))
    assert len(neighbours) == 12 and set(neighbours.values()) == {1}


@pytest.mark.parametrize("n", [2, 3, 4, 5, 6])
def test_latin_square_rows_and_columns(n):
    sq = balanced_latin_square(n)
    for k in range(n):
        assert sorted(sq[k]) == list(range(n)) and sorted(sq[:, k]) == list(range(n))


def test_same_seed_same_study_other_seed_differs():
    a = build_study(template("otake2021-3afc", seed=7), software_version="x")
    b = build_study(template("otake2021-3afc", seed=7), software_version="x")
    c = build_study(template("otake2021-3afc", seed=8), software_version="x")
    assert a.model_dump() == b.model_dump()
    assert a.model_dump() != c.model_dump()


def test_bad_params_name_the_field():
    d = DesignSpec(kind="nafc", name="x", participants=2, params={"repetitions": 0})
    with pytest.raises(StudyFormatError, match="params.repetitions"):
        build_study(d)
    d = DesignSpec(kind="nafc", name="x", participants=2, params={"colour": "red"})
    with pytest.raises(StudyFormatError, match="params.colour"):
        build_study(d)


def test_all_templates_build():
    for name in TEMPLATES:
        assert build_study(template(name, participants=2)).participants[1].trials
