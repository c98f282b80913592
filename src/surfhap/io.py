"""``sh.io``: every file surfhap reads or writes, readers beside writers.

Materials (JSON, HaTT XML), recordings, trajectories, meshes, display files, renders,
shape results and calibrations, tribometer recordings. Each reader raises an
:class:`~surfhap.errors.InputError` naming the file and the field on bad input. Loaded on
first use (the formats themselves live in :mod:`surfhap.exchange`).
"""

from surfhap._lazy import lazy_names

_MODULES = {
    "surfhap.exchange.materials": ("builtin_names", "load_material"),
    "surfhap.exchange.material_json": ("read_material_json", "write_material_json"),
    "surfhap.exchange.hatt": ("import_hatt_folder", "read_hatt_xml", "write_hatt_xml"),
    "surfhap.exchange.recordings": ("read_recording", "read_recordings", "Recording"),
    "surfhap.exchange.trajectory_csv": ("read_trajectory_csv", "write_trajectory_csv"),
    "surfhap.exchange.mesh": ("read_mesh",),
    "surfhap.exchange.display_file": ("load_display", "read_display_json"),
    "surfhap.exchange.render_store": ("read_render",),
    "surfhap.exchange.render_files": ("write_render",),
    "surfhap.exchange.shape_files": ("read_calibration", "write_calibration", "write_shape"),
    "surfhap.exchange.tribometer": ("read_tribometer",),
}
__all__ = sorted(name for names in _MODULES.values() for name in names)
__getattr__, __dir__ = lazy_names(__name__, _MODULES, globals())
