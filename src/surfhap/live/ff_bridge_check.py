"""Test a running force-feedback bridge against the OSC bridge contract (``surfhap ff bridge-check``).

The check plays the host: it sends ``/surfhap/ff/force`` at 1 kHz to the bridge with its own
session token and listens for ``/surfhap/ff/position`` on ``listen`` (where the bridge is
configured to send them, as for ``ff run --device-listen``). Rows, in order:

=========  ======================================================================
reply      positions arrive from the bridge's own address, in the contract's format,
           with the check's session token
rate       >= 500 positions/s over 0.5 s
sequence   position numbers strictly increasing; a stale force (lower number) sent
           after a newer one is ignored
units      positions finite and within +-0.1 m of X0 (metres, not mm)
axes       a force along x, y and z is reported applied on that axis alone, with its sign
nonfinite  a force of NaN is applied as zero
clamp      (only with ``full_scale``) +-1e6 device units are applied clamped to ``limit``
watchdog   after the last force message the applied force is zero within 20 ms and
           positions keep coming (``trials`` times, the worst counts)
=========  ======================================================================

The forces stay small (``force`` N x gain, 0.1-4 N). The clamp row drives the device at the
bridge's full limit for 30 ms, so it runs only when asked (``full_scale``, ``--clamp``): run
it with the device free, nothing held on it. Timing is measured where the
positions arrive; ``tolerance`` (s) is added to the 20 ms for the delivery on a busy host.
"""

from __future__ import annotations

import math
from collections import namedtuple
from dataclasses import dataclass
from typing import Annotated

from pydantic import Field

from surfhap.checked import checked_dataclass
from surfhap.runtime.clock import now, sleep_until
from surfhap.live.ff_bridge_wire import (BRIDGE_WATCHDOG_S, MIN_POSITION_RATE_HZ, PositionReceiver, encode_force,
                                         new_token)

__all__ = ["CheckRow", "BridgeSettings", "BridgeCheck"]

UNITS_BOUND_M = 0.1  # a position further than this from X0 is not metres of a desk device


@dataclass(frozen=True)
class CheckRow:
    name: str
    passed: bool
    detail: str


_Received = namedtuple("_Received", "t seq p a")  # arrival s, sequence number, position m, applied force


@checked_dataclass
class BridgeSettings:
    """What :class:`BridgeCheck` sends and how it judges.

    gain        : device units per N (4.5, a Falcon through CHAI3D).
    limit       : device units, the largest applied force per axis the bridge may report.
    force       : N, the force used for the axes and watchdog rows.
    tolerance_ms: ms, added to the 20 ms watchdog for delivery delays.
    trials      : watchdog trials; the worst counts.
    full_scale  : also run the clamp row (30 ms at the bridge's full limit: the device free).
    """

    gain: Annotated[float, Field(gt=0.1, le=1000.0)] = 4.5
    limit: Annotated[float, Field(gt=0.0, le=1e5)] = 36.0
    force: Annotated[float, Field(ge=0.1, le=4.0)] = 1.0
    tolerance_ms: Annotated[float, Field(ge=0.0, le=1000.0)] = 5.0
    trials: Annotated[int, Field(ge=1, le=20)] = 3
    full_scale: bool = False


class BridgeCheck:
    """One check run against the bridge at ``host:port`` (positions expected on ``listen``,
    with the session ``token``); :meth:`run` returns the rows."""

    def __init__(self, host: str, port: int, settings: BridgeSettings = BridgeSettings(),
                 listen: tuple = ("127.0.0.1", 9101), token: int | None = None):
        self.host, self.port, self.listen, self.settings = host, port, listen, settings
        self.token = new_token() if token is None else int(token)
        self.tolerance = settings.tolerance_ms * 1e-3
        self._seq = 0
        self.receiver = PositionReceiver(host, port, listen, self.token)
        self.log: list[_Received] = []

    # --------------------------------------------------------------- wire
    def _send(self, f, seq: int | None = None) -> None:
        if seq is None:
            seq, self._seq = self._seq, self._seq + 1
        try:
            self.receiver.sock.sendto(encode_force(self.token, seq, *f), (self.host, self.port))
        except OSError:
            pass

    def _drain(self) -> None:
        rx = self.receiver
        while True:
            try:
                data, addr = rx.sock.recvfrom(1024)
            except OSError:  # nothing more (non-blocking), or the socket failed
                return
            t = now()
            msg = rx.accept(data, addr)
            if msg is not None:
                self.log.append(_Received(t, msg[1], tuple(msg[2:5]), tuple(msg[5:8])))

    def _stream(self, f, seconds: float, min_positions: int = 0, max_seconds: float = 0.5) -> tuple[int, float]:
        """Send ``f`` every ms for ``seconds`` and on (up to ``max_seconds``) until
        ``min_positions`` positions have come back (a bridge delayed by a busy host is not
        judged on an empty window); returns (index of the first position received from now
        on, time of the last force sent)."""
        start = len(self.log)
        t0 = now()
        k = 0
        t = t0
        while t - t0 < seconds or (len(self.log) - start < min_positions and t - t0 < max_seconds):
            self._send(f)
            self._drain()
            k += 1
            t = sleep_until(t0 + k * 1e-3)
        self._drain()
        return start, t0 + (k - 1) * 1e-3

    def _listen(self, seconds: float) -> None:
        end = now() + seconds
        while now() < end:
            self._drain()
            sleep_until(now() + 5e-4)
        self._drain()

    # --------------------------------------------------------------- rows
    def run(self) -> list[CheckRow]:
        self.receiver.open(0.0)
        try:
            return self._rows()
        finally:
            self._send((0.0, 0.0, 0.0))
            self.receiver.close()

    def _rows(self) -> list[CheckRow]:
        rows = []
        self._stream((0.0, 0.0, 0.0), 0.5)
        got = list(self.log)
        rx = self.receiver
        if not got:
            counts = ((rx.dropped_token, "with a wrong token"), (rx.rejected, "malformed"),
                      (rx.dropped_sender, f"from another address than {self.host}:{self.port}"))
            why = ", ".join(f"{n} {what}" for n, what in counts if n)
            rows.append(CheckRow("reply", False, f"no valid position in 0.5 s on {self.listen[0]}:{self.listen[1]} "
                                 f"({why or 'nothing received'}); nothing else can be checked"))
            return rows
        rows.append(CheckRow("reply", not (rx.dropped_sender or rx.rejected or rx.dropped_token),
                             f"{len(got)} positions; {rx.dropped_sender} from another address, {rx.rejected} malformed, "
                             f"{rx.dropped_token} with a wrong token"))
        gaps = [b.t - a.t for a, b in zip(got, got[1:])]
        span = got[-1].t - got[0].t
        rate = (len(got) - 1) / span if span > 0 else 0.0
        rows.append(CheckRow("rate", rate >= MIN_POSITION_RATE_HZ,
                             f"{rate:.0f} positions/s (>= {MIN_POSITION_RATE_HZ:.0f}), largest gap "
                             f"{max(gaps, default=math.inf) * 1e3:.1f} ms"))
        rows.append(self._sequence_row())
        far = max(max(abs(v) for v in r.p) for r in self.log)
        rows.append(CheckRow("units", far <= UNITS_BOUND_M,
                             f"largest |position| {far * 1e3:.1f} mm (<= {UNITS_BOUND_M * 1e3:.0f} mm: metres "
                             "relative to X0)"))
        rows.append(self._axes_row())
        rows.append(self._nonfinite_row())
        if self.settings.full_scale:
            rows.append(self._clamp_row())
        rows.append(self._watchdog_row())
        return rows

    def _sequence_row(self) -> CheckRow:
        back = sum(1 for a, b in zip(self.log, self.log[1:]) if b.seq <= a.seq)
        f = self.settings.force * self.settings.gain
        seen = []
        for _ in range(5):  # until positions come back within the 12 ms (a busy host may delay them)
            start, t_last = self._stream((f, 0.0, 0.0), 0.05, min_positions=5)
            self._send((-f, 0.0, 0.0), seq=self._seq - 2)  # older than the last one sent: must be ignored
            self._listen(0.012)  # < 20 ms: the bridge still applies the newest force
            seen = [r.a for r in self.log[start:] if r.t >= t_last]
            if seen:
                break
        stale = sum(1 for a in seen if a[0] < 0.0)
        ok = back == 0 and stale == 0 and bool(seen)
        detail = (f"{back} positions not above the previous number; stale force applied in {stale} of "
                  f"{len(seen)} positions")
        self._stream((0.0, 0.0, 0.0), 0.03)
        return CheckRow("sequence", ok, detail)

    def _axes_row(self) -> CheckRow:
        f = self.settings.force * self.settings.gain
        bad = []
        for i, axis in enumerate("xyz"):
            cmd = [0.0, 0.0, 0.0]
            cmd[i] = f
            start, _ = self._stream(tuple(cmd), 0.06, min_positions=10)
            seen = [r.a for r in self.log[start:]]
            tol = 0.05 * f + 1e-6
            hits = [k for k, a in enumerate(seen) if all(abs(a[j] - cmd[j]) <= tol for j in range(3))]
            hit = bool(hits)
            # once applied (earlier positions may still show the previous command), never off-axis
            off = [a for a in seen[hits[0]:] if any(abs(a[j]) > tol for j in range(3) if j != i)
                   or a[i] < -tol] if hits else []
            if not hit or off:
                shown = (off or seen or [None])[-1]
                bad.append(f"{axis}: sent {tuple(round(c, 3) for c in cmd)}, applied "
                           f"{None if shown is None else tuple(round(v, 3) for v in shown)}")
        self._stream((0.0, 0.0, 0.0), 0.03)
        return CheckRow("axes", not bad, "; ".join(bad) if bad else f"{f:.2f} device units along x, y, z applied "
                        "on that axis alone")

    def _nonfinite_row(self) -> CheckRow:
        m0 = self.receiver.rejected
        start, _ = self._stream((math.nan, math.nan, math.nan), 0.03, min_positions=5)
        seen = [r.a for r in self.log[start:]]
        ok = bool(seen) and all(v == 0.0 for v in seen[-1]) and self.receiver.rejected == m0
        self._stream((0.0, 0.0, 0.0), 0.03)
        return CheckRow("nonfinite", ok, f"NaN applied as {'zero' if ok else 'non-zero or not reported'}")

    def _clamp_row(self) -> CheckRow:
        big = 1e6
        start, _ = self._stream((big, -big, big), 0.03, min_positions=5, max_seconds=0.2)
        seen = [r.a for r in self.log[start:]]
        peak = max((max(abs(v) for v in a) for a in seen), default=math.nan)
        self._stream((0.0, 0.0, 0.0), 0.03)
        ok = bool(seen) and peak <= self.settings.limit * (1 + 1e-6)
        return CheckRow("clamp", ok, f"+-1e6 applied as at most {peak:.2f} (limit {self.settings.limit:g})")

    def _watchdog_row(self) -> CheckRow:
        f = self.settings.force * self.settings.gain
        bound = BRIDGE_WATCHDOG_S + self.tolerance
        worst, fails = 0.0, []
        for _ in range(max(1, self.settings.trials)):
            start, t_last = self._stream((0.0, 0.0, f), 0.1, min_positions=10)
            self._listen(bound + 0.15)
            after = [r for r in self.log[start:] if r.t > t_last]
            if not after:
                fails.append("no positions during the silence (the bridge must keep reporting)")
                continue
            last_nonzero = max((r.t for r in after if any(v != 0.0 for v in r.a)), default=None)
            if last_nonzero is not None and last_nonzero >= after[-1].t:
                fails.append(f"still applying {max(abs(v) for v in after[-1].a):.2f} device units "
                             f"{(after[-1].t - t_last) * 1e3:.0f} ms after the last force")
                continue
            zero_at = 0.0 if last_nonzero is None else last_nonzero - t_last
            worst = max(worst, zero_at)
        ok = not fails and worst <= bound
        detail = fails[0] if fails else (f"zero force {worst * 1e3:.1f} ms after the last force message "
                                         f"(<= {BRIDGE_WATCHDOG_S * 1e3:.0f} + {self.tolerance * 1e3:.0f} ms)")
        return CheckRow("watchdog", ok, detail)
