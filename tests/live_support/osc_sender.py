"""A separate OSC client process: sends a touch stroke, some hostile datagrams, then a lift.

usage: osc_sender.py PORT SECONDS
"""

import socket
import sys
import time

from pythonosc.udp_client import SimpleUDPClient


def main(port: int, seconds: float) -> None:
    c = SimpleUDPClient("127.0.0.1", port)
    raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    t0 = time.perf_counter()
    i = 0
    while time.perf_counter() - t0 < seconds:  # bounded
        t = time.perf_counter() - t0
        u = 0.2 + 0.6 * abs(((t * 2.0) % 2.0) - 1.0)
        c.send_message("/surfhap/touch/norm", [u, 0.5, 0.6])
        if i % 20 == 5:  # hostile traffic mixed in
            c.send_message("/surfhap/touch", [float("nan"), 0.0])
            c.send_message("/surfhap/unknown", [1, 2])
            c.send_message("/surfhap/touch/norm", ["0.5", 0.5])
            raw.sendto(b"\x00garbage-not-osc", ("127.0.0.1", port))
            raw.sendto(b"/surfhap/touch\x00\x00" + b"x" * 2000, ("127.0.0.1", port))
        i += 1
        time.sleep(0.004)
    c.send_message("/surfhap/lift", [])
    print(i)


if __name__ == "__main__":
    main(int(sys.argv[1]), float(sys.argv[2]))
