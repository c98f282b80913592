"""Every result class a user gets back answers the one base (surfhap.results.Result, issue 20 item 6):
``summary()`` and ``to_dict()`` are strict JSON, ``plot(ax=None)`` returns a new Figure, and
``plot(ax=...)`` draws into the Axes the caller laid out (one, or one per panel)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from matplotlib.figure import Figure
from scipy.signal import lfilter

from surfhap.results import Result


def _ar_noise(n, seed, phi=(1.2, -0.6)):
    return lfilter([1.0], [1.0, *(-np.asarray(phi))], np.random.default_rng(seed).normal(size=n))


def _friction_fit():
    from surfhap.fit.material_fit import fit_friction
    from surfhap.fit.synthetic import random_ar, scale_to_std, synthetic_friction_recordings
    from surfhap.models.friction import QuasiStaticLaw

    phi = random_ar(4, np.random.default_rng(1), 2000.0)
    recs = synthetic_friction_recordings(QuasiStaticLaw(0.4, 0.35, 2.0, 3.0, 0.6), {0.1: (phi, scale_to_std(phi, 0.01))},
                                         participants=2, duration=6.0, seed=1)
    return fit_friction(recs, "x", reference_speeds=(0.1,))


def _accel_fit():
    from surfhap.fit.accel import fit_accel
    from surfhap.fit.synthetic import random_ar, scale_to_std, synthetic_accel_recording

    rng = np.random.default_rng(3)
    pieces = []
    for k, (v, f) in enumerate(((0.05, 0.5), (0.15, 0.5), (0.05, 1.5), (0.15, 1.5))):
        phi = random_ar(4, rng, 1000.0, freq_range=(30.0, 480.0))
        pieces.append((phi, scale_to_std(phi, 1.0 + k), 1500, v, f))
    return fit_accel([synthetic_accel_recording(pieces, sample_rate=1000.0, mu=0.4, seed=3)], "tool", highpass=20.0,
                     max_order=10)


def _imu_fit():
    from surfhap.fit.imu import fit_imu_texture

    accel = np.stack([_ar_noise(4000, s) for s in range(3)], axis=1)
    return fit_imu_texture(accel, 1000.0, max_order=12)


def _order_selection():
    from surfhap.signal.ar import select_order

    return select_order(_ar_noise(3000, 0), max_order=12)


def _shape_calibration():
    from surfhap.shape.calibration import ScanPlan, calibrate
    from surfhap.shape.scenes import builtin_shape

    return calibrate(builtin_shape("frustum-bump"), ScanPlan(directions=8, speeds=(0.05, 0.1), lines=4))


def _profile():
    from surfhap.shape.profiles import formative_profile

    return formative_profile("bump", "IP0.7", n=101)


def _lab_calibration():
    from surfhap.lab.calibration import calibrate
    from surfhap.lab.tribometer_synth import synthetic_tribometer

    return calibrate([synthetic_tribometer(lv, "intensity", mu_panel=0.45, static=(0.01, 0.02, 0.18),
                                           amplitude=(0.0, 0.05, 0.2), noise=0.005, duration=2.0, seed=i)
                      for i, lv in enumerate((0.2, 0.5, 0.8, 1.0))])


def _comparison():
    from surfhap.lab.compare import compare_materials

    return compare_materials(["cork", "wood"], duration=0.6)


def _staircase():
    from surfhap.lab.staircase import Staircase, StaircaseParams

    sc = Staircase(StaircaseParams(start=10.0, steps=(2.0, 1.0), max_trials=30))
    while not sc.finished:
        sc.update(sc.level > 6.0)
    return sc.result()


def _proportions():
    from surfhap.lab.analysis import proportions

    return proportions([8, 5, 10], [10, 10, 10], ["a", "b", "c"], title="correct")


def _confusion():
    from surfhap.lab.analysis import confusion

    return confusion(list("aabbcc"), list("abbbca"), title="ident")


def _pearson():
    from surfhap.lab.analysis import pearson

    return pearson([1.0, 2.0, 3.5, 4.0], [1.2, 1.9, 3.0, 4.4], labels=["w", "x", "y", "z"])


def _art():
    from surfhap.lab.art import art_anova

    rng = np.random.default_rng(4)  # 6 subjects x 2 x 2 cells, an effect of a
    recs = [{"s": s, "a": a, "b": b, "y": float(a == "a1") + rng.normal()} for s in range(6)
            for a in ("a0", "a1") for b in ("b0", "b1")]
    return art_anova(recs, "y", "s", ["a", "b"])


def _study():
    from surfhap.lab.analyze_study import Section, StudyAnalysis

    sec = Section("identification", ["overall 0.67 correct"], [(["a"], [["1"]])],
                  [("bars", _proportions(), {"chance": 1 / 3}), ("confusion", _confusion(), {})])
    return StudyAnalysis("s", "identification", ["P01", "P02"], 12, [], [sec, Section("ratings", [], [],
                         [("r", _pearson(), {})])])


def _ff_sim():
    from surfhap.ff import FALCON, FFEngine, Stiffness
    from surfhap.models.trajectory import Trajectory
    from surfhap.render.kinematics import TouchPredictor
    from surfhap.sim.ff_device import SimDevice, SimFinger
    from surfhap.live.ff_loop import simulate_ff

    t = np.arange(0.0, 0.5, 1 / 120)
    tr = Trajectory(t, 0.1 + 0.02 * t, np.full(t.size, 0.07), np.full(t.size, 0.5))
    return simulate_ff(FFEngine([Stiffness(300.0)], FALCON, TouchPredictor()), SimFinger(tr), SimDevice(gain=FALCON.gain))


def _gain_plan():
    from surfhap import load_material
    from surfhap.render.gain_plan import plan_gains

    return plan_gains(load_material("wood"), "otake2022")


def _fidelity():
    from surfhap import ChainConfig, constant_scan, load_material
    from surfhap.render.fidelity import fidelity_metrics
    from surfhap.texture import render

    return fidelity_metrics(render(load_material("wood"), constant_scan(0.1, 0.5, 1.5), ChainConfig(seed=1)))


def _device_curve():
    from surfhap.models.device_curve import DeviceCurve

    return DeviceCurve.kim2017()


def _shape_result():
    from surfhap.render.shape_chain import render_shape
    from surfhap.shape.calibration import ShapeCalibration
    from surfhap.shape.scan import straight_scan
    from surfhap.shape.scenes import builtin_shape

    return render_shape(builtin_shape("frustum-bump"), straight_scan(-0.03, 0.001, 0.03, 0.001, 0.1),
                        ShapeCalibration.manual(-1.5, 1.5))


BUILDERS = {f.__name__[1:]: f for f in (
    _friction_fit, _accel_fit, _imu_fit, _order_selection, _shape_calibration, _profile, _lab_calibration,
    _comparison, _staircase, _proportions, _confusion, _pearson, _art, _study, _ff_sim, _gain_plan, _fidelity,
    _device_curve, _shape_result)}


def _drawn(ax) -> bool:
    """The axes hold drawn artists and a label (title or axis label)."""
    artists = ax.lines or ax.patches or ax.collections or ax.images or ax.texts
    return bool(artists) and any((ax.get_title(), ax.get_xlabel(), ax.get_ylabel()))


@pytest.mark.parametrize("name", sorted(BUILDERS))
def test_result_answers_summary_to_dict_and_plot(name):
    result = BUILDERS[name]()
    assert isinstance(result, Result)
    summary, full = result.summary(), result.to_dict()
    assert isinstance(summary, dict) and summary and isinstance(full, dict)
    json.dumps(summary, allow_nan=False)  # strict JSON: no NaN, no numpy types
    json.dumps(full, allow_nan=False)

    fig = result.plot()
    assert isinstance(fig, Figure) and any(_drawn(a) for a in fig.axes)

    host = Figure(figsize=(3 * result.panels, 3))
    given = host.subplots(1, result.panels, squeeze=False)[0]
    out = result.plot(ax=given[0] if result.panels == 1 else list(given))
    assert out is host
    empty = [i for i, a in enumerate(given) if not _drawn(a)]
    assert not empty, f"{name}: nothing drawn into the given panels {empty}"
    # no stray axes besides the given ones, their twins and colour bars
    assert all(a in given or a.get_label() == "<colorbar>" or a.bbox.bounds in [g.bbox.bounds for g in given]
               for a in host.axes)

    with pytest.raises(ValueError, match="panel"):
        result.plot(ax=list(Figure().subplots(1, result.panels + 1)))
