"""Mesh loading: formats through trimesh, orientation, scale, clear errors."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from surfhap.errors import MeshFormatError, MeshUnitsWarning
from surfhap.exchange.mesh import builtin_mesh_path, orient_up, read_mesh
from surfhap.shape.topsurface import TopSurface


@pytest.mark.parametrize("ext", ["stl", "ply", "glb", "off", "obj"])
@pytest.mark.filterwarnings("ignore::surfhap.errors.MeshUnitsWarning")  # Suzanne at SI scale: 2.7 m
def test_formats_round_trip(tmp_path, ext):
    ref = TopSurface.from_file("suzanne")
    mesh = trimesh.Trimesh(ref.vertices, ref.faces, process=False)
    path = tmp_path / f"suz.{ext}"
    mesh.export(path)
    surf = TopSurface.from_file(path)
    xy = np.random.default_rng(0).uniform(-1.3, 1.3, (500, 2))
    za, _ = ref.query(xy)
    zb, _ = surf.query(xy)
    np.testing.assert_array_equal(np.isnan(za), np.isnan(zb))
    np.testing.assert_allclose(zb, za, atol=1e-6)  # float32 formats
    assert surf.theta_min == pytest.approx(ref.theta_min, abs=1e-3)  # STL vertices are welded on load


def test_suzanne_ships_with_its_licence():
    p = builtin_mesh_path("suzanne")
    assert p.exists() and (p.parent / "SOURCE.md").exists() and (p.parent / "BLENDER-LICENSE-AGREEMENT.txt").exists()
    with pytest.warns(MeshUnitsWarning, match="suzanne: the mesh spans 2.734 m across"):
        m = read_mesh("suzanne")
    assert m.faces.shape[0] in (967, 968)
    lo, hi = m.vertices.min(axis=0), m.vertices.max(axis=0)
    np.testing.assert_allclose(hi, [1.367188, 0.984375, 0.851562], atol=1e-6)


def test_orientation_scale_and_size():
    v = np.array([[1.0, 2.0, 3.0]])
    np.testing.assert_allclose(orient_up(v, "y"), [[1.0, -3.0, 2.0]])
    for up in ("x", "y", "z", "-x", "-y", "-z"):
        basis = orient_up(np.eye(3), up)
        assert np.linalg.det(basis) == pytest.approx(1.0)  # proper rotation: windings survive
        axis = {"x": 0, "y": 1, "z": 2}[up[-1]]
        np.testing.assert_allclose(basis[axis], [0, 0, -1 if up.startswith("-") else 1])
    m = read_mesh("suzanne", scale=0.01)
    assert m.vertices[:, 0].max() == pytest.approx(0.01367188)
    m = read_mesh("suzanne", size=0.1)
    ext = m.vertices.max(axis=0) - m.vertices.min(axis=0)
    assert max(ext[0], ext[1]) == pytest.approx(0.1)
    assert m.vertices[:, 0].min() == pytest.approx(-0.05)


def test_clear_errors(tmp_path):
    with pytest.raises(MeshFormatError, match="no such file"):
        read_mesh(tmp_path / "missing.obj")
    (tmp_path / "x.docx").write_text("hello")
    with pytest.raises(MeshFormatError, match="unknown mesh format"):
        read_mesh(tmp_path / "x.docx")
    with pytest.raises(MeshFormatError, match="folder"):
        read_mesh(tmp_path)
    (tmp_path / "nan.obj").write_text("v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n")
    with pytest.raises(MeshFormatError):
        read_mesh(tmp_path / "nan.obj")
    (tmp_path / "pts.ply").write_text("ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                                      "property float z\nend_header\n0 0 0\n1 1 1\n")
    with pytest.raises(MeshFormatError) as err:
        read_mesh(tmp_path / "pts.ply")
    assert str(tmp_path / "pts.ply") in str(err.value) and "\n" not in str(err.value)
    with pytest.raises(MeshFormatError):
        read_mesh("suzanne", scale=-1.0)
    with pytest.raises(MeshFormatError):
        read_mesh("suzanne", up="w")


# -- units (issue 17 item 12): a mesh in millimetres read as metres is said, not silently used


def _sphere(tmp_path, radius, ext):
    path = tmp_path / f"sphere_r{radius:g}.{ext}"
    trimesh.creation.icosphere(subdivisions=2, radius=radius).export(path)
    return path


@pytest.mark.parametrize("ext", ["obj", "stl"])
def test_mesh_in_millimetres_warns_in_the_cli(tmp_path, ext):
    """A 20 mm-radius sphere modelled in mm (40 units across) gives one warning line naming the
    file and --size; the same sphere in metres (r = 0.02) gives none. Through the real CLI."""
    import subprocess
    import sys

    def run(mesh, speed):  # a quick calibration: few, fast scans (the mm sphere is 40 m wide)
        cmd = [sys.executable, "-m", "surfhap", "shape", "calibrate", str(mesh), "--directions", "2", "--speeds", "1",
               "--lines", "2", "--v-min", speed, "--v-max", speed, "--out", str(tmp_path / "cal.json"), "--overwrite"]
        return subprocess.run(cmd, capture_output=True, text=True, timeout=300)

    mm = _sphere(tmp_path, 20.0, ext)
    res = run(mm, "2")
    assert res.returncode == 0, res.stderr
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1 and lines[0].startswith("warning: "), res.stderr
    assert str(mm) in lines[0] and "--size" in lines[0] and "40 m across" in lines[0], lines[0]
    res = run(_sphere(tmp_path, 0.02, ext), "0.05")
    assert res.returncode == 0 and res.stderr.strip() == "", res.stderr


def test_mesh_extent_bounds(tmp_path):
    """The library warns (a typed warning, no print) outside 1 mm - 1 m, after --scale/--size."""
    import warnings

    mm = _sphere(tmp_path, 20.0, "stl")
    with pytest.warns(MeshUnitsWarning) as rec:
        read_mesh(mm)
    assert rec[0].message.source == str(mm)
    with pytest.warns(MeshUnitsWarning, match="0.0004 m across"):
        read_mesh(_sphere(tmp_path, 0.0002, "stl"))
    with warnings.catch_warnings():
        warnings.simplefilter("error", MeshUnitsWarning)
        read_mesh(mm, scale=0.001)  # 40 mm across
        read_mesh(mm, size=0.05)
        read_mesh(_sphere(tmp_path, 0.4, "stl"))  # 0.8 m: a large but plausible surface
        TopSurface.from_file("suzanne", size=0.1)


def test_trimesh_reads_a_latin1_ascii_stl(tmp_path):
    """An ASCII STL whose solid name is not UTF-8 (a CAD export in cp1252) loads: trimesh
    guesses its encoding with charset-normalizer, a dependency since issue 17."""
    from surfhap.exchange.mesh import read_mesh

    p = tmp_path / "wuerfel.stl"
    tri = "facet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 0.01 0 0\nvertex 0 0.01 0\nendloop\nendfacet\n"
    p.write_bytes(b"solid W\xfcrfel\n" + tri.encode() + b"endsolid W\xfcrfel\n")
    m = read_mesh(p)
    assert m.faces.shape == (1, 3) and np.isclose(np.ptp(m.vertices[:, 0]), 0.01)
    assert isinstance(trimesh.load(str(p), force="mesh"), trimesh.Trimesh)
