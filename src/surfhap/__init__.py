"""surfhap: make flat touchscreens feel like materials and shapes.

Public API (see the README for a tour)::

    import surfhap as sh
    cork = sh.load_material("cork")
    result = sh.render(cork, sh.constant_scan(speed=0.1, load=0.5, duration=5.0))
    result.plot()

Plotting and file I/O are separate calls (``result.plot()``, ``sh.write_render``).
"""

from surfhap.errors import (
    ConfigError,
    InputError,
    MaterialFormatError,
    MeshFormatError,
    RecordingFormatError,
    SurfhapError,
    TrajectoryFormatError,
    UnknownMaterialError,
)
from surfhap.exchange.materials import builtin_names, load_material, read_material_json, write_material_json
from surfhap.exchange.render_files import write_render
from surfhap.exchange.trajectory_csv import read_trajectory_csv, write_trajectory_csv
from surfhap.models.friction import CoulombLaw, QuasiStaticLaw
from surfhap.models.material import Material, MaterialFile
from surfhap.models.texture import ARModel, TextureBank
from surfhap.render.chain import ChainConfig, TextureChain
from surfhap.render.drive import METHODS, DriveParams
from surfhap.render.offline import RenderResult, render
from surfhap.render.safety import SafetyLimits, SafetyStage
from surfhap.sim.display import DisplayModel, SimulatedDisplay
from surfhap.sim.electrostatics import ElectrostaticStack, electrostatic_constant
from surfhap.sim.trajectory import Trajectory, constant_scan, strokes

__version__ = "0.1.0"

__all__ = [
    "ARModel",
    "ChainConfig",
    "ConfigError",
    "CoulombLaw",
    "DisplayModel",
    "DriveParams",
    "ElectrostaticStack",
    "InputError",
    "METHODS",
    "Material",
    "MaterialFile",
    "MaterialFormatError",
    "MeshFormatError",
    "QuasiStaticLaw",
    "RecordingFormatError",
    "RenderResult",
    "SafetyLimits",
    "SafetyStage",
    "SimulatedDisplay",
    "SurfhapError",
    "TextureBank",
    "TextureChain",
    "Trajectory",
    "TrajectoryFormatError",
    "UnknownMaterialError",
    "builtin_names",
    "constant_scan",
    "electrostatic_constant",
    "load_material",
    "read_material_json",
    "read_trajectory_csv",
    "render",
    "strokes",
    "write_material_json",
    "write_render",
    "write_trajectory_csv",
]
