"""Analysis: the papers' own summary numbers from their published tables, and scipy /
statsmodels references."""

import numpy as np
import pytest
from scipy import stats

from surfhap.lab.analysis import (bonferroni, binomial_test, confusion, discrimination_score, participant_means,
                                  pearson, proportions, rm_anova, t_test, z_test_one, z_test_two)

MATS = ("leather", "cork", "denim", "wood")
# Otake et al. 2022 Table III: rows = answered (actual) material, columns = presented (virtual)
T3A = np.array([[.71, .00, .18, .11], [.07, .75, .11, .00], [.14, .21, .68, .07], [.07, .04, .04, .82]])
T3B = np.array([[.39, .14, .36, .11], [.46, .43, .04, .04], [.11, .36, .46, .14], [.04, .07, .14, .71]])
N_PER_MATERIAL = 14 * 2  # 14 participants, each material twice (Sec. IV-B, IV-C)


@pytest.mark.parametrize("table,overall", [(T3A, 0.74), (T3B, 0.50)])
def test_otake2022_overall_identification_from_table_iii(table, overall):
    counts = np.rint(table.T * N_PER_MATERIAL).astype(int)  # presented x answered
    assert np.all(counts.sum(axis=1) == N_PER_MATERIAL)  # the table is consistent with 28 answers each
    res = confusion(counts=counts, labels=MATS)
    assert round(res.accuracy, 2) == overall  # "0.74 ... combined", "0.50 ... low-frequency friction"
    assert np.allclose(res.per_class, np.diag(table), atol=0.006)


def test_otake2022_participant_intervals():
    # 27 of 28 (Table II cork, .96 +- .07): 13 participants chose it twice, one once
    res = participant_means([[1.0] * 13 + [0.5], [0.5] + [0.0] * 13, [0.0] * 14], labels=["cork", "x", "zero"])
    assert round(res.proportion[0], 2) == 0.96 and round(res.half_width[0], 2) == 0.07
    # 1 of 28 (Table III(a) wood answered as cork, .04 +- .07)
    assert round(res.proportion[1], 2) == 0.04 and round(res.half_width[1], 2) == 0.07
    assert res.half_width[2] == res.ci_high[2] == res.ci_low[2] == 0.0  # .00 +- .00
    # the printed form passes 1 and 0; the bootstrap interval over participants stays within [0, 1]
    assert res.proportion[0] + res.half_width[0] > 1 and res.proportion[1] - res.half_width[1] < 0
    assert np.all((res.ci_low >= 0) & (res.ci_high <= 1) & (res.ci_low <= res.proportion) & (res.proportion <= res.ci_high))


def test_otake2022_bonferroni_of_tables_ii_and_iv():
    z = np.array([2.58, 2.58, 1.95])  # Table IV leather, cork, denim
    p = bonferroni(2 * stats.norm.sf(z) * np.ones(1))  # a family of 4 materials is m = 4
    p4 = np.minimum(1, 4 * 2 * stats.norm.sf(z))
    assert np.allclose(np.round(p4, 2), [0.04, 0.04, 0.20])
    assert np.allclose(bonferroni(np.r_[2 * stats.norm.sf(z), 0.5]), np.r_[p4, 1.0])
    # Table II leather / wood: z = .35 -> p = 1.00 after correction
    assert bonferroni([2 * stats.norm.sf(0.35)] * 4)[0] == 1.0
    assert p.shape == (3,)


def test_otake2021_overall_and_one_sided_t():
    # Table III diagonals: overall proportion correct is their mean (0.78 and 0.68)
    assert round(np.mean([0.81, 0.75, 0.67, 0.89]), 2) == 0.78
    assert round(np.mean([0.64, 0.64, 0.67, 0.78]), 2) == 0.68
    # "t = 0.63, p = 0.27" etc.: one-sided tests between two groups of 6 participants (df = 10)
    base = np.array([-1.5, -0.9, -0.3, 0.3, 0.9, 1.5])
    for t_paper, p_paper in [(0.63, 0.27), (0.94, 0.18), (0.64, 0.27), (0.95, 0.18), (0.0, 0.5)]:
        d = t_paper * base.std(ddof=1) * np.sqrt(2 / 6)
        res = t_test(base + d, base, alternative="greater")
        assert res.statistic == pytest.approx(t_paper) and res.df == 10
        assert round(res.p, 2) == p_paper


def test_zhao_pearson_p_values():
    # Zhao et al. Sec. 4: ten materials; r -> p as printed
    rng = np.random.default_rng(0)
    x = rng.normal(size=10)
    x = (x - x.mean()) / x.std()
    e = rng.normal(size=10)
    e -= e.mean()
    e -= (e @ x) / (x @ x) * x
    e /= e.std()
    for r, p_paper, digits in [(0.935, 7.3e-5, 2), (0.926, 1.22e-4, 3), (-0.936, 6.9e-5, 2), (-0.851, 2e-3, 1)]:
        # r is printed to 3 decimals, p to `digits` significant digits: the p of some r within
        # the rounding of r must round to the printed p
        ps = []
        for rr in np.linspace(r - 0.0005, r + 0.0005, 41):
            y = rr * x + np.sqrt(1 - rr * rr) * e  # exactly correlation rr
            res = pearson(x, y)
            assert res.r == pytest.approx(rr) and res.n == 10 and res.ci_low < res.r < res.ci_high
            ps.append(float(f"{res.p:.{digits}g}"))
        assert p_paper in ps


def test_kinestouch_discrimination_score_table_3():
    rates = [0.5, 0.6, 0.75, 0.8, 0.9, 0.95, 1.0]
    assert np.allclose(discrimination_score(np.array(rates)), [0, 0.2, 0.5, 0.6, 0.8, 0.9, 1])
    assert discrimination_score(0.1) == pytest.approx(0.8)  # the other stimulus preferred: same score


def test_proportion_intervals_match_scipy():
    for k, n in [(0, 10), (7, 24), (20, 28), (24, 24)]:
        for method, sp in (("wilson", "wilson"), ("beta", "exact")):
            res = proportions([k], [n], method=method)
            ref = stats.binomtest(k, n).proportion_ci(confidence_level=0.95, method=sp)
            assert res.ci_low[0] == pytest.approx(ref.low, abs=1e-9)
            assert res.ci_high[0] == pytest.approx(ref.high, abs=1e-9)


def test_chance_tests_match_references():
    assert binomial_test(14, 24, 1 / 3).p == pytest.approx(stats.binomtest(14, 24, 1 / 3, alternative="greater").pvalue)
    z = z_test_one(20, 28, 0.25)
    assert z.statistic == pytest.approx((20 / 28 - 0.25) / np.sqrt(0.25 * 0.75 / 28))
    z2 = z_test_two(20, 28, 11, 28)
    pool = 31 / 56
    assert z2.statistic == pytest.approx((20 / 28 - 11 / 28) / np.sqrt(pool * (1 - pool) * 2 / 28))
    wald = z_test_two(20, 28, 11, 28, pooled=False)  # unpooled: p1 q1 / n1 + p2 q2 / n2
    se = np.sqrt((20 / 28) * (8 / 28) / 28 + (11 / 28) * (17 / 28) / 28)
    assert wald.statistic == pytest.approx(9 / 28 / se) and wald.p == pytest.approx(2 * stats.norm.sf(9 / 28 / se))


def test_rm_anova_matches_hand_computation_and_kim_dfs():
    rng = np.random.default_rng(1)
    subj, lev = 8, 3
    effect = np.array([0.0, 0.3, 0.6])
    s_eff = rng.normal(0, 0.5, subj)
    y = s_eff[:, None] + effect[None, :] + rng.normal(0, 0.3, (subj, lev))
    recs = [{"s": i, "f": j, "y": y[i, j]} for i in range(subj) for j in range(lev)]
    res = rm_anova(recs, "y", "s", ["f"])
    gm = y.mean()
    ss_f = subj * np.sum((y.mean(0) - gm) ** 2)
    ss_s = lev * np.sum((y.mean(1) - gm) ** 2)
    ss_e = np.sum((y - gm) ** 2) - ss_f - ss_s
    f = (ss_f / (lev - 1)) / (ss_e / ((lev - 1) * (subj - 1)))
    name, F, d1, d2, p = res.rows[0]
    assert F == pytest.approx(f) and (d1, d2) == (2, 14)
    assert p == pytest.approx(stats.f.sf(f, 2, 14))
    # Kim et al. Table 2: 20 participants, task x light x geometry x configuration (2x2x2x5)
    recs = [{"s": s, "task": t, "light": lt, "geom": g, "conf": c, "y": rng.random()}
            for s in range(20) for t in "VH" for lt in "sd" for g in "gf" for c in range(5)]
    res = rm_anova(recs, "y", "s", ["task", "light", "geom", "conf"])
    assert res.effect("task")[2:4] == (1.0, 19.0)
    assert res.effect("conf")[2:4] == (4.0, 76.0)
    assert res.effect("task:light:geom:conf")[2:4] == (4.0, 76.0)
