"""Kernels for tests/core/test_stage.py (a module of their own: a stage's generated wrapper imports
its kernel by module and name)."""
from typing import NamedTuple

import numpy as np

from pinclear.core.jit import njit


class Pair(NamedTuple):
    a: np.ndarray
    M: np.ndarray
    s: float
    k: int


@njit(cache=True)
def mix(p, x, t, out, c):
    """out = a + M[:, 0] * s + k + x[0, 1] + t + c, elementwise over a; returns out's sum."""
    acc = 0.0
    for i in range(out.shape[0]):
        out[i] = p.a[i] + p.M[i, 0] * p.s + p.k + x[0, 1] + t + c
        acc += out[i]
    return acc
