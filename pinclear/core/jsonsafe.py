"""JSON-safe copies of results (what saved runs, summaries and reports write)."""
from __future__ import annotations

import numpy as np


def jsonable(x):
    """A JSON-safe copy of x (arrays to lists, numpy scalars to Python, others by repr)."""
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, (np.floating, np.integer, np.bool_)):
        return x.item()
    if isinstance(x, (str, int, float, bool)) or x is None:
        return x
    return repr(x)
