"""A loopback stand-in of the Haply Inverse Service's simulation channel (service 3.5), on a real
WebSocket at 127.0.0.1 (a random port), for the tests of :mod:`surfhap.live.ff_haply`.

It speaks the messages Haply documents ("Simulation Channel",
https://docs.haply.co/inverseSDK/service/api/simulation; "WebSocket Protocol",
https://docs.haply.co/inverseSDK/service/realtime/websocket-protocol; "Control Commands",
https://docs.haply.co/inverseSDK/service/realtime/control-commands): an initial inventory on
connect (``session_id``, ``inverse3`` entries with ``device_id``, ``config``, ``state``, ``status``),
then exactly one state update per message received -- the real service does not stream on its own,
the client's commands set the cadence (so the surfhap loop's 1 kHz is the state rate). It records
every ``set_cursor_force`` vector received, in order.

Knobs (any thread): ``position`` (the cursor, m, service frame) or ``script`` (one position per
reply, the last one held); ``inject`` (raw texts sent instead of the next state updates);
``silent_after`` (answer this many messages, then record but never answer); ``silent`` (an Event,
set once it went silent).
"""

from __future__ import annotations

import collections
import json
import threading

from websockets.exceptions import ConnectionClosed
from websockets.sync.server import serve


def _vec(p) -> dict:
    return {"x": p[0], "y": p[1], "z": p[2]}


class HaplyService:
    def __init__(self, device_id: str = "049D", position=(0.0, -0.12, 0.15)):
        self.device_id = device_id
        self.position = tuple(position)
        self.script: collections.deque = collections.deque()
        self.inject: collections.deque = collections.deque()
        self.silent_after: int | None = None
        self.silent = threading.Event()
        self.forces: list[tuple[float, float, float]] = []  # every set_cursor_force vector, in order
        self.sessions: list[dict] = []  # every "session" part received
        self.messages = 0
        self.connections = 0
        self.finished = 0  # connections whose every message has been handled
        self.changed = threading.Condition()
        self.server = self.thread = None
        self.port = 0

    # ------------------------------------------------------------- the protocol
    def _state(self) -> dict:
        return {"cursor_position": _vec(self.position), "cursor_velocity": _vec((0.0, 0.0, 0.0)),
                "angular_position": {"a0": 0.0, "a1": 0.0, "a2": 0.0},
                "angular_velocity": {"a0": 0.0, "a1": 0.0, "a2": 0.0},
                "body_orientation": {"w": 1.0, "x": 0.0, "y": 0.0, "z": 0.0},
                "current_cursor_force": _vec(self.forces[-1] if self.forces else (0.0, 0.0, 0.0)),
                "control_domain": "cartesian", "control_mode": "force" if self.forces else "idle"}

    def _status(self) -> dict:
        return {"calibrated": True, "in_use": True, "power_supply": True, "ready": True, "started": True}

    def inventory(self) -> str:
        return json.dumps({"session_id": self.connections, "inverse3": [{
            "device_id": self.device_id,
            "config": {"type": "inverse3", "port": "loopback", "handedness": "right", "preset": "defaults",
                       "basis": {"permutation": "XYZ"}, "gravity_compensation": {"enabled": True, "scaling_factor": 1.0},
                       "device_info": {"major_version": 7, "minor_version": 4, "id": self.device_id, "device_type": 4}},
            "state": self._state(), "status": self._status()}], "wireless_verse_grip": []})

    def update(self) -> str:
        if self.script:
            self.position = tuple(self.script.popleft())
        return json.dumps({"session_id": self.connections, "inverse3": [
            {"device_id": self.device_id, "state": self._state(), "status": self._status()}]})

    def _handler(self, ws) -> None:
        self.connections += 1
        try:
            ws.send(self.inventory())
            for raw in ws:
                self._take(json.loads(raw))
                if not self.silent.is_set():
                    try:
                        ws.send(self.inject.popleft() if self.inject else self.update())
                    except ConnectionClosed:  # the client is closing: still take what it sent before
                        pass
        except ConnectionClosed:  # a client that closes without waiting for the close reply
            pass
        finally:
            with self.changed:
                self.finished += 1
                self.changed.notify_all()

    def _take(self, msg: dict) -> None:
        with self.changed:
            for e in msg.get("inverse3", []):
                f = e.get("commands", {}).get("set_cursor_force")
                if f is not None and e.get("device_id") == self.device_id:
                    v = f["vector"]
                    self.forces.append((float(v["x"]), float(v["y"]), float(v["z"])))
            if "session" in msg:
                self.sessions.append(msg["session"])
            self.messages += 1
            if self.silent_after is not None and self.messages > self.silent_after:
                self.silent.set()
            self.changed.notify_all()

    # ------------------------------------------------------------- life cycle
    def start(self) -> "HaplyService":
        self.server = serve(self._handler, "127.0.0.1", 0, compression=None)
        self.port = self.server.socket.getsockname()[1]
        self.thread = threading.Thread(target=self.server.serve_forever, name="haply-service", daemon=True)
        self.thread.start()
        return self

    def stop(self) -> None:
        self.server.shutdown()
        self.thread.join(10.0)

    def wait(self, cond, timeout: float = 30.0) -> bool:
        """Wait until ``cond()`` holds (checked on each message received); False on timeout (a failure guard)."""
        with self.changed:
            return self.changed.wait_for(cond, timeout)

    def wait_closed(self, timeout: float = 60.0) -> bool:
        """Wait until every connection so far has ended and each of its messages was recorded."""
        return self.wait(lambda: self.finished == self.connections, timeout)

    def __enter__(self) -> "HaplyService":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
