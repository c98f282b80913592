"""The one base of surfhap's result objects (python-control style: compute, then ``.plot()``).

Every object a computation returns to a user (a render, a fit, a calibration, a study
analysis, ...) derives from :class:`Result` and so answers the same three calls:

* ``summary() -> dict``: the headline figures, JSON-ready (plain floats, ints, strings,
  lists), what a command prints and ``--json`` writes;
* ``to_dict() -> dict``: everything needed to report or rebuild the result, JSON-ready
  (by default the summary; results with arrays worth keeping add them as lists);
* ``plot(ax=None)``: draws the result with matplotlib and returns the ``Figure``. ``ax`` is
  ``None`` (a new figure), one ``Axes`` for single-panel results, or a sequence of ``Axes``
  (one per panel, ``panels`` of them) to draw into a figure the caller laid out.

Plotting lives in :mod:`surfhap.report`; ``plot`` only imports and calls it, so computing
never draws and nothing is imported for drawing until a figure is asked for.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import Any, ClassVar

import numpy as np

__all__ = ["Result", "jsonable"]


def jsonable(value: Any) -> Any:
    """``value`` as plain JSON types: numpy scalars and arrays to floats, ints and lists,
    tuples to lists, non-finite floats to None (JSON has no NaN)."""
    if isinstance(value, dict):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [jsonable(v) for v in value]
    if isinstance(value, (np.ndarray, np.generic)):
        return jsonable(value.tolist())
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    return value


class Result(ABC):
    """Base of result objects: ``summary()``, ``to_dict()`` and ``plot(ax=None)`` (both abstract)."""

    #: how many Axes :meth:`plot` draws (the length of the ``ax`` sequence it accepts)
    panels: ClassVar[int] = 1

    @abstractmethod
    def summary(self) -> dict:
        """The headline figures, JSON-ready."""

    def to_dict(self) -> dict:
        """Everything needed to report the result, JSON-ready (default: the summary)."""
        return jsonable(self.summary())

    @abstractmethod
    def plot(self, ax=None):
        """Draw the result (see the module docstring for ``ax``); returns the Figure."""
