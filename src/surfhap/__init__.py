"""surfhap: make flat touchscreens feel like materials and shapes.

Public API (see the README for a tour)::

    import surfhap as sh
    cork = sh.load_material("cork")
    result = sh.render(cork, sh.constant_scan(speed=0.1, load=0.5, duration=5.0))
    result.plot()

Plotting and file I/O are separate calls (``result.plot()``, ``sh.write_render``).

``import surfhap`` is cheap: every public name except the exceptions is loaded from its
module on first use (numba, scipy, trimesh and matplotlib are imported only when a name
that needs them is touched), so the command line starts quickly.
"""

from __future__ import annotations

import sys as _sys
import types as _types
from importlib import import_module as _import_module

from surfhap.errors import (
    ConfigError,
    StudyFormatError,
    InputError,
    MaterialFormatError,
    MeshFormatError,
    RecordingFormatError,
    SurfhapError,
    TrajectoryFormatError,
    UnknownMaterialError,
)

# public name -> module that defines it, loaded on first attribute access
_LAZY_MODULES = {
    "surfhap.exchange.display_file": ("load_display", "read_display_json"),
    "surfhap.exchange.hatt": ("import_hatt_folder", "read_hatt_xml", "write_hatt_xml"),
    "surfhap.exchange.material_json": ("read_material_json", "write_material_json"),
    "surfhap.exchange.materials": ("builtin_names", "load_material"),
    "surfhap.exchange.mesh": ("read_mesh",),
    "surfhap.exchange.recordings": ("read_recording", "read_recordings", "Recording"),
    "surfhap.exchange.render_files": ("write_render",),
    "surfhap.exchange.shape_files": ("read_calibration", "write_calibration", "write_shape"),
    "surfhap.exchange.trajectory_csv": ("read_trajectory_csv", "write_trajectory_csv"),
    "surfhap.fit.accel": ("AccelFit", "fit_accel"),
    "surfhap.fit.material_fit": ("fit_friction", "FrictionFit"),
    "surfhap.models.friction": ("CoulombLaw", "QuasiStaticLaw"),
    "surfhap.models.interpolated": ("InterpolatedARMABank",),
    "surfhap.models.material": ("Material", "MaterialFile"),
    "surfhap.models.texture": ("ARModel", "TextureBank"),
    "surfhap.render.chain": ("ChainConfig", "TextureChain"),
    "surfhap.render.drive": ("DriveParams", "METHODS"),
    "surfhap.render.fidelity": ("FidelityMetrics", "fidelity_metrics"),
    "surfhap.render.gain_plan": ("GainPlan", "OperatingRange", "plan_gains"),
    "surfhap.render.grains": ("DeviceCurve", "GrainParams"),
    "surfhap.render.offline": ("render", "RenderResult"),
    "surfhap.render.safety": ("SafetyLimits", "SafetyStage"),
    "surfhap.render.shape_chain": ("render_shape",),
    "surfhap.render.shape_renderer": ("ShapeConfig", "ShapeResult"),
    "surfhap.shape": ("all_scenes", "builtin_shape", "calibrate", "formative_profile", "get_scene",
                      "heightmap_surface", "ScanPlan", "ShapeCalibration", "straight_scan", "TopHits",
                      "TopSurface"),
    "surfhap.models.panel": ("DisplayModel", "SimulatedDisplay"),
    "surfhap.models.electrostatics": ("electrostatic_constant", "ElectrostaticStack"),
    "surfhap.models.trajectory": ("constant_scan", "strokes", "Trajectory"),
    "surfhap.exchange.tribometer": ("read_tribometer",),
    "surfhap.lab.calibration": ("calibrate_display",),
    "surfhap.lab.staircase": ("Staircase", "StaircaseParams"),
    "surfhap.lab.designs": ("build_study", "study_template"),
    "surfhap.lab.analyze_study": ("analyze_study",),
    "surfhap.lab.compare": ("compare_materials",),
    "surfhap.ff.engine": ("FFEngine",),
    "surfhap.ff.params": ("DeviceParams",),
    "surfhap.ff.scene": ("load_ff_scene",),
    "surfhap.sim.ff_sim": ("simulate_ff",),
    "surfhap.sim.ff_device": ("SimDevice", "SimFinger"),
}
_LAZY = {name: module for module, names in _LAZY_MODULES.items() for name in names}


def _package_version() -> str:
    """The installed distribution's version (importlib.metadata is slow to import: on demand)."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("surfhap")
    except PackageNotFoundError:  # a source tree on sys.path that was never installed
        return "0+unknown"


def __getattr__(name: str):
    if name == "__version__":
        globals()[name] = value = _package_version()
        return value
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'surfhap' has no attribute {name!r}")
    value = getattr(_import_module(module), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(_LAZY) | {"__version__"})


class _SurfhapModule(_types.ModuleType):
    """``surfhap.render`` is the function :func:`surfhap.render.offline.render`, as it was
    when everything was imported eagerly: importing the subpackage ``surfhap.render`` must
    not rebind the name to the package (the import system sets it on the parent)."""

    def __setattr__(self, name: str, value) -> None:
        if name in _LAZY and isinstance(value, _types.ModuleType):
            return
        super().__setattr__(name, value)


_sys.modules[__name__].__class__ = _SurfhapModule

__all__ = [
    "AccelFit",
    "DeviceParams",
    "FFEngine",
    "load_ff_scene",
    "SimDevice",
    "SimFinger",
    "simulate_ff",
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
    "FidelityMetrics",
    "fidelity_metrics",
    "GainPlan",
    "load_display",
    "OperatingRange",
    "plan_gains",
    "read_display_json",
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
    # lab tools
    "analyze_study",
    "build_study",
    "calibrate_display",
    "compare_materials",
    "read_tribometer",
    "Staircase",
    "StaircaseParams",
    "study_template",
    "StudyFormatError",
]
