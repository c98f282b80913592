"""Play a scripted scan through PortAudio into a JACK server and record what reaches it.

Run in its own process (PortAudio enumerates devices once per process) with
``JACK_DEFAULT_SERVER`` set: ``sound_check.py OUTDIR [CHANNELS]`` opens the engine on the JACK
"system" device (drive on channel 0 of 2, or on the 0-based CHANNELS such as ``1,2,5,7``
through the output registry, as ``--channels`` does), starts ``jack_rec`` on the stream's
output ports, streams touch samples, stops, and prints one JSON line: engine status, the
samples the backend wrote (npy path), the recording path and the ports' connections.

On a loaded machine every step before the recording (the stream's ports appearing, the
recorder starting) can take seconds, so nothing here is timed: the strokes start once the
stream's ports exist and go on until the recorder has finished (it records only while they
run), and the backend keeps every sample it wrote until the guards below run out (CAPTURE).
"""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time

import numpy as np

from surfhap.exchange.materials import load_material
from surfhap.live.backends.output import OutputOptions, SoundOutput, open_backend
from surfhap.live.backends.sound import SoundBackend, list_devices
from surfhap.live.engine import LiveEngine
from surfhap.live.engine_config import EngineConfig
from surfhap.render.chain import ChainConfig, TextureChain

GUARD = 60.0  # s, failure guard of each wait (a loaded machine), never a speed target
CAPTURE = 3 * GUARD + 30.0  # s the backend keeps: the start, the recorder's start and its run, within their guards


def strokes(engine, stop: threading.Event, counter: list) -> None:
    """200 Hz finger strokes until ``stop`` (bounded by the guard)."""
    t0 = time.perf_counter()
    while not stop.is_set() and time.perf_counter() - t0 < 3 * GUARD:
        t = time.perf_counter() - t0
        x = 0.04 * abs(((t * 2.0) % 2.0) - 1.0)
        engine.push_touch(1, x, 0.03, 0.6, t_event=t)
        counter[0] += 1
        stop.wait(0.005)


def main(outdir: str, channels: str | None = None) -> None:
    devices = list_devices()
    chain = TextureChain(load_material("cork"), ChainConfig(drive_rate=48000))
    engine = LiveEngine(chain, EngineConfig(block_seconds=0.001))
    engine.warm_up()
    if channels is None:
        backend = SoundBackend(device="system", amp_gain=250.0, n_channels=2, channels=(0,), capture_seconds=CAPTURE)
    else:
        chans = tuple(int(c) for c in channels.split(","))
        backend = open_backend(SoundOutput("system"), OutputOptions(amp_gain=250.0, channels=chans))
        backend.capture_seconds = CAPTURE
    backend.start(engine)
    wav = f"{outdir}/jack_rec.wav"
    ports = []
    end = time.monotonic() + GUARD  # the stream's ports appear once it runs
    n_open = 2 if channels is None else max(chans) + 1  # the stream's channels: one port each
    while len(ports) < n_open and time.monotonic() < end:
        lsp = subprocess.run(["jack_lsp"], capture_output=True, text=True, timeout=30).stdout.split()
        ports = [p for p in lsp if p.startswith("PortAudio") and ":out_" in p]
        if len(ports) < n_open:
            time.sleep(0.05)
    ports = sorted(ports, key=lambda p: int(p.rsplit("_", 1)[1]))  # out_1, out_2, ... (channel order)
    # the strokes run before the recorder connects and until it has finished: whenever its
    # 1.2 s begin, they hold the drive (not a fixed sleep that a slow recorder start outlasts)
    stop, count = threading.Event(), [0]
    finger = threading.Thread(target=strokes, args=(engine, stop, count), daemon=True)
    finger.start()
    rec = subprocess.Popen(["jack_rec", "-f", wav, "-d", "1.2", "-b", "32", *ports],
                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        rec.wait(2 * GUARD)
    finally:
        stop.set()
        finger.join(GUARD)
    k = count[0]
    connections = subprocess.run(["jack_lsp", "-c"], capture_output=True, text=True, timeout=30).stdout
    backend.stop()
    np.save(f"{outdir}/engine_out.npy", backend.capture[: backend.captured])
    print(json.dumps({"devices": devices, "status": engine.status(), "touches": k, "ports": ports,
                      "captured": backend.captured, "wav": wav, "npy": f"{outdir}/engine_out.npy",
                      "connections": connections}))


if __name__ == "__main__":
    main(*sys.argv[1:3])
