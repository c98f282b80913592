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
from surfhap.exchange.mesh import read_mesh
from surfhap.exchange.shape_files import read_calibration, write_calibration, write_shape
from surfhap.exchange.trajectory_csv import read_trajectory_csv, write_trajectory_csv
from surfhap.models.friction import CoulombLaw, QuasiStaticLaw
from surfhap.models.material import Material, MaterialFile
from surfhap.models.texture import ARModel, TextureBank
from surfhap.render.chain import ChainConfig, TextureChain
from surfhap.render.drive import METHODS, DriveParams
from surfhap.render.grains import DeviceCurve, GrainParams
from surfhap.render.offline import RenderResult, render
from surfhap.render.safety import SafetyLimits, SafetyStage
from surfhap.render.shape_renderer import ShapeConfig, ShapeResult, render_shape
from surfhap.shape import (
    ScanPlan,
    ShapeCalibration,
    TopHits,
    TopSurface,
    all_scenes,
    builtin_shape,
    calibrate,
    formative_profile,
    get_scene,
    heightmap_surface,
    straight_scan,
)
from surfhap.sim.display import DisplayModel, SimulatedDisplay
from surfhap.sim.electrostatics import ElectrostaticStack, electrostatic_constant
from surfhap.sim.trajectory import Trajectory, constant_scan, strokes

__version__ = "0.1.0"

# Heavier corners (fitting pulls in scipy.optimize) load on first use.
_LAZY = {
    "Recording": "surfhap.exchange.recordings",
    "read_recording": "surfhap.exchange.recordings",
    "read_recordings": "surfhap.exchange.recordings",
    "read_hatt_xml": "surfhap.exchange.hatt",
    "write_hatt_xml": "surfhap.exchange.hatt",
    "import_hatt_folder": "surfhap.exchange.hatt",
    "FrictionFit": "surfhap.fit.material_fit",
    "fit_friction": "surfhap.fit.material_fit",
    "AccelFit": "surfhap.fit.accel",
    "fit_accel": "surfhap.fit.accel",
    "InterpolatedARMABank": "surfhap.models.interpolated",
}


def __getattr__(name: str):
    if name in _LAZY:
        from importlib import import_module

        value = getattr(import_module(_LAZY[name]), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'surfhap' has no attribute {name!r}")


def __dir__():
    return sorted(set(globals()) | set(_LAZY))

__all__ = [
    "AccelFit",
    "all_scenes",
    "ARModel",
    "builtin_names",
    "builtin_shape",
    "calibrate",
    "ChainConfig",
    "ConfigError",
    "constant_scan",
    "CoulombLaw",
    "DeviceCurve",
    "DisplayModel",
    "DriveParams",
    "electrostatic_constant",
    "ElectrostaticStack",
    "fit_accel",
    "fit_friction",
    "formative_profile",
    "FrictionFit",
    "get_scene",
    "GrainParams",
    "heightmap_surface",
    "import_hatt_folder",
    "InputError",
    "InterpolatedARMABank",
    "load_material",
    "Material",
    "MaterialFile",
    "MaterialFormatError",
    "MeshFormatError",
    "METHODS",
    "QuasiStaticLaw",
    "read_calibration",
    "read_hatt_xml",
    "read_material_json",
    "read_mesh",
    "read_recording",
    "read_recordings",
    "read_trajectory_csv",
    "Recording",
    "RecordingFormatError",
    "render",
    "render_shape",
    "RenderResult",
    "SafetyLimits",
    "SafetyStage",
    "ScanPlan",
    "ShapeCalibration",
    "ShapeConfig",
    "ShapeResult",
    "SimulatedDisplay",
    "straight_scan",
    "strokes",
    "SurfhapError",
    "TextureBank",
    "TextureChain",
    "TopHits",
    "TopSurface",
    "Trajectory",
    "TrajectoryFormatError",
    "UnknownMaterialError",
    "write_calibration",
    "write_hatt_xml",
    "write_material_json",
    "write_render",
    "write_shape",
    "write_trajectory_csv",
]
