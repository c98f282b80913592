"""Opening the user's files: bytes, text, NPZ archives and written outputs, with located errors.

Every reader and writer of :mod:`surfhap.exchange` goes through these helpers (and through
:func:`surfhap.errors.reading` / :func:`surfhap.errors.writing`), so a missing, unreadable,
undecodable, truncated or corrupt file, an NPZ holding object arrays or an array where a number
belongs, and a write that fails (no space left) all become one :class:`~surfhap.errors.InputError`
line naming the file (and the field), never a traceback.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

import numpy as np

from surfhap.errors import InputError, reading, writing

__all__ = ["read_text", "read_json_object", "validated", "read_model", "parse_pairs", "file_sha256",
           "load_npz", "npz_number", "numeric", "write_text"]

def read_text(path: str | Path, error: type[InputError] = InputError) -> str:
    """The file's text (UTF-8, a BOM is dropped); ``error`` naming it when unreadable or not UTF-8."""
    with reading(path, error):
        return Path(path).read_bytes().decode("utf-8-sig")


def read_json_object(path: str | Path, error: type[InputError] = InputError) -> dict:
    """The file's top-level JSON object; ``error`` naming the file when unreadable, malformed or not an object."""
    text = read_text(path, error)
    try:
        raw = json.loads(text)
    except json.JSONDecodeError as exc:
        raise error(f"malformed JSON at line {exc.lineno} column {exc.colno}: {exc.msg}", source=str(path)) from None
    if not isinstance(raw, dict):
        raise error("top level must be a JSON object", source=str(path))
    return raw


def validated(model: Any, raw: object, source: str, error: type[InputError] = InputError, *, prefix: str = ""):
    """``model.model_validate(raw)`` (a pydantic model class); the first error as ``error``
    naming ``source`` and the dotted field (after ``prefix``, e.g. "display.")."""
    from pydantic import ValidationError

    from surfhap.checked import first_error

    try:
        return model.model_validate(raw)
    except ValidationError as exc:
        field, msg = first_error(exc)
        field = (prefix.rstrip(".") if field == "(top)" else prefix + field) if prefix else field
        raise error(msg, source=source, field=field) from None


def read_model(path: str | Path, model: Any, error: type[InputError] = InputError):
    """A JSON file validated as ``model`` (:func:`read_json_object`, then :func:`validated`)."""
    return validated(model, read_json_object(path, error), str(path), error)


def parse_pairs(text: str, source: str, known, error: type[InputError] = InputError, *, what: str = "key=value",
                numbers: bool = False) -> dict:
    """``"a=1,b=x[mm]"`` -> {"a": "1", "b": "x[mm]"} (floats with ``numbers``): the one parser of
    comma-separated pairs (``--scan``, ``--display``, ``--columns``). A part without "=", a key
    not in ``known`` or (``numbers``) a value that is not a number is ``error`` naming ``source``."""
    out: dict = {}
    for part in filter(None, (p.strip() for p in text.split(","))):
        if "=" not in part:
            raise error(f"expected {what}, got {part!r}", source=source)
        key, value = (s.strip() for s in part.split("=", 1))
        if key not in known:
            raise error(f"unknown key {key!r} (known: {', '.join(known)})", source=source)
        try:
            out[key] = float(value) if numbers else value
        except ValueError:
            raise error(f"{value!r} is not a number", source=source, field=key) from None
    return out


def file_sha256(path: str | Path, error: type[InputError] = InputError) -> str:
    """Hex SHA-256 of the file's bytes, read in chunks (memory stays bounded)."""
    with reading(path, error), open(path, "rb") as fh:
        return hashlib.file_digest(fh, "sha256").hexdigest()


def load_npz(path: str | Path, error: type[InputError] = InputError) -> dict[str, np.ndarray]:
    """Every array of an NPZ file (read now, without pickles). A truncated or corrupt archive,
    an array that is not readable, or an object array is ``error`` naming the file (and the key)."""
    src = str(path)
    with reading(path, error, what="NPZ file"):
        try:
            z = np.load(path, allow_pickle=False)
        except ValueError as exc:  # numpy: not an npz / npy at all
            raise error(f"not a readable NPZ file ({str(exc).splitlines()[0][:120]})", source=src) from None
        if not isinstance(z, np.lib.npyio.NpzFile):
            raise error("not an NPZ archive (a single .npy array?)", source=src)
        out: dict[str, np.ndarray] = {}
        with z:
            for key in z.files:
                try:
                    out[key] = z[key]
                except ValueError as exc:
                    reason = ("holds Python objects (an object array), which surfhap does not load"
                              if "allow_pickle" in str(exc) else f"unreadable array ({str(exc).splitlines()[0][:120]})")
                    raise error(reason, source=src, field=key) from None
    return out


def numeric(x: np.ndarray, source: str, field: str, error: type[InputError] = InputError) -> np.ndarray:
    """``x`` as a float array; ``error`` naming the field when it does not hold numbers."""
    a = np.asarray(x)
    if a.dtype.kind not in "biuf":
        raise error(f"must hold numbers, not {a.dtype} values", source=source, field=field)
    return a.astype(float, copy=False)


def npz_number(x: np.ndarray, source: str, field: str, error: type[InputError] = InputError) -> float:
    """A single number stored in an NPZ (a 0-d or one-element array); ``error`` otherwise."""
    a = numeric(x, source, field, error)
    if a.size != 1:
        raise error(f"must be a single number, got an array of shape {a.shape}", source=source, field=field)
    return float(a.reshape(()))


def write_text(path: str | Path, text: str) -> Path:
    """Write ``text`` (UTF-8) to ``path``, its folder created if missing; a failing write (no
    space left...) names the path."""
    path = Path(path)
    with writing(path):
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
    return path
