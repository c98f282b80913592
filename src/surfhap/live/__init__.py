"""surfhap.live: the real-time engine, its backends and touch sources (the pages that feed
it are the web app of :mod:`surfhap.web`).

Importing this package is cheap: the backends (sounddevice, python-osc) are imported only
when used.
"""

from surfhap.live.audit import audit_drive
from surfhap.live.engine import LiveEngine
from surfhap.live.engine_config import EngineConfig
from surfhap.render.kinematics import TouchPredictor
from surfhap.live.queues import CommandQueue, TouchRing

__all__ = ["EngineConfig", "LiveEngine", "audit_drive", "TouchPredictor", "TouchRing", "CommandQueue"]
