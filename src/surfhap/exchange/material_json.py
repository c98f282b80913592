"""The material JSON format (``schema_version`` 1): read and write one file.

Every other material format converts to this one; :mod:`surfhap.exchange.materials` finds
files and dispatches on the suffix.
"""

from __future__ import annotations

from pathlib import Path

from surfhap.errors import MaterialFormatError
from surfhap.exchange.files import read_json_object, validated, write_text
from surfhap.models.material import Material, MaterialFile

__all__ = ["read_material_json", "write_material_json"]


def read_material_json(path: str | Path) -> Material:
    """Read and validate a material JSON file. Raises MaterialFormatError on any problem."""
    raw = read_json_object(path, MaterialFormatError)
    version = raw.get("schema_version")
    if version != 1:
        raise MaterialFormatError(f"unsupported schema_version {version!r} (this surfhap reads 1)", source=str(path), field="schema_version")
    return Material.from_spec(validated(MaterialFile, raw, str(path), MaterialFormatError))


def write_material_json(material: Material | MaterialFile, path: str | Path) -> Path:
    """Write a material (its spec, provenance included) as indented JSON; returns the path."""
    spec = material.spec if isinstance(material, Material) else material
    return write_text(path, spec.model_dump_json(indent=2, exclude_none=True) + "\n")
