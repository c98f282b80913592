"""Domain exceptions.

Every error a user can cause by giving surfhap bad input is one of these. They subclass
the matching builtin, so ``except ValueError`` still works, and each carries the file and
the field it is about, so the CLI can print one clear line and exit with code 2.
"""

from __future__ import annotations

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
]


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
        super().__init__(self._line())

    def _line(self) -> str:
        parts = [p for p in (self.source, self.field) if p]
        # one line whatever the input held: a JSON key or value with a line break (any of
        # str.splitlines' separators) is quoted into the field or message by the readers
        return " ".join(": ".join([*parts, self.message]).splitlines())


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
