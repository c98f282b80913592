"""``sound``: PortAudio output through sounddevice (sound card -> high-voltage amplifier).

The stream runs at the engine's drive rate and block size; PortAudio's audio thread calls
:meth:`SoundBackend._callback`, which only calls ``engine.render`` (the real-time contract of
:mod:`surfhap.live.engine`) and writes ``volts / amp_gain`` (``amp_gain``: the amplifier's V
per DAC full-scale unit; float32, clipped just below 1, since +1.0 wraps to -1 in some
integer converters) to the 0-based ``channels`` (default: all), any subset of the device's
channels; the stream opens channels 0 to the highest routed one and the others carry 0 V. The
drive is one signal, so the engine's one output safety stage, before this fan-out, holds on
every routed channel.

Each block is rendered for the moment its first sample reaches the DAC
(:meth:`surfhap.runtime.clock.AudioClock.dac_time`: ``outputBufferDacTime``, or the stream's
nominal latency when the host API gives no usable times), so the engine's watchdog (touch older
than 50 ms -> 0 V within 5 ms) holds at the DAC. Underflow flags count as engine underruns. An
exception in the callback writes 0 V and calls ``engine.fail``; no callback for
``stall_timeout`` s also does and aborts the stream. ``capture_seconds`` keeps a copy of the
first samples written (preallocated), for checking the amplifier chain.
"""

from __future__ import annotations

import logging

import numpy as np

from surfhap.errors import ConfigError
from surfhap.live.backends.base import PacedBackend, StallWatch
from surfhap.runtime.clock import AudioClock

__all__ = ["SoundBackend", "list_devices"]

log = logging.getLogger("surfhap.live")

_FULL_SCALE = float(np.nextafter(np.float32(1.0), np.float32(0.0)))


def _sd():
    try:
        import sounddevice as sd
    except OSError as exc:  # PortAudio library missing
        raise ConfigError(f"PortAudio is not available ({exc}); install libportaudio2", source="--output") from None
    except ImportError:
        raise ConfigError("sounddevice is not installed; pip install 'surfhap[live]'", source="--output") from None
    return sd


def list_devices() -> list[dict]:
    """Output-capable sound devices: index, name, host API, channels, default rate."""
    sd = _sd()
    apis = sd.query_hostapis()
    out = []
    for i, d in enumerate(sd.query_devices()):
        if d["max_output_channels"] > 0:
            out.append({"index": i, "name": d["name"], "hostapi": apis[d["hostapi"]]["name"],
                        "channels": int(d["max_output_channels"]), "default_rate": float(d["default_samplerate"])})
    return out


class SoundBackend(PacedBackend):
    """PortAudio's callback renders the blocks (no thread of its own); stopping is
    :meth:`PacedBackend.stop`'s."""

    name = "sound"
    paced_by_device = True

    def __init__(self, device: int | str | None = None, amp_gain: float = 250.0, n_channels: int | None = None,
                 channels: tuple[int, ...] | None = None, latency: str | float = "low",
                 capture_seconds: float = 0.0):
        super().__init__()
        if not (np.isfinite(amp_gain) and amp_gain > 0):
            raise ConfigError("must be > 0 V per DAC unit", field="amp_gain")
        self.device = device
        self.amp_gain = float(amp_gain)
        self.n_channels = n_channels
        self.channels = channels
        self.latency = latency
        self.capture_seconds = float(capture_seconds)
        self.capture = np.zeros(0, dtype=np.float32)
        self.captured = 0
        self._chans: tuple[int, ...] = ()
        self._stream = None
        self.nominal_latency = 0.0

    def start(self, engine) -> None:
        sd = _sd()
        try:
            dev = sd.query_devices(self.device, "output")
        except (ValueError, sd.PortAudioError) as exc:
            raise ConfigError(f"no such output device ({exc}); see `surfhap devices`", source="--output") from None
        m = int(dev["max_output_channels"])
        bad = [c for c in self.channels or () if not 0 <= c < m]
        if bad:
            raise ConfigError(f"{dev['name']!r} has {m} output channels (0-{m - 1}); there is no channel {bad[0]}",
                              source="--channels")
        n_ch = int(self.n_channels or m)
        if not 1 <= n_ch <= m:
            raise ConfigError(f"device has {m} output channels, asked for {n_ch}", field="channels")
        chans = tuple(range(n_ch)) if self.channels is None else tuple(self.channels)
        if not chans or any(not 0 <= c < n_ch for c in chans):
            raise ConfigError(f"drive channels must be within 0-{n_ch - 1}", field="channels")
        self.bind(engine, chans)
        try:
            self._stream = sd.OutputStream(device=self.device, samplerate=engine.drive_rate, channels=n_ch,
                                           dtype="float32", blocksize=engine.block_frames, latency=self.latency,
                                           callback=self._callback)
            self.nominal_latency = max(0.0, float(self._stream.latency))  # s, before the first callback
            self._stream.start()
        except sd.PortAudioError as exc:
            self._stream = None
            raise ConfigError(f"cannot open sound output at {engine.drive_rate} Hz ({exc})", source="--output") from None
        self._watch = StallWatch(engine, self.name, self.stall_timeout, on_stall=self.abort).start()
        log.info("sound output on %r: %d channel(s) at %d Hz, block %d, output latency %.1f ms",
                 dev["name"], n_ch, engine.drive_rate, engine.block_frames, 1e3 * self._stream.latency)

    def bind(self, engine, chans: tuple[int, ...], nominal_latency: float = 0.0) -> None:
        """Allocate the callback's buffers for ``engine`` writing to ``chans`` (0-based);
        ``nominal_latency`` (s) stands in for a host API without usable DAC times."""
        self._chans = tuple(chans)
        self._inv_gain = 1.0 / self.amp_gain
        self._units = np.zeros(engine.config.max_block_frames, dtype=np.float32)
        self.capture = np.zeros(int(self.capture_seconds * engine.drive_rate), dtype=np.float32)
        self.captured = 0
        self.engine = engine
        self.nominal_latency = float(nominal_latency)

    def _callback(self, outdata, frames, time_info, status) -> None:
        try:
            self._fill(outdata, frames, time_info, status)
        except Exception as exc:  # noqa: BLE001 - the device must not keep the last samples
            outdata.fill(0.0)
            if self.error is None:
                self.error = f"sound output failed: {type(exc).__name__}: {exc}"
            self.engine.fail(self.error)

    def abort(self) -> None:
        stream = self._stream
        if stream is not None:
            stream.abort()

    def _fill(self, outdata, frames, time_info, status) -> None:
        # real-time: no allocation beyond numpy views, no locks, no logging
        eng = self.engine
        if status.output_underflow:
            eng.counters["underruns"] += 1
        volts = eng.render(frames, AudioClock.dac_time(eng.clock(), time_info, self.nominal_latency))
        u = self._units[:frames]
        np.multiply(volts, self._inv_gain, out=u, casting="same_kind")
        np.clip(u, -_FULL_SCALE, _FULL_SCALE, out=u)
        outdata.fill(0.0)
        for c in self._chans:
            outdata[:, c] = u
        cap = self.capture
        k = self.captured
        if k < cap.shape[0]:
            m = min(frames, cap.shape[0] - k)
            cap[k : k + m] = u[:m]
            self.captured = k + m

    def live(self) -> bool:
        return self._stream is not None

    def close(self) -> None:
        if self._stream is None:
            return
        try:
            self._stream.stop()
            self._stream.close()
        finally:
            self._stream = None

    def info(self) -> dict:
        lat = self._stream.latency if self._stream is not None else None
        return {"name": self.name, "device": self.device, "amp_gain": self.amp_gain,
                "output_latency": lat, "channels": list(self._chans)}
