"""The result base: JSON-ready output that the standard library's json accepts strictly."""

import json

import numpy as np

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

    assert R().to_dict() == {"rms": 2.0}
    assert type(R().to_dict()["rms"]) is float
