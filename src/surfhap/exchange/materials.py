"""Material files: find, read and write them.

``load_material(ref)`` accepts a built-in name (``surfhap materials`` lists them) or a path
to a material JSON file. Readers are registered by file suffix, so other formats (HaTT
``Models_*.xml``) plug in with :func:`register_reader`.
"""

from __future__ import annotations

import json
from importlib import resources
from pathlib import Path
from typing import Callable

from pydantic import ValidationError

from surfhap.errors import MaterialFormatError, UnknownMaterialError
from surfhap.models.material import Material, MaterialFile

__all__ = [
    "builtin_names",
    "builtin_path",
    "load_material",
    "read_material_json",
    "write_material_json",
    "register_reader",
    "validation_error_to_format_error",
]

_READERS: dict[str, Callable[[Path], Material]] = {}


def register_reader(suffix: str, reader: Callable[[Path], Material]) -> None:
    """Register ``reader(path) -> Material`` for files ending in ``suffix`` (e.g. ".xml")."""
    _READERS[suffix.lower()] = reader


def _builtin_dir():
    return resources.files("surfhap.models") / "builtin"


def builtin_names() -> list[str]:
    """Names of the built-in materials, sorted."""
    return sorted(p.name[:-5] for p in _builtin_dir().iterdir() if p.name.endswith(".json"))


def builtin_path(name: str) -> Path:
    """Path of a built-in material file."""
    return Path(str(_builtin_dir() / f"{name}.json"))


def validation_error_to_format_error(err: ValidationError, source: str, cls=MaterialFormatError):
    """Turn the first pydantic error into one located error line."""
    first = err.errors()[0]
    field = ".".join(str(p) for p in first.get("loc", ())) or None
    msg = first.get("msg", "invalid value")
    return cls(msg, source=source, field=field)


def read_material_json(path: str | Path) -> Material:
    """Read and validate a material JSON file. Raises MaterialFormatError on any problem."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise MaterialFormatError(f"cannot read file ({exc.strerror})", source=str(path)) from None
    try:
        raw = json.loads(text)
    except json.JSONDecodeError as exc:
        raise MaterialFormatError(f"malformed JSON at line {exc.lineno} column {exc.colno}: {exc.msg}", source=str(path)) from None
    if not isinstance(raw, dict):
        raise MaterialFormatError("top level must be a JSON object", source=str(path))
    version = raw.get("schema_version")
    if version != 1:
        raise MaterialFormatError(f"unsupported schema_version {version!r} (this surfhap reads 1)", source=str(path), field="schema_version")
    try:
        spec = MaterialFile.model_validate(raw)
    except ValidationError as exc:
        raise validation_error_to_format_error(exc, str(path)) from None
    return Material.from_spec(spec)


def write_material_json(material: Material | MaterialFile, path: str | Path) -> Path:
    """Write a material (its spec, provenance included) as indented JSON; returns the path."""
    spec = material.spec if isinstance(material, Material) else material
    path = Path(path)
    path.write_text(spec.model_dump_json(indent=2, exclude_none=True) + "\n", encoding="utf-8")
    return path


register_reader(".json", read_material_json)


def load_material(ref: str | Path) -> Material:
    """A built-in material by name, or a material file by path (any registered suffix)."""
    ref_str = str(ref)
    path = Path(ref_str)
    if path.suffix.lower() == ".xml" and ".xml" not in _READERS:
        import surfhap.exchange.hatt  # noqa: F401  (registers the HaTT Models_*.xml reader)
    if path.suffix.lower() in _READERS and (path.exists() or path.parent != Path(".")):
        if not path.exists():
            raise UnknownMaterialError("no such file", source=ref_str)
        return _READERS[path.suffix.lower()](path)
    names = builtin_names()
    if ref_str in names:
        return read_material_json(builtin_path(ref_str))
    if path.exists():
        raise MaterialFormatError(f"unknown material file type {path.suffix!r} (known: {', '.join(sorted(set(_READERS) | {'.xml'}))})", source=ref_str)
    raise UnknownMaterialError(f"unknown material (built-in: {', '.join(names)}; or give a path to a material file)", source=ref_str)
