"""One chain block is a few compiled calls (issue 20): the resampler, carrier, touch hold and
safety stage run in one kernel through their compiled entry points, the synthesiser picks its
models in its kernel, and the drive law fills one (4, n) block; results are checked against
independent references (nearest reference speed by argmin, the stages' own wrappers)."""

import dataclasses

import numpy as np
import pytest

from surfhap import ChainConfig, TextureChain, load_material
from surfhap.models.synth import ARSynthesizer
from surfhap.models.texture import ARModel, TextureBank
from surfhap.render.carrier import PolarityCarrier
from surfhap.render.safety import SafetyStage
from surfhap.signal.resample import RationalResampler

REFS = (0.05, 0.1, 0.15, 0.3)
BANK = TextureBank("cof", 2000.0, tuple(ARModel([0.5], 1e-4, v) for v in REFS))


def test_model_selection_is_the_nearest_reference_speed():
    speed = np.r_[np.random.default_rng(3).uniform(-0.5, 0.5, 500), np.nan, 0.0]
    nearest = np.argmin(np.abs(np.abs(np.nan_to_num(speed))[:, None] - np.array(REFS)[None, :]), axis=1)
    np.testing.assert_array_equal(BANK.select(speed), nearest)
    synth = ARSynthesizer(BANK, seed=2, max_block=16)  # a block longer than max_block grows the buffers
    y = synth.process(speed)
    np.testing.assert_array_equal(synth.model_index, nearest)
    one = ARSynthesizer(BANK, seed=2)
    np.testing.assert_array_equal(y, np.concatenate([one.process(speed[i:i + 3]) for i in range(0, speed.size, 3)]))


def test_chain_block_makes_no_python_stage_calls(monkeypatch):
    material = dataclasses.replace(load_material("leather"), texture=BANK)
    chain = TextureChain(material, ChainConfig(drive_rate=20000))
    ref_up = RationalResampler(chain.control_rate, chain.drive_rate)
    ref_carrier = PolarityCarrier(chain.carrier_hz, chain.drive_rate)
    ref_safety = SafetyStage(chain.drive_rate, chain.config.limits)

    def forbidden(*args, **kwargs):
        raise AssertionError("a chain block called a stage's Python wrapper")

    for cls in (RationalResampler, SafetyStage, PolarityCarrier):
        monkeypatch.setattr(cls, "process", forbidden)
    rng = np.random.default_rng(4)
    blocks = []
    for n in (2, 1, 3, 2, 6, 6, 5, 200, 2):  # 6 at 10x: n + m > the first scratch (64), drive_tail uses n + m
        speed, load = rng.uniform(0.0, 0.3, n), rng.uniform(0.1, 0.8, n)
        blocks.append((chain.process(speed, load, np.zeros(n)), load))
    monkeypatch.undo()
    # the same drive from the stages' own wrappers, block by block: all touch stamps are 0, so
    # the touch age of drive sample J is J / drive_rate
    j0 = 0
    for blk, load in blocks:
        envelope = ref_up.process(blk.drive_law.voltage)
        ages = (j0 + np.arange(envelope.shape[0])) / chain.drive_rate
        j0 += envelope.shape[0]
        np.testing.assert_array_equal(blk.drive, ref_safety.process(ref_carrier.process(envelope), blk.load_drive, ages))
    assert chain.safety.counters == ref_safety.counters and ref_safety.counters.watchdog > 0


def test_chain_writes_the_drive_into_a_given_buffer():
    """drive_out (what a kept offline render passes: its preallocated drive array) receives the
    block's drive in place, the same samples as a fresh array; a buffer below the block's bound
    is refused (the compiled tail does not check bounds)."""
    material = load_material("leather")
    fresh, into = (TextureChain(material, ChainConfig(drive_rate=44100)) for _ in range(2))
    rng = np.random.default_rng(7)
    buf = np.full(4000, np.nan)
    at = 0
    for n in (37, 1, 90):
        speed, load = rng.uniform(0.0, 0.3, n), rng.uniform(0.1, 0.8, n)
        ref = fresh.process(speed, load, np.zeros(n)).drive
        got = into.process(speed, load, np.zeros(n), drive_out=buf[at:]).drive
        assert np.shares_memory(got, buf)
        np.testing.assert_array_equal(got, ref)
        np.testing.assert_array_equal(buf[at:at + ref.size], ref)
        at += ref.size
    with pytest.raises(ValueError, match="drive_out"):
        into.process(np.zeros(10), np.zeros(10), np.zeros(10), drive_out=np.empty(10 * 44100 // 2000 + 1))


def test_chain_writes_the_law_rows_into_given_rows_and_refuses_short_ones():
    """law_out (a kept offline render's model-rate rows) receives voltage, target, mu_low, mu_tex
    and texture in place, the same as the block's own; fewer than 5 rows or n columns is refused
    before any kernel runs (the compiled law would write past them), the rows left untouched."""
    material = load_material("leather")
    fresh, into = (TextureChain(material, ChainConfig(drive_rate=20000)) for _ in range(2))
    rng = np.random.default_rng(8)
    speed, load = rng.uniform(0.0, 0.3, 40), rng.uniform(0.1, 0.8, 40)
    ref = fresh.process(speed, load, np.zeros(40))
    rows = np.full((5, 50), np.nan)
    got = into.process(speed, load, np.zeros(40), law_out=rows)
    np.testing.assert_array_equal(rows[:, :40], np.vstack([*ref.drive_law, ref.texture]))
    assert np.isnan(rows[:, 40:]).all() and np.shares_memory(got.target, rows)
    for short in (np.full((5, 39), np.nan), np.full((4, 60), np.nan)):
        with pytest.raises(ValueError, match="law_out"):
            into.process(speed, load, np.zeros(40), law_out=short)
        assert np.isnan(short).all()


def _forbid(monkeypatch, *classes):
    def forbidden(*args, **kwargs):
        raise AssertionError("a chain block called a stage's Python wrapper")

    for cls in classes:
        monkeypatch.setattr(cls, "process", forbidden)


def test_texture_law_runs_inside_the_block_kernel(monkeypatch):
    """The drive law is evaluated inside the chain's compiled block (no DriveLaw.process per
    block); its rows equal the law object's own evaluation on the cleaned inputs, and its
    clipped/touching counts advance as that of a law run block by block."""
    from surfhap.render.drive import DriveLaw

    material = dataclasses.replace(load_material("leather"), texture=BANK)
    for method in ("otake2022", "otake2021", "zhao", "friction-only"):
        chain = TextureChain(material, ChainConfig(method=method, drive_rate=20000))
        ref = TextureChain(material, ChainConfig(method=method, drive_rate=20000)).law
        rng = np.random.default_rng(5)
        blocks = []
        _forbid(monkeypatch, DriveLaw)
        for n in (2, 1, 3, 40):
            speed, load = rng.uniform(-0.3, 0.3, n), rng.uniform(-0.2, 0.8, n)
            blocks.append((chain.process(speed, load, np.zeros(n)), speed, load))
        monkeypatch.undo()
        for blk, speed, load in blocks:
            clean_speed = np.minimum(np.abs(speed), 10.0)
            clean_load = np.where((load > 0) & (load <= chain.config.limits.max_load), load, 0.0)
            want = ref.process(clean_speed, clean_load, blk.texture)
            for got, exp in zip(blk.drive_law, want):
                np.testing.assert_array_equal(got, exp)
        assert (chain.law.clipped, chain.law.touching) == (ref.clipped, ref.touching) and ref.touching > 0


def test_shape_drive_is_one_compiled_call(monkeypatch):
    """The shape chain's drive-rate stage (grains, voltage, carrier, safety stage) calls no
    stage's Python wrapper per block, and gives the drive of those wrappers run one after the
    other on the held finger (grainy grains: the envelope's random draws included)."""
    from surfhap.render.drive_kernel import target_to_voltage
    from surfhap.render.grains import GrainPlayer
    from surfhap.render.shape_renderer import ShapeConfig, ShapeDrive

    cfg = ShapeConfig(grain="area-grainy", seed=4)
    drive_stage = ShapeDrive(cfg, control_rate=1000)
    grains = GrainPlayer(cfg.grain, cfg.drive_rate, drive_stage.device, seed=cfg.seed, params=cfg.grain_params)
    carrier = PolarityCarrier(cfg.carrier, cfg.drive_rate)
    safety = SafetyStage(cfg.drive_rate, cfg.limits)
    rng = np.random.default_rng(6)
    blocks = []
    _forbid(monkeypatch, GrainPlayer, PolarityCarrier, SafetyStage)
    for b in range(30):
        inten = np.full(20, rng.uniform(0.3, 1.0))
        tick = np.zeros(20)
        tick[3] = 0.8 if b % 7 == 0 else 0.0
        load = np.array([0.0 if b in (10, 11) else 0.5])
        blocks.append((inten, tick, load, drive_stage.process(inten, tick, load, np.array([b * 1e-3]))))
    monkeypatch.undo()
    for b, (inten, tick, load, (drive, target, load_drive, _)) in enumerate(blocks):
        want_target = grains.process(inten, tick)
        np.testing.assert_array_equal(target, want_target)
        np.testing.assert_array_equal(load_drive, np.full(20, load[0]))  # one model sample held over its 20 drive samples
        envelope = np.empty(20)
        target_to_voltage(want_target, want_target, drive_stage.alpha, envelope)
        ages = (b * 20 + np.arange(20)) / cfg.drive_rate - b * 1e-3
        np.testing.assert_array_equal(drive, safety.process(carrier.process(envelope), load_drive, ages))
    assert drive_stage.safety.counters == safety.counters and safety.counters.lifted > 0


def test_drive_tail_refuses_a_scratch_too_short_for_its_chunks():
    # numba checks no bounds: the tail writes the carrier's output after the n model samples in
    # work[0], so a scratch shorter than n + min(m, chunk) must be an error, not a silent overwrite
    from surfhap.render.hold import drive_tail, tail_state

    safety = SafetyStage(20000, ChainConfig().limits)
    n, m = 6, 60
    state = np.append(tail_state(2000.0, 20000.0, 0.1), 1.0)
    args = (np.full(n, 0.5), np.zeros(n), state)
    with pytest.raises(ValueError, match="work needs"):
        drive_tail(m, *args, np.zeros((2, 64)), np.zeros(m, dtype=np.int64), safety.kernel_args(), np.ones(m), np.zeros(m))
    assert drive_tail(m, *args, np.zeros((2, n + m)), np.zeros(m, dtype=np.int64), safety.kernel_args(), np.ones(m),
                      np.zeros(m)) == m


def test_shape_drive_takes_blocks_that_grow():
    # the tail's scratch must hold n model + m drive samples of every block, not only of the first
    from surfhap.render.shape_renderer import ShapeConfig, ShapeDrive

    stage = ShapeDrive(ShapeConfig(), control_rate=1000)
    for m, n in ((10, 1), (20, 10), (400, 300)):
        drive, target, load_drive, _ = stage.process(np.full(m, 0.8), np.zeros(m), np.full(n, 0.5), np.zeros(n))
        assert drive.shape == (m,) and np.all(np.abs(drive) <= stage.config.limits.v_max)
        np.testing.assert_array_equal(load_drive, np.full(m, 0.5))


def test_texture_block_refuses_a_fill_that_changed_since_kernel_args(monkeypatch):
    """The upsampled texture's block count k is worked out from the buffer's fill in Python
    (kernel_args) and used in the kernel: a fill changed in between (a reset from another
    thread) would make the resampler write past the buffer. The kernel refuses it (ValueError,
    the engine then writes 0 V) before it writes anything."""
    from surfhap.render.texture_source import TextureSource

    chain = TextureChain(load_material("denim"), ChainConfig(drive_rate=20000))  # a 100 Hz model, resampled up
    assert chain.synth.compiled and chain.synth.resampler is not None
    rng = np.random.default_rng(3)
    for n in (7, 40):
        chain.process(rng.uniform(0.05, 0.2, n), np.full(n, 0.5), np.zeros(n))
    kernel_args = TextureSource.kernel_args

    for moved in (-40, 1 << 20):  # a fill below 0 (the old overrun) or beyond the buffer
        def raced(self, n, moved=moved):
            tex = kernel_args(self, n)
            self._fill[0] = moved
            return tex

        monkeypatch.setattr(TextureSource, "kernel_args", raced)
        buf = chain.synth._buf.copy()
        with pytest.raises(ValueError, match="texture_block"):
            chain.process(np.full(40, 0.1), np.full(40, 0.5), np.zeros(40))
        np.testing.assert_array_equal(chain.synth._buf, buf)
