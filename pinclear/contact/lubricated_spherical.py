"""Lubricated spherical clearance: a ball in an oil-filled spherical socket, in mixed lubrication.

The lubricated ball-in-socket of the clearance-joint literature (Tian et al. 2009, Computers &
Structures 87, 913, the spherical joints of paper 000's ref. [8]; the spherical bearing's Reynolds
equation as Goenka & Booker 1980, ASME J. Lubr. Technol. 102, 308 write it), here solved in closed
form (docs/wear_lubrication.md sec. 4 gives the derivation). Ball radius R, radial clearance c, ball
centre displaced by e from the socket centre (eps = |e| / c, e_hat = e / |e|), film thickness
h = c (1 - eps cos theta), theta from e_hat (the narrowest gap at theta = 0), viscosity mu. The thin
film's Reynolds equation on the sphere, with the socket at rest in its own frame,

    div_s(h^3 grad_s p) / (12 mu) = dh/dt + div_s(h U_mean) = -n . V,   V = edot - (1/2) w x e,

(edot: rate of e in the socket frame, w = w_ball - w_socket; the spin enters only through V, as the
journal bearing's wedge speed does: the mean surface speed of a rigid rotation is divergence-free
on the sphere and U_mean . grad h = (1/2) n . (w x e)). Its full-film solution over the whole
sphere, ambient pressure at the widest gap (theta = pi, as the long journal bearing of
lubricated.py), is the sum of two closed forms (x = cos theta, u = 1 - eps x):

* squeeze along e (V_par = V . e_hat):
  p_par = 3 mu R^2 V_par / (c^3 eps) (u^-2 - (1 + eps)^-2)
        = 3 mu R^2 V_par (1 + x)(2 + eps (1 - x)) / (c^3 u^2 (1 + eps)^2);
* across e (V_perp = |V - V_par e_hat|, phi from its direction):
  p_perp = 12 mu R^2 V_perp sin theta cos phi (2 - eps x) / (c^3 (4 + eps^2) u^2)

(each satisfies the equation exactly: tests/contact/test_lubricated_spherical.py checks the residual).
Cavitation: Guembel's condition, the film carries no tension, p+ = max(p_par + p_perp, 0). On each
ring of constant theta the phi integrals of p+ and p+ cos phi are closed forms (``ring``); theta is
integrated by Gauss-Legendre (``NQ`` nodes). Without cavitation (a ball approaching the wall, no
spin) the force is the closed form F = -W e_hat,
W = 6 pi mu R^4 eps_dot / (c^2 eps^3) (2 eps / (1 - eps^2) - ln((1 + eps) / (1 - eps))), and a ball
leaving the wall without spin feels none.

Loads on the ball: F = -int p+ n dA (through its centre) and the film's shear torque about its
centre, T = -(mu R^4 / c) (alpha w_perp + beta w_par) - (1/2) e x F (Couette part over the whole
sphere, alpha = pi (I0 + I2), beta = 2 pi (I0 - I2), I_k = int_-1^1 x^k / (1 - eps x) dx; the
Poiseuille part -int R n x (h / 2) grad p+ dA = -(1/2) e x F by Stokes' theorem on the closed
sphere); the socket takes the opposite wrench about the ball centre (the film holds no momentum).
Their power is P = F . edot + T . w = F . V - (mu R^4 / c)(alpha |w_perp|^2 + beta w_par^2)
= -(1 / 12 mu) int_{p > 0} h^3 |grad p|^2 dA - Couette <= 0 at every state (docs): the film only
dissipates. Neglected: terms of order c / R (the tangential motion of the ball's surface by
translation, curvature of the film), inertia of the oil, the socket's rim (the film covers the
whole sphere), thermal and piezo-viscous effects.

The Couette shear acts over the whole sphere (Petroff's full film), also where Guembel's film has
ruptured: a limit of this model (the journal bearing's shear, lubricated.py, acts over the
full-film arc only). As there, u is floored at FLOOR x sigma / c (mixed.py) and the film carries
load down to contact; the power identity is exact above the floor.

Dry contact, asperities and friction: contact/mixed.py (FilmJoint): the dry spherical law acts on
|e| - c, the asperities (Greenwood-Tripp) share the load within a few sigma of contact, and every
load is compiled in one kernel.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np

from pinclear.contact import channels
from pinclear.contact.channels import channel_geometry
from pinclear.contact.mixed import KEYS as FILM_KEYS
from pinclear.contact.mixed import FilmJoint, WornFilmJoint, apply_loads, centre_rates, contact_loads, film_spec
from pinclear.contact.spherical import _RADIUS, SPHERICAL, SphericalClearance, WornSphericalClearance
from pinclear.contact.spherical import from_spec as _dry_from_spec
from pinclear.core.jit import njit
from pinclear.core.registry import PluginType, key_names
from pinclear.model.forces import place_frames

#: Gauss-Legendre nodes in theta over [0, pi]: the integrands are smooth but for the kinks of the
#: cavitation boundary; 256 nodes keep the uncavitated squeeze force within 1e-12 of its closed form
#: at eps 0.97 (tests/contact/test_lubricated_spherical.py)
NQ = 256
_XI, _WXI = np.polynomial.legendre.leggauss(NQ)
_TH = 0.5 * math.pi * (_XI + 1.0)
_CT, _ST = np.cos(_TH), np.sin(_TH)
_WT = 0.5 * math.pi * _WXI * _ST             # dA / R^2 = sin theta dtheta dphi


@njit(cache=True, inline="always")
def ring_integrals(a, b):
    """(int max(a + b cos phi, 0) dphi, int max(a + b cos phi, 0) cos phi dphi) over [0, 2 pi], b >= 0
    (Guembel's cavitation on a ring of constant theta; phi0 = arccos(-a / b) bounds the wet arc)."""
    if a >= b:
        return 2.0 * math.pi * a, math.pi * b
    if a <= -b:
        return 0.0, 0.0
    r = -a / b
    ph = math.acos(r)
    sn = (1.0 - r * r) ** 0.5
    return 2.0 * (a * ph + b * sn), 2.0 * a * sn + b * (ph + sn * r)


def ring(a, b):
    """ring_integrals over arrays (a, b)."""
    a, b = np.broadcast_arrays(np.asarray(a, float), np.asarray(b, float))
    pairs = [ring_integrals(x, y) for x, y in zip(a.ravel(), b.ravel())]
    I0, I1 = (np.array(v).reshape(a.shape) for v in zip(*pairs))
    return I0, I1


@njit(cache=True, inline="always")
def couette(eps):
    """(alpha, beta): int (1 - (n . w_hat)^2) / (1 - eps cos theta) dOmega for w across and along e."""
    if eps < 0.1:
        # I0 = 2 sum eps^2k / (2k + 1), I2 = 2 sum eps^2k / (2k + 3) (no cancellation near eps = 0)
        I0 = I2 = 0.0
        e2k = 1.0
        for k in range(16):
            I0 += 2.0 * e2k / (2 * k + 1)
            I2 += 2.0 * e2k / (2 * k + 3)
            e2k *= eps * eps
    else:
        I0 = 2.0 * math.atanh(eps) / eps
        I2 = (I0 - 2.0) / (eps * eps)
    return math.pi * (I0 + I2), 2.0 * math.pi * (I0 - I2)


@njit(cache=True, inline="always")
def pressure_terms(eps, kpar, kperp, qmin, x, y):
    """(p_par, across term) at x = cos theta: p = p_par + kperp y (2 - eps x) / u^2, with y = n . (V_perp
    direction) the pressure itself, with y = sin theta its coefficient of cos phi on a ring."""
    u = max(1.0 - eps * x, qmin)
    u2 = u * u
    return kpar * (1.0 + x) * (2.0 + eps * (1.0 - x)) / (u2 * (1.0 + eps) ** 2), kperp * y * (2.0 - eps * x) / u2


@njit(cache=True)
def ball_film(mu, R, c, qmin, e, edot, w, F, T):
    """The cavitated film's force F (3,) on the ball and torque T (3,) about its centre at
    eccentricity e (world), its rate in the socket frame edot and the relative spin w = w_ball -
    w_socket; returns (power of the film's loads on ball and socket (<= 0), eps) (module doc)."""
    r = (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) ** 0.5
    eps = r / c
    # the squeeze velocity equivalent to squeeze + spin: V = edot - (1/2) w x e
    V0 = edot[0] - 0.5 * (w[1] * e[2] - w[2] * e[1])
    V1 = edot[1] - 0.5 * (w[2] * e[0] - w[0] * e[2])
    V2 = edot[2] - 0.5 * (w[0] * e[1] - w[1] * e[0])
    if r > 1e-12 * c:
        eh0, eh1, eh2 = e[0] / r, e[1] / r, e[2] / r
    else:
        # centred: the widest gap taken opposite V (the ambient reference is arbitrary at eps = 0)
        nv = (V0 * V0 + V1 * V1 + V2 * V2) ** 0.5
        if nv > 0.0:
            eh0, eh1, eh2 = V0 / nv, V1 / nv, V2 / nv
        else:
            eh0, eh1, eh2 = 1.0, 0.0, 0.0
    Vpar = V0 * eh0 + V1 * eh1 + V2 * eh2
    p0, p1, p2 = V0 - Vpar * eh0, V1 - Vpar * eh1, V2 - Vpar * eh2
    vp = (p0 * p0 + p1 * p1 + p2 * p2) ** 0.5
    if vp > 0.0:
        p0, p1, p2 = p0 / vp, p1 / vp, p2 / vp
    k = mu * R * R / c ** 3
    kpar, kperp = 3.0 * k * Vpar, 12.0 * k * vp / (4.0 + eps * eps)
    Fa = Fb = 0.0
    for i in range(NQ):
        a, b = pressure_terms(eps, kpar, kperp, qmin, _CT[i], _ST[i])
        I0, I1 = ring_integrals(a, b)
        Fa += _WT[i] * _CT[i] * I0
        Fb += _WT[i] * _ST[i] * I1
    F[0] = -R * R * (Fa * eh0 + Fb * p0)
    F[1] = -R * R * (Fa * eh1 + Fb * p1)
    F[2] = -R * R * (Fa * eh2 + Fb * p2)
    alpha, beta = couette(min(eps, 1.0 - qmin))
    wp = w[0] * eh0 + w[1] * eh1 + w[2] * eh2
    kc = mu * R ** 4 / c
    T[0] = -kc * (alpha * (w[0] - wp * eh0) + beta * wp * eh0) - 0.5 * (e[1] * F[2] - e[2] * F[1])
    T[1] = -kc * (alpha * (w[1] - wp * eh1) + beta * wp * eh1) - 0.5 * (e[2] * F[0] - e[0] * F[2])
    T[2] = -kc * (alpha * (w[2] - wp * eh2) + beta * wp * eh2) - 0.5 * (e[0] * F[1] - e[1] * F[0])
    power = F[0] * edot[0] + F[1] * edot[1] + F[2] * edot[2] + T[0] * w[0] + T[1] * w[1] + T[2] * w[2]
    return power, eps


@njit(cache=True, inline="always")
def ball_loads(bodies, laws, fr, ch, mp, fo, M1, v, z, zdot):
    """After the dry geometry: the contact and asperity loads (mixed.contact_loads) and the film's,
    their dissipated power into zdot (module doc of mixed.py)."""
    loss = contact_loads(bodies, laws, fr, ch, mp, fo, v, z, zdot)
    n, p2, j = ch.n, ch.p2, fo.j
    for i in range(3):
        j[i] = p2[0, i] - mp.R * n[0, i]
    centre_rates(bodies, v, j, fo.edot, fo.w)
    if mp.kind == 3:
        # a worn socket: the film at the ray's gap, the equivalent eccentricity (r - w(e_hat)) e_hat
        # the worn kernel left in scratch[2] (continuous in e, where the nearest point can jump)
        e = ch.scratch[2]
    else:
        e = ch.scratch[0]                     # the dry geometry's |e| - c = delta, along n
        r = ch.delta[0] + mp.c
        for i in range(3):
            e[i] = r * n[0, i]
    power, eps = ball_film(mp.mu, mp.R, mp.c, mp.qmin, e, fo.edot, fo.w, fo.F, fo.T)
    fo.res[0], fo.res[3], fo.res[4], fo.res[5] = eps, power, 0.0, 0.0
    zdot[mp.film_state] = -power
    zdot[ch.delta.shape[0]] = loss - power


@njit(cache=True)
def ball_eval(bodies, laws, fr, ch, mp, fo, M1, v, z, zdot):
    """ball_loads from Python (FilmJoint._compute)."""
    ball_loads(bodies, laws, fr, ch, mp, fo, M1, v, z, zdot)


@njit(cache=True, inline="always")
def ball_force(geo, frames, bodies, laws, fr, ch, mp, fo, v, z, tau, zdot):
    """The lubricated ball's whole right-hand-side contribution in one call: its frames'
    placements, the dry geometry, the loads (ball_loads), their wrenches into tau."""
    M = frames.M
    place_frames(frames)
    channel_geometry(geo.code, geo.gpar, M[0], M[1], ch.scratch, ch.delta, ch.n, ch.p1, ch.p2)
    ball_loads(bodies, laws, fr, ch, mp, fo, M[0], v, z, zdot)
    apply_loads(bodies, ch, fo, tau)
    return 1


def film_pressure(mu, R, c, e, edot, w, n, qmin=0.0):
    """The full film's pressure (Pa, before cavitation) at unit normals n (k, 3) from the socket centre."""
    e, edot, w, n = (np.asarray(x, float) for x in (e, edot, w, n))
    r = float(np.linalg.norm(e))
    eps = r / c
    V = edot - 0.5 * np.cross(w, e)
    eh = e / r if r > 1e-12 * c else (V / np.linalg.norm(V) if np.linalg.norm(V) > 0 else np.array([1.0, 0, 0]))
    Vpar = float(V @ eh)
    Vp = V - Vpar * eh
    vp = float(np.linalg.norm(Vp))
    ep = Vp / vp if vp > 0 else np.zeros(3)
    k = mu * R * R / c ** 3
    out = [sum(pressure_terms(eps, 3 * k * Vpar, 12 * k * vp / (4 + eps * eps), qmin, float(x), float(y)))
           for x, y in zip(n @ eh, n @ ep)]
    return np.array(out)


def film_loads(mu, R, c, e, edot, w, qmin=0.0):
    """(F on the ball (3,), torque T on the ball about its centre (3,), power of the film's loads
    on ball and socket (<= 0), eps): ball_film from Python."""
    F, T = np.zeros(3), np.zeros(3)
    power, eps = ball_film(mu, R, c, qmin, np.asarray(e, float), np.asarray(edot, float), np.asarray(w, float), F, T)
    return F, T, power, eps


class LubricatedSphericalClearance(FilmJoint, SphericalClearance):
    """Ball in an oil-filled socket (module doc)."""

    kind = "lubricated_spherical"
    film_code = 2
    film_kernel = ball_force
    film_eval = ball_eval


class WornLubricatedSphericalClearance(WornFilmJoint, LubricatedSphericalClearance):
    """A lubricated ball in a worn socket (``wear:`` on a lubricated_spherical entry; mixed.WornFilmJoint).
    The film's closed form is taken at the equivalent eccentricity (r - w(e_hat)) e_hat: its gap on
    the line of centres is the worn socket's, c + w - r, its shape away from it the unworn sphere's
    (an error of order w / c in the gap). At zero wear it is the lubricated joint exactly."""

    geometry_code = channels.G_WORN_SPHERICAL
    film_code = 3
    _geometry_params = WornSphericalClearance._geometry_params
    profile = WornSphericalClearance.profile
    wear_description = WornSphericalClearance.wear_description


def from_spec(sp, mech, closure):
    film, sp_dry = film_spec(sp)
    joint = _dry_from_spec(sp_dry, mech, closure)
    args = (joint.name, mech.model, joint.f1, joint.f2, joint.c, joint.R2, joint.law, joint.friction)
    kw = dict(stiffness_note=joint.stiffness_note, **film, **sp.common(joint.c))
    if isinstance(joint, WornSphericalClearance):
        if (sp.d.get("wear") or {}).get("contact", "least_distance") != "least_distance":
            raise sp.error("wear.contact", "an oiled ball's film and asperities need the least gap: its worn "
                           "socket's contact is least_distance (the foundation is the dry joint's)", ["least_distance"])
        return WornLubricatedSphericalClearance(*args, wear=dataclasses.replace(joint.wear, contact="least_distance"),
                                                **kw)
    return LubricatedSphericalClearance(*args, **kw)


LUBRICATED_SPHERICAL = PluginType(
    "lubricated_spherical", parse=from_spec, replaces=("spherical",),
    doc="A ball in an oil-filled spherical socket in mixed lubrication: the squeeze and spin (wedge) force of the "
        "full-sphere film in closed form with Guembel's cavitation down to contact, its shear torque, the asperities "
        "(Greenwood-Tripp) sharing the load within a few roughnesses of contact, the dry spherical law beyond "
        "(docs/wear_lubrication.md).",
    source="Reynolds' equation on the sphere (Goenka & Booker 1980); Tian et al. 2009; Greenwood & Tripp 1970",
    keys=(_RADIUS,) + FILM_KEYS + tuple(k for k in SPHERICAL.keys if k.name == "wear"), plot=SPHERICAL.plot)
KEYS = key_names(LUBRICATED_SPHERICAL.keys)
