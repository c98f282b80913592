"""A loopback ATI Net F/T box for tests and the RDT benchmark: the real RDT protocol byte for byte.

* UDP (RDT, ATI 9620-05-NET FT): waits for 8-byte requests ``>HHI`` = (0x1234, command,
  count); command 0x0002 starts streaming 36-byte ``>IIIiiiiii`` records (rdt_sequence,
  ft_sequence, status, Fx Fy Fz Tx Ty Tz counts) to the requester at ``rate`` Hz, ``count``
  records (0 = endless); 0x0000 stops. A request with another header is ignored.
* HTTP: ``/netftapi2.xml`` with ``cfgcpf``, ``cfgcpt``, ``scfgfu``, ``scfgtu``, ``comrdtrate``.

Faults: ``seq0`` (first rdt_sequence, e.g. 2**32 - 3 to wrap), ``drop`` (record indices
never sent; their sequence numbers are skipped), ``status`` ({index: word}), ``silent_after``
(stop sending after that many records while still running). ``forces(t)`` gives the six
values (N, N m) of the record at box time ``t`` s (default: a fixed load); the stream started at
``t0`` (``time.perf_counter``), so a record sent late still carries the values of its own time.

Run alone (the benchmark): ``python netft_box.py --rate 7000`` prints ``UDP_PORT HTTP_PORT``;
``--forces FX,FY,FZ,TX,TY,TZ`` (fixed values) and ``--silent-after N`` as above. When its stdin
closes it takes the requests still queued, prints them (``requests HEX ...``) and ends.
:class:`NetFTBoxProcess` runs it so, its sender thread at real-time priority where the OS
grants it (``--realtime``): the box then keeps its own pace beside a test that loads its own
process (its threads, the cyclic collector) and a loaded machine, as a real box does.
"""

from __future__ import annotations

import argparse
import os
import socket
import struct
import subprocess
import sys
import threading
import time
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

CPF, CPT = 1_000_000, 1_000_000  # counts per N and per N m of this box (any positive integer: the client reads them)
XML = ("<?xml version=\"1.0\"?><netft><cfgcpf>{cpf}</cfgcpf><cfgcpt>{cpt}</cfgcpt><scfgfu>{fu}</scfgfu>"
       "<scfgtu>N-m</scfgtu><comrdtrate>{rate}</comrdtrate><comrdte>Enabled</comrdte></netft>")


class NetFTBox:
    def __init__(self, rate: float = 1000.0, *, seq0: int = 0, drop=(), status=None, silent_after: int | None = None,
                 forces=None, cpf: int = CPF, force_unit: str = "N", host: str = "127.0.0.1", realtime: bool = False):
        self.rate, self.seq0, self.drop = float(rate), int(seq0), set(drop)
        self.status, self.silent_after = dict(status or {}), silent_after
        self.forces = forces or (lambda t: (0.2, 0.0, 4.6, 0.0, 0.0, 0.0))
        self.cpf, self.force_unit, self.realtime = cpf, force_unit, realtime
        self.requests: list[bytes] = []
        self.sent, self.t0 = 0, 0.0
        self.udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.udp.bind((host, 0))
        self.udp.settimeout(0.05)
        self.port = self.udp.getsockname()[1]
        box = self

        class Handler(BaseHTTPRequestHandler):
            def do_GET(self):
                body = XML.format(cpf=box.cpf, cpt=CPT, fu=box.force_unit, rate=f"{box.rate:g}").encode()
                code = 200 if self.path == "/netftapi2.xml" else 404
                self.send_response(code)
                self.send_header("Content-Type", "text/xml")
                self.send_header("Content-Length", str(len(body)))
                self.end_headers()
                self.wfile.write(body)

            def log_message(self, *args):
                pass

        self.http = ThreadingHTTPServer((host, 0), Handler)
        self.http_port = self.http.server_address[1]
        self.address = f"netft://{host}:{self.port}?http={self.http_port}"
        self._run = True
        self._stream: tuple | None = None  # (peer, count)
        self._threads = [threading.Thread(target=self.http.serve_forever, daemon=True),
                         threading.Thread(target=self._loop, daemon=True)]

    def __enter__(self) -> "NetFTBox":
        for t in self._threads:
            t.start()
        return self

    def __exit__(self, *exc) -> None:
        self._run = False
        self.http.shutdown()
        self.http.server_close()
        self._threads[1].join(2.0)
        self.udp.close()

    def record(self, i: int, t: float) -> bytes:
        f = self.forces(t)
        counts = [int(round(v * (self.cpf if k < 3 else CPT))) for k, v in enumerate(f)]
        return struct.pack(">IIIiiiiii", (self.seq0 + i) % (1 << 32), (self.seq0 + i) % (1 << 32),
                           self.status.get(i, 0), *counts)

    def _loop(self) -> None:
        if self.realtime:  # a box is its own hardware: its sender keeps pace beside a loaded machine
            try:
                os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(20))  # this thread (Linux; root or CAP_SYS_NICE)
            except (AttributeError, OSError):
                pass  # not granted: normal priority
        i, t0 = 0, 0.0
        while self._run:
            try:
                data, peer = self.udp.recvfrom(64)
                if len(data) == 8:
                    header, cmd, count = struct.unpack(">HHI", data)
                    if header == 0x1234:
                        self.requests.append(data)
                        if cmd == 0x0002:
                            self._stream, i, t0 = (peer, count), 0, time.perf_counter()
                            self.t0 = t0
                        elif cmd == 0x0000:
                            self._stream = None
            except (socket.timeout, BlockingIOError):
                pass
            except OSError:
                return
            if self._stream is None:
                continue
            self.udp.settimeout(0.0005)  # streaming: poll requests between bursts
            due = int((time.perf_counter() - t0) * self.rate) + 1
            peer, count = self._stream
            while i < due and (not count or i < count):
                if (self.silent_after is None or i < self.silent_after) and i not in self.drop:
                    try:
                        self.udp.sendto(self.record(i, i / self.rate), peer)
                        self.sent += 1
                    except OSError:
                        pass
                i += 1


    def take_queued(self) -> None:
        """Record the requests still queued on the socket (after the loop has stopped)."""
        self.udp.setblocking(False)
        while True:
            try:
                data = self.udp.recv(64)
            except OSError:
                return
            if len(data) == 8 and struct.unpack(">HHI", data)[0] == 0x1234:
                self.requests.append(data)


class NetFTBoxProcess:
    """:class:`NetFTBox` with fixed ``forces`` in its own process: ``address``, ``port`` while
    it runs; ``requests`` (as NetFTBox's) once the ``with`` block has ended."""

    GUARD = 120.0  # s, failure guard of the start and the end (a loaded machine)

    def __init__(self, rate: float = 1000.0, *, forces=(0.2, 0.0, 4.6, 0.0, 0.0, 0.0), silent_after: int | None = None):
        self.args = [sys.executable, __file__, "--rate", f"{rate:g}", "--forces", ",".join(f"{v!r}" for v in forces),
                     "--realtime"]
        self.args += [] if silent_after is None else ["--silent-after", str(silent_after)]
        self.requests: list[bytes] = []

    def __enter__(self) -> "NetFTBoxProcess":
        self.proc = subprocess.Popen(self.args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        line = self.proc.stdout.readline().split()  # once it listens (EOF: it failed, the error is on stderr)
        if len(line) != 2:
            self.proc.kill()
            raise RuntimeError("the Net F/T box process did not start")
        self.port, self.http_port = int(line[0]), int(line[1])
        self.address = f"netft://127.0.0.1:{self.port}?http={self.http_port}"
        return self

    def __exit__(self, *exc) -> None:
        try:
            out, _ = self.proc.communicate("", timeout=self.GUARD)  # closes its stdin: it ends
        finally:
            if self.proc.poll() is None:
                self.proc.kill()
                self.proc.wait()
        words = next((ln.split()[1:] for ln in out.splitlines() if ln.startswith("requests")), [])
        self.requests = [bytes.fromhex(w) for w in words]


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--rate", type=float, default=7000.0)
    ap.add_argument("--forces", default=None)
    ap.add_argument("--silent-after", type=int, default=None)
    ap.add_argument("--realtime", action="store_true", help="the sender thread at SCHED_FIFO where granted")
    args = ap.parse_args()
    fixed = None if args.forces is None else tuple(float(v) for v in args.forces.split(","))
    box = NetFTBox(args.rate, forces=None if fixed is None else (lambda t: fixed), silent_after=args.silent_after,
                   realtime=args.realtime)
    with box:
        print(box.port, box.http_port, flush=True)
        sys.stdin.read()  # until the parent closes our stdin
        box._run = False
        box._threads[1].join(2.0)
        box.take_queued()  # a stop request sent just before the parent closed our stdin
        print("requests", *(r.hex() for r in box.requests), flush=True)
