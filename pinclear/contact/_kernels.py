"""Compiled inner loops of the clearance joints (numba), for the same reason as
pinclear._kernels: the arithmetic per contact channel is a handful of flops, and ~30 small numpy
calls per right-hand side cost far more than the work. The maths is in pinclear.contact.base and
pinclear.contact.laws.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from pinclear._jit import njit
from pinclear.forces import add_wrenches, place_frames, relative_velocity


#: penetration (m) and rate ratio dd/dd0 beyond which the laws are held constant (never physical)
DELTA_CAP, RATE_CAP = 0.1, 1e6

#: friction codes (``FrictionLaw.kernel_params()``): the memoryless laws of pinclear.contact.laws,
#: and LuGre (three bristle states per channel in the joint's z)
F_NONE, F_COULOMB, F_MODIFIED, F_STICKSLIP, F_LUGRE = 0, 1, 2, 3, 4

# The laws below exist once: pinclear.contact.laws calls them through the vectorised wrappers
# (power_law_forces, damped_forces, friction_coefficients, memoryless_friction) and the joints
# through their kernels' channel loops (channel_forces, prismatic_energy_force). Formulas and sources: laws.py.


@njit(cache=True)
def damped(fe, dd, dd0, chi):
    """Hysteresis of the damped family: fe (1 + chi dd/dd0), clipped at zero (never pulls)."""
    f = fe * (1.0 + chi * min(max(dd / dd0, -RATE_CAP), RATE_CAP))
    return f if f > 0.0 else 0.0


@njit(cache=True)
def power_elastic(d, K, expo):
    """Elastic part K d^e of the power laws (zero out of contact)."""
    if d <= 0.0:
        return 0.0
    # trial stages of an explicit step may propose absurd states; keep the force finite so
    # the step is rejected by its error estimate rather than poisoned by inf/NaN
    return K * min(d, DELTA_CAP) ** expo


@njit(cache=True)
def power_law(d, dd, dd0, K, expo, chi):
    """(F, F_elastic) of the damped power law F = K d^e (1 + chi dd/dd0), clipped at zero."""
    if d <= 0.0:
        return 0.0, 0.0
    fe = power_elastic(d, K, expo)
    return damped(fe, dd, dd0, chi), fe


#: normal-law codes (``NormalLaw.kernel_params()``): damped power law K d^n; line law (paper 003 eq. 6)
N_POWER, N_LINE = 0, 1


@njit(cache=True)
def line_elastic(d, c, a):
    """Load P of a line contact at deflection d: the root of d = c P (1 - ln(a P)) (paper 003 eq.
    6 with c = 1/(pi E* l), a = R/(pi E* l^3)), by Newton on x = ln P from the linear estimate
    with the log at a typical load; steps clipped to +-2 in x."""
    if d <= 0.0:
        return 0.0
    x = math.log(d / (c * 10.0))
    for _ in range(60):
        P = math.exp(x)
        lg = math.log(a * P)
        step = (c * P * (1.0 - lg) - d) / (-c * P * lg)          # f / (df/dx), df/dx = P d'(P)
        x -= min(max(step, -2.0), 2.0)
        if abs(step) < 1e-13:
            break
    return math.exp(x)


@njit(cache=True)
def line_elastic_all(d, c, a, P):
    for k in range(d.shape[0]):
        P[k] = line_elastic(d[k], c, a)


@njit(cache=True)
def normal_force(code, d, dd, dd0, p0, p1, chi):
    """(F, F_elastic) of normal law ``code`` with parameters (p0, p1): (K, n) of a power law,
    (c, a) of the line law; the same hysteresis factor chi for both."""
    if code == N_LINE:
        if d <= 0.0:
            return 0.0, 0.0
        fe = line_elastic(d, p0, p1)
        return damped(fe, dd, dd0, chi), fe
    return power_law(d, dd, dd0, p0, p1, chi)


@njit(cache=True)
def friction_coefficient(code, par, s):
    """mu(|vt|) of the memoryless friction laws."""
    if code == F_COULOMB:
        return par[0] * s / (s * s + par[1] * par[1]) ** 0.5
    if code == F_MODIFIED:
        x = (s - par[1]) / (par[2] - par[1])
        return par[0] * min(max(x, 0.0), 1.0)
    if code == F_STICKSLIP:
        mu_s, mu_d, vs, vd = par[0], par[1], par[2], par[3]
        if s < vs:
            return mu_s * np.sin(0.5 * np.pi * s / vs)
        if s > vd:
            return mu_d
        return 0.5 * (mu_s + mu_d) + 0.5 * (mu_s - mu_d) * np.cos(np.pi * (s - vs) / (vd - vs))
    return 0.0


@njit(cache=True)
def friction_scale(code, par, s, fn):
    """g with Ft = -g vt for slip speed s = |vt| under the normal force fn (mu(s)/s stays finite
    at s = 0 for every law here, since mu ~ s near 0; s = 0 gives no force)."""
    if s > 0.0 and code != F_NONE:
        return friction_coefficient(code, par, s) * fn / s
    return 0.0


@njit(cache=True)
def power_energy(d, K, expo):
    """Potential of power_elastic: K d^(e+1)/(e+1), continued linearly beyond DELTA_CAP where the
    force is held constant (so the force stays its exact derivative everywhere)."""
    if d <= 0.0:
        return 0.0
    if d <= DELTA_CAP:
        return K * d ** (expo + 1.0) / (expo + 1.0)
    return K * DELTA_CAP ** expo * (DELTA_CAP / (expo + 1.0) + (d - DELTA_CAP))


@njit(cache=True)
def power_law_energy(d, K, expo, U):
    for k in range(d.shape[0]):
        U[k] = power_energy(d[k], K, expo)


@njit(cache=True)
def power_law_forces(d, dd, dd0, K, expo, chi, F, Fe):
    for k in range(d.shape[0]):
        F[k], Fe[k] = power_law(d[k], dd[k], dd0[k], K, expo, chi)


@njit(cache=True)
def power_law_elastic(d, K, expo, Fe):
    for k in range(d.shape[0]):
        Fe[k] = power_elastic(d[k], K, expo)


@njit(cache=True)
def damped_forces(fe, dd, dd0, chi, F):
    for k in range(fe.shape[0]):
        F[k] = damped(fe[k], dd[k], dd0[k], chi)


@njit(cache=True)
def friction_coefficients(code, par, s, mu):
    for k in range(s.shape[0]):
        mu[k] = friction_coefficient(code, par, s[k])


@njit(cache=True)
def memoryless_friction(code, par, Fn, vt, Ft):
    for k in range(vt.shape[0]):
        t0, t1, t2 = vt[k, 0], vt[k, 1], vt[k, 2]
        g = friction_scale(code, par, (t0 * t0 + t1 * t1 + t2 * t2) ** 0.5, Fn[k])
        Ft[k, 0] = -g * t0
        Ft[k, 1] = -g * t1
        Ft[k, 2] = -g * t2


@njit(cache=True)
def channel_force(k, f, vt, n, fcode, fpar, F2):
    """Channel k's force on body 2 from its normal load f: -f n plus memoryless friction
    -mu(|vt|) f vt/|vt|. Returns the friction's dissipated power -Ft . vt (>= 0)."""
    t0, t1, t2 = vt[k, 0], vt[k, 1], vt[k, 2]
    s = (t0 * t0 + t1 * t1 + t2 * t2) ** 0.5
    g = friction_scale(fcode, fpar, s, f)
    F2[k, 0] = -g * t0 - f * n[k, 0]
    F2[k, 1] = -g * t1 - f * n[k, 1]
    F2[k, 2] = -g * t2 - f * n[k, 2]
    return g * s * s


@njit(cache=True)
def lugre_channel(k, par, f, vt, n, zs, dzs, F2):
    """Channel k's force on body 2 under LuGre friction (Canudas de Wit et al. 1995, normalised
    by the normal load f, as laws.LuGre): the bristle deflection zs (3,) and the force are kept
    in the contact's tangent plane, which turns with the normal (a normal component would work on
    the penetration rate):

        z = zs - (zs . n) n,  g = mu_c + (mu_s - mu_c) exp(-(|vt|/vs)^2)
        dz/dt = vt - s0 |vt| z / g,  Ft = -f (s0 z + s1 dz/dt + s2 vt), less its normal part

    par = (mu_s, mu_c, vs, s0, s1, s2). Writes dz/dt into dzs and -f n + Ft into F2[k]; returns
    -Ft . vt (the friction power, bristle energy rate included: it may be negative)."""
    mu_s, mu_c, vs, s0, s1, s2 = par[0], par[1], par[2], par[3], par[4], par[5]
    n0, n1, n2 = n[k, 0], n[k, 1], n[k, 2]
    t0, t1, t2 = vt[k, 0], vt[k, 1], vt[k, 2]
    zn = zs[0] * n0 + zs[1] * n1 + zs[2] * n2
    z0, z1, z2 = zs[0] - zn * n0, zs[1] - zn * n1, zs[2] - zn * n2
    s = (t0 * t0 + t1 * t1 + t2 * t2) ** 0.5
    g = mu_c + (mu_s - mu_c) * math.exp(-(s / vs) ** 2)
    r = s0 * s / g
    d0, d1, d2 = t0 - r * z0, t1 - r * z1, t2 - r * z2
    dzs[0], dzs[1], dzs[2] = d0, d1, d2
    f0 = -f * (s0 * z0 + s1 * d0 + s2 * t0)
    f1 = -f * (s0 * z1 + s1 * d1 + s2 * t1)
    f2 = -f * (s0 * z2 + s1 * d2 + s2 * t2)
    fn = f0 * n0 + f1 * n1 + f2 * n2
    f0, f1, f2 = f0 - fn * n0, f1 - fn * n1, f2 - fn * n2
    F2[k, 0] = f0 - f * n0
    F2[k, 1] = f1 - f * n1
    F2[k, 2] = f2 - f * n2
    return -(f0 * t0 + f1 * t1 + f2 * t2)


@njit(cache=True)
def lugre_forces(par, Fn, vt, state, dstate, Ft):
    """laws.LuGre.force: lugre_channel on each row with no normal to project on (the joints
    project with theirs): friction forces into Ft, state rates into dstate."""
    none = np.zeros((vt.shape[0], 3))
    for k in range(vt.shape[0]):
        lugre_channel(k, par, Fn[k], vt, none, state[k], dstate[k], Ft)


class Geometry(NamedTuple):
    """A joint's compiled geometry: its code (G_* below) and parameters (channel_geometry)."""
    code: int
    gpar: np.ndarray


class Channels(NamedTuple):
    """What one workspace writes per contact channel (ClearanceData's arrays): penetration
    delta, outward normal n, contact points p1 (body 1) and p2 (body 2), normal rate dd, slip
    velocity vt, floored onset speed dd0, normal force Fn and its elastic part Fel, force F2 on
    body 2 at p2, and a (4, 3) work array of the geometry."""
    delta: np.ndarray
    n: np.ndarray
    p1: np.ndarray
    p2: np.ndarray
    dd: np.ndarray
    vt: np.ndarray
    dd0: np.ndarray
    Fn: np.ndarray
    Fel: np.ndarray
    F2: np.ndarray
    scratch: np.ndarray


class Laws(NamedTuple):
    """Each channel's normal law (``NormalLaw.kernel_params()``): code, p0, p1, hysteresis chi,
    weight W (the share of a line or plane load a corner carries), and the joint's floor vmin
    of the onset speed the damping divides by."""
    code: np.ndarray
    P0: np.ndarray
    P1: np.ndarray
    chi: np.ndarray
    W: np.ndarray
    vmin: float


class Friction(NamedTuple):
    """The joint's friction law (``FrictionLaw.kernel_params()``): its code and parameters."""
    code: int
    par: np.ndarray


class Modes(NamedTuple):
    """The prismatic joint's contact-mode classification (paper 003 Table 1): the four channels
    of each guide face, the mode number by (points, lines, planes), and the result (info:
    mode, counts, kind of each face)."""
    members: np.ndarray
    table: np.ndarray
    info: np.ndarray


class Foundation(NamedTuple):
    """The energy-consistent prismatic model's Winkler foundation: moduli kf of the x and y faces
    (Pa/m), hysteresis chi of the corner loads, onset-speed floor vmin, the clipped-polygon
    work array and the energy Uf of each face."""
    kf: np.ndarray
    chi: float
    vmin: float
    poly: np.ndarray
    Uf: np.ndarray


# The kernels below take the structured arguments above and unpack them once, at the top: the
# helpers they call take plain arrays, because handing a tuple of arrays to a compiled call, or
# reading its fields inside a loop of an inlined one, reference-counts every array each time
# (measured: the prismatic kernel ran 1.6x slower).


@njit(cache=True, inline="always")
def channel_friction(k, fcode, fpar, f, vt, n, F2, z, zdot):
    """Channel k's force on body 2 (F2[k]) from its normal load f and the friction law; for a
    law with states, their rates into zdot (same layout as z: [onset speeds (nc) | dissipated
    energy | 3 states per channel]). Returns the friction power -Ft . vt."""
    if fcode == F_LUGRE:
        b = n.shape[0] + 1 + 3 * k
        return lugre_channel(k, fpar, f, vt, n, z[b:b + 3], zdot[b:b + 3], F2)
    return channel_force(k, f, vt, n, fcode, fpar, F2)


@njit(cache=True, inline="always")
def free_flight(zdot, Fn, Fel, F2):
    """No channel touches: no force, nothing to integrate."""
    for k in range(zdot.shape[0]):
        zdot[k] = 0.0
    for k in range(Fn.shape[0]):
        Fn[k] = 0.0
        Fel[k] = 0.0
        F2[k, 0] = F2[k, 1] = F2[k, 2] = 0.0


@njit(cache=True, inline="always")
def onset_speeds(z, vmin, dd0, zdot):
    """dd0 = the recorded onset speeds floored at vmin (the damping divides by them); zdot = 0."""
    for k in range(zdot.shape[0]):
        zdot[k] = 0.0
    for k in range(dd0.shape[0]):
        dd0[k] = max(z[k], vmin)


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


#: geometry codes of the fused channel evaluation (``ClearanceJoint.geometry_code``)
G_SPHERICAL, G_PLANAR_REVOLUTE, G_REVOLUTE, G_PRISMATIC, G_WORN_PLANAR, G_WORN_SPHERICAL = 0, 1, 2, 3, 4, 5
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


@njit(cache=True)
def prismatic_geometry(gpar, M1, M2, delta, n, p1, p2):
    """Corners of the slider box (half sizes gpar[2:5] in frame 2) against the guide faces at
    +-a'/2 (x1) and +-b'/2 (y1), gpar[0:2] = (a'/2, b'/2), paper 003 eq. 1: channel 2k + 0 is
    corner k against its x face, 2k + 1 against its y face; corner k has the signs of its
    bits (4: x, 2: y, 1: z). Contact points: the corner itself on both bodies."""
    ha, hb = gpar[0], gpar[1]
    for k in range(8):
        s1 = 1.0 if k & 4 else -1.0
        s2 = 1.0 if k & 2 else -1.0
        s3 = 1.0 if k & 1 else -1.0
        cx, cy, cz = s1 * gpar[2], s2 * gpar[3], s3 * gpar[4]
        r0 = 0.0
        r1 = 0.0
        for i in range(3):
            P = M2[i, 3] + (cx * M2[i, 0] + cy * M2[i, 1] + cz * M2[i, 2])
            p1[2 * k, i] = p1[2 * k + 1, i] = p2[2 * k, i] = p2[2 * k + 1, i] = P
            r0 += (P - M1[i, 3]) * M1[i, 0]
            r1 += (P - M1[i, 3]) * M1[i, 1]
            n[2 * k, i] = s1 * M1[i, 0]
            n[2 * k + 1, i] = s2 * M1[i, 1]
        delta[2 * k] = s1 * r0 - ha
        delta[2 * k + 1] = s2 * r1 - hb


#: contact kinds of a guide face (pinclear.contact.prismatic.classify names them)
K_NONE, K_POINT, K_POINTS2, K_LINE_LONG, K_LINE_SHORT, K_PLANE = 0, 1, 2, 3, 4, 5


@njit(cache=True)
def prismatic_mode(delta, members, modes, info):
    """Contact kind of each guide face from its touching corners and the paper's mode (paper 003
    Table 1): info = (mode, points, lines, planes, kind of face 0..3). members[f] are the four
    channels of face f (channel 2k + d: corner k)."""
    pts = lines = planes = 0
    for f in range(4):
        m = 0
        c0 = c1 = -1
        for j in range(4):
            ch = members[f, j]
            if delta[ch] > 0.0:
                if m == 0:
                    c0 = ch
                elif m == 1:
                    c1 = ch
                m += 1
        kind = K_NONE
        if m == 1:
            kind = K_POINT
            pts += 1
        elif m == 2:
            # corners differ in one sign: they share an edge, along the slide axis (bit 0) or across
            x = (c0 // 2) ^ (c1 // 2)
            if x == 1:
                kind = K_LINE_LONG
                lines += 1
            elif x == 2 or x == 4:
                kind = K_LINE_SHORT
                lines += 1
            else:
                kind = K_POINTS2
                pts += 2
        elif m > 2:
            kind = K_PLANE
            planes += 1
        info[4 + f] = kind
    info[1], info[2], info[3] = pts, lines, planes
    info[0] = modes[pts, lines, planes]


@njit(cache=True)
def prismatic_laws(info, members, table, code, P0, P1, chi, W):
    """Each channel's normal law and weight for the face kinds in info: a point law per touching
    corner, half a line load per edge end, a quarter of a plane load per corner (paper 003 sec.
    2.2). table rows: point, line_long, line_x, line_y, plane_x, plane_y (code, p0, p1, chi)."""
    for f in range(4):
        kind = info[4 + f]
        row, w = 0, 0.0
        if kind == K_POINT or kind == K_POINTS2:
            row, w = 0, 1.0
        elif kind == K_LINE_LONG:
            row, w = 1, 0.5
        elif kind == K_LINE_SHORT:
            row, w = (2 if f < 2 else 3), 0.5
        elif kind == K_PLANE:
            row, w = (4 if f < 2 else 5), 0.25
        for j in range(4):
            ch = members[f, j]
            code[ch] = int(table[row, 0])
            P0[ch], P1[ch], chi[ch] = table[row, 1], table[row, 2], table[row, 3]
            W[ch] = w


@njit(cache=True)
def channel_geometry(code, gpar, M1, M2, scratch, delta, n, p1, p2):
    """The geometry hooks of the spherical and revolute joints (``_geometry``) from the frame
    placements M1 (socket/bearing) and M2 (ball/journal) as 4x4 homogeneous matrices.
    gpar = (c, R1, R2, ca, L); scratch is a (4, 3) work array: s, a, and two journal points."""
    if code == G_PRISMATIC:
        prismatic_geometry(gpar, M1, M2, delta, n, p1, p2)
        return
    if code == G_WORN_SPHERICAL:
        worn_spherical_geometry(gpar, M1, M2, delta, n, p1, p2, scratch)
        return
    c, R1, R2 = gpar[0], gpar[1], gpar[2]
    s, a, pts = scratch[0], scratch[1], scratch[2:4]
    for i in range(3):
        s[i] = M1[i, 3]
        a[i] = 0.0 if code == G_SPHERICAL else M1[i, 2]
        pts[0, i] = M2[i, 3]
    if code == G_WORN_PLANAR:
        worn_planar_geometry(gpar, M1, s, a, pts[0], delta, n, p1, p2, scratch)
        return
    if code != G_REVOLUTE:
        radial_geometry(s, a, pts[0:1], c, R1, R2, delta, n, p1, p2)
        return
    # journal ends against the bearing cylinder (channels 0, 1), centre against the thrust faces
    ca, half = gpar[3], 0.5 * gpar[4]
    u = 0.0
    for i in range(3):
        j = M2[i, 3]
        pts[0, i] = j + half * M2[i, 2]
        pts[1, i] = j - half * M2[i, 2]
        u += (j - s[i]) * a[i]
    radial_geometry(s, a, pts, c, R1, R2, delta[:2], n[:2], p1[:2], p2[:2])
    delta[2], delta[3] = u - ca, -u - ca
    for i in range(3):
        n[2, i], n[3, i] = a[i], -a[i]
        p1[2, i] = p1[3, i] = p2[2, i] = p2[3, i] = M2[i, 3]


@njit(cache=True, inline="always")
def channel_penetrations(geo, frames, ch, snap):
    """Penetration of every channel (the event values), values within ``snap`` of zero set to 0."""
    M, delta = frames.M, ch.delta
    place_frames(frames)
    channel_geometry(geo.code, geo.gpar, M[0], M[1], ch.scratch, delta, ch.n, ch.p1, ch.p2)
    for k in range(delta.shape[0]):
        if abs(delta[k]) < snap:
            delta[k] = 0.0


@njit(cache=True, inline="always")
def event_penetrations(geo, frames, ch, snap, g):
    """channel_penetrations into the event values g (ForceElement.event_kernel)."""
    channel_penetrations(geo, frames, ch, snap)
    delta = ch.delta
    for k in range(delta.shape[0]):
        g[k] = delta[k]


@njit(cache=True, inline="always")
def channel_forces(bodies, laws, fr, ch, v, z, tau, zdot):
    """After the geometry: relative velocity, each channel's normal law (times its weight W: the
    share of a line or plane load a corner carries) and the friction law, wrenches into tau;
    zdot = (0 per channel, dissipated power (Fn - Fel) dd - Ft . vt, friction-state rates).
    Returns the number of touching channels (0: free flight, no velocities computed, as in
    ClearanceJoint._compute)."""
    delta, n, p1, p2, dd, vt, dd0 = ch.delta, ch.n, ch.p1, ch.p2, ch.dd, ch.vt, ch.dd0
    Fn, Fel, F2 = ch.Fn, ch.Fel, ch.F2
    code, P0, P1, chi, W = laws.code, laws.P0, laws.P1, laws.chi, laws.W
    fcode, fpar = fr.code, fr.par
    nc = delta.shape[0]
    on = 0
    for k in range(nc):
        if delta[k] > 0.0:
            on += 1
    if on == 0:
        free_flight(zdot, Fn, Fel, F2)
        return 0
    relative_velocity(bodies.J, bodies.idx1, bodies.idx2, v, n, p1, p2, dd, vt)
    onset_speeds(z, laws.vmin, dd0, zdot)
    loss = 0.0
    for k in range(nc):
        f, fe = normal_force(code[k], delta[k], dd[k], dd0[k], P0[k], P1[k], chi[k])
        f *= W[k]
        fe *= W[k]
        Fn[k] = f
        Fel[k] = fe
        if delta[k] <= 0.0:
            F2[k, 0] = F2[k, 1] = F2[k, 2] = 0.0
            continue
        loss += (f - fe) * dd[k] + channel_friction(k, fcode, fpar, f, vt, n, F2, z, zdot)
    zdot[nc] = loss
    add_wrenches(bodies.J, bodies.idx1, bodies.idx2, F2, p1, p2, tau)
    return on


@njit(cache=True, inline="always")
def clearance_force(geo, frames, bodies, laws, fr, ch, v, z, tau, zdot):
    """One spherical or revolute clearance joint's whole right-hand-side contribution in one call,
    the same steps as ClearanceJoint._compute + add_force: its frames' placements from the
    workspace's frame kinematics, the geometry, then channel_forces."""
    M = frames.M
    place_frames(frames)
    channel_geometry(geo.code, geo.gpar, M[0], M[1], ch.scratch, ch.delta, ch.n, ch.p1, ch.p2)
    return channel_forces(bodies, laws, fr, ch, v, z, tau, zdot)


@njit(cache=True, inline="always")
def worn_clearance_force(geo, frames, bodies, laws, fr, ch, v, z, tau, zdot):
    """clearance_force of a worn planar bearing: the normal law's force scaled by |grad delta|
    (worn_planar_geometry leaves it in scratch[3, 0]; laws.W is this workspace's own array)."""
    M = frames.M
    place_frames(frames)
    channel_geometry(geo.code, geo.gpar, M[0], M[1], ch.scratch, ch.delta, ch.n, ch.p1, ch.p2)
    laws.W[0] = ch.scratch[3, 0]
    return channel_forces(bodies, laws, fr, ch, v, z, tau, zdot)


@njit(cache=True, inline="always")
def prismatic_force(geo, frames, bodies, modes, rows, laws, fr, ch, v, z, tau, zdot):
    """The prismatic clearance's right-hand-side contribution in one call (model paper003):
    placements, corner geometry, the contact mode and each channel's law from the law table
    ``rows`` (into ``laws``' arrays), then channel_forces."""
    M, delta, members, info = frames.M, ch.delta, modes.members, modes.info
    place_frames(frames)
    prismatic_geometry(geo.gpar, M[0], M[1], delta, ch.n, ch.p1, ch.p2)
    prismatic_mode(delta, members, modes.table, info)
    prismatic_laws(info, members, rows, laws.code, laws.P0, laws.P1, laws.chi, laws.W)
    return channel_forces(bodies, laws, fr, ch, v, z, tau, zdot)


#: layout of channel_record's output row: (name, start, size); potential last
RECORD = (("penetration", 0, 1), ("normal_force", 1, 3), ("friction_force", 4, 3), ("fn", 7, 1),
          ("contact", 8, 1), ("dissipated", 9, 1), ("eccentricity", 10, 3))
RECORD_SIZE = 14


@njit(cache=True)
def law_energy(code, d, p0, p1):
    """Elastic energy of normal law ``code`` at penetration d: K d^(n+1)/(n+1) for a power law,
    P d - int_0^P d(P') dP' for the line law (see laws.LineLaw)."""
    if d <= 0.0:
        return 0.0
    if code == N_LINE:
        P = line_elastic(d, p0, p1)
        if P <= 0.0:
            return 0.0
        return P * d - p0 * (0.75 * P * P - 0.5 * P * P * math.log(p1 * P))
    return power_energy(d, p0, p1)


@njit(cache=True)
def channel_record(delta, n, Fn, F2, M1, M2, dissipated, code, P0, P1, W, out):
    """One output sample of a clearance joint (ClearanceJoint.outputs, in the RECORD layout) and
    its elastic energy, from what the fused evaluation left: the deepest penetration, the normal
    and friction resultants on body 2 (world), the total normal force, contact (0/1), the
    dissipated energy, frame 2's origin in frame 1 axes (paper 000 eq. 3)."""
    out[:] = 0.0
    out[0] = delta[0]
    for k in range(delta.shape[0]):
        out[0] = max(out[0], delta[k])
        for i in range(3):
            out[1 + i] -= Fn[k] * n[k, i]
            out[4 + i] += F2[k, i] + Fn[k] * n[k, i]
        out[7] += Fn[k]
        if delta[k] > 0.0:
            out[8] = 1.0
            out[13] += W[k] * law_energy(code[k], delta[k], P0[k], P1[k])
    out[9] = dissipated
    for i in range(3):
        acc = 0.0
        for j in range(3):
            acc += M1[j, i] * (M2[j, 3] - M1[j, 3])
        out[10 + i] = acc


@njit(cache=True)
def clearance_record(ch, M, z, zdot, nc, code, P0, P1, W, work, row):
    """One output sample of a clearance joint (ClearanceJoint.record after its compiled force at
    this state): row = [elastic energy, dissipated power (the rate of its dissipation state), the
    RECORD outputs]."""
    channel_record(ch.delta, ch.n, ch.Fn, ch.F2, M[0], M[1], z[nc], code, P0, P1, W, work)
    row[0] = work[RECORD_SIZE - 1]
    row[1] = zdot[nc]
    for i in range(RECORD_SIZE - 1):
        row[2 + i] = work[i]


@njit(cache=True)
def worn_record(ch, M, z, zdot, nc, code, P0, P1, W, work, row):
    """clearance_record followed by the slip speed |vt| of the contact (0 without load): the
    Archard wear integrand's speed (pinclear.contact.wear)."""
    clearance_record(ch, M, z, zdot, nc, code, P0, P1, W, work, row)
    vt = ch.vt
    slip = (vt[0, 0] * vt[0, 0] + vt[0, 1] * vt[0, 1] + vt[0, 2] * vt[0, 2]) ** 0.5
    row[RECORD_SIZE + 1] = slip if ch.Fn[0] > 0.0 else 0.0


@njit(cache=True)
def total_normal_force(Fn, out, k):
    """out[k] = the joint's total normal force (the ``fn`` output): its contact-force peak's value."""
    acc = 0.0
    for i in range(Fn.shape[0]):
        acc += Fn[i]
    out[k] = acc


# ------------------------------------------------------------------ energy-consistent prismatic model
# Each of the slider's four side faces rests on a linear elastic foundation (Winkler) against
# the guide face it can reach: pressure p = kf delta(xi, eta) where it penetrates. The slider is
# rigid, so delta is affine over the face, and the penetrated region is the face rectangle
# clipped by a line. Potential U = kf/2 int delta^2 dA; its gradient is the virtual work of p,
# which bilinear shape functions N_j (exact for an affine field) lump onto the face's corner
# channels: F_j = int p N_j dA >= 0. Integrated exactly (degree-3 rule on the triangles of the
# clipped polygon), so the forces are the exact gradient of the reported energy and a corner, an
# edge and a face are limits of one law (F ~ delta^3, delta^2, delta). Maths: docs/contact_models.md.


@njit(cache=True)
def _tri_moments(x0, y0, d0, x1, y1, d1, x2, y2, d2):
    """int over the triangle of (d, d x, d y, d x y, d^2/2) for an affine d (vertex values d_i):
    the 7-point rule exact to degree 3 (vertices 3/60, edge midpoints 8/60, centroid 27/60)."""
    A = 0.5 * abs((x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0))
    s0 = s1 = s2 = s3 = s4 = 0.0
    for i in range(7):
        if i < 3:
            w = 3.0
            if i == 0:
                x, y, d = x0, y0, d0
            elif i == 1:
                x, y, d = x1, y1, d1
            else:
                x, y, d = x2, y2, d2
        elif i < 6:
            w = 8.0
            if i == 3:
                x, y, d = 0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5 * (d0 + d1)
            elif i == 4:
                x, y, d = 0.5 * (x1 + x2), 0.5 * (y1 + y2), 0.5 * (d1 + d2)
            else:
                x, y, d = 0.5 * (x2 + x0), 0.5 * (y2 + y0), 0.5 * (d2 + d0)
        else:
            w = 27.0
            x, y, d = (x0 + x1 + x2) / 3.0, (y0 + y1 + y2) / 3.0, (d0 + d1 + d2) / 3.0
        s0 += w * d
        s1 += w * d * x
        s2 += w * d * y
        s3 += w * d * x * y
        s4 += w * 0.5 * d * d
    A /= 60.0
    return A * s0, A * s1, A * s2, A * s3, A * s4


#: rectangle corners in cyclic order as member indices j (xi sign: bit 1, eta sign: bit 0)
_CYCLE = (0, 2, 3, 1)


@njit(cache=True)
def foundation_face(d, hx, hy, kf, poly, F):
    """Nodal loads F[j] (j: member index, xi sign bit 1, eta sign bit 0) of a Winkler foundation
    of modulus kf (Pa/m) on the rectangle |xi| <= hx, |eta| <= hy, for the corner penetrations d
    (4,), and its elastic energy (returned). The affine field is the least-squares plane of the
    four corner values (equal to them for a rigid slider up to round-off)."""
    c0 = 0.25 * (d[0] + d[1] + d[2] + d[3])
    gx = 0.25 * ((d[2] + d[3]) - (d[0] + d[1])) / hx
    gy = 0.25 * ((d[1] + d[3]) - (d[0] + d[2])) / hy
    F[0] = F[1] = F[2] = F[3] = 0.0
    if c0 + abs(gx) * hx + abs(gy) * hy <= 0.0:
        return 0.0
    # clip the rectangle by delta > 0 (Sutherland-Hodgman, one line): at most 5 vertices
    m = 0
    for i in range(4):
        ji, jn = _CYCLE[i], _CYCLE[(i + 1) % 4]
        xi = hx if ji & 2 else -hx
        yi = hy if ji & 1 else -hy
        xn = hx if jn & 2 else -hx
        yn = hy if jn & 1 else -hy
        di = c0 + gx * xi + gy * yi
        dn = c0 + gx * xn + gy * yn
        if di > 0.0:
            poly[m, 0], poly[m, 1], poly[m, 2] = xi, yi, di
            m += 1
        if (di > 0.0) != (dn > 0.0):
            t = di / (di - dn)
            poly[m, 0], poly[m, 1], poly[m, 2] = xi + t * (xn - xi), yi + t * (yn - yi), 0.0
            m += 1
    I0 = Ix = Iy = Ixy = U = 0.0
    for i in range(1, m - 1):
        a0, a1, a2, a3, a4 = _tri_moments(poly[0, 0], poly[0, 1], poly[0, 2], poly[i, 0], poly[i, 1], poly[i, 2],
                                          poly[i + 1, 0], poly[i + 1, 1], poly[i + 1, 2])
        I0 += a0
        Ix += a1
        Iy += a2
        Ixy += a3
        U += a4
    # N_j = (1 + sx xi/hx)(1 + sy eta/hy)/4
    for j in range(4):
        sx = 1.0 if j & 2 else -1.0
        sy = 1.0 if j & 1 else -1.0
        F[j] = 0.25 * kf * (I0 + sx * Ix / hx + sy * Iy / hy + sx * sy * Ixy / (hx * hy))
    return kf * U


@njit(cache=True)
def prismatic_foundation(gpar, kf, members, delta, poly, Fel, Uf):
    """Elastic nodal loads Fel of every corner channel and the energy Uf[f] of each face f
    (0, 1: the x faces, modulus kf[0], half widths b/2 x L/2; 2, 3: the y faces, kf[1], a/2 x
    L/2). members[f, j]: face f's channel with xi sign bit 1, eta sign bit 0 of j (the
    prismatic module's face table). Returns the number of faces in contact."""
    d4 = poly[5, 0:4]
    F4 = poly[6, 0:4]
    on = 0
    for f in range(4):
        for j in range(4):
            d4[j] = delta[members[f, j]]
        hx = gpar[3] if f < 2 else gpar[2]
        U = foundation_face(d4, hx, gpar[4], kf[0] if f < 2 else kf[1], poly, F4)
        Uf[f] = U
        if U > 0.0:
            on += 1
        for j in range(4):
            Fel[members[f, j]] = F4[j]
    return on


@njit(cache=True, inline="always")
def prismatic_energy_force(geo, frames, bodies, modes, found, fr, ch, v, z, tau, zdot):
    """The energy-consistent prismatic clearance's right-hand-side contribution in one call:
    placements, corner geometry, the paper's mode (an output only), the foundation's corner
    loads Fel, then per loaded corner the damping F = Fel (1 + chi dd/dd0) clipped at zero and
    friction from F, and the wrenches. zdot = (0 per channel, dissipated power (F - Fel) dd -
    Ft . vt, friction-state rates). Returns the number of faces in contact."""
    delta, n, p1, p2, dd, vt, dd0 = ch.delta, ch.n, ch.p1, ch.p2, ch.dd, ch.vt, ch.dd0
    Fn, Fel, F2 = ch.Fn, ch.Fel, ch.F2
    M, gpar, members = frames.M, geo.gpar, modes.members
    fcode, fpar, chi = fr.code, fr.par, found.chi
    place_frames(frames)
    prismatic_geometry(gpar, M[0], M[1], delta, n, p1, p2)
    prismatic_mode(delta, members, modes.table, modes.info)
    on = prismatic_foundation(gpar, found.kf, members, delta, found.poly, Fel, found.Uf)
    if on == 0:
        free_flight(zdot, Fn, Fel, F2)
        return 0
    relative_velocity(bodies.J, bodies.idx1, bodies.idx2, v, n, p1, p2, dd, vt)
    onset_speeds(z, found.vmin, dd0, zdot)
    loss = 0.0
    for k in range(delta.shape[0]):
        fe = Fel[k]
        if fe <= 0.0:
            Fn[k] = 0.0
            F2[k, 0] = F2[k, 1] = F2[k, 2] = 0.0
            continue
        f = damped(fe, dd[k], dd0[k], chi)
        Fn[k] = f
        loss += (f - fe) * dd[k] + channel_friction(k, fcode, fpar, f, vt, n, F2, z, zdot)
    zdot[delta.shape[0]] = loss
    add_wrenches(bodies.J, bodies.idx1, bodies.idx2, F2, p1, p2, tau)
    return on
