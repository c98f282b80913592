"""Start and stop a private JACK server with the dummy backend (no sound hardware).

Used by the sound tests: ``with jack_dummy(rate=48000, period=48) as name:`` starts
``jackd --no-realtime -n NAME -d dummy`` and waits until it accepts clients; the caller
passes ``JACK_DEFAULT_SERVER=NAME`` to the processes that should use it.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import tempfile
import time
import uuid
from contextlib import contextmanager

__all__ = ["jack_available", "jack_dummy"]


def jack_available() -> str | None:
    """None when jackd, jack_rec, jack_lsp and PortAudio are all installed, else the reason."""
    for tool in ("jackd", "jack_rec", "jack_lsp"):
        if shutil.which(tool) is None:
            return f"{tool} not found (Debian package jackd2)"
    import ctypes.util

    if ctypes.util.find_library("portaudio") is None:
        return "PortAudio library not found (Debian package libportaudio2)"
    return None


def jack_env(name: str) -> dict:
    env = dict(os.environ)
    env["JACK_DEFAULT_SERVER"] = name
    env["JACK_NO_AUDIO_RESERVATION"] = "1"
    env["JACK_NO_START_SERVER"] = "1"
    return env


@contextmanager
def jack_dummy(rate: int = 48000, period: int = 48, playback: int = 2):
    name = f"surfhap-test-{uuid.uuid4().hex[:8]}"
    env = jack_env(name)
    # jackd's log goes to a file, never to a pipe nobody reads: on a loaded machine it logs
    # every late cycle, a full pipe would block the server and with it every client.
    log = tempfile.TemporaryFile()
    proc = subprocess.Popen(
        ["jackd", "--no-realtime", "-n", name, "-d", "dummy", "-r", str(rate), "-p", str(period), "-C", "0",
         "-P", str(playback)],
        env=env, stdout=log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 60.0  # generous: a loaded machine
        while True:
            if proc.poll() is not None:
                log.seek(0)
                raise RuntimeError("jackd exited: " + log.read().decode(errors="replace")[-500:])
            r = subprocess.run(["jack_lsp"], env=env, capture_output=True, text=True, timeout=30)
            if r.returncode == 0 and "system:playback_1" in r.stdout:
                break
            if time.monotonic() > deadline:
                raise RuntimeError("jackd did not come up within 60 s")
            time.sleep(0.1)
        yield name
    finally:
        proc.terminate()
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)
        log.close()
