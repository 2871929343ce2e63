"""Compiled geometry of the radial clearances (revolute journal in its bearing, ball in its
socket): penetration, normal and contact points of one channel (paper 002 eqs. 1-6).
"""
from __future__ import annotations

from pinclear.core.jit import njit


@njit(cache=True)
def radial_geometry(s, a, pts, c, R1, R2, delta, n, p1, p2):
    """Journal points pts (m, 3) in a bearing of centre s and unit axis a (a = 0: a spherical
    socket): eccentricity e = pt - s less its axial part u a, n = e/|e|, delta = |e| - c,
    bearing point p1 = s + u a + R1 n (at the journal point's axial station), journal point
    p2 = pt + R2 n (paper 000 eqs. 3-9, paper 002 eqs. 1-3 and 6)."""
    for k in range(pts.shape[0]):
        e0, e1, e2 = pts[k, 0] - s[0], pts[k, 1] - s[1], pts[k, 2] - s[2]
        u = e0 * a[0] + e1 * a[1] + e2 * a[2]
        e0 -= u * a[0]
        e1 -= u * a[1]
        e2 -= u * a[2]
        el = (e0 * e0 + e1 * e1 + e2 * e2) ** 0.5
        if el > 0.0:
            n0, n1, n2 = e0 / el, e1 / el, e2 / el
        else:
            # centred: any radial direction (the force is zero there anyway)
            if abs(a[0]) < 0.9:
                n0, n1, n2 = 0.0, a[2], -a[1]
            else:
                n0, n1, n2 = -a[2], 0.0, a[0]
            nn = (n0 * n0 + n1 * n1 + n2 * n2) ** 0.5
            if nn > 0.0:
                n0, n1, n2 = n0 / nn, n1 / nn, n2 / nn
            else:
                n0, n1, n2 = 1.0, 0.0, 0.0
        delta[k] = el - c
        n[k, 0], n[k, 1], n[k, 2] = n0, n1, n2
        p1[k, 0] = s[0] + u * a[0] + R1 * n0
        p1[k, 1] = s[1] + u * a[1] + R1 * n1
        p1[k, 2] = s[2] + u * a[2] + R1 * n2
        p2[k, 0] = pts[k, 0] + R2 * n0
        p2[k, 1] = pts[k, 1] + R2 * n1
        p2[k, 2] = pts[k, 2] + R2 * n2
