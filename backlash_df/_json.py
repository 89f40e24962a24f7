"""JSON-ready copies of result dictionaries (shared by every ``to_dict()``)."""

import math

import numpy as np

__all__ = ["json_ready"]


def json_ready(obj):
    """A copy of nested dicts and lists with numpy scalars as Python numbers and NaN, inf as None.

    JSON has no NaN; a result that has no value there says ``null``.
    """
    if isinstance(obj, dict):
        return {key: json_ready(value) for key, value in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_ready(value) for value in obj]
    if isinstance(obj, np.ndarray):
        return json_ready(obj.tolist())
    if isinstance(obj, (np.bool_, bool)):
        return bool(obj)
    if isinstance(obj, (np.integer, int)):
        return int(obj)
    if isinstance(obj, (np.floating, float)):
        return float(obj) if math.isfinite(obj) else None
    return obj
