"""The material JSON format (``schema_version`` 1): read and write one file.

Every other material format converts to this one; :mod:`surfhap.exchange.materials` finds
files and dispatches on the suffix.
"""

from __future__ import annotations

import json
from pathlib import Path

from pydantic import ValidationError

from surfhap.errors import MaterialFormatError
from surfhap.exchange.files import read_text, write_text
from surfhap.models.material import Material, MaterialFile

__all__ = ["read_material_json", "write_material_json", "validation_error_to_format_error"]


def validation_error_to_format_error(err: ValidationError, source: str, cls=MaterialFormatError):
    """Turn the first pydantic error into one located error line."""
    first = err.errors()[0]
    field = ".".join(str(p) for p in first.get("loc", ())) or None
    msg = first.get("msg", "invalid value")
    return cls(msg, source=source, field=field)


def read_material_json(path: str | Path) -> Material:
    """Read and validate a material JSON file. Raises MaterialFormatError on any problem."""
    path = Path(path)
    text = read_text(path, MaterialFormatError)
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
    return write_text(path, spec.model_dump_json(indent=2, exclude_none=True) + "\n")
