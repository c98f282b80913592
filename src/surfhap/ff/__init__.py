"""Force-feedback touchscreen (KinesTouch, paper 004): effects, control law, safety stage, scenes.

Layer: same as :mod:`surfhap.render` (imports signal, models, shape, render; never live or cli).
"""

from surfhap.ff.control import ControlLaw
from surfhap.ff.effects import Attraction, Effect, Idle, Roughness, Shape, Sliding, Stiffness, TickState
from surfhap.ff.engine import FFEngine
from surfhap.ff.fields import ConstantField, Field, GridField, MeshHeightField, RectsField
from surfhap.ff.params import FALCON, DeviceParams
from surfhap.ff.safety import ForceSafety, ForceSafetyCounters

__all__ = [
    "ControlLaw", "Attraction", "Effect", "Idle", "Roughness", "Shape", "Sliding", "Stiffness", "TickState",
    "FFEngine", "ConstantField", "Field", "GridField", "MeshHeightField", "RectsField", "FALCON", "DeviceParams",
    "ForceSafety", "ForceSafetyCounters",
]
