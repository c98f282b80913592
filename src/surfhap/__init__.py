"""surfhap: make flat touchscreens feel like materials and shapes.

Public API (see the README for a tour)::

    import surfhap as sh
    cork = sh.load_material("cork")
    result = sh.texture.render(cork, sh.constant_scan(speed=0.1, load=0.5, duration=5.0))
    result.plot()

Plotting and file I/O are separate calls (``result.plot()``, ``sh.io.write_render``).

Namespaces: ``sh.texture`` (render materials: the texture pipeline), ``sh.shape`` (3-D shapes),
``sh.ff`` (force feedback), ``sh.lab`` (calibration, studies, staircases) and ``sh.io`` (every
file format, readers beside writers). The most used names are also at the top level. No
public name shadows a subpackage: the texture renderer is ``sh.texture.render``, and
``sh.render`` is the package :mod:`surfhap.render`.

``import surfhap`` is cheap: every public name except the exceptions is loaded from its
module on first use (numba, scipy, trimesh and matplotlib are imported only when a name
that needs them is touched), so the command line starts quickly.
"""

from __future__ import annotations

from importlib import import_module as _import_module

from surfhap._lazy import lazy_names as _lazy_names

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
    # the file formats (surfhap.exchange): sh.io lists these entries
    "surfhap.exchange.display_file": ("load_display", "read_display_json"),
    "surfhap.exchange.hatt": ("import_hatt_folder", "read_hatt_xml", "write_hatt_xml"),
    "surfhap.exchange.material_json": ("read_material_json", "write_material_json"),
    "surfhap.exchange.materials": ("builtin_names", "load_material"),
    "surfhap.exchange.mesh": ("read_mesh",),
    "surfhap.exchange.recordings": ("read_recording", "read_recordings", "Recording"),
    "surfhap.exchange.render_files": ("write_render",),
    "surfhap.exchange.render_store": ("read_render",),
    "surfhap.exchange.shape_files": ("read_calibration", "write_calibration", "write_shape"),
    "surfhap.exchange.trajectory_csv": ("read_trajectory_csv", "write_trajectory_csv"),
    "surfhap.exchange.tribometer": ("read_tribometer",),
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
    "surfhap.render.grains": ("GrainParams",),
    "surfhap.models.device_curve": ("DeviceCurve",),
    "surfhap.render.offline": ("RenderResult",),
    "surfhap.render.safety": ("SafetyLimits", "SafetyStage"),
    "surfhap.render.shape_chain": ("render_shape",),
    "surfhap.render.shape_renderer": ("ShapeConfig", "ShapeResult"),
    "surfhap.shape": ("all_scenes", "builtin_shape", "calibrate", "formative_profile", "get_scene",
                      "heightmap_surface", "ScanPlan", "ShapeCalibration", "straight_scan", "TopHits",
                      "TopSurface"),
    "surfhap.models.panel": ("DisplayModel", "SimulatedDisplay"),
    "surfhap.models.electrostatics": ("electrostatic_constant", "ElectrostaticStack"),
    "surfhap.models.trajectory": ("constant_scan", "strokes", "Trajectory"),
    "surfhap.lab.calibration": ("calibrate_display",),
    "surfhap.lab.staircase": ("Staircase", "StaircaseParams"),
    "surfhap.lab.designs": ("build_study", "study_template"),
    "surfhap.lab.analyze_study": ("analyze_study",),
    "surfhap.lab.compare": ("compare_materials",),
    "surfhap.ff.engine": ("FFEngine",),
    "surfhap.ff.params": ("DeviceParams",),
    "surfhap.ff.scene": ("load_ff_scene",),
    "surfhap.live.ff_loop": ("simulate_ff",),
    "surfhap.sim.ff_device": ("SimDevice", "SimFinger"),
}
# the namespaces (subpackages and facade modules), imported on first attribute access
_NAMESPACES = ("texture", "io", "shape", "ff", "lab", "fit")
_lazy_getattr, _lazy_dir = _lazy_names(__name__, _LAZY_MODULES, globals())


def __getattr__(name: str):
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            value = version("surfhap")
        except PackageNotFoundError:  # a source tree on sys.path that was never installed
            value = "0+unknown"
        globals()[name] = value
        return value
    if name in _NAMESPACES:
        return _import_module(f"{__name__}.{name}")
    return _lazy_getattr(name)


def __dir__():
    return sorted(set(_lazy_dir()) | set(_NAMESPACES) | {"__version__"})


#: the exceptions imported above and every lazy name
__all__ = sorted({name for name, value in list(globals().items())
                  if isinstance(value, type) and issubclass(value, SurfhapError)}
                 | {name for names in _LAZY_MODULES.values() for name in names})
