"""Issue 20 item 5: ChainConfig and EngineConfig are checked dataclasses (pydantic, one line
naming the field) instead of hand-written ``__post_init__`` range checks."""

import dataclasses

import pytest

from surfhap.errors import ConfigError
from surfhap.exchange.materials import load_material
from surfhap.live.engine_config import EngineConfig
from surfhap.render.chain import ChainConfig, TextureChain
from surfhap.render.shape_renderer import ShapeConfig


@pytest.mark.parametrize("cls, field, value", [
    (ChainConfig, "display", "big"),  # the old dataclass kept any object and failed later
    (ChainConfig, "seed", "lucky"),
    (ChainConfig, "drive_rate", 20000.5),
    (EngineConfig, "simulate_display", "maybe"),
    (EngineConfig, "block_seconds", "fast"),  # the old check raised a TypeError traceback
    (EngineConfig, "takeover", None),
])
def test_a_wrong_type_is_one_line_naming_the_field(cls, field, value):
    with pytest.raises(ConfigError) as err:
        cls(**{field: value})
    assert err.value.field == field and len(str(err.value).splitlines()) == 1


@pytest.mark.parametrize("make, line", [
    (lambda: EngineConfig(block_seconds=0.5), "block_seconds: must be within 0.2-100 ms"),
    (lambda: EngineConfig(touch_latency=0.9), "touch_latency: must be within 0-200 ms"),
    (lambda: EngineConfig(smoothing=0.0), "smoothing: must be in (0, 1]"),
    (lambda: EngineConfig(stop_ramp=float("nan")), "stop_ramp: must be within 0-1 s"),
    (lambda: EngineConfig(trace_capacity=100), "trace_capacity: must be a power of two"),
    (lambda: ChainConfig(carrier=500), "carrier: must be 0 (off) or within 2000-20000 Hz, got 500"),
    (lambda: ShapeConfig(carrier=500), "carrier: must be 0 (off) or within 2000-20000 Hz, got 500"),
    (lambda: dataclasses.replace(ChainConfig(), drive_rate=20000, carrier=15000),
     "carrier: 15000 Hz needs a drive rate of at least 30000 Hz (got 20000)"),
    (lambda: ChainConfig(alpha=-1.0), "alpha: Input should be greater than 0"),
    (lambda: TextureChain(load_material("cork"), ChainConfig(drive_rate=2000, control_rate=3000)),
     "drive_rate: drive rate 2000 Hz is below the control rate 3000 Hz"),
])
def test_out_of_range_values_keep_their_one_line(make, line):
    with pytest.raises(ConfigError) as err:
        make()
    assert str(err.value) == line
