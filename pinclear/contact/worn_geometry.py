"""Compiled geometry of the worn clearances: the worn bearing's profile (a periodic cubic spline
over the wear nodes) and the worn socket's mesh (Catmull-Rom), with the penetration, normal and
contact points a worn channel needs (pinclear.contact.wear, pinclear.contact.wear_spherical).
"""
from __future__ import annotations

import math

from pinclear.core.jit import njit

#: worn planar bearing: gpar = (c, R1, R2, ca, L, N, then the periodic cubic spline's 4 N
#: coefficients of the wear depth, cell i = [i, i + 1) 2 pi / N, highest power first)
WORN_HEAD = 6


@njit(cache=True)
def worn_depth(gpar, theta):
    """(w, dw/dtheta): wear depth of the bearing at its own angle theta (rad, frame1 x towards y),
    from the periodic cubic spline in gpar (C2 in theta: penetration and normal continuous)."""
    N = int(gpar[5])
    h = 2.0 * math.pi / N
    t = theta % (2.0 * math.pi)
    i = min(int(t / h), N - 1)
    x = t - i * h
    b = WORN_HEAD + 4 * i
    c3, c2, c1, c0 = gpar[b], gpar[b + 1], gpar[b + 2], gpar[b + 3]
    return ((c3 * x + c2) * x + c1) * x + c0, (3.0 * c3 * x + 2.0 * c2) * x + c1


@njit(cache=True)
def worn_planar_geometry(gpar, M1, s, a, j, delta, n, p1, p2, scratch):
    """A journal (centre j, radius R2) in a worn bearing of radius R1 + w(theta): with e the
    eccentricity in the bearing plane, r = |e|, theta its angle in frame1,
    delta = r - c - w(theta) (the penetration measured along e, as worn-joint models take it:
    Flores 2009, Mech. Mach. Theory 44, 1211, eq. 5) and n the unit direction of grad delta =
    e/r - (w'/r) t (t = a x e/r). The contact points lie on the line through j along n (p2 = j +
    R2 n, p1 = j + (R2 - delta) n), so n . (v2(p2) - v1(p1)) = d(delta)/dt / |grad delta|:
    scratch[3, 0] = |grad delta|, the factor the normal law's force is scaled by (the force is
    then -F(delta) grad delta, the exact gradient of the law's energy)."""
    c, R2 = gpar[0], gpar[2]
    e0, e1, e2 = j[0] - s[0], j[1] - s[1], j[2] - s[2]
    u = e0 * a[0] + e1 * a[1] + e2 * a[2]
    e0 -= u * a[0]
    e1 -= u * a[1]
    e2 -= u * a[2]
    ex = e0 * M1[0, 0] + e1 * M1[1, 0] + e2 * M1[2, 0]
    ey = e0 * M1[0, 1] + e1 * M1[1, 1] + e2 * M1[2, 1]
    r = (e0 * e0 + e1 * e1 + e2 * e2) ** 0.5
    w, dw = worn_depth(gpar, math.atan2(ey, ex))
    if r > 0.0:
        r0, r1, r2 = e0 / r, e1 / r, e2 / r
    else:
        r0, r1, r2 = M1[0, 0], M1[1, 0], M1[2, 0]
    # far from any surface (r < c / 2: delta < 0) the tangential term is dropped (it grows as 1/r)
    k = dw / r if r > 0.5 * c else 0.0
    t0, t1, t2 = a[1] * r2 - a[2] * r1, a[2] * r0 - a[0] * r2, a[0] * r1 - a[1] * r0
    g = (1.0 + k * k) ** 0.5
    n0, n1, n2 = (r0 - k * t0) / g, (r1 - k * t1) / g, (r2 - k * t2) / g
    d = r - c - w
    delta[0] = d
    n[0, 0], n[0, 1], n[0, 2] = n0, n1, n2
    p2[0, 0], p2[0, 1], p2[0, 2] = j[0] + R2 * n0, j[1] + R2 * n1, j[2] + R2 * n2
    p1[0, 0], p1[0, 1], p1[0, 2] = j[0] + (R2 - d) * n0, j[1] + (R2 - d) * n1, j[2] + (R2 - d) * n2
    scratch[3, 0] = g


#: worn spherical socket: gpar = (c, R1, R2, pole axis of frame1 (0, 1, 2), 0, Nt, Np, then the Nt x Np node
#: depths row by row: row i at theta = (i + 1/2) pi / Nt from the pole, column j at phi = 2 pi j / Np)
WORN_SPHERE_HEAD = 7


@njit(cache=True)
def sphere_node(gpar, i, j):
    """Depth of socket node (row i, column j); rows continue across the poles (row -1 - k is row k
    at phi + pi, row Nt + k is row Nt - 1 - k at phi + pi: the great circle through the pole)."""
    Nt, Np = int(gpar[5]), int(gpar[6])
    if i < 0:
        i = -1 - i
        j += Np // 2
    elif i >= Nt:
        i = 2 * Nt - 1 - i
        j += Np // 2
    return gpar[WORN_SPHERE_HEAD + i * Np + (j % Np)]


@njit(cache=True)
def catmull_rom(x, f0, f1, f2, f3):
    """(value, d/dx) at x in [0, 1] of the Catmull-Rom cubic between f1 (x = 0) and f2 (x = 1) of
    four equally spaced values: passes through the nodes, C1, local (Catmull & Rom 1974)."""
    x2 = x * x
    x3 = x2 * x
    v = 0.5 * ((-x3 + 2.0 * x2 - x) * f0 + (3.0 * x3 - 5.0 * x2 + 2.0) * f1 + (-3.0 * x3 + 4.0 * x2 + x) * f2
               + (x3 - x2) * f3)
    d = 0.5 * ((-3.0 * x2 + 4.0 * x - 1.0) * f0 + (9.0 * x2 - 10.0 * x) * f1 + (-9.0 * x2 + 8.0 * x + 1.0) * f2
               + (3.0 * x2 - 2.0 * x) * f3)
    return v, d


@njit(cache=True)
def sphere_row(gpar, i, j, y):
    """catmull_rom along row i at column j + y."""
    return catmull_rom(y, sphere_node(gpar, i, j - 1), sphere_node(gpar, i, j), sphere_node(gpar, i, j + 1),
                       sphere_node(gpar, i, j + 2))


@njit(cache=True)
def worn_sphere_depth(gpar, theta, phi):
    """(w, dw/dtheta, dw/dphi): wear depth of the socket at the direction (theta from the mesh pole,
    phi), the tensor Catmull-Rom interpolant of the node depths (C1, local: 4 x 4 nodes). Where the
    two rows next to a pole carry no wear (contact.wear_spherical checks it) the field is exactly 0
    within half a row of the pole, so it is continuous through the pole too."""
    Nt, Np = int(gpar[5]), int(gpar[6])
    ht, hp = math.pi / Nt, 2.0 * math.pi / Np
    tt = theta / ht - 0.5
    i = int(math.floor(tt))
    x = tt - i
    ss = (phi % (2.0 * math.pi)) / hp
    j = int(math.floor(ss))
    y = ss - j
    v0, d0 = sphere_row(gpar, i - 1, j, y)
    v1, d1 = sphere_row(gpar, i, j, y)
    v2, d2 = sphere_row(gpar, i + 1, j, y)
    v3, d3 = sphere_row(gpar, i + 2, j, y)
    w, wt = catmull_rom(x, v0, v1, v2, v3)
    wp = catmull_rom(x, d0, d1, d2, d3)[0]
    return w, wt / ht, wp / hp


@njit(cache=True)
def worn_spherical_geometry(gpar, M1, M2, delta, n, p1, p2, scratch):
    """A ball (centre M2, radius R2) in a worn socket of radius R1 + w(direction): e = ball centre -
    socket centre, r = |e|, u = e/r, delta = r - c - w(u) (along e, as the worn revolute:
    worn_planar_geometry) and n the unit direction of grad delta = u - (w_theta e_theta + w_phi /
    sin(theta) e_phi)/r in the mesh's spherical coordinates (frame1 axes cyclically permuted so the
    pole is the third). Contact points on the line through the ball centre along n; scratch[3, 0] =
    |grad delta|, the factor of the law's force (force = -F(delta) grad delta, energy-exact)."""
    c, R2 = gpar[0], gpar[2]
    ip = int(gpar[3])
    ia, ib = (ip + 1) % 3, (ip + 2) % 3
    e0, e1, e2 = M2[0, 3] - M1[0, 3], M2[1, 3] - M1[1, 3], M2[2, 3] - M1[2, 3]
    ea = e0 * M1[0, ia] + e1 * M1[1, ia] + e2 * M1[2, ia]
    eb = e0 * M1[0, ib] + e1 * M1[1, ib] + e2 * M1[2, ib]
    ep = e0 * M1[0, ip] + e1 * M1[1, ip] + e2 * M1[2, ip]
    r = (ea * ea + eb * eb + ep * ep) ** 0.5
    if r > 0.0:
        ua, ub, up = ea / r, eb / r, ep / r
    else:
        ua, ub, up = 1.0, 0.0, 0.0
    th = math.acos(min(max(up, -1.0), 1.0))
    ph = math.atan2(ub, ua)
    w, wt, wp = worn_sphere_depth(gpar, th, ph)
    st, ct, sp, cp = math.sin(th), math.cos(th), math.sin(ph), math.cos(ph)
    # far from the surface (r < c/2: delta < 0) the tangential terms (~1/r) are dropped; wp is 0
    # where sin(theta) is (the field vanishes near the poles)
    kt = wt / r if r > 0.5 * c else 0.0
    kp = wp / (st * r) if (r > 0.5 * c and wp != 0.0) else 0.0
    ga, gb, gp = ua - kt * ct * cp + kp * sp, ub - kt * ct * sp - kp * cp, up + kt * st
    g = (1.0 + kt * kt + kp * kp) ** 0.5
    d = r - c - w
    delta[0] = d
    for i in range(3):
        ni = (M1[i, ia] * ga + M1[i, ib] * gb + M1[i, ip] * gp) / g
        n[0, i] = ni
        p2[0, i] = M2[i, 3] + R2 * ni
        p1[0, i] = M2[i, 3] + (R2 - d) * ni
    scratch[3, 0] = g
