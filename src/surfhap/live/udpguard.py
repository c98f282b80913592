"""A UDP listener that a flood from one sender cannot starve: the kernel drops the flood.

A receiver cannot outrun a local sender (one ``recvfrom`` costs what one ``sendto`` does), so
under a flood the socket's queue fills and the kernel drops every sender's datagrams (a touch
stream beside a junk flood lost 553 of 585 touches). :meth:`UdpListener.penalise` binds a
second socket of the listener's ``SO_REUSEPORT`` group to the same address, *connected* to
the offender, with a tiny receive buffer that is never read: Linux delivers a datagram to the
connected socket that matches its source best, so the offender's datagrams are dropped there
while the others keep arriving on the main socket; after ``hold`` s the sender is back (and
its token bucket decides again). The port is first bound without ``SO_REUSEPORT``, so a port
in use fails as before and no other listener can join the group. Elsewhere than Linux,
:meth:`~UdpListener.penalise` does nothing (the token bucket alone drops the flood).
"""

from __future__ import annotations

import socket
import sys

__all__ = ["UdpListener"]

_STEERING = sys.platform.startswith("linux")


class UdpListener:
    """A bound UDP socket (``.sock``, ``.port``) with a penalty box for flooding senders:
    at most ``max_penalised`` penalty sockets (file descriptors) at once, ``hold`` s each."""

    def __init__(self, host: str, port: int, *, rcvbuf: int = 1 << 20, max_penalised: int = 16, hold: float = 1.0):
        self.host = host
        self.family = socket.AF_INET6 if ":" in host else socket.AF_INET
        probe = socket.socket(self.family, socket.SOCK_DGRAM)
        try:  # the port must be free: fails as a plain bind does when it is in use
            probe.bind((host, int(port)))
            self.port = probe.getsockname()[1]
        finally:
            probe.close()
        self.sock = self._socket()
        try:
            try:  # absorb bursts (best effort: the kernel caps it at net.core.rmem_max)
                self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, int(rcvbuf))
            except OSError:
                pass
            self.sock.bind((host, self.port))
        except OSError:
            self.sock.close()
            raise
        self.max_penalised = int(max_penalised)
        self.hold = float(hold)
        self.penalised = 0  # senders put in the penalty box so far
        self._box: dict[tuple, tuple[socket.socket, float]] = {}
        self._next_release = float("inf")

    def _socket(self) -> socket.socket:
        s = socket.socket(self.family, socket.SOCK_DGRAM)
        if _STEERING:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEPORT, 1)
        return s

    def penalise(self, addr: tuple, t: float) -> bool:
        """Have the kernel drop ``addr``'s datagrams until ``t + hold``; False when the box
        is full, the sender is already in it, or the platform cannot steer."""
        key = (addr[0], addr[1])
        if not _STEERING or key in self._box or len(self._box) >= self.max_penalised or self.sock is None:
            return False
        s = self._socket()
        try:
            s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1)  # the kernel's minimum: a few datagrams
            s.bind((self.host, self.port))
            s.connect(addr)
        except OSError:
            s.close()
            return False
        self._box[key] = (s, t + self.hold)
        self._next_release = min(self._next_release, t + self.hold)
        self.penalised += 1
        return True

    def release_due(self, t: float) -> None:
        """Close the penalty sockets whose time is up (cheap when none is)."""
        if t < self._next_release:
            return
        for key, (s, until) in list(self._box.items()):
            if until <= t:
                s.close()
                del self._box[key]
        self._next_release = min((u for _, u in self._box.values()), default=float("inf"))

    @property
    def boxed(self) -> int:
        """Senders in the penalty box now."""
        return len(self._box)

    def close(self) -> None:
        for s, _ in self._box.values():
            s.close()
        self._box.clear()
        if self.sock is not None:
            self.sock.close()
            self.sock = None
