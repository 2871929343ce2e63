"""Lubricated spherical clearance: a ball in an oil-filled spherical socket, blended into dry contact.

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

Dry contact and blend: as lubricated.py (FilmJoint): the dry spherical law acts on |e| - (c - h_a)
and the film's loads fade out by smoothstep((h_min - h_a) / band), h_min = c - |e|.
"""
from __future__ import annotations

import math

import numpy as np

from pinclear.contact.lubricated import FILM_KEYS, FilmJoint, film_spec
from pinclear.contact.spherical import _RADIUS, SPHERICAL, SphericalClearance
from pinclear.contact.spherical import from_spec as _dry_from_spec
from pinclear.core.registry import PluginType, key_names
from pinclear.model.forces import body_twist

#: Gauss-Legendre nodes in theta over [0, pi]: the integrands are smooth but for the kinks of the
#: cavitation boundary; 256 nodes keep the uncavitated squeeze force within 1e-12 of its closed form
#: at eps 0.97 (tests/contact/test_lubricated_spherical.py)
NQ = 256
_XI, _WXI = np.polynomial.legendre.leggauss(NQ)
_TH = 0.5 * math.pi * (_XI + 1.0)
_CT, _ST = np.cos(_TH), np.sin(_TH)
_WT = 0.5 * math.pi * _WXI * _ST             # dA / R^2 = sin theta dtheta dphi


def ring(a, b):
    """(int max(a + b cos phi, 0) dphi, int max(a + b cos phi, 0) cos phi dphi) over [0, 2 pi], b >= 0
    (Guembel's cavitation on a ring of constant theta; phi0 = arccos(-a / b) bounds the wet arc)."""
    with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
        r = np.clip(-a / np.maximum(b, 1e-300), -1.0, 1.0)
    ph = np.arccos(r)
    sn = np.sqrt(1.0 - r * r)
    full = a >= b
    I0 = np.where(full, 2.0 * math.pi * a, 2.0 * (a * ph + b * sn))
    I1 = np.where(full, math.pi * b, 2.0 * a * sn + b * (ph + sn * r))
    return I0, I1


# the series' exponents and coefficients, built once (couette runs at every film evaluation)
_TWO_K = 2.0 * np.arange(16)
_INV_2K1, _INV_2K3 = 1.0 / (_TWO_K + 1.0), 1.0 / (_TWO_K + 3.0)


def couette(eps):
    """(alpha, beta): int (1 - (n . w_hat)^2) / (1 - eps cos theta) dOmega for w across and along e."""
    if eps < 0.1:
        # I0 = 2 sum eps^2k / (2k + 1), I2 = 2 sum eps^2k / (2k + 3) (no cancellation near eps = 0)
        e2k = eps ** _TWO_K
        I0 = 2.0 * float(e2k @ _INV_2K1)
        I2 = 2.0 * float(e2k @ _INV_2K3)
    else:
        I0 = 2.0 * math.atanh(eps) / eps
        I2 = (I0 - 2.0) / (eps * eps)
    return math.pi * (I0 + I2), 2.0 * math.pi * (I0 - I2)


def film_frame(mu, R, c, e, edot, w):
    """(eps, e_hat, unit direction of V_perp, pressure scales k_par = 3 mu R^2 V_par / c^3 and
    k_perp = 12 mu R^2 V_perp / (c^3 (4 + eps^2))) of the film at eccentricity e (world), its rate
    in the socket frame edot and the relative spin w = w_ball - w_socket (module doc)."""
    r = float(np.linalg.norm(e))
    eps = min(r / c, 1.0 - 1e-9)
    V = edot - 0.5 * np.cross(w, e)            # the squeeze velocity equivalent to squeeze + spin
    if r > 1e-12 * c:
        eh = e / r
    else:
        # centred: the widest gap taken opposite V (the ambient reference is arbitrary at eps = 0)
        nv = float(np.linalg.norm(V))
        eh = V / nv if nv > 0 else np.array([1.0, 0.0, 0.0])
    Vpar = float(V @ eh)
    Vp = V - Vpar * eh
    vp = float(np.linalg.norm(Vp))
    k = mu * R * R / c ** 3
    return eps, eh, (Vp / vp if vp > 0 else np.zeros(3)), 3.0 * k * Vpar, 12.0 * k * vp / (4.0 + eps * eps)


def pressure_terms(eps, kpar, kperp, x, y):
    """(p_par, across term) at x = cos theta: p = p_par + kperp y (2 - eps x) / u^2, with y = n . (V_perp
    direction) the pressure itself, with y = sin theta its coefficient of cos phi on a ring."""
    u2 = (1.0 - eps * x) ** 2
    return kpar * (1.0 + x) * (2.0 + eps * (1.0 - x)) / (u2 * (1.0 + eps) ** 2), kperp * y * (2.0 - eps * x) / u2


def film_pressure(mu, R, c, e, edot, w, n):
    """The full film's pressure (Pa, before cavitation) at unit normals n (k, 3) from the socket centre."""
    eps, eh, ep, kpar, kperp = film_frame(mu, R, c, e, edot, w)
    a, b = pressure_terms(eps, kpar, kperp, n @ eh, n @ ep)
    return a + b


def film_loads(mu, R, c, e, edot, w):
    """(F on the ball (3,), torque T on the ball about its centre (3,), power of the film's loads
    on ball and socket (<= 0), eps): the cavitated film's loads (module doc)."""
    eps, eh, ep, kpar, kperp = film_frame(mu, R, c, e, edot, w)
    I0, I1 = ring(*pressure_terms(eps, kpar, kperp, _CT, _ST))
    F = -R * R * (float(_WT @ (_CT * I0)) * eh + float(_WT @ (_ST * I1)) * ep)
    alpha, beta = couette(eps)
    wpar = float(w @ eh) * eh
    T = -(mu * R ** 4 / c) * (alpha * (w - wpar) + beta * wpar) - 0.5 * np.cross(e, F)
    power = float(F @ edot) + float(T @ w)
    return F, T, power, eps


class LubricatedSphericalClearance(FilmJoint, SphericalClearance):
    """Ball in an oil-filled socket (module doc)."""

    kind = "lubricated_spherical"

    def _compute(self, ws, d, v, z):
        super()._compute(ws, d, v, z)
        n = d.n[0]
        e = (d.delta[0] + self.c) * n          # the dry geometry's |e| - c_dry = delta
        j = d.p2[0] - self.R2 * n              # ball centre
        u, b = body_twist(ws.J6, self.idx1, v), body_twist(ws.J6, self.idx2, v)
        w1, w2 = np.array(u[3:]), np.array(b[3:])
        # rate of e in the socket frame: the ball centre's velocity relative to the socket's point there
        edot = (np.array(b[:3]) + np.cross(w2, j)) - (np.array(u[:3]) + np.cross(w1, j))
        F, T, power, eps = film_loads(self.mu_oil, self.R2, self.c_film, e, edot, w2 - w1)
        self._blend(d, F, T, j, power, eps, T)


def from_spec(sp, mech, closure):
    film, sp_dry = film_spec(sp)
    joint = _dry_from_spec(sp_dry, mech, closure)
    # the socket is R_ball + c: the dry channel's radii are those of the clearance c - h_a
    return LubricatedSphericalClearance(joint.name, mech.model, joint.f1, joint.f2, joint.c, joint.R2, joint.law,
                                        joint.friction, stiffness_note=joint.stiffness_note, **film,
                                        **sp.common(film["c_nominal"]))


LUBRICATED_SPHERICAL = PluginType(
    "lubricated_spherical", parse=from_spec, replaces=("spherical",),
    doc="A ball in an oil-filled spherical socket: the squeeze and spin (wedge) force of the full-sphere film in "
        "closed form with Guembel's cavitation, its shear torque, faded out over a band above the asperity height, "
        "below which the dry spherical law acts (docs/wear_lubrication.md).",
    source="Reynolds' equation on the sphere (Goenka & Booker 1980); Tian et al. 2009", keys=(_RADIUS,) + FILM_KEYS,
    plot=SPHERICAL.plot)
KEYS = key_names(LUBRICATED_SPHERICAL.keys)
