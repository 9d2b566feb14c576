"""Diagnostics and solver summaries become plain JSON (no NaN/inf, no numpy types)."""

from __future__ import annotations

import json

import numpy as np

from alcove.science.json_values import json_safe


def test_numpy_values_and_non_finite_numbers_become_plain_json() -> None:
    raw = {
        "peak": np.float64(221.5),
        "steps": np.int64(401),
        "ok": np.bool_(True),
        "energy": float("nan"),
        "bound": np.float32(np.inf),
        "curve": np.array([[1.0, np.nan], [2.0, 3.0]]),
        "pair": (1, np.float64(-np.inf)),
        3: "three",
        "nothing": None,
        "path": object,
    }
    out = json_safe(raw)
    assert out["peak"] == 221.5 and type(out["peak"]) is float
    assert out["steps"] == 401 and type(out["steps"]) is int
    assert out["ok"] is True
    assert out["energy"] is None and out["bound"] is None
    assert out["curve"] == [[1.0, None], [2.0, 3.0]] and out["pair"] == [1, None]
    assert out["3"] == "three" and out["nothing"] is None and isinstance(out["path"], str)
    json.dumps(out, allow_nan=False)  # strict JSON
