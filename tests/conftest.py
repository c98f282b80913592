import os
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    if not SHARED_DATA.is_dir():
        if os.environ.get("CI"):
            pytest.fail(f"CI needs the shared data at {SHARED_DATA}")
        pytest.skip(f"shared data not found at {SHARED_DATA}")
    return SHARED_DATA


# Hypothesis on a loaded 2-core machine: no per-example deadline and no "too slow" health
# check (both are timing, not correctness); tests that set @settings inherit this profile.
from hypothesis import HealthCheck, settings  # noqa: E402

settings.register_profile("surfhap", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "surfhap"))


@pytest.fixture
def frozen_heap():
    """The heap this test process has built up so far (the whole suite's: modules, compiled
    kernels) is left out of the cyclic collector while a live run goes on in this process, as a
    command's own process starts small: a full collection over it pauses every thread of the
    process, the engine's and an in-process sensor box's among them (``ff run`` and the web
    process freeze their start-up heap for the same reason)."""
    import gc

    gc.collect()
    gc.freeze()
    yield
    gc.unfreeze()
