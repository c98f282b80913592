"""Penn Haptic Texture Toolkit (HaTT) model sets: ``Models_<name>.xml`` reader and writer.

HaTT models may not be redistributed (Penn licence), so surfhap ships none: it reads a
folder the user brings, and the writer exists so tests can make small synthetic files in
the same schema. The schema (every tag of the 100 HaTT files) is described in
``shared/data/README.md`` and summarised in ``docs/fitting.md``; in short: ``mu``,
``SampleRate``, ``maxSpeed`` (mm/s), ``maxForce`` (N), ``speedList`` / ``forceList``
(vertices), ``tri`` (1-based Delaunay triangles), ``numARCoeff`` / ``numMACoeff`` and one
``model`` per vertex with ``ARcoeff`` / ``ARlsf`` / ``MAcoeff`` / ``MAlsf`` / ``var`` /
``gain`` / ``speedMod`` / ``forceMod``.

Reading gives a :class:`HattModelSet` (file units) and, through :func:`hatt_to_material`,
a :class:`~surfhap.models.material.Material` whose texture is an
:class:`~surfhap.models.interpolated.InterpolatedARMABank` (SI: speeds in m/s) and whose
friction is Coulomb with HaTT's ``mu``. :func:`surfhap.exchange.materials.load_material`
reads ``.xml`` files through :func:`read_hatt_material`.
"""

from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from surfhap.errors import MaterialFormatError
from surfhap.exchange.files import file_sha256
from surfhap.exchange.material_json import write_material_json
from surfhap.signal.lsf import lsf_is_valid, lsf_to_poly

__all__ = [
    "HattModel",
    "HattModelSet",
    "read_hatt_xml",
    "write_hatt_xml",
    "hatt_to_bank",
    "hatt_to_material",
    "bank_to_hatt",
    "read_hatt_material",
    "import_hatt_folder",
]

MM = 1e-3


@dataclass(frozen=True)
class HattModel:
    """One ``<model>``: polynomials with leading 1, LSFs (rad), var, gain, speed (mm/s), force (N)."""

    mod_num: int
    ar_coeff: np.ndarray
    ar_lsf: np.ndarray
    ma_coeff: np.ndarray
    ma_lsf: np.ndarray
    var: float
    gain: float
    speed: float
    force: float


@dataclass(frozen=True)
class HattModelSet:
    """A whole ``Models_*.xml`` in file units (speeds mm/s, forces N, accelerations m/s^2).

    speeds, forces : (k,) vertex lists; triangles (t, 3) **1-based** as in the file.
    """

    texture: str
    material: str
    mu: float
    sample_rate: float
    max_speed: float
    max_force: float
    speeds: np.ndarray
    forces: np.ndarray
    triangles: np.ndarray
    models: tuple
    accel_units: str = "m/s^2"
    speed_units: str = "mm/s"
    force_units: str = "N"
    pictures: dict = field(default_factory=dict)

    @property
    def num_ar(self) -> int:
        return int(self.models[0].ar_lsf.size)

    @property
    def num_ma(self) -> int:
        return int(self.models[0].ma_lsf.size)


def _err(path, msg, tag=None):
    return MaterialFormatError(msg, source=str(path), field=tag)


def _text(root, tag, path, conv=str):
    el = root.find(tag)
    if el is None or el.text is None or not el.text.strip():
        raise _err(path, "missing tag", tag)
    try:
        return conv(el.text.strip())
    except ValueError:
        raise _err(path, f"{el.text.strip()!r} is not a valid value", tag) from None


def _values(el, path, tag, conv=float) -> np.ndarray:
    if el is None:
        raise _err(path, "missing tag", tag)
    vals = []
    for v in el.findall("value"):
        try:
            vals.append(conv((v.text or "").strip()))
        except ValueError:
            raise _err(path, f"{(v.text or '').strip()!r} is not a number", tag) from None
    return np.array(vals, dtype=float if conv is float else np.int64)


def read_hatt_xml(path: str | Path) -> HattModelSet:
    """Parse and check a HaTT ``Models_*.xml``. Raises MaterialFormatError (file + tag)."""
    path = Path(path)
    try:
        root = ET.parse(path).getroot()
    except OSError as exc:
        raise _err(path, f"cannot read file ({exc.strerror})") from None
    except ET.ParseError as exc:
        raise _err(path, f"malformed XML ({exc})") from None
    if root.tag != "modelSet":
        raise _err(path, f"root element is <{root.tag}>, a HaTT model set has <modelSet>")
    for tag, want in (("AccelUnits", "m/s^2"), ("SpeedUnits", "mm/s"), ("ForceUnits", "N")):
        el = root.find(tag)
        if el is not None and (el.text or "").strip() != want:
            raise _err(path, f"unit {(el.text or '').strip()!r} is not supported (HaTT files use {want})", tag)
    num_mod = _text(root, "numMod", path, int)
    num_tri = _text(root, "numTri", path, int)
    num_ar = _text(root, "numARCoeff", path, int)
    num_ma = _text(root, "numMACoeff", path, int)
    speeds = _values(root.find("speedList"), path, "speedList")
    forces = _values(root.find("forceList"), path, "forceList")
    if speeds.size != num_mod or forces.size != num_mod:
        raise _err(path, f"speedList/forceList have {speeds.size}/{forces.size} values, numMod is {num_mod}", "speedList")
    tris = [_values(t, path, "tri", int) for t in root.findall("tri")]
    if len(tris) != num_tri or any(t.size != 3 for t in tris):
        raise _err(path, f"expected {num_tri} <tri> elements of 3 values", "tri")
    triangles = np.array(tris, dtype=np.int64).reshape(-1, 3)
    if triangles.size and (triangles.min() < 1 or triangles.max() > num_mod):
        raise _err(path, f"triangle vertex indices must be within 1..{num_mod} (1-based)", "tri")
    models = []
    for i, m in enumerate(root.findall("model")):
        where = f"model[{i + 1}]"
        ar = _values(m.find("ARcoeff"), path, f"{where}.ARcoeff")
        ar_lsf = _values(m.find("ARlsf"), path, f"{where}.ARlsf")
        ma = _values(m.find("MAcoeff"), path, f"{where}.MAcoeff") if m.find("MAcoeff") is not None else np.ones(1)
        ma_lsf = _values(m.find("MAlsf"), path, f"{where}.MAlsf") if m.find("MAlsf") is not None else np.zeros(0)
        if ar_lsf.size != num_ar or ar.size != num_ar + 1:
            raise _err(path, f"{ar_lsf.size} AR LSFs and {ar.size} AR coefficients; numARCoeff is {num_ar}", f"{where}.ARlsf")
        if ma_lsf.size != num_ma or ma.size != num_ma + 1:
            raise _err(path, f"{ma_lsf.size} MA LSFs and {ma.size} MA coefficients; numMACoeff is {num_ma}", f"{where}.MAlsf")
        if not lsf_is_valid(ar_lsf):
            raise _err(path, "LSFs must increase strictly within (0, pi)", f"{where}.ARlsf")
        if num_ma and not lsf_is_valid(ma_lsf):
            raise _err(path, "LSFs must increase strictly within (0, pi)", f"{where}.MAlsf")
        var = _text(m, "var", path, float)
        if not (np.isfinite(var) and var >= 0):
            raise _err(path, "must be >= 0", f"{where}.var")
        mod_num = _text(m, "modNum", path, int) if m.find("modNum") is not None else i + 1
        models.append(HattModel(mod_num, ar, ar_lsf, ma, ma_lsf, var, _text(m, "gain", path, float),
                                _text(m, "speedMod", path, float), _text(m, "forceMod", path, float)))
    if len(models) != num_mod:
        raise _err(path, f"{len(models)} <model> elements, numMod is {num_mod}", "model")
    pictures = {t: (root.find(t).text or "") for t in ("htmlPicture", "picture", "DTpicture", "LinuxDTpicture") if root.find(t) is not None}
    return HattModelSet(
        texture=root.get("texture", ""), material=_text(root, "material", path), mu=_text(root, "mu", path, float),
        sample_rate=_text(root, "SampleRate", path, float), max_speed=_text(root, "maxSpeed", path, float),
        max_force=_text(root, "maxForce", path, float), speeds=speeds, forces=forces, triangles=triangles,
        models=tuple(models), pictures=pictures,
    )


def _fmt(x: float) -> str:
    return repr(float(x))


def write_hatt_xml(ms: HattModelSet, path: str | Path) -> Path:
    """Write a model set in the HaTT schema (full float precision). For tests and for
    exporting models fitted by surfhap to HaTT-based renderers."""
    path = Path(path)
    root = ET.Element("modelSet", texture=str(ms.texture))

    def add(parent, tag, text):
        el = ET.SubElement(parent, tag)
        el.text = str(text)
        return el

    def arr(parent, tag, values, conv=_fmt):
        el = ET.SubElement(parent, tag, type="array")
        for v in values:
            add(el, "value", conv(v))
        return el

    add(root, "material", ms.material)
    add(root, "AccelUnits", ms.accel_units)
    add(root, "SpeedUnits", ms.speed_units)
    add(root, "ForceUnits", ms.force_units)
    add(root, "SampleRate", f"{ms.sample_rate:g}")
    add(root, "mu", _fmt(ms.mu))
    for tag in ("htmlPicture", "picture"):
        add(root, tag, ms.pictures.get(tag, ""))
    add(root, "numMod", len(ms.models))
    add(root, "numTri", ms.triangles.shape[0])
    add(root, "maxSpeed", _fmt(ms.max_speed))
    add(root, "maxForce", _fmt(ms.max_force))
    arr(root, "speedList", ms.speeds)
    arr(root, "forceList", ms.forces)
    for tri in ms.triangles:
        arr(root, "tri", tri, lambda v: str(int(v)))
    for tag in ("DTpicture", "LinuxDTpicture"):
        add(root, tag, ms.pictures.get(tag, ""))
    add(root, "numARCoeff", ms.num_ar)
    add(root, "numMACoeff", ms.num_ma)
    for m in ms.models:
        el = ET.SubElement(root, "model")
        add(el, "modNum", m.mod_num)
        arr(el, "ARcoeff", m.ar_coeff)
        arr(el, "ARlsf", m.ar_lsf)
        arr(el, "MAcoeff", m.ma_coeff)
        arr(el, "MAlsf", m.ma_lsf)
        add(el, "var", _fmt(m.var))
        add(el, "gain", _fmt(m.gain))
        add(el, "speedMod", _fmt(m.speed))
        add(el, "forceMod", _fmt(m.force))
    ET.indent(root, space="   ")
    ET.ElementTree(root).write(path, encoding="utf-8", xml_declaration=True)
    return path


def hatt_to_bank(ms: HattModelSet):
    """The :class:`~surfhap.models.interpolated.InterpolatedARMABank` of a model set (SI).

    The vertices are ``speedList`` / ``forceList`` (which HaTT triangulates), converted to
    m/s; the triangles become 0-based."""
    from surfhap.models.interpolated import InterpolatedARMABank

    return InterpolatedARMABank(
        "acceleration", ms.sample_rate, ms.speeds * MM, ms.forces, np.array([m.ar_lsf for m in ms.models]),
        np.array([m.ma_lsf for m in ms.models]).reshape(len(ms.models), -1), np.array([m.var for m in ms.models]),
        np.array([m.gain for m in ms.models]), ms.triangles - 1, ms.max_speed * MM, ms.max_force,
    )


def bank_to_hatt(bank, material: str, mu: float, texture: str = "0") -> HattModelSet:
    """A HaTT model set from an interpolated bank (speeds back to mm/s, 1-based triangles)."""
    models = []
    for i in range(bank.speeds.size):
        ar_lsf = bank.ar_lsf[i]
        ma_lsf = bank.ma_lsf[i]
        models.append(HattModel(i + 1, lsf_to_poly(ar_lsf), ar_lsf.copy(), lsf_to_poly(ma_lsf), ma_lsf.copy(),
                                float(bank.variances[i]), float(bank.gains[i]), float(bank.speeds[i] / MM), float(bank.forces[i])))
    return HattModelSet(str(texture), material, float(mu), float(bank.sample_rate), float(bank.max_speed / MM),
                        float(bank.max_force), bank.speeds / MM, bank.forces.copy(), bank.triangles + 1, tuple(models))


def _slug(name: str) -> str:
    s = re.sub(r"[^A-Za-z0-9]+", "-", name.strip()).strip("-").lower()
    return s or "hatt-material"


def hatt_to_material(ms: HattModelSet, source: str, sha256: str | None = None, command: str | None = None):
    """A :class:`~surfhap.models.material.Material`: Coulomb mu from ``<mu>``, interpolated
    ARMA acceleration texture (for Zhao et al.'s drive law, f_texture = m_eff x acc)."""
    from surfhap.models.material import CoulombSpec, FrictionSpec, InterpolatedTextureSpec, Material, MaterialFile, Provenance

    cmd = command or f"surfhap import hatt (read {Path(source).name})"
    note = "Penn Haptic Texture Toolkit model set supplied by the user; HaTT files may not be redistributed"
    prov = Provenance(source="recording", recording=Path(source).name, sha256=sha256, command=cmd, note=note)
    bank = hatt_to_bank(ms)
    texture = InterpolatedTextureSpec.of_bank(bank, prov)
    spec = MaterialFile(
        name=_slug(ms.material), description=f"HaTT model set '{ms.material}' (texture {ms.texture})",
        friction=FrictionSpec(coulomb=CoulombSpec(mu0=ms.mu, provenance=prov)), texture=texture,
        notes=[f"imported from {Path(source).name}: {len(ms.models)} ARMA({ms.num_ar},{ms.num_ma}) models at "
               f"{ms.sample_rate:g} Hz, {ms.triangles.shape[0]} triangles"],
    )
    return Material.from_spec(spec)


def read_hatt_material(path: str | Path):
    """Reader for :func:`surfhap.exchange.materials.load_material` (``.xml``)."""
    path = Path(path)
    ms = read_hatt_xml(path)
    try:
        return hatt_to_material(ms, str(path), file_sha256(path, MaterialFormatError))
    except ValueError as exc:
        if isinstance(exc, MaterialFormatError):
            raise
        raise _err(path, str(exc).splitlines()[0]) from None


def import_hatt_folder(folder: str | Path, out_dir: str | Path) -> list[Path]:
    """Convert every ``Models_*.xml`` of a HaTT folder into a material JSON in ``out_dir``.

    Returns the written paths. Raises MaterialFormatError when there is no model file."""
    folder = Path(folder)
    if folder.is_file():
        files = [folder]
    else:
        if not folder.is_dir():
            raise MaterialFormatError("no such folder", source=str(folder))
        files = sorted(folder.rglob("Models_*.xml"))
    if not files:
        raise MaterialFormatError("no Models_*.xml file found (point at the HaTT folder that holds them)", source=str(folder))
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for f in files:
        ms = read_hatt_xml(f)
        mat = hatt_to_material(ms, str(f), file_sha256(f, MaterialFormatError),
                               command=f"surfhap import hatt {folder} --out {out_dir}")
        written.append(write_material_json(mat, out_dir / f"{mat.name}.json"))
    return written

