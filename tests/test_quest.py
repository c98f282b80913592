"""QUEST (Watson & Pelli 1983): the posterior against a brute-force Bayes computation written here,
convergence on simulated observers of known threshold, the design file's ``adaptive`` choice
through the CLI, and PsychoPy's QuestHandler as a reference when it is installed."""

import json
import math

import numpy as np
import pytest
from scipy.optimize import brentq

from surfhap.cli import main
from surfhap.errors import ConfigError
from surfhap.lab.designs import template
from surfhap.lab.quest import Quest, QuestParams
from surfhap.lab.triallog import read_log


def _weibull(x, t, beta, delta, gamma, eps):
    """Watson & Pelli's psi written out: delta gamma + (1 - delta)(1 - (1 - gamma) exp(-10^(beta (x - t + eps))))."""
    return delta * gamma + (1 - delta) * (1 - (1 - gamma) * math.exp(-10 ** (beta * (x - t + eps))))


def _brute_posterior(xs, responses, grid, mean, sd, beta, delta, gamma, p_thr):
    """Bayes by hand: eps found numerically (psi(T) = p_thr), Gaussian prior, product of likelihoods."""
    eps = brentq(lambda e: _weibull(0.0, 0.0, beta, delta, gamma, e) - p_thr, -5, 5)
    post = []
    for t in grid:
        w = math.exp(-0.5 * ((t - mean) / sd) ** 2)
        for x, r in zip(xs, responses):
            p = _weibull(x, t, beta, delta, gamma, eps)
            w *= p if r else 1 - p
        post.append(w)
    total = sum(post)
    return [w / total for w in post]


@pytest.mark.parametrize("gamma,p_thr,placement", [(0.5, 0.82, "mean"), (0.0, 0.5, "mode"), (1 / 3, 0.7, "quantile")])
def test_posterior_after_a_fixed_sequence_equals_brute_force_bayes(gamma, p_thr, placement):
    params = QuestParams(prior_mean=-1.0, prior_sd=0.6, gamma=gamma, p_threshold=p_thr, grain=0.02, range=4.0,
                         placement=placement, quantile=0.3, scale="linear")
    q = Quest(params)
    assert params.beta == 3.5 and params.delta == 0.01  # Watson & Pelli's defaults
    xs = [-1.0, -1.4, -0.8, -1.2, -0.9, -1.5, -1.1, -0.7]
    resp = [True, False, True, True, False, False, True, True]
    for x, r in zip(xs, resp):
        q.update(r, x)
    ref = _brute_posterior(xs, resp, q.t.tolist(), -1.0, 0.6, 3.5, 0.01, gamma, p_thr)
    assert q.posterior() == pytest.approx(ref, abs=1e-12)
    m = sum(w * t for w, t in zip(ref, q.t))
    assert q.mean() == pytest.approx(m, abs=1e-12)
    assert q.sd() == pytest.approx(math.sqrt(sum(w * (t - m) ** 2 for w, t in zip(ref, q.t))), abs=1e-12)
    expect = {"mean": m, "mode": q.t[int(np.argmax(ref))],
              "quantile": float(np.interp(0.3, np.cumsum(ref), q.t))}[placement]
    assert q.x == pytest.approx(expect, abs=1e-12) and q.level == q.x
    assert params.psi(-1.0, -1.0) == pytest.approx(p_thr)


def _run(true_t, seed, **kw):
    params = QuestParams(**{"prior_mean": 0.0, "prior_sd": 1.0, "max_trials": 64, "scale": "linear", **kw})
    rng = np.random.default_rng(seed)
    q = Quest(params)
    while not q.finished:
        q.update(rng.random() < params.psi(q.x, true_t))
    return q


def test_the_estimate_converges_on_a_simulated_observer_of_known_threshold():
    """A 2AFC observer following the model with T = 0.4 log units, prior N(0, 1): after 64 trials
    the posterior mean lies near T in every run, unbiased over the runs, and the posterior SD
    reflects the run-to-run spread."""
    runs = [_run(0.4, seed) for seed in range(40)]
    est = np.array([q.mean() for q in runs])
    sds = np.array([q.sd() for q in runs])
    assert abs(est.mean() - 0.4) < 0.04
    assert np.all(np.abs(est - 0.4) < 0.35)
    assert 0.5 < est.std() / np.sqrt(np.mean(sds ** 2)) < 1.6
    res = runs[0].result()
    assert res.levels.size == 64 and res.stopped_by == "trials" and res.threshold == pytest.approx(runs[0].mean())


def test_the_posterior_sd_stop_and_the_level_clamp():
    q = _run(0.4, 1, sd_stop=0.1, max_trials=500)
    assert q.sd() < 0.1 and q.result().stopped_by == "posterior SD" and q.result().levels.size < 500
    low = _run(-3.0, 2, max_level=0.5, min_level=-0.2, max_trials=20)
    assert np.all((low.result().levels >= -0.2) & (low.result().levels <= 0.5))
    with pytest.raises(ConfigError, match="p_threshold"):
        QuestParams(prior_mean=0.0, prior_sd=1.0, gamma=0.5, p_threshold=0.4)  # below the guess rate
    with pytest.raises(ConfigError, match="finished"):
        q.update(True)


def _design(tmp_path, adaptive, participants=1):
    spec = template("kim-shapes", participants=participants).model_dump(mode="json")
    spec["adaptive"] = adaptive
    (tmp_path / "design.json").write_text(json.dumps(spec))
    return tmp_path / "design.json"


def test_the_design_files_adaptive_field_chooses_quest_for_the_comfort_run(tmp_path):
    """``adaptive: {method: quest}`` in the design: 'study comfort' (no --method) runs QUEST on
    log10 V; the simulated participant is uncomfortable with P = 1 / (1 + exp(-(v - 120) / 12)),
    whose 20.6 % point is 103.8 V; results.json carries the method and its estimate."""
    d = _design(tmp_path, {"method": "quest", "prior_mean": 1.8, "prior_sd": 0.5, "gamma": 0.0,
                           "p_threshold": 0.206, "max_trials": 30, "min_level": 0.7, "max_level": 3.0})
    study = tmp_path / "s"
    assert main(["study", "new", str(d), "--out", str(study)]) == 0
    assert main(["study", "comfort", str(study), "-p", "P01", "--simulate", "4"]) == 0
    doc = json.loads((study / "logs" / "P01-comfort.json").read_text())
    assert doc["adaptive"]["method"] == "quest" and doc["adaptive"]["max_level"] == pytest.approx(math.log10(250))
    assert len(doc["levels_V"]) == 30 and max(doc["levels_V"]) <= 250.0
    assert doc["staircase_threshold_V"] == pytest.approx(103.8, rel=0.2) and doc["quest_sd_log10"] < 0.15
    assert read_log(study / "logs" / "P01-comfort.jsonl").sessions[0]["config"]["method"] == "quest"
    assert main(["study", "run", str(study), "-p", "P01", "--simulate", "1"]) == 0
    assert main(["study", "analyze", str(study), "--report", str(tmp_path / "rep")]) == 0
    est = json.loads((tmp_path / "rep" / "results.json").read_text())["estimates"]
    assert est[0]["adaptive"] == "quest" and est[0]["adaptive_estimate_V"] == doc["staircase_threshold_V"]


@pytest.mark.parametrize("adaptive,field", [
    ({"method": "qest"}, "adaptive"),
    ({"method": "quest", "prior_mean": 1.8, "prior_sd": -1}, "adaptive.quest.prior_sd"),
    ({"method": "staircase", "start": 60, "up": 0}, "adaptive.staircase.up"),
    ({"method": "questplus", "max_trials": "many"}, "adaptive.questplus.max_trials"),
])
def test_a_bad_adaptive_field_is_one_line_naming_the_file_and_field_exit_2(tmp_path, capsys, adaptive, field):
    d = _design(tmp_path, adaptive)
    capsys.readouterr()
    assert main(["study", "new", str(d), "--out", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "design.json" in err[0] and f"{field}:" in err[0], err


def test_method_option_overrides_the_design_with_that_methods_comfort_defaults(tmp_path):
    """A design choosing a staircase; 'study comfort --method quest' runs QUEST with the comfort
    defaults (yes/no, T at 20.6 % uncomfortable, prior centred on --start, 40 trials in 5-250 V)."""
    d = _design(tmp_path, {"method": "staircase", "start": 60, "up": 3, "down": 1, "step_type": "db", "steps": [4, 2],
                           "min_level": 5, "max_level": 240}, participants=2)
    study = tmp_path / "s"
    assert main(["study", "new", str(d), "--out", str(study)]) == 0
    assert main(["study", "comfort", str(study), "-p", "P01", "--simulate", "3", "--method", "quest"]) == 0
    doc = json.loads((study / "logs" / "P01-comfort.json").read_text())
    a = doc["adaptive"]
    assert a["method"] == "quest" and a["gamma"] == 0 and a["p_threshold"] == pytest.approx(1 - 0.5 ** (1 / 3))
    assert a["prior_mean"] == pytest.approx(math.log10(60)) and len(doc["levels_V"]) == 40
    assert 5.0 <= min(doc["levels_V"]) and max(doc["levels_V"]) <= 250.0
    assert doc["staircase_threshold_V"] == pytest.approx(103.8, rel=0.2)
    assert main(["study", "comfort", str(study), "-p", "P02", "--simulate", "3"]) == 0  # the design's own staircase
    doc = json.loads((study / "logs" / "P02-comfort.json").read_text())
    assert doc["adaptive"]["method"] == "staircase" and doc["adaptive"]["max_level"] == 240
    assert doc["adaptive"]["steps"] == [4, 2] and max(doc["levels_V"]) <= 240
