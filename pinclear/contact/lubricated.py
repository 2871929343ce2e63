"""Lubricated planar revolute clearance: a hydrodynamic journal bearing, blended into dry contact.

Film (Reynolds' equation for an incompressible isoviscous film; the short- and long-bearing
approximations as the clearance-joint literature takes them from Pinkus & Sternlicht 1961, Theory
of Hydrodynamic Lubrication, ch. 4 and 13, e.g. Flores et al. 2009, Nonlinear Dyn. 56, 277, eqs.
4-13). With e the eccentricity of the journal centre in the bearing frame, eps = |e| / c, phi the
angle from the line of centres' far side (film h = c (1 + eps cos phi)), the relative spin
w = w_journal - w_bearing and the whirl gdot (rate of e's direction in the bearing frame), the
wedge speed is Om = w - 2 gdot and

* short bearing (Ocvirk; L/D small), integrated across the length:
  P(phi) = mu L^3 / (2 c^2) (Om eps sin phi - 2 eps_dot cos phi) / (1 + eps cos phi)^3;
* long bearing (Sommerfeld; L/D large), times L:
  P(phi) = 6 mu R^2 L / c^2 [Om eps sin phi (2 + eps cos phi) / ((2 + eps^2)(1 + eps cos phi)^2)
           + (eps_dot / eps) ((1 + eps cos phi)^-2 - (1 + eps)^-2)]
  (ambient pressure at the widest gap, phi = 0).

Cavitation: Guembel's half-Sommerfeld condition, the film carries no tension: P+ = max(P, 0).
At a steady load (eps_dot = gdot = 0) this gives the closed forms of the load and attitude angle
(short: W = mu w R L^3 eps sqrt(16 eps^2 + pi^2 (1 - eps^2)) / (4 c^2 (1 - eps^2)^2), tan psi =
pi sqrt(1 - eps^2) / (4 eps); long: W = 6 mu w R^3 L eps sqrt(pi^2 - eps^2 (pi^2 - 4)) /
(c^2 (2 + eps^2)(1 - eps^2)), tan psi = pi sqrt(1 - eps^2) / (2 eps)) that tests/contact/test_lubricated.py
checks through the coupled dynamics.

Force on the journal: F = R int P+ (cos phi e_hat + sin phi t_hat) dphi (t_hat = axis x e_hat),
its reaction on the bearing. Torque of the film's shear on the journal (Pinkus & Sternlicht eq.
4-47, the Couette part over the whole circumference, the Poiseuille part by parts):
T_j = -2 pi mu R^3 L w / (c sqrt(1 - eps^2)) - (|e| / 2) F_t, and on the bearing the opposite of
the journal's moment (the film holds no momentum). The power of these loads on the two bodies is

    P_film = -(R c / 2) int P+ (Om eps sin phi - 2 eps_dot cos phi) dphi - 2 pi mu R^3 L w^2 / (c sqrt(1 - eps^2))

<= 0 at every state: for the short bearing P+ > 0 only where the bracket is; for the long bearing,
where P+ > 0 is not tied to the bracket's sign when squeeze and wedge mix, Reynolds' equation
(h^3 P')' = -6 mu R^2 c (bracket) integrated by parts over each interval where P > 0 (P+ vanishes
at its ends) gives int P+ (bracket) = int_{P>0} h^3 P'^2 / (6 mu R^2 c) >= 0. The film only
dissipates (tests/contact/test_lubricated.py checks both at random states, the long one to the quadrature's
error); its dissipation is a state of the joint (output ``film_dissipated``) and part of the energy
audit's E_diss.

Dry contact and blend: the asperities touch when the film's minimum h_min = c - |e| falls to
``asperity`` (h_a): the dry law acts on the penetration |e| - (c - h_a) (the joint's dry clearance
is c - h_a), and the film's loads are scaled by s = smoothstep((h_min - h_a) / band) (3 x^2 -
2 x^3, 0 at h_a, 1 at h_a + band): no force jumps, and s P_film <= 0 still.
"""
from __future__ import annotations

import math

import numpy as np

from pinclear.contact.revolute import _PLANAR, _PLOT, RevoluteClearance, check_bearing_radius
from pinclear.contact.revolute import from_spec as _dry_from_spec
from pinclear.core.registry import Key, PluginType, key_names
from pinclear.model.forces import add_body_wrench, add_wrenches, body_twist

THEORIES = ("short", "long")
#: quadrature points over the circumference (trapezoid, periodic; the Guembel kinks at P = 0 make
#: it second order: 4096 points keep the steady load within 1e-5 of the closed forms at eps 0.9)
NPHI = 1024
_PHI = np.arange(NPHI) * (2.0 * math.pi / NPHI)
_COS, _SIN = np.cos(_PHI), np.sin(_PHI)

_LUB = (Key("viscosity", "number", "Pa s", None, "> 0", "Pinkus & Sternlicht 1961", "dynamic viscosity of the oil"),
        Key("theory", "string", "-", "short", ", ".join(THEORIES), "Pinkus & Sternlicht 1961 ch. 4",
            "short (Ocvirk) or long (Sommerfeld) bearing"),
        Key("asperity", "number", "m", "0.02 x clearance", ">= 0, < clearance", "contact/lubricated.py",
            "film thickness at which the asperities touch (dry law from there)"),
        Key("band", "number", "m", "asperity (or 0.02 x clearance)", "> 0", "contact/lubricated.py",
            "film thickness band above the asperity height over which the film fades out"))
#: the film keys every lubricated type takes (lubricated_spherical.py has no bearing theory)
FILM_KEYS = tuple(k for k in _LUB if k.name != "theory")


def film_pressure(theory, mu, R, L, c, eps, eps_dot, Om):
    """P(phi) (N/m, integrated over the length) at the quadrature angles, before cavitation."""
    q = 1.0 + eps * _COS
    if theory == "short":
        return mu * L ** 3 / (2 * c * c) * (Om * eps * _SIN - 2 * eps_dot * _COS) / q ** 3
    wedge = Om * eps * _SIN * (2 + eps * _COS) / ((2 + eps * eps) * q * q)
    # squeeze: (eps_dot / eps)(q^-2 - (1 + eps)^-2), written without the 1/eps (finite at eps = 0)
    squeeze = eps_dot * (1 - _COS) * (2 + eps * (1 + _COS)) / ((1 + eps) ** 2 * q * q)
    return 6 * mu * R * R * L / (c * c) * (wedge + squeeze)


def film_loads(theory, mu, R, L, c, e, edot, axis, w):
    """(F on the journal (3,), torque T_j on the journal about ``axis``, power of the film's loads
    on the two bodies (<= 0 for the short bearing), eps) at eccentricity e (world, bearing plane),
    its rate in the bearing frame edot, and the relative spin w (rad/s)."""
    r = float(np.linalg.norm(e))
    eps = min(r / c, 1.0 - 1e-9)
    if r > 1e-12 * c:
        eh = e / r
    else:
        # centred: any radial direction (the wedge force vanishes with eps)
        eh = np.cross(axis, [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0])
        eh /= np.linalg.norm(eh)
    th = np.cross(axis, eh)
    eps_dot = float(eh @ edot) / c
    gdot = float(th @ edot) / r if r > 1e-12 * c else 0.0
    Om = w - 2.0 * gdot
    P = np.maximum(film_pressure(theory, mu, R, L, c, eps, eps_dot, Om), 0.0)
    dphi = 2.0 * math.pi / NPHI
    Fe, Ft = R * dphi * float(P @ _COS), R * dphi * float(P @ _SIN)
    couette = 2.0 * math.pi * mu * R ** 3 * L / (c * math.sqrt(1.0 - eps * eps))
    Tj = -couette * w - 0.5 * r * Ft
    F = Fe * eh + Ft * th
    power = float(F @ edot) + Tj * w
    return F, Tj, power, eps


def smoothstep(x):
    x = min(max(x, 0.0), 1.0)
    return x * x * (3.0 - 2.0 * x)


class FilmJoint:
    """Mixin of the lubricated clearance types (this module, lubricated_spherical.py): a dry joint
    (the next base class, its clearance reduced to c - asperity) plus an oil film whose loads a
    subclass computes in ``_compute`` and hands to :meth:`_blend`. z = [onset speeds |
    E_dissipated | friction states | film dissipation]; the film is evaluated in Python."""

    def __init__(self, *args, viscosity, asperity, band, c_nominal, **kw):
        self.mu_oil = float(viscosity)
        self.h_a, self.band, self.c_film = float(asperity), float(band), float(c_nominal)
        super().__init__(*args, **kw)

    def _freeze(self):
        self.kind = type(self).kind          # the dry base may have set its own
        self.nz = self.nc + 2 + self.nfs
        self.film_state = self.nz - 1
        super()._freeze()

    def _compiled_kernel(self):
        return None                       # the film is evaluated in Python (add_force)

    def record_layout(self):
        return None

    def _blend(self, d, F, T, j, power, eps, torque_out):
        """The film's loads (F on body 2, torque T on body 2 about its centre j, their power on the
        two bodies) faded out over the band above the asperity height: s = smoothstep((h_min -
        h_a) / band) scales loads and power alike, so s P_film <= 0 still (module doc)."""
        s = smoothstep((self.c_film * (1.0 - eps) - self.h_a) / self.band)
        d.film = (s * F, s * T, j, eps, s, s * torque_out)
        d.film_loss = -s * power
        d.loss += d.film_loss

    def add_force(self, mech, ws, d, t, q, v, z, tau, zdot):
        self._eval(ws, d, t, q, v, z)
        nc = self.nc
        zdot[:nc] = 0.0
        zdot[nc] = d.loss
        zdot[nc + 1:self.film_state] = d.dzf
        zdot[self.film_state] = d.film_loss
        if d.on.any():
            add_wrenches(ws.J6, self.idx1, self.idx2, d.F2, d.p1, d.p2, tau)
        F, T, j = d.film[:3]
        m = np.cross(j, F) + T            # the film's wrench on body 2 about the origin
        # the film holds no momentum: body 1 takes the opposite wrench about the same point
        add_body_wrench(ws.J6, self.idx2, F[0], F[1], F[2], m[0], m[1], m[2], tau)
        add_body_wrench(ws.J6, self.idx1, -F[0], -F[1], -F[2], -m[0], -m[1], -m[2], tau)

    def outputs(self, mech, ws, d, t, q, v, z):
        out = super().outputs(mech, ws, d, t, q, v, z)
        F, _, _, eps, s, T = d.film
        out.update(film_force=F.copy(), film_torque=T, eccentricity_ratio=eps, film_weight=s,
                   film_dissipated=float(z[self.film_state]))
        return out

    def describe(self):
        return {**super().describe(), "viscosity": self.mu_oil, "asperity": self.h_a, "band": self.band,
                "film_clearance": self.c_film}


def film_spec(sp, own=()):
    """(the film's keyword arguments of FilmJoint, the dry joint's Spec) of a lubricated entry:
    viscosity, asperity height and band read and checked; the dry law acts from h_min = asperity,
    so the dry joint's clearance is c - asperity (its radii are those of that clearance). ``own``:
    the type's further keys the dry parser does not take."""
    c = sp.clearance()
    mu = sp.number("viscosity")
    h_a = sp.number("asperity", 0.02 * c, allow_zero=True)
    if h_a >= c:
        raise sp.error("asperity", f"must be below the clearance {c} m, got {h_a}")
    band = sp.number("band", h_a if h_a > 0 else 0.02 * c)
    dry = dict(sp.d, clearance=c - h_a)
    for k in ("viscosity", "asperity", "band") + tuple(own):
        dry.pop(k, None)
    sp_dry = type(sp).__new__(type(sp))
    sp_dry.__dict__.update(sp.__dict__, d=dry)
    return dict(viscosity=mu, asperity=h_a, band=band, c_nominal=c), sp_dry


class LubricatedRevoluteClearance(FilmJoint, RevoluteClearance):
    """Planar journal bearing with an oil film (module doc)."""

    kind = "lubricated_revolute"

    def __init__(self, *args, theory, **kw):
        self.theory = theory
        super().__init__(*args, **kw)

    def _compute(self, ws, d, v, z):
        super()._compute(ws, d, v, z)
        n = d.n[0]
        e = (d.delta[0] + self.c) * n      # the dry geometry's |e| - c_dry = delta
        j = d.p2[0] - self.R2 * n
        u, b = body_twist(ws.J6, self.idx1, v), body_twist(ws.J6, self.idx2, v)
        w1, w2 = np.array(u[3:]), np.array(b[3:])
        edot = (np.array(b[:3]) + np.cross(w2, j)) - (np.array(u[:3]) + np.cross(w1, j))
        axis = ws.data.oMf[self.f1].rotation[:, 2].copy()
        edot -= (edot @ axis) * axis
        F, Tj, power, eps = film_loads(self.theory, self.mu_oil, self.R2, self.L, self.c_film, e, edot, axis,
                                       float(axis @ (w2 - w1)))
        self._blend(d, F, Tj * axis, j, power, eps, Tj)

    def describe(self):
        return {**super().describe(), "theory": self.theory}


def from_spec(sp, mech, closure):
    theory = sp.choice("theory", THEORIES)
    film, sp_dry = film_spec(sp, own=("theory", "bearing_radius"))
    joint = _dry_from_spec(sp_dry, mech, closure, spatial=False)
    # the dry channel's clearance is c - asperity, so bearing_radius is checked against the nominal c
    check_bearing_radius(sp, joint.R2, film["c_nominal"])
    # the bearing is R_j + c: the dry channel's radii are those of the clearance c - h_a
    return LubricatedRevoluteClearance(joint.name, mech.model, joint.f1, joint.f2, joint.c, joint.R2, joint.law,
                                       joint.friction, length=joint.L, stiffness_note=joint.stiffness_note,
                                       theory=theory, **film, **sp.common(film["c_nominal"]))


LUBRICATED_REVOLUTE = PluginType(
    "lubricated_revolute", parse=from_spec, replaces=("revolute", "planar_point", "spherical"),
    doc="A planar journal bearing with an oil film: the hydrodynamic force and friction torque of the short "
        "(Ocvirk) or long (Sommerfeld) bearing with Guembel's cavitation, faded out over a band above the asperity "
        "height, below which the dry law acts (docs/wear_lubrication.md).",
    source="Pinkus & Sternlicht 1961; Flores et al. 2009", keys=_PLANAR + _LUB, plot=_PLOT)
KEYS = key_names(_PLANAR + _LUB)
