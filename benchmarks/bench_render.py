"""Offline render, full chain at a 20 kHz drive rate: >= 1000x real time on one core.

Full chain: kinematics, AR texture synthesis (bank of 5 reference velocities, order 37 —
the leather order of Otake et al. 2021 Table II), otake2022 drive law, polyphase
resampling 2 kHz -> 20 kHz, 2 kHz polarity carrier, safety stage, and the simulated display
(electrical model + decimation back to 2 kHz). The texture models are synthetic (a benchmark
needs a realistic load, not a material).
"""

import dataclasses

import numpy as np
from _common import best_time, report, run

from surfhap import ChainConfig, load_material, strokes
from surfhap.texture import render
from surfhap.models.texture import ARModel, TextureBank
from surfhap.signal.ar import yule_walker


def bank():
    rng = np.random.default_rng(0)
    models = []
    for i, v in enumerate((0.05, 0.075, 0.1, 0.125, 0.15)):
        x = np.convolve(rng.standard_normal(40000), np.hanning(9 + 2 * i), mode="same")
        phi, var = yule_walker(x, 37)
        models.append(ARModel(phi, var * 1e-4, v))
    return TextureBank("cof", 2000.0, tuple(models))


def main():
    material = dataclasses.replace(load_material("leather"), texture=bank())
    seconds = 60.0
    traj = strokes(0.1, 0.4, seconds)
    cfg = ChainConfig(drive_rate=20000, carrier=2000.0)
    render(material, strokes(0.1, 0.4, 1.0), cfg)  # compile
    t = best_time(lambda: render(material, traj, cfg), repeat=12)  # 0.05 s each: the least disturbed of 12
    factor = seconds / t
    report("offline_render_20khz", {"seconds_rendered": seconds, "compute_s": round(t, 4), "realtime_factor": round(factor, 1)},
           factor / 1000.0, "realtime_factor >= 1000 (ratio = factor / 1000 >= 1)", factor >= 1000.0)


if __name__ == "__main__":
    run(main)
