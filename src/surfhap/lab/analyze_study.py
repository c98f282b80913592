"""Analyse a study folder: every participant's log, analysed as in the paper of the design.

=================== =======================================================================
kind                analysis
=================== =======================================================================
nafc                proportion correct per condition (Wilson CI), exact binomial test against
                    chance 1/n; per material pair; one-sided Student t test of the participants'
                    proportions between two conditions (001 Sec. V; params alternative, paired)
realism             per material, the proportion choosing the first condition: mean over
                    participants with a normal CI, one-sided z test "greater than" 0.5,
                    Bonferroni over materials (003 Table II; params alternative)
identification      confusion matrix per condition; proportion correct per material (mean
                    over participants, normal CI) and overall; binomial test against chance;
                    two-sided unpooled two-proportion z test between conditions per material,
                    Bonferroni (003 Tables III-IV; params alternative, pooled)
ratings             real-vs-virtual mean rating per material and adjective, Pearson r;
                    similarity per rendering method: between-subjects method x material
                    ANOVA, data-driven similarity vs real ratings, Pearson r (000 Sec. 4;
                    params anova: between | repeated)
shape-choice        confusion of shape vs answer; proportion correct overall and per
                    condition; one-sided t test of the participants' proportions against 0.25
                    (002 Sec. 3.4.2)
scene-recognition   proportion of objects right per task and light; four-way repeated-measures
                    ANOVA task x light x profile x configuration (002 Table 2; params
                    anova: repeated | between)
sliding-pairs       discrimination score |2p - 1| per participant, comparison, visual and
                    tactile condition; aligned rank transform ANOVA on the scores (004 Sec.
                    5.3, :mod:`surfhap.lab.art`; params anova: art | repeated)
=================== =======================================================================

Every test also goes to :meth:`StudyAnalysis.results` (``results.json`` of ``study analyze``).
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path

import numpy as np

from surfhap.errors import ConfigError, StudyFormatError
from surfhap.lab import analysis as A
from surfhap.lab.art import art_anova
from surfhap.lab.designs import analysis_params
from surfhap.lab.schema import Study, load_study
from surfhap.lab.study_result import Section, StudyAnalysis
from surfhap.lab.triallog import read_log
from surfhap.results import jsonable

__all__ = ["Section", "StudyAnalysis", "analyze_study", "load_trials"]


def load_trials(study_dir: str | Path) -> tuple[Study, list[dict], list[str], list[str]]:
    """(study, trial records with their participant, ids of incomplete participants, warnings:
    logs written against another version of study.json)."""
    import hashlib

    study = load_study(study_dir)
    folder = Path(study_dir) if Path(study_dir).is_dir() else Path(study_dir).parent
    digest = hashlib.sha256((folder / "study.json").read_bytes()).hexdigest()
    records, incomplete, warnings = [], [], []
    for plan in study.participants:
        log = read_log(folder / "logs" / f"{plan.id}.jsonl")
        if not log.trials:
            continue
        if any(s.get("config", {}).get("study_sha256") not in (None, digest) for s in log.sessions):
            warnings.append(f"{plan.id}: logged against a different study.json (edited after the session?)")
        run = [r for r in log.trials if not r.get("practice")]  # practice (and training) trials are not analysed
        if len(run) < sum(not t.practice for t in plan.trials):
            incomplete.append(plan.id)
        analysed = [r for r in run if not r.get("skipped")]  # skipped by the experimenter: no answer
        if len(analysed) < len(run):
            warnings.append(f"{plan.id}: {len(run) - len(analysed)} trial(s) skipped by the experimenter, not analysed")
        records += [{**r, "participant": plan.id, "group": plan.group} for r in analysed]
    if not records:
        raise StudyFormatError("no trials logged yet", source=str(folder / "logs"), field="log")
    return study, records, incomplete, warnings


def _by(records, *keys):
    out = defaultdict(list)
    for r in records:
        c = r.get("condition", {})
        out[tuple(c[k] if k in c else r[k] for k in keys)].append(r)
    return out


def _pp(records, value=lambda r: float(r["score"])):
    """Per-participant mean of ``value``: {participant: mean}."""
    return {p: float(np.mean([value(r) for r in rs])) for (p,), rs in _by(records, "participant").items()}


def _correct_rows(groups, join: bool = False) -> list[list]:
    """[*key, correct/n, proportion] per group of records (``join``: the key joined with "-")."""
    return [[*(["-".join(key)] if join else key), f"{sum(r['is_correct'] for r in rs)}/{len(rs)}",
             f"{np.mean([r['is_correct'] for r in rs]):.2f}"] for key, rs in sorted(groups.items())]


def _mean_rows(recs, factors, value, sd: bool = True) -> list[list]:
    """[factor, level, mean (, SD), n] of ``value`` per level of each of ``factors``."""
    rows = []
    for factor in factors:
        for (lev,), rs in sorted(_by(recs, factor).items()):
            v = [value(r) for r in rs]
            sd_col = [f"{np.std(v, ddof=1) if len(v) > 1 else 0:.2f}"] if sd else []
            rows.append([factor, lev, f"{np.mean(v):.2f}", *sd_col, len(v)])
    return rows


def _mean_ci_rows(labels, pm: A.ProportionResult) -> list[list]:
    """[label, proportion, CI, half width] of a mean of participants' proportions (:data:`_PM_CI`)."""
    return [[m, f"{p:.2f}", f"[{lo:.2f}, {hi:.2f}]", f"{h:.2f}"]
            for m, p, lo, hi, h in zip(labels, pm.proportion, pm.ci_low, pm.ci_high, pm.half_width)]


_ANOVA = {"repeated": "F (repeated-measures ANOVA)", "between": "F (between-subjects ANOVA)",
          "art": "F (aligned rank transform, repeated-measures ANOVA on the aligned ranks)"}


def _anova(sec: Section, records, depvar: str, subject: str, factors: list[str], kind: str = "repeated") -> None:
    """The ANOVA table (``kind``: repeated, between or art) into ``sec``, or why there is none."""
    try:
        an = (art_anova(records, depvar, subject, factors) if kind == "art" else
              A.factorial_anova(records, depvar, factors) if kind == "between" else
              A.rm_anova(records, depvar, subject, factors))
    except (ConfigError, ValueError, np.linalg.LinAlgError) as exc:  # too few complete participants: a normal state
        sec.text.append(f"no {kind} ANOVA: {exc}")
        return
    sec.tables.append((["effect", "F", "df", "p"], [[e, f"{f:.3f}", f"({d1:g}, {d2:g})", f"{p:.3g}"]
                                                     for e, f, d1, d2, p in an.rows]))
    for e, f, d1, d2, p in an.rows:
        sec.add(e, A.TestResult(_ANOVA[kind], f, p, (d1, d2)), list(factors))
    sec.figures.append((f"{kind} ANOVA", an, {}))


def _nafc(study, recs):
    n_alt = len(study.participants[0].trials[0].choices)
    sec = Section("Discrimination (n-AFC)")
    by_cond = {c: rs for (c,), rs in _by(recs, "condition").items()}
    conds = sorted(by_cond)
    k = [sum(r["is_correct"] for r in by_cond[c]) for c in conds]
    n = [len(by_cond[c]) for c in conds]
    res = A.proportions(k, n, conds, title="proportion correct")
    sec.text.append(", ".join(f"{c} {p:.2f}" for c, p in zip(conds, res.proportion)) + f" correct (chance {1 / n_alt:.2f})")
    sec.tables.append((["condition", "correct/n", "proportion", "95 % CI (Wilson)"], res.rows()))
    for c, kk, nn in zip(conds, k, n):
        sec.text.append(sec.add(f"{c} vs chance", A.binomial_test(kk, nn, 1 / n_alt), [c]))
    sec.figures.append(("nafc_conditions", res, {"chance": 1 / n_alt}))
    sec.tables.append((["condition", "pair", "correct/n", "proportion"], _correct_rows(_by(recs, "condition", "pair"))))
    if len(conds) == 2:
        a, b = _pp(by_cond[conds[0]]), _pp(by_cond[conds[1]])
        both = sorted(set(a) & set(b))
        if len(both) >= 2:
            prm = analysis_params(study)
            x, y = ([a[p] for p in both], [b[p] for p in both]) if prm.paired else ([*a.values()], [*b.values()])
            sec.text.append(sec.add(f"{conds[0]} vs {conds[1]} ({len(x)} participants)",
                                    A.t_test(x, y, paired=prm.paired, alternative=prm.alternative), conds[:2]))
    return [sec]


# the columns of a mean of participants' proportions (analysis.participant_means)
_PM_CI = ("95 % CI (bootstrap over participants)", "+- (1.96 SD / sqrt n, as Otake et al. 2022)")


def _realism(study, recs):
    first = list(study.params["conditions"])[0]
    sec = Section(f"Realism: proportion choosing {first}")
    by_mat = {m: rs for (m,), rs in sorted(_by(recs, "material").items())}
    mats = list(by_mat)
    per = [list(_pp(rs, value=lambda r: float(r["answer"] == first)).values()) for rs in by_mat.values()]
    if min(len(v) for v in per) < 2:
        sec.text.append("needs two participants or more")
        return [sec]
    res = A.participant_means(per, mats, title=f"chose {first}")
    alt = analysis_params(study).alternative
    tests = [A.z_test_one(sum(r["answer"] == first for r in rs), len(rs), 0.5, alternative=alt)
             for rs in by_mat.values()]
    padj = A.bonferroni([t.p for t in tests])
    for m, t, pa in zip(mats, tests, padj):
        sec.add(f"{m}: {first} vs chance 0.5", t, [m], pa, "Bonferroni")
    sec.text.append(", ".join(f"{m} {p:.2f}" for m, p in zip(mats, res.proportion)))
    sec.tables.append((["material", "proportion", *_PM_CI, "z", "p (Bonferroni)"],
                       [[*row, f"{t.statistic:.2f}", f"{pa:.3g}"]
                        for row, t, pa in zip(_mean_ci_rows(mats, res), tests, padj)]))
    sec.figures.append(("realism", res, {"chance": 0.5}))
    return [sec]


def _identification(study, recs):
    mats = list(study.params["materials"])
    out = []
    by_cond = {c: rs for (c,), rs in sorted(_by(recs, "condition").items())}
    conds = list(by_cond)
    counts = {}
    for c, rs in by_cond.items():
        conf = A.confusion([r["correct"] for r in rs], [r["answer"] for r in rs], mats, title=c)
        sec = Section(f"Identification: {c}")
        k = int(np.trace(conf.counts))
        n = int(conf.counts.sum())
        sec.text.append(f"overall {conf.accuracy:.2f} correct (chance {1 / len(mats):.2f}); "
                        + sec.add(f"{c} vs chance", A.binomial_test(k, n, 1 / len(mats)), [c]))
        per = [list(_pp([r for r in rs if r["correct"] == m], value=lambda r: float(r["is_correct"])).values())
               for m in mats]
        if min(len(v) for v in per) >= 2:
            pm = A.participant_means(per, mats, title=f"correct ({c})")
            sec.tables.append((["material", "proportion", *_PM_CI], _mean_ci_rows(mats, pm)))
            sec.figures.append((f"identification_{c}_bars", pm, {"chance": 1 / len(mats)}))
        sec.tables.append((["presented \\ answered", *mats],
                           [[m, *[f"{x:.2f}" for x in row]] for m, row in zip(mats, conf.proportions)]))
        sec.figures.append((f"identification_{c}_confusion", conf, {}))
        counts[c] = conf
        out.append(sec)
    if len(conds) == 2:
        a, b = counts[conds[0]], counts[conds[1]]
        prm = analysis_params(study)
        tests = [A.z_test_two(a.counts[i, i], a.counts[i].sum(), b.counts[i, i], b.counts[i].sum(),
                              alternative=prm.alternative, pooled=prm.pooled)
                 for i in range(len(mats)) if a.counts[i].sum() and b.counts[i].sum()]
        if len(tests) == len(mats):
            padj = A.bonferroni([t.p for t in tests])
            sec = Section(f"Identification: {conds[0]} vs {conds[1]}")
            sec.text.append(f"two-proportion z tests per material ({tests[0].name}, {prm.alternative}), "
                            "Bonferroni-corrected")
            for m, t, pa in zip(mats, tests, padj):
                sec.add(f"{m}: {conds[0]} vs {conds[1]}", t, [conds[0], conds[1]], pa, "Bonferroni")
            sec.tables.append((["material", "z", "p", "p (Bonferroni)"],
                               [[m, f"{t.statistic:.2f}", f"{t.p:.3g}", f"{pa:.3g}"]
                                for m, t, pa in zip(mats, tests, padj)]))
            out.append(sec)
    return out


def _ratings(study, recs):
    out = []
    mats = list(study.params["materials"])
    # mean rating per (material, adjective, source)
    cell = {k: np.mean([float(r["answer"]) for r in rs])
            for k, rs in _by([r for r in recs if r["task"] == "rating"], "material", "adjective", "source").items()}
    for a in study.params["adjectives"]:
        labs = [m for m in mats if (m, a, "real") in cell and (m, a, "virtual") in cell]
        sec = Section(f"Adjective ratings: {a}")
        if len(labs) >= 3:
            pr = A.pearson([cell[m, a, "real"] for m in labs], [cell[m, a, "virtual"] for m in labs], labs,
                           x_name=f"{a} (real)", y_name=f"{a} (virtual)")
            sec.text.append(f"real vs virtual: r = {pr.r:.3f}, p = {pr.p:.3g} (n = {pr.n} materials)")
            sec.add(f"{a}: real vs virtual", A.TestResult("r (Pearson)", pr.r, pr.p, pr.n - 2, estimate=pr.r), labs)
            sec.figures.append((f"ratings_{a}", pr, {}))
        else:
            sec.text.append("needs three materials or more rated real and virtual")
        out.append(sec)
    sim = [r for r in recs if r["task"] == "similarity"]
    if sim:
        sec = Section("Similarity ratings")
        rows = [[meth, n, mean, sd]
                for _, meth, mean, sd, n in _mean_rows(sim, ["method"], lambda r: float(r["answer"]))]
        sec.tables.append((["method", "n", "mean", "SD"], rows))
        sec.text.append("; ".join(f"{r[0]} {r[2]} (SD {r[3]})" for r in rows))
        _anova(sec, [{"p": r["participant"], "method": r["condition"]["method"], "material": r["condition"]["material"],
                      "y": float(r["answer"])} for r in sim], "y", "p", ["method", "material"], analysis_params(study).anova)
        dd = {m[0]: np.mean([float(r["answer"]) for r in rs]) for m, rs in _by(sim, "material", "method").items()
              if m[1] == "data-driven"}
        for a in study.params["adjectives"]:  # 000 Sec. 4: data-driven similarity vs the real rating
            labs = [m for m in mats if m in dd and (m, a, "real") in cell]
            if len(labs) >= 3:
                pr = A.pearson([dd[m] for m in labs], [cell[m, a, "real"] for m in labs], labs)
                sec.text.append(sec.add(f"similarity (data-driven) vs {a} (real)",
                                        A.TestResult("r (Pearson)", pr.r, pr.p, pr.n - 2, estimate=pr.r), labs))
        out.append(sec)
    return out


def _shape_choice(study, recs):
    recs = [r for r in recs if r["task"] == "shape"]  # not the free-text descriptions (Part 1)
    labels = ["bump", "hole", "flat", "none"]
    conf = A.confusion([r["correct"] for r in recs], [r["answer"] for r in recs], labels, title="shape")
    sec = Section("Closed choice: bump / hole / flat")
    pp = _pp(recs, value=lambda r: float(r["is_correct"]))
    sec.text.append(f"overall {conf.accuracy:.2f} correct (chance 0.25)")
    if len(pp) >= 2:
        sec.text.append(sec.add("participants vs chance", A.t_test(list(pp.values()), 0.25, alternative="greater"),
                                ["participants"]))
    sec.tables.append((["condition", "correct/n", "proportion"],
                       _correct_rows(_by(recs, "shape", "profile", "grain"), join=True)))
    sec.figures.append(("shape_confusion", conf, {}))
    return [sec]


def _scenes(study, recs):
    sec = Section("Scene recognition: V vs V+H")
    factors = ["task", "light", "profile", "configuration"]
    sec.tables.append((["factor", "level", "proportion of objects right", "trials"],
                       _mean_rows(recs, factors, lambda r: r["score"], sd=False)))
    by_task = sorted(_by(recs, "task").items())
    tasks = [t for (t,), _ in by_task]
    res = A.proportions([sum(r["score"] * 4 for r in rs) for _, rs in by_task], [4 * len(rs) for _, rs in by_task],
                        tasks, title="objects right")
    sec.text.append(", ".join(f"{t} {p:.2f}" for t, p in zip(tasks, res.proportion)))
    sec.figures.append(("scenes_task", res, {"chance": 0.5}))
    _anova(sec, [{"p": r["participant"], **{f: r["condition"][f] for f in factors}, "y": r["score"]} for r in recs],
           "y", "p", factors, analysis_params(study).anova)
    return [sec]


def sliding_scores(recs) -> list[dict]:
    """Discrimination score per participant x comparison x visual x tactile (004 Sec. 5.2):
    +1 when the alphabetically first effect of the comparison is chosen, -1 otherwise; the
    mean (the normalised preference, 2p - 1) in absolute value."""
    acc = defaultdict(list)
    for r in recs:
        c = r["condition"]
        a = c["comparison"].split(" vs ")[0]
        acc[(r["participant"], c["comparison"], c["visual"], c["tactile"])].append(1.0 if r["answer"] == a else -1.0)
    return [{"participant": p, "comparison": comp, "visual": v, "tactile": t,
             "score": float(A.discrimination_score((np.mean(x) + 1) / 2)), "n": len(x)}
            for (p, comp, v, t), x in sorted(acc.items())]


def _sliding(study, recs):
    scores = sliding_scores(recs)
    sec = Section("Sliding: discrimination scores")
    sec.tables.append((["factor", "level", "mean score", "SD", "n"],
                       _mean_rows(scores, ["visual", "tactile", "comparison"], lambda s: s["score"])))
    sec.text.append("mean discrimination score " + f"{np.mean([s['score'] for s in scores]):.2f}")
    _anova(sec, scores, "score", "participant", ["visual", "tactile", "comparison"], analysis_params(study).anova)
    return [sec]


_ANALYSES = {"nafc": _nafc, "realism": _realism, "identification": _identification, "ratings": _ratings,
             "shape-choice": _shape_choice, "scene-recognition": _scenes, "sliding-pairs": _sliding}


def _comfort_section(folder: Path) -> Section | None:
    """Comfort voltages measured with 'study comfort' (logs/<P>-comfort.json), if any, and the
    50 % point with its credible interval from each run's trials (logs/<P>-comfort.jsonl)."""
    from surfhap.lab.comfort import comfort_estimate, read_comfort

    rows, sec = [], Section("Comfort thresholds (staircase)")
    for p in sorted((folder / "logs").glob("*-comfort.json")):
        d = read_comfort(p)
        try:
            rows.append([d["participant"], "-" if d["comfort_voltage"] is None else f"{d['comfort_voltage']:.1f}",
                         len(d["levels_V"]), d["stopped_by"]])
        except (KeyError, TypeError):
            raise StudyFormatError("not a comfort result", source=str(p), field="comfort_voltage") from None
        log = read_log(p.with_suffix(".jsonl"))
        try:
            e = comfort_estimate(log.trials)
        except ConfigError:  # fewer than two levels: nothing to fit
            rows[-1] += ["-", "-"]
            continue
        method = next((s["config"].get("method", "staircase") for s in log.sessions), "staircase")
        rows[-1] += [f"{e['value']:.1f}", "{:.1f}-{:.1f}".format(*e["ci"])]
        sec.estimates.append(jsonable({"name": "50 % discomfort voltage", "participant": d["participant"], **e,
                                       "adaptive": method, "adaptive_estimate_V": d.get("staircase_threshold_V"),
                                       "method": "posterior mean, 95 % credible interval (logistic, lapse 1 %, "
                                                 f"flat prior; ml_value: ML fit) of the {method} trials"}))
    if not rows:
        return None
    volts = [float(r[1]) for r in rows if r[1] != "-"]
    sec.text.append(f"median {np.median(volts):.0f} V, range {min(volts):.0f}-{max(volts):.0f} V" if volts else
                    "no threshold reached")
    sec.tables.append((["participant", "comfort voltage (V)", "trials", "stopped by", "50 % point (V)",
                        "95 % CI (V)"], rows))
    return sec


def analyze_study(study_dir: str | Path) -> StudyAnalysis:
    """Analyse every logged trial of the study in ``study_dir``."""
    study, recs, incomplete, warnings = load_trials(study_dir)
    sections = _ANALYSES[study.design.kind](study, recs)
    rts = [r["rt_s"] for r in recs if r.get("rt_s") is not None]
    if rts:
        sections.append(Section("Response times", [f"median {np.median(rts):.2f} s, IQR "
                                                   f"{np.percentile(rts, 25):.2f}-{np.percentile(rts, 75):.2f} s "
                                                   f"({len(rts)} answers)"]))
    folder = Path(study_dir) if Path(study_dir).is_dir() else Path(study_dir).parent
    comfort = _comfort_section(folder)
    if comfort is not None:
        sections.append(comfort)
    parts = sorted({r["participant"] for r in recs})
    return StudyAnalysis(study.design.name, study.design.kind, parts, len(recs), incomplete, sections, warnings)
