"""Material files: find them and read them by suffix.

``load_material(ref)`` accepts a built-in name (``surfhap materials`` lists them) or a path
to a material file. This module is the registry: it imports its readers (the JSON format of
:mod:`surfhap.exchange.material_json`, HaTT ``Models_*.xml`` of :mod:`surfhap.exchange.hatt`,
loaded on first use) and the readers never import it.
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path
from typing import Callable

from surfhap.errors import MaterialFormatError, UnknownMaterialError
from surfhap.exchange.material_json import read_material_json
from surfhap.models.material import Material

__all__ = [
    "builtin_names",
    "builtin_path",
    "load_material",
]


def _read_hatt(path: Path) -> Material:
    from surfhap.exchange.hatt import read_hatt_material  # numpy and XML: loaded on first use

    return read_hatt_material(path)


_READERS: dict[str, Callable[[Path], Material]] = {".json": read_material_json, ".xml": _read_hatt}


def _builtin_dir():
    return resources.files("surfhap.models") / "builtin"


def builtin_names() -> list[str]:
    """Names of the built-in materials, sorted."""
    return sorted(p.name[:-5] for p in _builtin_dir().iterdir() if p.name.endswith(".json"))


def builtin_path(name: str) -> Path:
    """Path of a built-in material file."""
    return Path(str(_builtin_dir() / f"{name}.json"))


def material_path(ref: str | Path) -> Path:
    """The file of a material reference: an existing file itself, else a built-in name's file
    (so a built-in name works wherever a material file is read)."""
    path = Path(ref)
    return builtin_path(str(ref)) if not path.exists() and str(ref) in builtin_names() else path


def load_material(ref: str | Path) -> Material:
    """A built-in material by name, or a material file by path (any registered suffix)."""
    ref_str = str(ref)
    path = Path(ref_str)
    reader = _READERS.get(path.suffix.lower())
    if reader is not None and (path.exists() or path.parent != Path(".")):
        if not path.exists():
            raise UnknownMaterialError("no such file", source=ref_str)
        return reader(path)
    names = builtin_names()
    if ref_str in names:
        return read_material_json(builtin_path(ref_str))
    if path.exists():
        raise MaterialFormatError(f"unknown material file type {path.suffix!r} (known: {', '.join(_READERS)})", source=ref_str)
    raise UnknownMaterialError(f"unknown material (built-in: {', '.join(names)}; or give a path to a material file)", source=ref_str)
