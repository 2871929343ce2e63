"""Compiled kinematics of the 4-UPS/UPR platform (paper 004, Geng et al. 2014): the coupled
platform acceleration and the limbs' lengths, rates and accelerations along a motion, for
pinclear.mechanisms.four_ups_upr (numba).
"""
from __future__ import annotations

import math

import numpy as np

from pinclear.core.jit import njit


@njit(cache=True)
def _rotation(a, b, R):
    """R = R(x, a) R(y', b) (paper 004, eq. 3)."""
    ca, sa, cb, sb = math.cos(a), math.sin(a), math.cos(b), math.sin(b)
    R[0, 0], R[0, 1], R[0, 2] = cb, 0.0, sb
    R[1, 0], R[1, 1], R[1, 2] = sa * sb, ca, -sa * cb
    R[2, 0], R[2, 1], R[2, 2] = -ca * sb, sa, ca * cb


# 3-vectors as tuples in the compiled kernels below: no allocation per call (the drives ask
# for them at every right-hand side)
@njit(cache=True)
def _c(a, b):
    return a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]


@njit(cache=True)
def _sum(a, b, kb=1.0):
    """a + kb b."""
    return a[0] + kb * b[0], a[1] + kb * b[1], a[2] + kb * b[2]


@njit(cache=True)
def _mv(R, x, y, z):
    """R (x, y, z)."""
    return (R[0, 0] * x + R[0, 1] * y + R[0, 2] * z, R[1, 0] * x + R[1, 1] * y + R[1, 2] * z,
            R[2, 0] * x + R[2, 1] * y + R[2, 2] * z)


@njit(cache=True)
def _coupled_accel(x, xd, xdd, H, R, out):
    """out[0] = V = (omega; v_o), out[1] = A = (domega; a_o); R receives the rotation."""
    a, b = x[0], x[1]
    ad, bd = xd[0], xd[1]
    add, bdd = xdd[0], xdd[1]
    _rotation(a, b, R)
    ca, sa = math.cos(a), math.sin(a)
    w = (ad, bd * ca, bd * sa)                              # ad e_x + bd y', y' = (0, cos a, sin a)
    dw = (add, bdd * ca - bd * ad * sa, bdd * sa + bd * ad * ca)   # + bd d(y')/dt, d(y')/dt = ad e_x x y'
    Rp = _mv(R, x[2], 0.0, H + x[3])
    Rpd = _mv(R, xd[2], 0.0, xd[3])
    Rpdd = _mv(R, xdd[2], 0.0, xdd[3])
    wRp = _c(w, Rp)
    ppd = _sum(wRp, Rpd)                                    # eq. 4
    ppdd = _sum(_sum(_sum(_c(dw, Rp), _c(w, Rpd), 2.0), _c(w, wRp)), Rpdd)   # eq. 5
    vo = _sum(ppd, wRp, -1.0)                               # eq. 6
    ao = _sum(_sum(ppdd, _c(dw, Rp), -1.0), _c(w, ppd), -1.0)
    for i in range(3):
        out[0, i], out[0, 3 + i] = w[i], vo[i]
        out[1, i], out[1, 3 + i] = dw[i], ao[i]


@njit(cache=True)
def _limb_kinematics(R, p, V, A, bl, base, out):
    w, vo, dw, ao = (V[0], V[1], V[2]), (V[3], V[4], V[5]), (A[0], A[1], A[2]), (A[3], A[4], A[5])
    for i in range(bl.shape[0]):
        b = _sum(p, _mv(R, bl[i, 0], bl[i, 1], bl[i, 2]))    # world hinge point on the platform
        d = (b[0] - base[i, 0], b[1] - base[i, 1], b[2] - base[i, 2])
        ell = math.sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2])
        n = (d[0] / ell, d[1] / ell, d[2] / ell)
        bd = _sum(vo, _c(w, b))                             # velocity field of the platform twist
        ld = n[0] * bd[0] + n[1] * bd[1] + n[2] * bd[2]
        bdd = _sum(_sum(ao, _c(dw, b)), _c(w, bd))
        out[0, i] = ell
        out[1, i] = ld
        out[2, i] = (n[0] * bdd[0] + n[1] * bdd[1] + n[2] * bdd[2]
                     + (bd[0] * bd[0] + bd[1] * bd[1] + bd[2] * bd[2] - ld * ld) / ell)


@njit(cache=True)
def _limb_lengths_into(t, amp, w, H, bl, base, out):
    """limb_lengths at t written into out (3, 4): the motion law, the coupled motion and the
    limb kinematics in one compiled call (the drives ask for it at every right-hand side)."""
    x = (amp[0] * math.sin(w[0] * t), amp[1] * math.sin(w[1] * t), amp[2] * math.sin(w[2] * t),
         amp[3] * math.sin(w[3] * t))
    xd = (amp[0] * w[0] * math.cos(w[0] * t), amp[1] * w[1] * math.cos(w[1] * t),
          amp[2] * w[2] * math.cos(w[2] * t), amp[3] * w[3] * math.cos(w[3] * t))
    xdd = (-w[0] * w[0] * x[0], -w[1] * w[1] * x[1], -w[2] * w[2] * x[2], -w[3] * w[3] * x[3])
    R = np.empty((3, 3))
    VA = np.empty((2, 6))
    _coupled_accel(x, xd, xdd, H, R, VA)
    _limb_kinematics(R, _mv(R, x[2], 0.0, H + x[3]), VA[0], VA[1], bl, base, out)
