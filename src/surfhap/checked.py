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

import functools

from pydantic import BaseModel, ConfigDict, ValidationError
from pydantic.dataclasses import dataclass as _pydantic_dataclass

from surfhap.errors import ConfigError

__all__ = ["Checked", "checked_dataclass", "first_error"]

_CONFIG = ConfigDict(extra="forbid", arbitrary_types_allowed=True)


def first_error(exc: ValidationError) -> tuple[str, str]:
    """(field, message) of a validation error's first entry; ``field`` is its dotted location
    ("(top)" for a whole-object rule) and ``message`` pydantic's text without its "Value error, " prefix."""
    err = exc.errors()[0]
    loc = ".".join(str(x) for x in err.get("loc", ())) or "(top)"
    msg = str(err.get("msg", "invalid"))
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

    @functools.wraps(validate)
    def __init__(self, *args, **kwargs):
        try:
            validate(self, *args, **kwargs)
        except ValidationError as exc:
            field, msg = first_error(exc)
            head, _, rest = field.partition(".")
            if head.isdigit() and int(head) < len(names):  # a positional argument: its field's name
                field = ".".join(filter(None, (names[int(head)], rest)))
            raise ConfigError(msg, field=field) from None

    names = list(dc.__dataclass_fields__)
    dc.__init__ = __init__
    return dc
