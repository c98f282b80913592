"""The shipped texture models are what their recorded command fits from the real recordings,
checked against an independent pipeline: the recording's bytes by their SHA-256, and the model
against a reference written here from the method's definition (DFT321 of Landin et al. 2010 in
numpy, the 3.5 Hz zero-phase Butterworth split of Otake et al. 2022 in scipy, Yule-Walker in
statsmodels). The shipped model may differ from the reference only by the edge handling of the
band split, so their spectra must agree within 1 dB over the texture band."""

import hashlib
import shlex

import numpy as np
import pytest
from scipy.signal import butter, freqz, sosfiltfilt
from statsmodels.regression.linear_model import yule_walker

from surfhap.exchange.materials import builtin_names, load_material


def _reference_high_band(path, unit_scale, cutoff):
    data = np.genfromtxt(path, delimiter=",", names=True)
    xyz = np.column_stack([data["accel_x"], data["accel_y"], data["accel_z"]]) * unit_scale
    fs = 1.0 / np.median(np.diff(data["time"]))
    spec = np.fft.rfft(xyz, axis=0)  # DFT321: summed energy, phase of the summed spectrum
    combined = np.fft.irfft(np.sqrt((np.abs(spec) ** 2).sum(axis=1)) * np.exp(1j * np.angle(spec.sum(axis=1))),
                            n=xyz.shape[0])
    low = sosfiltfilt(butter(4, cutoff, btype="low", fs=fs, output="sos"), combined)
    return combined - low, fs


def _ar_spectrum_db(phi, sigma2, fs, freqs):
    _, h = freqz([1.0], np.concatenate(([1.0], -np.asarray(phi))), worN=freqs, fs=fs)  # scipy, not surfhap
    return 10 * np.log10(2.0 * sigma2 / fs * np.abs(h) ** 2)


@pytest.mark.parametrize("name", [n for n in builtin_names() if load_material(n).texture is not None])
def test_shipped_model_matches_an_independent_fit_of_its_recording(name, shared_data):
    mat = load_material(name)
    prov = mat.spec.texture.provenance
    args = shlex.split(prov.command)
    assert args[:3] == ["surfhap", "fit", "imu"]
    rec_path = shared_data / "hapmat-imu" / prov.recording.split("/")[-1]
    assert hashlib.sha256(rec_path.read_bytes()).hexdigest() == prov.sha256
    shipped = mat.texture.models[0]
    order = shipped.coefficients.size
    assert 1 <= order <= int(args[args.index("--max-order") + 1])
    if "--order" in args:
        assert order == int(args[args.index("--order") + 1])
    high, fs = _reference_high_band(rec_path, float(args[args.index("--unit-scale") + 1]),
                                    float(args[args.index("--cutoff") + 1]))
    assert mat.texture.sample_rate == pytest.approx(fs) == pytest.approx(100.0)
    rho, sigma = yule_walker(high, order=order, method="mle", result_object=False)
    freqs = np.linspace(5.0, 45.0, 81)
    diff = _ar_spectrum_db(shipped.coefficients, shipped.variance, fs, freqs) - _ar_spectrum_db(rho, sigma ** 2, fs, freqs)
    assert np.max(np.abs(diff)) < 1.0, f"{name}: shipped and reference spectra differ by {np.max(np.abs(diff)):.2f} dB"
