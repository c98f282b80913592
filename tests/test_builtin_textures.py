"""The shipped texture models are exactly what the recorded command fits from the real recordings."""

import shlex

import numpy as np
import pytest

from surfhap.exchange.imu_csv import read_imu_csv
from surfhap.exchange.materials import builtin_names, load_material
from surfhap.fit.imu import fit_imu_texture


@pytest.mark.parametrize("name", [n for n in builtin_names() if load_material(n).texture is not None])
def test_refit_reproduces_shipped_model(name, shared_data):
    mat = load_material(name)
    prov = mat.spec.texture.provenance
    args = shlex.split(prov.command)
    assert args[:3] == ["surfhap", "fit", "imu"]
    rec_path = shared_data / "hapmat-imu" / prov.recording.split("/")[-1]
    rec = read_imu_csv(rec_path, unit_scale=float(args[args.index("--unit-scale") + 1]))
    assert rec.sha256 == prov.sha256
    order = int(args[args.index("--order") + 1]) if "--order" in args else None
    fit = fit_imu_texture(rec.accel, rec.sample_rate, cutoff=float(args[args.index("--cutoff") + 1]), order=order,
                          max_order=int(args[args.index("--max-order") + 1]))
    shipped = mat.texture.models[0]
    np.testing.assert_allclose(fit.coefficients, shipped.coefficients, rtol=0, atol=1e-12)
    assert fit.variance == pytest.approx(shipped.variance, rel=1e-12)
    assert mat.texture.sample_rate == pytest.approx(100.0)
