"""Force-feedback touchscreen (KinesTouch, paper 004): effects, control law, safety stage, scenes.

Layer: same as :mod:`surfhap.render` (imports signal, models, shape, render; never live or cli).
"""

from surfhap.ff.effects import Attraction, Effect, Idle, Roughness, Shape, Sliding, Stiffness, TickState
from surfhap.ff.engine import FFCounters, FFEngine
from surfhap.ff.fields import ConstantField, Field, GridField, MeshHeightField, RectsField
from surfhap.ff.params import FALCON, DeviceParams

__all__ = [
    "Attraction", "Effect", "Idle", "Roughness", "Shape", "Sliding", "Stiffness", "TickState",
    "FFEngine", "FFCounters", "ConstantField", "Field", "GridField", "MeshHeightField", "RectsField", "FALCON", "DeviceParams",
]
