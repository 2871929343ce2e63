"""Lubricated planar revolute clearance: a hydrodynamic journal bearing in mixed lubrication.

Film (Reynolds' equation for an incompressible isoviscous film; the short- and long-bearing
approximations as the clearance-joint literature takes them from Pinkus & Sternlicht 1961, Theory
of Hydrodynamic Lubrication, ch. 4 and 13, e.g. Flores et al. 2009, Nonlinear Dyn. 56, 277, eqs.
4-13). With e the eccentricity of the journal centre in the bearing frame, eps = |e| / c, phi the
angle from the line of centres' far side (film h = c q, q = 1 + eps cos phi), the relative spin
w = w_journal - w_bearing and the whirl gdot (rate of e's direction in the bearing frame), the
wedge speed is Om = w - 2 gdot and

* short bearing (Ocvirk; L/D small), integrated across the length:
  P(phi) = mu L^3 / (2 c^2) (Om eps sin phi - 2 eps_dot cos phi) / q^3;
* long bearing (Sommerfeld; L/D large), times L:
  P(phi) = 6 mu R^2 L / c^2 [Om eps sin phi (2 + eps cos phi) / ((2 + eps^2) q^2)
           + (eps_dot / eps) (q^-2 - (1 + eps)^-2)]
  (ambient pressure at the widest gap, phi = 0).

The film carries load down to contact: the gap's minimum in q is held at ``FLOOR`` x sigma (sigma
the combined roughness, mixed.py; short: eps in q capped at 1 - FLOOR sigma / c, long: q floored
there), a gap inside the roughness where the asperities carry the load; above it the film is the
smooth-surface film unchanged.

Integration: the short bearing in closed form (``short_bearing``: Sommerfeld's substitution makes
every integrand a trigonometric polynomial, and its full-film arc is one arc of known ends, so its
loads are exact at any eps, down to contact); the long bearing by the periodic trapezoid over NPHI
points (the Guembel kinks make it second order). The long bearing's squeeze term, with the ambient
pressure at the widest gap, jumps where e passes through the centre (the widest gap flips side):
a limit of that boundary condition (the short bearing's force is continuous there).

Cavitation: Guembel's half-Sommerfeld condition, the film carries no tension: P+ = max(P, 0).
At a steady load (eps_dot = gdot = 0) this gives the closed forms of the load and attitude angle
(short: W = mu w R L^3 eps sqrt(16 eps^2 + pi^2 (1 - eps^2)) / (4 c^2 (1 - eps^2)^2), tan psi =
pi sqrt(1 - eps^2) / (4 eps); long: W = 6 mu w R^3 L eps sqrt(pi^2 - eps^2 (pi^2 - 4)) /
(c^2 (2 + eps^2)(1 - eps^2)), tan psi = pi sqrt(1 - eps^2) / (2 eps)) that tests/contact/test_lubricated.py
checks through the coupled dynamics.

Force on the journal: F = R int P+ (cos phi e_hat + sin phi t_hat) dphi (t_hat = axis x e_hat),
its reaction on the bearing. Torque of the film's shear on the journal (Pinkus & Sternlicht eq.
4-47, the Poiseuille part by parts): T_j = -(mu R^3 L w / c) S - (|e| / 2) F_t. The Couette part
acts over the full-film arc only, S = int_{P > 0} dphi / q: where Guembel's film has ruptured the
gap holds no continuous film and carries no shear (the half-Sommerfeld friction; for a steady
journal, P > 0 on exactly half the circle, S = pi / sqrt(1 - eps^2), half of Petroff's full
film; where the film carries no pressure at all, S is half the circle's integral, the limit of a
vanishing load). On the bearing the opposite of the journal's moment (the film holds no
momentum). The power of these loads on the two bodies is

    P_film = -(R c / 2) int P+ (Om eps sin phi - 2 eps_dot cos phi) dphi - (mu R^3 L w^2 / c) S

<= 0 at every state. Proof: S >= 0; for the short bearing P+ > 0 only where the bracket is (q > 0);
for the long bearing, where P+ > 0 is not tied to the bracket's sign when squeeze and wedge mix,
Reynolds' equation (h^3 P')' = -6 mu R^2 c (bracket) integrated by parts over each interval where
P > 0 (P+ vanishes at its ends) gives int P+ (bracket) = int_{P>0} h^3 P'^2 / (6 mu R^2 c) >= 0
(exact above the floor of q; tests/contact/test_lubricated.py checks both at random states, also
below the floor, the long one to the quadrature's error). The film only dissipates; its
dissipation is a state of the joint (output ``film_dissipated``) and part of the energy audit's
E_diss.

Dry contact, asperities and friction: contact/mixed.py (FilmJoint): the dry law acts on the
penetration |e| - c of the full clearance, the asperities (Greenwood-Tripp) share the load when
h_min = c - |e| is within a few sigma, and every load is compiled in one kernel.
"""
from __future__ import annotations

import math

import numpy as np

from pinclear.contact.channels import channel_geometry
from pinclear.contact.mixed import KEYS as MIXED_KEYS
from pinclear.contact import channels
from pinclear.contact.mixed import FilmJoint, WornFilmJoint, apply_loads, centre_rates, contact_loads, film_spec
from pinclear.contact.revolute import (_PLANAR, _PLOT, _WEAR, RevoluteClearance, WornRevoluteClearance,
                                       check_bearing_radius)
from pinclear.contact.revolute import from_spec as _dry_from_spec
from pinclear.core.jit import njit
from pinclear.core.registry import Key, PluginType, key_names
from pinclear.model.forces import place_frames

THEORIES = ("short", "long")
#: quadrature points of the long bearing over the circumference (trapezoid, periodic; the Guembel
#: kinks at P = 0 make it second order: 4096 points keep the steady load within 1e-5 of the closed
#: forms at eps 0.9)
NPHI = 1024
_PHI = np.arange(NPHI) * (2.0 * math.pi / NPHI)
_COS, _SIN = np.cos(_PHI), np.sin(_PHI)

_LUB = (MIXED_KEYS[0], Key("theory", "string", "-", "short", ", ".join(THEORIES), "Pinkus & Sternlicht 1961 ch. 4",
                           "short (Ocvirk) or long (Sommerfeld) bearing")) + MIXED_KEYS[1:]
#: the film keys every lubricated type takes (lubricated_spherical.py has no bearing theory)
FILM_KEYS = MIXED_KEYS


@njit(cache=True, inline="always")
def _pressure(long, k, eps, eps_dot, Om, qmin, co, si):
    """(P, 1 / q) at one angle (cos, sin = co, si) before cavitation (module doc); k the scale."""
    q = max(1.0 + eps * co, qmin)
    if long:
        wedge = Om * eps * si * (2.0 + eps * co) / ((2.0 + eps * eps) * q * q)
        # squeeze: (eps_dot / eps)(q^-2 - (1 + eps)^-2), written without the 1/eps (finite at eps = 0)
        squeeze = eps_dot * (1.0 - co) * (2.0 + eps * (1.0 + co)) / ((1.0 + eps) ** 2 * q * q)
        return k * (wedge + squeeze), 1.0 / q
    q = 1.0 + min(eps, 1.0 - qmin) * co
    return k * (Om * eps * si - 2.0 * eps_dot * co) / (q * q * q), 1.0 / q


@njit(cache=True)
def journal_pressure(long, mu, R, L, c, qmin, eps, eps_dot, Om, P):
    """P(phi) (N/m, integrated over the length) at the quadrature angles, before cavitation."""
    k = 6.0 * mu * R * R * L / (c * c) if long else mu * L ** 3 / (2.0 * c * c)
    for i in range(NPHI):
        P[i] = _pressure(long, k, eps, eps_dot, Om, qmin, _COS[i], _SIN[i])[0]


@njit(cache=True, inline="always")
def short_bearing(k, eps, A, B, qmin):
    """(F_e, F_t per unit R, the full-film shear integral S) of the short bearing in closed form:
    P = k (A sin phi + B cos phi) / q^3 with q = 1 + e cos phi, e = min(eps, 1 - qmin) (module doc).
    Sommerfeld's substitution cos phi = (cos g - e) / (1 - e cos g) turns q^-3 dphi into
    (1 - e cos g)^2 dg / (1 - e^2)^(5/2) and dphi / q into dg / sqrt(1 - e^2): the integrands are
    trigonometric polynomials of degree 2 in g, and P > 0 on the one arc where
    a sin g + b cos g > B e (a = A sqrt(1 - e^2), b = B), of half-angle pi / 2 - asin(B e / rho)."""
    e = min(eps, 1.0 - qmin)
    w = (1.0 - e * e) ** 0.5
    a, b = A * w, B
    rho = (a * a + b * b) ** 0.5
    if rho == 0.0:
        return 0.0, 0.0, math.pi / w            # no pressure: half the circle (the vanishing-load limit)
    beta = math.atan2(b, a)
    r = min(max(b * e / rho, -1.0), 1.0)
    g1 = math.asin(r) - beta
    g2 = math.pi - math.asin(r) - beta
    s1, c1, s2, c2 = math.sin(g1), math.cos(g1), math.sin(g2), math.cos(g2)
    dg = g2 - g1
    # int s c, int s, int c^2, int c, int s^2 over [g1, g2]
    isc = 0.5 * (s2 * s2 - s1 * s1)
    i_s = c1 - c2
    icc = 0.5 * dg + 0.5 * (s2 * c2 - s1 * c1)
    i_c = s2 - s1
    iss = 0.5 * dg - 0.5 * (s2 * c2 - s1 * c1)
    scale = k / w ** 5
    Fe = scale * (a * isc - a * e * i_s + b * icc - 2.0 * b * e * i_c + b * e * e * dg)
    Ft = scale * w * (a * iss + b * isc - b * e * i_s)
    return Fe, Ft, dg / w


@njit(cache=True)
def journal_film(long, mu, R, L, c, qmin, e, edot, axis, w, F):
    """The film's force F (3,) on the journal at eccentricity e (world, bearing plane), its rate in
    the bearing frame edot and the relative spin w (rad/s); returns (T_j about the axis, the power
    of the film's loads on the two bodies, eps, the full-film shear integral S) (module doc)."""
    r = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) ** 0.5
    eps = r / c
    if r > 1e-12 * c:
        eh0, eh1, eh2 = e[0] / r, e[1] / r, e[2] / r
    else:
        # centred: any radial direction (the wedge force vanishes with eps)
        if abs(axis[0]) < 0.9:
            eh0, eh1, eh2 = 0.0, axis[2], -axis[1]
        else:
            eh0, eh1, eh2 = -axis[2], 0.0, axis[0]
        nn = (eh0 * eh0 + eh1 * eh1 + eh2 * eh2) ** 0.5
        eh0, eh1, eh2 = eh0 / nn, eh1 / nn, eh2 / nn
    th0 = axis[1] * eh2 - axis[2] * eh1
    th1 = axis[2] * eh0 - axis[0] * eh2
    th2 = axis[0] * eh1 - axis[1] * eh0
    eps_dot = (eh0 * edot[0] + eh1 * edot[1] + eh2 * edot[2]) / c
    gdot = (th0 * edot[0] + th1 * edot[1] + th2 * edot[2]) / r if r > 1e-12 * c else 0.0
    Om = w - 2.0 * gdot
    k = 6.0 * mu * R * R * L / (c * c) if long else mu * L ** 3 / (2.0 * c * c)
    if long:
        Fe, Ft, S = long_bearing(k, eps, eps_dot, Om, qmin)
    else:
        Fe, Ft, S = short_bearing(k, eps, Om * eps, -2.0 * eps_dot, qmin)
    Fe *= R
    Ft *= R
    Tj = -mu * R ** 3 * L * w * S / c - 0.5 * r * Ft
    F[0] = Fe * eh0 + Ft * th0
    F[1] = Fe * eh1 + Ft * th1
    F[2] = Fe * eh2 + Ft * th2
    power = F[0] * edot[0] + F[1] * edot[1] + F[2] * edot[2] + Tj * w
    return Tj, power, eps, S


@njit(cache=True, inline="always")
def long_bearing(k, eps, eps_dot, Om, qmin):
    """(F_e, F_t per unit R, the full-film shear integral S) of the long bearing by the periodic
    trapezoid over NPHI points, the full-film arc's ends interpolated linearly (module doc)."""
    dphi = 2.0 * math.pi / NPHI
    Fe = Ft = wet = full = 0.0
    P0, g0 = _pressure(True, k, eps, eps_dot, Om, qmin, _COS[0], _SIN[0])
    Pa, ga = P0, g0
    for i in range(NPHI):
        if i + 1 < NPHI:
            Pb, gb = _pressure(True, k, eps, eps_dot, Om, qmin, _COS[i + 1], _SIN[i + 1])
        else:
            Pb, gb = P0, g0
        if Pa > 0.0:
            Fe += Pa * _COS[i]
            Ft += Pa * _SIN[i]
        full += ga
        # the full-film arc of the segment [phi_i, phi_i+1]: the zero of P interpolated linearly
        if Pa > 0.0 and Pb > 0.0:
            wet += 0.5 * (ga + gb)
        elif Pa > 0.0:
            wet += Pa / (Pa - Pb) * ga
        elif Pb > 0.0:
            wet += Pb / (Pb - Pa) * gb
        Pa, ga = Pb, gb
    return Fe * dphi, Ft * dphi, (wet if wet > 0.0 else 0.5 * full) * dphi


@njit(cache=True, inline="always")
def journal_loads(bodies, laws, fr, ch, mp, fo, M1, v, z, zdot):
    """After the dry geometry: the contact and asperity loads (mixed.contact_loads) and the film's,
    their dissipated power into zdot (module doc of mixed.py)."""
    loss = contact_loads(bodies, laws, fr, ch, mp, fo, v, z, zdot)
    n, p2, j, edot, wv = ch.n, ch.p2, fo.j, fo.edot, fo.w
    for i in range(3):
        j[i] = p2[0, i] - mp.R * n[0, i]
    centre_rates(bodies, v, j, edot, wv)
    axis = fo.T                             # scratch: the bearing axis, then the torque along it
    a0, a1, a2 = M1[0, 2], M1[1, 2], M1[2, 2]
    ax = edot[0] * a0 + edot[1] * a1 + edot[2] * a2
    edot[0] -= ax * a0
    edot[1] -= ax * a1
    edot[2] -= ax * a2
    axis[0], axis[1], axis[2] = a0, a1, a2
    e = wv                                  # scratch after the spin is read
    w = wv[0] * a0 + wv[1] * a1 + wv[2] * a2
    if mp.kind >= 4:
        # a worn bearing: the film at the equivalent eccentricity (r - w(theta_e)) e / r, whose scale
        # the worn kernel left in scratch[3, 1] (e = j - s off the axis; scratch rows s, a, j)
        sc = ch.scratch
        f = sc[3, 1]
        u = (sc[2, 0] - sc[0, 0]) * a0 + (sc[2, 1] - sc[0, 1]) * a1 + (sc[2, 2] - sc[0, 2]) * a2
        e[0] = f * (sc[2, 0] - sc[0, 0] - u * a0)
        e[1] = f * (sc[2, 1] - sc[0, 1] - u * a1)
        e[2] = f * (sc[2, 2] - sc[0, 2] - u * a2)
    else:
        r = ch.delta[0] + mp.c              # the dry geometry's |e| - c = delta, along n
        for i in range(3):
            e[i] = r * n[0, i]
    long = mp.kind == 1 or mp.kind == 5
    Tj, power, eps, S = journal_film(long, mp.mu, mp.R, mp.L, mp.c, mp.qmin, e, edot, axis, w, fo.F)
    fo.T[0], fo.T[1], fo.T[2] = Tj * a0, Tj * a1, Tj * a2
    fo.res[0], fo.res[3], fo.res[4], fo.res[5] = eps, power, S, Tj
    zdot[mp.film_state] = -power
    zdot[ch.delta.shape[0]] = loss - power


@njit(cache=True)
def journal_eval(bodies, laws, fr, ch, mp, fo, M1, v, z, zdot):
    """journal_loads from Python (FilmJoint._compute)."""
    journal_loads(bodies, laws, fr, ch, mp, fo, M1, v, z, zdot)


@njit(cache=True, inline="always")
def journal_force(geo, frames, bodies, laws, fr, ch, mp, fo, v, z, tau, zdot):
    """The lubricated journal's whole right-hand-side contribution in one call: its frames'
    placements, the dry geometry, the loads (journal_loads), their wrenches into tau."""
    M = frames.M
    place_frames(frames)
    channel_geometry(geo.code, geo.gpar, M[0], M[1], ch.scratch, ch.delta, ch.n, ch.p1, ch.p2)
    journal_loads(bodies, laws, fr, ch, mp, fo, M[0], v, z, zdot)
    apply_loads(bodies, ch, fo, tau)
    return 1


def film_pressure(theory, mu, R, L, c, eps, eps_dot, Om, qmin=0.0):
    """P(phi) at the quadrature angles (journal_pressure from Python)."""
    P = np.empty(NPHI)
    journal_pressure(theory == "long", mu, R, L, c, qmin, eps, eps_dot, Om, P)
    return P


def film_loads(theory, mu, R, L, c, e, edot, axis, w, qmin=0.0):
    """(F on the journal (3,), torque T_j on the journal about ``axis``, power of the film's loads
    on the two bodies (<= 0), eps) (journal_film from Python)."""
    F = np.zeros(3)
    Tj, power, eps, _ = journal_film(theory == "long", mu, R, L, c, qmin, np.asarray(e, float),
                                     np.asarray(edot, float), np.asarray(axis, float), float(w), F)
    return F, Tj, power, eps


class LubricatedRevoluteClearance(FilmJoint, RevoluteClearance):
    """Planar journal bearing with an oil film (module doc)."""

    kind = "lubricated_revolute"
    film_kernel = journal_force
    film_eval = journal_eval
    #: MixedPar.kind = the theory's index + this (4: the bearing is worn)
    film_offset = 0

    def __init__(self, *args, theory, **kw):
        self.theory = theory
        self.film_code = THEORIES.index(theory) + self.film_offset
        super().__init__(*args, **kw)

    def describe(self):
        return {**super().describe(), "theory": self.theory}


class WornLubricatedRevoluteClearance(WornFilmJoint, LubricatedRevoluteClearance):
    """A lubricated journal in a worn bearing (``wear:`` on a lubricated_revolute entry;
    mixed.WornFilmJoint). The film's closed form is taken at the equivalent eccentricity
    (r - w(theta_e)) e / r: its gap on the line of centres is the worn bearing's, c + w - r, its
    shape away from it the round bearing's (an error of order w / c in the gap). At zero wear it
    is the lubricated journal exactly."""

    planar_geometry = channels.G_WORN_PLANAR
    _geometry_params = WornRevoluteClearance._geometry_params
    profile = WornRevoluteClearance.profile
    wear_description = WornRevoluteClearance.wear_description
    film_offset = 4


def from_spec(sp, mech, closure):
    theory = sp.choice("theory", THEORIES)
    film, sp_dry = film_spec(sp)
    sp_dry.d.pop("theory", None)
    joint = _dry_from_spec(sp_dry, mech, closure, spatial=False)
    check_bearing_radius(sp, joint.R2, joint.c)
    args = (joint.name, mech.model, joint.f1, joint.f2, joint.c, joint.R2, joint.law, joint.friction)
    kw = dict(length=joint.L, stiffness_note=joint.stiffness_note, theory=theory, **film, **sp.common(joint.c))
    if isinstance(joint, WornRevoluteClearance):
        return WornLubricatedRevoluteClearance(*args, wear=joint.wear, **kw)
    return LubricatedRevoluteClearance(*args, **kw)


LUBRICATED_REVOLUTE = PluginType(
    "lubricated_revolute", parse=from_spec, replaces=("revolute", "planar_point", "spherical"),
    doc="A planar journal bearing in mixed lubrication: the hydrodynamic force and friction torque of the short "
        "(Ocvirk) or long (Sommerfeld) bearing with Guembel's cavitation down to contact, the asperities "
        "(Greenwood-Tripp) sharing the load within a few roughnesses of it, the dry law beyond "
        "(docs/wear_lubrication.md).",
    source="Pinkus & Sternlicht 1961; Flores et al. 2009; Greenwood & Tripp 1970", keys=_PLANAR + _LUB + _WEAR,
    plot=_PLOT)
KEYS = key_names(_PLANAR + _LUB + _WEAR)
