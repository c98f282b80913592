"""surfhap.shape: 3-D shapes on an electrovibration display (Kim et al. 2017).

* :class:`TopSurface` — vertical ray casts onto a mesh (highest hit), batch or single;
* :mod:`~surfhap.shape.gradient` — lateral force from consecutive hits, eq. 3-9;
* :mod:`~surfhap.shape.edges` — edge emphasis, eq. 10-11;
* :func:`calibrate` — the Fsq range by simulated scans (Sec. 4.2);
* :mod:`~surfhap.shape.scenes` — Gaussian / frustum bumps and holes, the 20 study scenes;
* :mod:`~surfhap.shape.profiles` — the 1-D profiles of the formative study (IP0.5 / IP0.7);
* :mod:`~surfhap.shape.heightmap` — height maps (arrays, greyscale images) as surfaces.

Rendering (processors, grains, drive) lives in :mod:`surfhap.render.shape_renderer`.
"""

from surfhap.shape.calibration import ScanPlan, ShapeCalibration, calibrate
from surfhap.shape.gradient import intensity_from_fsq, lateral_force, signed_sqrt
from surfhap.shape.heightmap import heightmap_mesh, heightmap_surface, read_heightmap_image
from surfhap.shape.profiles import Profile1D, formative_profile
from surfhap.shape.scan import parse_scan, straight_scan, top_view
from surfhap.shape.scenes import Scene, all_scenes, builtin_shape, builtin_shape_names, frustum_bump, gaussian_bump, get_scene
from surfhap.shape.topsurface import TopHits, TopSurface

__all__ = [
    "Profile1D",
    "ScanPlan",
    "Scene",
    "ShapeCalibration",
    "TopHits",
    "TopSurface",
    "all_scenes",
    "builtin_shape",
    "builtin_shape_names",
    "calibrate",
    "formative_profile",
    "frustum_bump",
    "gaussian_bump",
    "get_scene",
    "heightmap_mesh",
    "heightmap_surface",
    "intensity_from_fsq",
    "lateral_force",
    "parse_scan",
    "read_heightmap_image",
    "signed_sqrt",
    "straight_scan",
    "top_view",
]
