"""A live block is one compiled call for the chain and the simulated display (issue 20,
live_overhead): a texture synthesised at its own rate (the built-in materials' 100 Hz AR
banks, upsampled to the control rate) and the display's electrical model and decimation run
inside the renderer's kernel. Checked against independent references: a separate
:class:`TextureSource` and :class:`SimulatedDisplay` run through their own Python wrappers."""

from pathlib import Path

import numpy as np

from surfhap import ChainConfig, TextureChain, load_material
from surfhap.models.panel import SimulatedDisplay
from surfhap.models.synth import ARSynthesizer
from surfhap.render.texture_source import TextureSource
from surfhap.signal.resample import RationalResampler

SIZES = (2, 1, 3, 40, 25, 2, 2, 2, 2, 2, 2, 2, 2, 2, 2, 64, 1)


def _forbid(monkeypatch, *classes):
    def forbidden(*args, **kwargs):
        raise AssertionError("a live block called a Python wrapper")

    for cls in classes:
        monkeypatch.setattr(cls, "process", forbidden)


def test_texture_and_display_run_inside_the_chain_call(monkeypatch):
    material = load_material("cork")  # a 100 Hz AR bank: upsampled 20x to the 2 kHz control rate
    chain = TextureChain(material, ChainConfig(drive_rate=20000))
    assert chain.synth.resampler is not None and chain.synth.compiled
    display = SimulatedDisplay(chain.config.display, chain.drive_rate, chain.control_rate)
    ref_tex = TextureSource(material.texture, chain.control_rate, seed=chain.config.seed)
    ref_disp = SimulatedDisplay(chain.config.display, chain.drive_rate, chain.control_rate)
    rng = np.random.default_rng(8)
    blocks = []
    _forbid(monkeypatch, TextureSource, ARSynthesizer, RationalResampler, SimulatedDisplay)
    for n in SIZES:
        speed, load = rng.uniform(-0.3, 0.3, n), rng.uniform(-0.2, 0.8, n)
        blocks.append((chain.process(speed, load, np.zeros(n), display=display), speed, load))
    monkeypatch.undo()
    frictions = 0
    for blk, speed, load in blocks:
        clean_speed = np.minimum(np.abs(speed), 10.0)
        clean_load = np.where((load > 0) & (load <= chain.config.limits.max_load), load, 0.0)
        np.testing.assert_array_equal(blk.texture, ref_tex.process(clean_speed, clean_load))
        np.testing.assert_array_equal(blk.friction, ref_disp.process(blk.drive, blk.load_drive))
        frictions += blk.friction.size
    assert frictions > 0 and np.abs(np.concatenate([b.texture for b, _, _ in blocks])).max() > 0


def test_a_chain_without_display_gives_the_same_drive():
    material = load_material("wood")
    with_disp, without = (TextureChain(material, ChainConfig(drive_rate=20000)) for _ in range(2))
    display = SimulatedDisplay(with_disp.config.display, with_disp.drive_rate, with_disp.control_rate)
    rng = np.random.default_rng(9)
    for n in SIZES:
        speed, load = rng.uniform(0.0, 0.3, n), rng.uniform(0.1, 0.8, n)
        a = with_disp.process(speed, load, np.zeros(n), display=display)
        b = without.process(speed, load, np.zeros(n))
        np.testing.assert_array_equal(a.drive, b.drive)
        assert b.friction is None and a.friction is not None


def test_shape_chain_runs_the_display_in_its_drive_call(monkeypatch):
    import surfhap
    from surfhap.live.session import load_live_shape

    chain, _ = load_live_shape(Path(surfhap.__file__).parent / "data" / "suzanne.obj", 20000, (0.217, 0.136))
    display = SimulatedDisplay(chain.config.display, chain.drive_rate, chain.control_rate)
    ref_disp = SimulatedDisplay(chain.config.display, chain.drive_rate, chain.control_rate)
    blocks = []
    _forbid(monkeypatch, SimulatedDisplay)
    for b in range(40):
        x = np.array([0.06 + 0.002 * b])
        one = np.ones(1)
        blocks.append(chain.process(np.zeros(1), 0.5 * one, b * 1e-3 * one, x, 0.068 * one, display=display))
    monkeypatch.undo()
    for blk in blocks:
        np.testing.assert_array_equal(blk.friction, ref_disp.process(blk.drive, blk.load_drive))
    assert np.abs(np.concatenate([b.drive for b in blocks])).max() > 0
