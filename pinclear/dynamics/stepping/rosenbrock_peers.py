"""Two Rosenbrock tableaus that ROS34PW2 (pinclear.dynamics.stepping.rosenbrock) is measured against:
ROS3PW (Rang & Angermann 2005) and RODASP (Steinebach 1995). Run through the same step logic as
``Rosenbrock(name, COEFFS)``; tests/dynamics/test_implicit.py and benchmarks/bench_implicit.py
compare their orders with a stale or perturbed Jacobian.
"""
from __future__ import annotations

import numpy as np

#: ROS3PW (Rang & Angermann 2005): 3 stages, order 3 with the exact Jacobian, 2 as a W-method,
#: R(inf) = 0.73 (not L-stable): the comparison of tests/dynamics/test_implicit.py and the benchmark.
_G3 = 7.8867513459481287e-01
ROS3PW_COEFFS = dict(
    alpha=[[0, 0, 0], [1.5773502691896257e+00, 0, 0], [0.5, 0, 0]],
    gamma=[[_G3, 0, 0], [-1.5773502691896257e+00, _G3, 0], [-6.7075317547305480e-01, -1.7075317547305482e-01, _G3]],
    b=[1.0566243270259355e-01, 4.9038105676657971e-02, 8.4529946162074843e-01],
    b_hat=[-1.7863279495408180e-01, 1.0 / 3.0, 8.4529946162074843e-01],
    order=3)


def _rodasp():
    """RODASP (G. Steinebach, Order-reduction of ROW-methods for DAEs and method of lines
    applications, TH Darmstadt preprint 1741, 1995): 6 stages, order 4 (3 embedded), stiffly
    accurate; a Rosenbrock method, not a W-method (it needs the exact Jacobian and, for a
    non-autonomous problem, df/dt). Given as alpha and beta = alpha + Gamma (i > j)."""
    al, be = np.zeros((6, 6)), np.zeros((6, 6))
    al[1, 0] = 0.75
    al[2, :2] = [8.6120400814152190e-2, 0.1238795991858478]
    al[3, :3] = [0.7749345355073236, 0.1492651549508680, -0.2941996904581916]
    al[4, :4] = [5.308746682646142, 1.330892140037269, -5.374137811655562, -0.2655010110278497]
    al[5, :5] = [-1.764437648774483, -0.4747565572063027, 2.369691846915802, 0.6195023590649829, 0.25]
    be[2, :2] = [-0.049392, -0.014112]
    be[3, :3] = [-0.4820494693877561, -0.1008795555555556, 0.9267290249433117]
    be[4, :4] = [-1.764437648774483, -0.4747565572063027, 2.369691846915802, 0.6195023590649829]
    be[5, :5] = [-8.0368370789113464e-2, -5.6490613592447572e-2, 0.4882856300427991, 0.5057162114816189,
                 -0.1071428571428569]
    g = 0.25
    gam = np.tril(be - al, -1) + g * np.eye(6)
    return dict(alpha=al, gamma=gam, b=np.r_[be[5, :5], g], b_hat=np.r_[be[4, :4], g, 0.0], order=4)


RODASP_COEFFS = _rodasp()
