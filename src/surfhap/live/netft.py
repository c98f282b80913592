"""ATI Net F/T over RDT (UDP), written from ATI's manual 9620-05-NET FT ("Raw Data Transfer")::

    request  8 B big-endian: uint16 0x1234, uint16 command (0x0002 start high-speed streaming,
                             0x0000 stop), uint32 sample count (0 = endless), to UDP port 49152
    record  36 B big-endian: uint32 rdt_sequence, ft_sequence, status; int32 Fx Fy Fz Tx Ty Tz counts

``http://HOST/netftapi2.xml`` gives ``cfgcpf`` (counts per force unit), ``scfgfu`` (the unit)
and ``comrdtrate`` (Hz). A record's time is ``(rdt_sequence - first) / comrdtrate`` (box clock),
the sequence unwrapped modulo 2^32: a jump ``d > 1`` is one gap of ``d - 1`` lost records; a
record going back is one gap and dropped. Non-zero status words are counted (first one kept).
No record for ``timeout`` s: :class:`SensorSilent`. ``normal``/``shear``: a signed axis
("z", "-z", "x", ...), default +Fz and +Fx in the sensor frame.
"""

from __future__ import annotations

import select
import socket
import struct
import time
import xml.etree.ElementTree as ET
from urllib.request import urlopen

import numpy as np

from surfhap.errors import InputError

__all__ = ["NetFT", "SensorError", "SensorSilent", "RDT_PORT", "RECORD", "request"]

RDT_PORT = 49152  # ATI 9620-05-NET FT, RDT section
HEADER, START, STOP = 0x1234, 0x0002, 0x0000
RECORD = np.dtype([("rdt", ">u4"), ("ft", ">u4"), ("status", ">u4"), ("counts", ">i4", (6,))])  # 36 bytes
FORCE_UNITS = {"N": 1.0, "kN": 1e3, "lbf": 4.4482216152605, "kgf": 9.80665, "g": 9.80665e-3}  # unit -> N (SI)
_AXES = {"x": 0, "y": 1, "z": 2}


class SensorError(InputError):
    """The sensor cannot be used (unreachable, bad configuration page): exit 2."""


class SensorSilent(SensorError):
    """No record within the timeout."""


def request(command: int, count: int = 0) -> bytes:
    return struct.pack(">HHI", HEADER, command, count)


def _axis(spec: str, field: str) -> tuple[int, float]:
    s = spec.strip().lower()
    if s.lstrip("+-") not in _AXES:
        raise InputError(f"{spec!r} is not a force axis (x, y, z, optionally signed: -z)", field=field)
    return _AXES[s.lstrip("+-")], -1.0 if s.startswith("-") else 1.0


class NetFT:
    """A :class:`~surfhap.runtime.protocols.ForceSensor`: reads ``netftapi2.xml``, starts the
    stream; :meth:`read` drains the socket. Counts: ``gaps``, ``lost``, ``status_count``.
    ``timeout`` s: for the configuration page and the first record; ``silence`` s (default
    ``timeout``): no record for that long later makes :meth:`read` raise :class:`SensorSilent`
    (``math.inf``: never, the caller handles silence)."""

    def __init__(self, host: str, port: int = RDT_PORT, *, http_port: int = 80, normal: str = "z", shear: str = "x",
                 timeout: float = 1.0, silence: float | None = None):
        self.name = f"netft://{host}:{port}"
        self._normal, self._shear = _axis(normal, "normal"), _axis(shear, "shear")
        self.timeout = float(timeout)
        self.silence = self.timeout if silence is None else float(silence)
        self.rate, self.scale = self._config(host, http_port)
        self.gaps = self.lost = self.status_count = 0
        self.first_status: int | None = None
        self._first: int | None = None
        self._last = 0  # unwrapped sequence of the last record kept
        self._sock = socket.socket(socket.AF_INET6 if ":" in host else socket.AF_INET, socket.SOCK_DGRAM)
        why = f"no record within {self.timeout:g} s of the start request: box silent or unreachable"
        try:
            self._sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 22)  # capped by the kernel's rmem_max
            self._sock.connect((host, port))
            self._sock.setblocking(False)
            self._sock.send(request(START))
            streaming = select.select([self._sock], [], [], self.timeout)[0]
        except OSError as exc:
            streaming, why = [], f"cannot start the RDT stream: {exc.strerror or exc}"
        if not streaming:
            self._sock.close()
            raise SensorSilent(why, source=self.name)
        self._heard = time.monotonic()

    def _config(self, host: str, http_port: int) -> tuple[float, float]:
        url = f"http://{host}:{http_port}/netftapi2.xml"
        try:
            with urlopen(url, timeout=self.timeout) as resp:
                root = ET.fromstring(resp.read())
        except (OSError, ET.ParseError) as exc:
            raise SensorError(f"cannot read the configuration page: {exc}", source=url) from None
        values = {el.tag.lower(): (el.text or "").strip() for el in root.iter()}
        try:
            cpf, rate = float(values["cfgcpf"]), float(values["comrdtrate"])
        except (KeyError, ValueError) as exc:
            raise SensorError(f"missing or not a number: {exc}", source=url, field="cfgcpf/comrdtrate") from None
        unit = values.get("scfgfu", "N")
        if unit not in FORCE_UNITS or not (cpf > 0 and rate > 0):
            raise SensorError(f"force unit {unit!r}, cfgcpf {cpf:g}, comrdtrate {rate:g} Hz: need a unit of "
                              f"{', '.join(FORCE_UNITS)} and positive numbers", source=url)
        return rate, FORCE_UNITS[unit] / cpf

    def _drain(self) -> np.ndarray:
        got = []
        while True:
            try:
                got.append(self._sock.recv(64))
            except BlockingIOError:
                break
            except OSError as exc:  # ICMP port unreachable on loopback, network down
                raise SensorSilent(f"stream failed: {exc.strerror or exc}", source=self.name) from None
        return np.frombuffer(b"".join(d for d in got if len(d) == RECORD.itemsize), dtype=RECORD)  # others: no record

    def read(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        now = time.monotonic()
        rec = self._drain()
        if rec.size == 0:
            if now - self._heard > self.silence:
                raise SensorSilent(f"no record for {1e3 * (now - self._heard):.0f} ms (timeout "
                                   f"{1e3 * self.silence:.0f} ms): box silent or unreachable", source=self.name)
            return np.zeros(0), np.zeros(0), np.zeros(0)
        self._heard = now
        seq = rec["rdt"].astype(np.int64)
        if self._first is None:
            self._first = self._last = int(seq[0]) - 1
        step = np.diff(np.r_[self._last, seq]) % (1 << 32)
        keep = np.ones(seq.size, bool)
        if np.any((step == 0) | (step >= 1 << 31)):  # a record going back (rare): relative to the last kept
            last = self._last
            for k in range(seq.size):
                d = (int(seq[k]) - last) % (1 << 32)
                keep[k] = 0 < d < 1 << 31
                step[k], last = (d, last + d) if keep[k] else (0, last)
        jumps = step[keep]
        self.gaps += int(np.count_nonzero(jumps > 1) + np.count_nonzero(~keep))
        self.lost += int(np.sum(jumps - 1))
        rec = rec[keep]
        useq = self._last + np.cumsum(jumps)
        if useq.size:
            self._last = int(useq[-1])
        bad = rec["status"][rec["status"] != 0]
        if bad.size:
            self.status_count += bad.size
            self.first_status = self.first_status if self.first_status is not None else int(bad[0])
        c = rec["counts"]
        (i, si), (j, sj) = self._normal, self._shear
        return ((useq - self._first - 1) / self.rate, si * self.scale * c[:, i].astype(float),
                sj * self.scale * c[:, j].astype(float))

    def close(self) -> None:
        try:
            self._sock.send(request(STOP))
        except OSError:
            pass
        self._sock.close()
