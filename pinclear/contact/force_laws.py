"""The normal-force and friction laws of the clearance contacts, compiled once (numba): scalar
laws, their vectorised wrappers (pinclear.contact.laws calls these) and the per-channel friction.
Formulas and sources: pinclear.contact.laws.
"""
from __future__ import annotations

import math

import numpy as np

from pinclear.core.jit import njit

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
