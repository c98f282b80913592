"""One base for surfhap's parameter types: pydantic-validated, frozen, and a bad value is one
:class:`~surfhap.errors.ConfigError` line naming the field.

A parameter object states its ranges as pydantic field constraints (``Field(gt=0)``,
``FiniteFloat``, ``Literal[...]``) and cross-field rules in one ``model_validator``; there is
no hand-written ``__post_init__``. Constructing one with a bad value raises ``ConfigError``
(a ``ValueError``) whose ``field`` is the dotted location of the first error, so the command
line prints ``field: message`` and exits 2. File readers that validate a whole document
(``Model.model_validate``) get pydantic's ``ValidationError`` and turn it into their format
error with :func:`first_error`.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Annotated

import numpy as np
from pydantic import AfterValidator, BaseModel, BeforeValidator, ConfigDict, ValidationError
from pydantic.dataclasses import dataclass as _pydantic_dataclass

from surfhap.errors import ConfigError

__all__ = ["Checked", "checked_dataclass", "first_error", "FiniteArray", "within"]

_CONFIG = ConfigDict(extra="forbid", arbitrary_types_allowed=True)


def _finite_array(value) -> np.ndarray:
    a = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(a)):
        raise ValueError("contains NaN or inf")
    return a


#: a float array field (any shape; lists accepted) whose values are all finite
FiniteArray = Annotated[np.ndarray, BeforeValidator(_finite_array)]


def within(low: float, high: float, message: str, *, open_low: bool = False):
    """A finite float field in [low, high] ((low, high] if ``open_low``); its error is ``message`` (the user's units)."""
    def check(value: float) -> float:
        if not (math.isfinite(value) and (value > low if open_low else value >= low) and value <= high):
            raise ValueError(message)
        return value
    return Annotated[float, AfterValidator(check)]


def first_error(exc: ValidationError) -> tuple[str, str]:
    """(field, message) of a validation error's first entry; ``field`` is its dotted location
    ("(top)" for a whole-object rule) and ``message`` pydantic's text without its "Value error, " prefix."""
    err = exc.errors()[0]
    loc = ".".join(str(x) for x in err.get("loc", ())) or "(top)"
    cause = err.get("ctx", {}).get("error")  # a validator calling a check that raises ConfigError: its bare message
    msg = cause.message if isinstance(cause, ConfigError) else str(err.get("msg", "invalid"))
    if isinstance(cause, ConfigError) and cause.field not in (None, "(top)") and not loc.endswith(cause.field):
        loc = f"{loc}.{cause.field}" if loc != "(top)" else cause.field  # e.g. a nested Checked model's own field
    return loc, msg.removeprefix("Value error, ").removeprefix("Assertion failed, ")


class Checked(BaseModel):
    """Frozen, validated parameters: keyword construction, unknown fields refused."""

    model_config = ConfigDict(frozen=True, **_CONFIG)

    def __init__(self, /, **data):
        try:
            super().__init__(**data)
        except ValidationError as exc:
            field, msg = first_error(exc)
            raise ConfigError(msg, field=field) from None


def checked_dataclass(cls):
    """Class decorator: ``cls`` as a frozen pydantic dataclass (positional construction,
    ``dataclasses.replace`` work as for a dataclass) whose bad value is one
    :class:`~surfhap.errors.ConfigError` naming the field, as :class:`Checked`."""
    dc = _pydantic_dataclass(frozen=True, config=_CONFIG)(cls)
    validate = dc.__init__
    names = [f.name for f in dataclasses.fields(dc) if f.init]

    @functools.wraps(validate)
    def __init__(self, *args, **kwargs):
        if len(args) > len(names):
            raise TypeError(f"{cls.__name__} takes at most {len(names)} positional arguments")
        try:  # positional arguments by name, so that an error names the field, not its position
            validate(self, **dict(zip(names, args)), **kwargs)
        except ValidationError as exc:
            field, msg = first_error(exc)
            raise ConfigError(msg, field=field) from None

    dc.__init__ = __init__
    return dc
