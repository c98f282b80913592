"""Domain exceptions.

Every error a user can cause by giving surfhap bad input is one of these. They subclass
the matching builtin, so ``except ValueError`` still works, and each carries the file and
the field it is about, so the CLI can print one clear line and exit with code 2.
"""

from __future__ import annotations

import errno
import zlib
from contextlib import contextmanager
from pathlib import Path

__all__ = [
    "SurfhapError",
    "InputError",
    "MaterialFormatError",
    "UnknownMaterialError",
    "TrajectoryFormatError",
    "RecordingFormatError",
    "MeshFormatError",
    "ConfigError",
    "StudyFormatError",
    "SceneFormatError",
    "OutputError",
    "InputWarning",
    "MeshUnitsWarning",
    "reading",
    "writing",
]


def _one_line(message: str, *where: str | None) -> str:
    """``source: field: message`` (the given ``where`` parts) on one line whatever the input held: a
    JSON key or value with a line break (any of str.splitlines' separators) is quoted into the
    field or message by the readers."""
    return " ".join(": ".join([*(p for p in where if p), message]).splitlines())


class SurfhapError(Exception):
    """Base class of every surfhap error."""


class InputError(SurfhapError, ValueError):
    """Bad user input, located by ``source`` (a file path or option) and ``field``.

    ``str(err)`` is the one line the CLI prints: ``source: field: message``.
    """

    def __init__(self, message: str, *, source: str | None = None, field: str | None = None):
        self.message = message
        self.source = None if source is None else str(source)
        self.field = field
        super().__init__(_one_line(message, self.source, field))


class MaterialFormatError(InputError):
    """A material file (JSON) that does not follow the schema."""


class UnknownMaterialError(InputError, LookupError):
    """A material name that is neither built in nor an existing file."""


class TrajectoryFormatError(InputError):
    """A finger trajectory file with missing columns, NaN, or non-monotonic time."""


class RecordingFormatError(InputError):
    """A recording (CSV / NPZ) that cannot be used for fitting."""


class MeshFormatError(InputError):
    """A mesh file that is malformed, empty, or not a surface."""


class ConfigError(InputError):
    """An option or configuration value outside its valid range."""


class StudyFormatError(InputError):
    """A study design, study folder or trial log that does not follow its schema."""


class SceneFormatError(InputError):
    """A force-feedback scene file (JSON) or one of its map / mesh files that cannot be used."""


class OutputError(InputError):
    """An output file that cannot be written: no space left, no permission, a folder in the way."""


class InputWarning(UserWarning):
    """Input that is accepted but probably not what the user meant (issued with
    :func:`warnings.warn`; the CLI prints it as one ``warning:`` line). ``source`` locates it
    like an :class:`InputError`."""

    def __init__(self, message: str, *, source: str | None = None):
        self.message = message
        self.source = None if source is None else str(source)
        super().__init__(_one_line(message, self.source))


class MeshUnitsWarning(InputWarning):
    """A mesh whose extent is implausible in metres (a mesh in millimetres, say)."""


# The one place where what the OS or a format library raises while a user's file is read or
# written becomes an InputError naming the file (every reader and writer in exchange/ uses it).
def _format_errors() -> tuple[type[BaseException], ...]:
    import zipfile  # when an error is matched, not at import: the CLI starts faster without it

    return (zipfile.BadZipFile, zlib.error, EOFError)


_OS_REASONS = {errno.ENOENT: "no such file", errno.EISDIR: "is a folder, not a file",
               errno.ENOSPC: "no space left on the device"}


def _os_reason(exc: OSError) -> str:
    return _OS_REASONS.get(exc.errno) or exc.strerror or type(exc).__name__


@contextmanager
def reading(source: str | Path, error: type[InputError] = InputError, what: str = "file"):
    """Read ``source`` inside this block: an OSError, undecodable text or a truncated/corrupt
    archive becomes ``error`` naming ``source`` (an InputError raised inside passes as is)."""
    try:
        yield
    except InputError:
        raise
    except UnicodeDecodeError as exc:
        raise error(f"not a UTF-8 text file ({exc.reason}; save the {what} as UTF-8)", source=str(source)) from None
    except OSError as exc:
        raise error(f"cannot read file ({_os_reason(exc)})", source=str(source)) from None
    except _format_errors() as exc:
        detail = str(exc).strip().splitlines()[0][:120] if str(exc).strip() else type(exc).__name__
        raise error(f"truncated or corrupt {what} ({detail})", source=str(source)) from None


@contextmanager
def writing(path: str | Path):
    """Write ``path`` inside this block: an OSError (no space left, no permission...) becomes
    an :class:`OutputError` naming ``path``."""
    try:
        yield
    except InputError:
        raise
    except OSError as exc:
        raise OutputError(f"cannot write file ({_os_reason(exc)})", source=str(path)) from None
