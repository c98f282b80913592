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
from dataclasses import astuple, dataclass, field
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


def _values(el, path, tag, conv=float, default=None) -> np.ndarray:
    if el is None:
        if default is not None:
            return default
        raise _err(path, "missing tag", tag)
    vals = []
    for v in el.findall("value"):
        try:
            vals.append(conv((v.text or "").strip()))
        except ValueError:
            raise _err(path, f"{(v.text or '').strip()!r} is not a number", tag) from None
    return np.array(vals, dtype=float if conv is float else np.int64)


#: the unit tags of every HaTT file (the only units the reader accepts, and what the writer writes)
UNITS = (("AccelUnits", "m/s^2"), ("SpeedUnits", "mm/s"), ("ForceUnits", "N"))
#: the tags of a ``<model>``, in the order of :class:`HattModel`'s fields
MODEL_TAGS = ("modNum", "ARcoeff", "ARlsf", "MAcoeff", "MAlsf", "var", "gain", "speedMod", "forceMod")


def _model(m, i: int, path, num_ar: int, num_ma: int) -> HattModel:
    """The ``i``-th (0-based) ``<model>`` element, its sizes checked against numARCoeff / numMACoeff."""
    where = f"model[{i + 1}]"
    ar, ar_lsf, ma, ma_lsf = (_values(m.find(tag), path, f"{where}.{tag}", default=d) for tag, d in
                              (("ARcoeff", None), ("ARlsf", None), ("MAcoeff", np.ones(1)), ("MAlsf", np.zeros(0))))
    for kind, coeff, lsf, num in (("AR", ar, ar_lsf, num_ar), ("MA", ma, ma_lsf, num_ma)):
        if lsf.size != num or coeff.size != num + 1:
            raise _err(path, f"{lsf.size} {kind} LSFs and {coeff.size} {kind} coefficients; num{kind}Coeff is {num}",
                       f"{where}.{kind}lsf")
        if (kind == "AR" or num) and not lsf_is_valid(lsf):
            raise _err(path, "LSFs must increase strictly within (0, pi)", f"{where}.{kind}lsf")
    var, gain, speed, force = (_text(m, tag, path, float) for tag in MODEL_TAGS[5:])
    if not (np.isfinite(var) and var >= 0):
        raise _err(path, "must be >= 0", f"{where}.var")
    mod_num = _text(m, "modNum", path, int) if m.find("modNum") is not None else i + 1
    return HattModel(mod_num, ar, ar_lsf, ma, ma_lsf, var, gain, speed, force)


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
    for tag, want in UNITS:
        el = root.find(tag)
        if el is not None and (el.text or "").strip() != want:
            raise _err(path, f"unit {(el.text or '').strip()!r} is not supported (HaTT files use {want})", tag)
    counts = ("numMod", "numTri", "numARCoeff", "numMACoeff")
    num_mod, num_tri, num_ar, num_ma = (_text(root, t, path, int) for t in counts)
    speeds, forces = (_values(root.find(t), path, t) for t in ("speedList", "forceList"))
    if speeds.size != num_mod or forces.size != num_mod:
        raise _err(path, f"speedList/forceList have {speeds.size}/{forces.size} values, numMod is {num_mod}", "speedList")
    tris = [_values(t, path, "tri", int) for t in root.findall("tri")]
    if len(tris) != num_tri or any(t.size != 3 for t in tris):
        raise _err(path, f"expected {num_tri} <tri> elements of 3 values", "tri")
    triangles = np.array(tris, dtype=np.int64).reshape(-1, 3)
    if triangles.size and (triangles.min() < 1 or triangles.max() > num_mod):
        raise _err(path, f"triangle vertex indices must be within 1..{num_mod} (1-based)", "tri")
    models = [_model(m, i, path, num_ar, num_ma) for i, m in enumerate(root.findall("model"))]
    if len(models) != num_mod:
        raise _err(path, f"{len(models)} <model> elements, numMod is {num_mod}", "model")
    pictures = {t: (root.find(t).text or "") for t in ("htmlPicture", "picture", "DTpicture", "LinuxDTpicture") if root.find(t) is not None}
    mu, rate, max_speed, max_force = (_text(root, t, path, float) for t in ("mu", "SampleRate", "maxSpeed", "maxForce"))
    return HattModelSet(root.get("texture", ""), _text(root, "material", path), mu, rate, max_speed, max_force, speeds,
                        forces, triangles, tuple(models), pictures)


def _fmt(x) -> str:
    """An element's text: integers and strings as they are, other numbers at full float precision."""
    return x if isinstance(x, str) else str(int(x)) if isinstance(x, (int, np.integer)) else repr(float(x))


def write_hatt_xml(ms: HattModelSet, path: str | Path) -> Path:
    """Write a model set in the HaTT schema (full float precision). For tests and for
    exporting models fitted by surfhap to HaTT-based renderers."""
    path = Path(path)
    root = ET.Element("modelSet", texture=str(ms.texture))

    def add(parent, tag, value):
        el = ET.SubElement(parent, tag)
        if isinstance(value, np.ndarray):
            el.set("type", "array")
            for v in value:
                ET.SubElement(el, "value").text = _fmt(v)
        else:
            el.text = _fmt(value)

    pictures = [(tag, ms.pictures.get(tag, "")) for tag in ("htmlPicture", "picture", "DTpicture", "LinuxDTpicture")]
    for tag, value in [("material", ms.material), *UNITS, ("SampleRate", f"{ms.sample_rate:g}"), ("mu", ms.mu),
                       *pictures[:2], ("numMod", len(ms.models)), ("numTri", ms.triangles.shape[0]),
                       ("maxSpeed", ms.max_speed), ("maxForce", ms.max_force), ("speedList", ms.speeds),
                       ("forceList", ms.forces), *(("tri", tri) for tri in ms.triangles), *pictures[2:],
                       ("numARCoeff", ms.num_ar), ("numMACoeff", ms.num_ma)]:
        add(root, tag, value)
    for m in ms.models:
        el = ET.SubElement(root, "model")
        for tag, value in zip(MODEL_TAGS, astuple(m)):
            add(el, tag, value)
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


def read_hatt_material(path: str | Path, command: str | None = None):
    """Reader for :func:`surfhap.exchange.materials.load_material` (``.xml``); ``command`` as in
    :func:`hatt_to_material`. A model set the material refuses is a MaterialFormatError too."""
    path = Path(path)
    ms = read_hatt_xml(path)
    try:
        return hatt_to_material(ms, str(path), file_sha256(path, MaterialFormatError), command)
    except MaterialFormatError:
        raise
    except ValueError as exc:
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
    out_dir, command = Path(out_dir), f"surfhap import hatt {folder} --out {out_dir}"
    materials = [read_hatt_material(f, command) for f in files]  # every file checked before one is written
    return [write_material_json(mat, out_dir / f"{mat.name}.json") for mat in materials]

