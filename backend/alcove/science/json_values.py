"""JSON-safe copies of result dictionaries (run diagnostics, solver summaries).

Diagnostics come from NumPy code: numpy scalars and arrays, tuples, and floats that may
be inf or NaN (which JSON cannot hold). :func:`json_safe` turns them into plain JSON values;
a non-finite float becomes ``None`` and anything else unknown its ``str``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np


def json_safe(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, np.ndarray):
        return json_safe(value.tolist())
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if value is None or isinstance(value, (bool, int, str)):
        return value
    return str(value)
