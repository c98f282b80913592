"""The result base: JSON-ready output that the standard library's json accepts strictly, and
abstract ``summary``/``plot`` (a result missing one fails when it is made, not when it is called)."""

import importlib
import inspect
import json
import pkgutil

import numpy as np
import pytest

import surfhap

from surfhap.results import Result, jsonable


def test_jsonable_is_strict_json():
    value = {"nan": np.float64("nan"), "inf": float("inf"), "arr": np.arange(3, dtype=np.int32),
             "nested": (np.float32(0.5), [np.bool_(True)]), 1: "key"}
    out = jsonable(value)
    text = json.dumps(out, allow_nan=False)  # raises on NaN/inf or numpy types
    assert json.loads(text) == {"nan": None, "inf": None, "arr": [0, 1, 2], "nested": [0.5, [True]], "1": "key"}


def test_base_to_dict_defaults_to_summary():
    class R(Result):
        def summary(self):
            return {"rms": np.float64(2.0)}

        def plot(self, ax=None):
            return None

    assert R().to_dict() == {"rms": 2.0}
    assert type(R().to_dict()["rms"]) is float


def test_a_result_missing_plot_or_summary_fails_when_made():
    class NoPlot(Result):
        def summary(self):
            return {}

    class NoSummary(Result):
        def plot(self, ax=None):
            return None

    for cls in (NoPlot, NoSummary):
        with pytest.raises(TypeError, match="abstract"):
            cls()


def test_every_result_class_implements_the_base():
    for mod in pkgutil.walk_packages(surfhap.__path__, "surfhap."):
        if ".cli" not in mod.name and not mod.name.endswith("__main__"):
            importlib.import_module(mod.name)
    found = set()
    todo = list(Result.__subclasses__())
    while todo:
        cls = todo.pop()
        found.add(cls)
        todo.extend(cls.__subclasses__())
    assert len(found) >= 21
    assert [c.__qualname__ for c in found if c.__module__.startswith("surfhap.") and inspect.isabstract(c)] == []
