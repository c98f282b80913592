"""The live block's Python glue (issue 20, last round): the output pass reads the drive FIFO in
place, copying (``fifo_read``) only when a block wraps the ring, and emits exactly what the
copying path emits, wraps, lifts and the watchdog included."""

from __future__ import annotations

import numpy as np

import surfhap.live.engine as engine_module
from surfhap.exchange.materials import load_material
from surfhap.live.engine import LiveEngine
from surfhap.live.engine_config import EngineConfig
from surfhap.render.chain import ChainConfig, TextureChain


def _engine():
    return LiveEngine(TextureChain(load_material("wood"), ChainConfig(drive_rate=20000)), EngineConfig(block_seconds=0.001))


def _run(eng, blocks):
    out = []
    for b in range(blocks):
        t = b * eng.block_period
        if b % 8 == 0 and not 300 <= b < 420:  # a 120 ms pause: the watchdog ramps down
            load = 0.0 if b == 600 else 0.5  # and a lift
            eng.push_touch(1, 0.06 + 0.05 * abs((t % 2.0) - 1.0), 0.068, load, t_event=t, t_arrival=t)
        out.append(eng.render(eng.block_frames, t + 2e-4).copy())
    return np.concatenate(out)


def test_output_pass_reads_the_fifo_in_place_and_copies_only_wrapping_blocks(monkeypatch):
    calls = []
    real = engine_module.fifo_read

    def counting(fifo, mask, r, out):
        calls.append(r)
        real(fifo, mask, r, out)

    monkeypatch.setattr(engine_module, "fifo_read", counting)
    eng = _engine()
    frames, cap = eng.block_frames, eng._fifo_cap
    blocks = cap // frames + 40  # past the first wrap of the ring
    got = _run(eng, blocks)
    wraps = [b * frames for b in range(blocks) if (b * frames) % cap + frames > cap]
    assert wraps and calls == wraps  # a copy only where the block wraps the ring
    calls.clear()
    ref = _engine()
    ref._fifo_cap = 0  # every block through fifo_read: the copying path
    want = _run(ref, blocks)
    assert len(calls) == blocks
    np.testing.assert_array_equal(got, want)
    assert np.abs(got).max() > 0.0 and np.abs(got).max() <= eng.v_max
    assert eng.counters["errors"] == 0
