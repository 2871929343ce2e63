"""Stiff test problems of the IVP Test Set (F. Mazzia, C. Magherini, Univ. Bari: VDPOL and ROBER,
reference solutions computed with RADAU in quadruple precision) as compiled right-hand sides of
the stage signature, for tests/dynamics/test_implicit.py and benchmarks/bench_implicit.py. Each reads x
from the head of one buffer and writes its rates after it (pinclear.dynamics.stepping.system.ode_system)."""
import numpy as np
from numba import carray, cfunc

from pinclear.core.call import CALLBACK, ptr_f8


@cfunc(CALLBACK)
def vdpol(ctx, t):
    """The Test Set's VDPOL: y1' = y2, y2' = ((1 - y1^2) y2 - y1) / eps, eps = 1e-6."""
    b = carray(ptr_f8(ctx), (3,))
    b[2] = ((1.0 - b[0] * b[0]) * b[1] - b[0]) / 1e-6
    return np.inf


@cfunc(CALLBACK)
def rober(ctx, t):
    """The Test Set's ROBER (Robertson's chemical kinetics)."""
    b = carray(ptr_f8(ctx), (6,))
    b[3] = -0.04 * b[0] + 1e4 * b[1] * b[2]
    b[5] = 3e7 * b[1] * b[1]
    b[4] = -b[3] - b[5]
    return np.inf


#: the Test Set's reference solutions: VDPOL at t = 2, ROBER at t = 1e11
VDPOL_REF = np.array([0.1706167732170483e1, -0.8928097010247975e0])
ROBER_REF = np.array([0.2083340149701255e-07, 0.8333360770334713e-13, 0.9999999791665050])
