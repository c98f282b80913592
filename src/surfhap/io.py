"""``sh.io``: every file surfhap reads or writes, readers beside writers.

Materials (JSON, HaTT XML), recordings, trajectories, meshes, display files, renders,
shape results and calibrations, tribometer recordings. Each reader raises an
:class:`~surfhap.errors.InputError` naming the file and the field on bad input. Loaded on
first use (the formats themselves live in :mod:`surfhap.exchange`).
"""

from surfhap import _LAZY_MODULES
from surfhap._lazy import lazy_names

_MODULES = {module: names for module, names in _LAZY_MODULES.items() if module.startswith("surfhap.exchange.")}
__all__ = sorted(name for names in _MODULES.values() for name in names)
__getattr__, __dir__ = lazy_names(__name__, _MODULES, globals())
