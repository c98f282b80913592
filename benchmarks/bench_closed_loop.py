"""Closed-loop friction under drift (issue 19 item 3): low-band error closed <= 1/3 of open loop.

The simulated display's k drifts by +-30 % over a minute with a +20 % step at half the minute
(:class:`surfhap.sim.closed_loop.Drift`); a simulated force sensor (5 ms delay, the noise of
the load cells of 003 Sec. II) closes the loop. For each case (loads 0.26-0.96 N, speeds up
to 1 m/s) one JSON line holds both figures of one run: the open- and closed-loop low-band RMS
error against the law (N), their ratio (target <= 1/3), the drive samples clamped by the safety
stage (closed <= open) and the largest octave-band change of the texture band (<= 1 dB).
"""

from _common import report, run

from surfhap.exchange.materials import load_material
from surfhap.models.trajectory import constant_scan
from surfhap.render.chain import ChainConfig
from surfhap.runtime.closed_loop import LoopDesign
from surfhap.sim.closed_loop import Drift, SensorModel, compare_loops

CASES = (("wood", 0.26, 0.1), ("denim", 0.5, 0.5), ("leather", 0.96, 0.25), ("drawing-paper", 0.96, 1.0))


def main():
    for name, load, speed in CASES:
        c = compare_loops(load_material(name), constant_scan(speed, load, 60.0), ChainConfig(seed=1), drift=Drift(),
                          sensor=SensorModel(delay=0.005), design=LoopDesign(sensor_delay=0.005))
        s = c.summary()
        ok = c.ratio <= 1 / 3 and c.closed.clamped <= c.open.clamped and c.texture_db <= 1.0
        report(f"closed_loop_{name}_{load:g}N_{speed:g}mps",
               {k: (round(v, 6) if isinstance(v, float) else v) for k, v in s.items() if k != "ratio"},
               c.ratio, "closed/open low-band RMS error <= 1/3, clamped closed <= open, texture band within 1 dB",
               ok)


if __name__ == "__main__":
    run(main)
