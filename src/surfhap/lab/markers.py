"""Lab Streaming Layer markers of a study session (optional: ``pip install surfhap[lsl]``).

With ``--lsl``, ``surfhap study run`` opens an LSL outlet (type ``Markers``, one string
channel, irregular rate, name ``surfhap-<participant>``) and pushes one JSON string per event,
so that EEG, EMG, force or video recorded with LSL can be aligned with the trials::

    {"event": "stimulus_on", "trial": "P01-0003", "index": 1, "label": "B"}
    {"event": "stimulus_off", "trial": "P01-0003"}
    {"event": "touch_down"} / {"event": "touch_up"}
    {"event": "answer", "trial": "P01-0003", "answer": "2", "rt_s": 4.21}
    {"event": "rest"} / {"event": "end"}

Blinding: a marker carries the page's opaque ids only (``label``: the stimulus button's label,
``answer``: the choice's position from 1, :mod:`surfhap.lab.blinding`); the trial record of the
log (``key``) maps them to the choice ids and render specs.

LSL time stamps are taken by pylsl at push time (``local_clock``). Without ``--lsl`` a
:class:`NullMarkers` does nothing.
"""

from __future__ import annotations

import json
import threading

from surfhap.errors import ConfigError

__all__ = ["NullMarkers", "LslMarkers", "open_markers"]


class NullMarkers:
    """Markers that go nowhere."""

    enabled = False

    def push(self, event: str, **fields) -> None:
        return None

    def close(self) -> None:
        return None


class LslMarkers:
    """An LSL marker outlet; :meth:`push` is thread-safe."""

    enabled = True

    def __init__(self, name: str, source_id: str):
        from pylsl import StreamInfo, StreamOutlet

        self.info = StreamInfo(name, "Markers", 1, 0, "string", source_id)
        self.outlet = StreamOutlet(self.info)
        self._lock = threading.Lock()

    def push(self, event: str, **fields) -> None:
        """Push one marker; after :meth:`close` (a page thread may still report an event) a no-op."""
        text = json.dumps({"event": event, **fields}, separators=(",", ":"))
        with self._lock:
            if self.outlet is not None:
                self.outlet.push_sample([text])

    def close(self) -> None:
        """Destroy the outlet (liblsl joins its transfer threads), never while a push runs."""
        with self._lock:
            self.outlet = None


def open_markers(enabled: bool, participant: str, study_name: str = "") -> NullMarkers | LslMarkers:
    """An LSL outlet when ``enabled`` (ConfigError naming the extra if pylsl is missing)."""
    if not enabled:
        return NullMarkers()
    try:
        import pylsl  # noqa: F401
    except ImportError:
        raise ConfigError("needs pylsl: pip install 'surfhap[lsl]'", source="--lsl", field="lsl") from None
    return LslMarkers(f"surfhap-{participant}", f"surfhap:{study_name}:{participant}")
