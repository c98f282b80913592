"""Pre-processing of friction recordings (Otake et al. 2021 Sec. II-C, 2022 Sec. II).

Only the instants where both the normal and the shear force exceed 0.05 N are kept (the
finger is clearly sliding on the material); CoF = shear / normal. Each continuous contact
run is split at the cut-off frequency by a zero-phase 4th-order Butterworth filter (2.5 Hz in
the 2021 paper, 3.5 Hz in 2022; at the run edges an odd extension through a least-squares
line over two cut-off periods, :class:`surfhap.signal.bands.BandSplit`, so that
no step enters the filter): the low band is the quasi-static friction, the high band the
textural CoF mu_t. Filtering run by run keeps the non-contact gaps (where the CoF is
undefined) out of the filter. Normal force and speed are low-passed the same way, as
regressors of the quasi-static law.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from surfhap.errors import RecordingFormatError
from surfhap.exchange.recordings import Recording
from surfhap.signal.bands import BandSplit
from surfhap.signal.splice import true_runs

__all__ = ["PreparedRecording", "prepare_friction_recording", "CONTACT_THRESHOLD"]

#: N, both forces must exceed this to count as contact (Otake et al. 2021, 2022)
CONTACT_THRESHOLD = 0.05


@dataclass(frozen=True)
class PreparedRecording:
    """A friction recording reduced to its contact runs, concatenated.

    All arrays are (m,) over the kept samples; ``runs`` (k, 2) holds [start, stop) of each
    contact run in them (spans never cross a run boundary).
    normal N, speed m/s (magnitude), cof_low, cof_high (cof = low + high), normal_low N,
    speed_low m/s; ``shear_sum`` / ``normal_sum`` N over the kept samples (for Coulomb mu0).
    """

    source: str
    participant: str
    sha256: str
    sample_rate: float
    cutoff: float
    normal: np.ndarray
    speed: np.ndarray
    cof_low: np.ndarray
    cof_high: np.ndarray
    normal_low: np.ndarray
    speed_low: np.ndarray
    runs: np.ndarray
    shear_sum: float
    normal_sum: float

    @property
    def n_kept(self) -> int:
        return int(self.normal.size)


def prepare_friction_recording(rec: Recording, cutoff: float = 3.5, min_run: float = 0.1,
                               threshold: float = CONTACT_THRESHOLD) -> PreparedRecording:
    """Contact selection, CoF and band split of one recording (see the module docstring).

    Needs channels normal_force, shear_force (or cof) and speed (or position). Contact runs
    shorter than ``min_run`` s are dropped. Raises RecordingFormatError when no run is left.
    """
    rec.require("normal_force", "shear_force", "speed")
    fs = rec.sample_rate
    if not 0 < cutoff < fs / 2:
        raise RecordingFormatError(f"cut-off {cutoff} Hz must be within (0, {fs / 2:g}) Hz", source=rec.source, field="--cutoff")
    fn = rec.get("normal_force")
    fsh = np.abs(rec.get("shear_force"))
    v = np.abs(rec.get("speed"))
    contact = (fn > threshold) & (fsh > threshold)
    runs = true_runs(contact, max(int(np.ceil(min_run * fs)), 16))
    if runs.shape[0] == 0:
        raise RecordingFormatError(f"no contact run of {min_run * 1000:.0f} ms or longer with normal and shear force above "
                                   f"{threshold} N", source=rec.source, field="normal_force")
    split = BandSplit(cutoff=cutoff)
    stops = np.cumsum(runs[:, 1] - runs[:, 0])
    out_runs = np.stack([stops - (runs[:, 1] - runs[:, 0]), stops], axis=1)
    keep = np.zeros(rec.n, dtype=bool)
    for a, b in runs:
        keep[a:b] = True
    normal, speed, shear = fn[keep], v[keep], fsh[keep]
    cof = shear / normal
    low = np.empty((3, normal.size))
    for a, b in out_runs:  # run by run: no edge step (BandSplit)
        low[:, a:b] = split.low(np.stack([cof[a:b], normal[a:b], speed[a:b]]), fs)
    return PreparedRecording(rec.source, rec.participant, rec.sha256, fs, float(cutoff), normal, speed, low[0], cof - low[0],
                             low[1], np.abs(low[2]), out_runs, float(np.sum(shear)), float(np.sum(normal)))
