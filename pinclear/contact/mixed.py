"""Mixed lubrication of the lubricated clearances (lubricated.py, lubricated_spherical.py): the film,
the asperities and the dry law sharing one joint's load, compiled in one kernel.

The film carries load down to contact (its loads are never faded out); the surfaces' roughness
shares it when the minimum film thickness h = c - |e| is of the order of the combined roughness
sigma = sqrt(sigma_1^2 + sigma_2^2) (key ``roughness``). Film parameter lambda = h / sigma.

Asperities (Greenwood & Tripp 1970-71, Proc. IMechE 185, 625: two Gaussian rough surfaces of
asperity density eta, summit radius beta, composite modulus E'), the nominal pressure

    p_a(h) = K E' F_{5/2}(h / sigma),   K = (16 sqrt 2 / 15) pi (eta beta sigma)^2 sqrt(sigma / beta),

with the closed-form fit F_{5/2}(lam) = 4.4086e-5 (4 - lam)^6.804 for lam < 4, 0 beyond (Hu, Cheng,
Arai, Kobayashi & Aoyama 1994, SAE 940603; as in Arcoumanis, Ostovar & Mortier 1997, SAE 970840).
Near the narrowest gap the local gap is h + c psi^2 / 2 (psi the angle from it; to O(h / c) and
O(psi^2) in the area, psi <= sqrt(8 sigma / c)), so the asperity load integrates in closed form
with F = a (4 - lam)^b:

* journal (length L, radius R): W_a = K E' a L R sqrt(2 sigma / c) B(b) (4 - lam)^(b + 1/2),
  B(b) = int_-1^1 (1 - s^2)^b ds = sqrt(pi) Gamma(b + 1) / Gamma(b + 3/2);
* ball (radius R): W_a = K E' a 2 pi R^2 (sigma / c) (4 - lam)^(b + 1) / (b + 1).

Both are A0 (4 - lam)^m, acting along the line of centres at the contact points of the dry
geometry, and elastic: their energy is U_a = int_h^{4 sigma} W_a dh' = A0 sigma (4 - lam)^(m + 1)
/ (m + 1) (part of the joint's potential, so elastic runs conserve energy). W_a and its
derivatives up to order 6 vanish at lam = 4: the load grows from the asperity onset without a
jump. With the defaults (machined steel, sigma 0.3 um) p_a is 1.2 kPa at lam = 3 and 2 MPa at
lam = 1: the asperity share of a film-carried load is below 1 % for lam >= 3 and grows through the
mixed regime 1 < lam < 3 (tests/contact/test_mixed_lubrication.py).

Friction: the film's shear (in the film's torque) plus the asperities' boundary friction
mu_b W_a along the slip at the contact points, regularised as -mu_b W_a vt / sqrt(|vt|^2 + v_s^2)
(power -mu_b W_a |vt|^2 / sqrt(...) <= 0); the dry law and its friction law act on the
penetration |e| - c beyond contact (their onset speed recorded by the contact event as for a dry
joint). The load is the sum of the three; each is continuous in the state.

Defaults (``KEYS``): sigma 0.3 um (ground or fine-turned steel, Ra 0.2-0.4 um a surface, Rq ~ 1.25 Ra,
combined sqrt 2 Rq: Hamrock, Schmid & Jacobson 2004, Fundamentals of Machine Elements, table 8.1);
eta beta sigma = 0.04 and sigma / beta = 1e-3 (Greenwood & Tripp's range 0.03-0.05 and
1e-4-1e-2, the values of Hu et al. 1994); E' the joint's Hertz modulus E* = 1 / sum (1 - nu^2) / E;
mu_b 0.1 (boundary-lubricated steel on steel, 0.05-0.15: Hutchings 1992, Tribology, table 3.2).

Energy: z = [onset speeds | E_dissipated | friction states | film dissipation]; E_dissipated is the
dry law's and the frictions' loss plus the film's (-P_film >= 0), the last state the film's alone.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from pinclear.contact.base import ClearanceData
from pinclear.contact.channels import channel_friction
from pinclear.contact.force_laws import normal_force
from pinclear.contact.wear import WornJoint
from pinclear.core.jit import njit
from pinclear.core.registry import Key
from pinclear.model.forces import add_body_wrench, add_wrenches, body_twist, relative_velocity

#: the fit of Greenwood-Tripp's F_{5/2} (Hu et al. 1994): a (4 - lam)^b for lam < LAM_ONSET
F52_A, F52_B, LAM_ONSET = 4.4086e-5, 6.804, 4.0
#: default surface data (module doc)
SIGMA_DEFAULT, ETA_BETA_SIGMA, SIGMA_OVER_BETA, MU_BOUNDARY = 0.3e-6, 0.04, 1e-3, 0.1
#: the range of the combined roughness the model takes (m): polished to coarse-machined steel
SIGMA_RANGE = (1e-9, 5e-6)
#: slip speed regularising the asperities' boundary friction (m/s; the modified Coulomb law's v0)
V_SLIP = 1e-4
#: the film's gap floor as a fraction of sigma: below it the nominal gap lies inside the roughness,
#: where the asperities carry the load and the smooth-film formulas lose meaning
FLOOR = 0.01
#: the sidecar keys replaced by ``roughness`` (refused with one line naming it)
REMOVED = ("asperity", "band")

KEYS = (Key("viscosity", "number", "Pa s", None, "> 0", "Pinkus & Sternlicht 1961", "dynamic viscosity of the oil"),
        Key("roughness", "number", "m", SIGMA_DEFAULT, f"{SIGMA_RANGE[0]:g}-{SIGMA_RANGE[1]:g}, 4 x roughness < clearance",
            "Hamrock et al. 2004 table 8.1", "combined rms roughness sigma of the two surfaces (film parameter "
            "h / sigma; asperities share the load below 4 sigma)"),
        Key("asperity_density", "number", "1/m^2", "0.04 / (beta sigma)", "> 0", "Greenwood & Tripp 1970; Hu et al. "
            "1994", "summit density eta (eta beta sigma 0.03-0.05)"),
        Key("asperity_radius", "number", "m", "1000 x roughness", "> 0", "Greenwood & Tripp 1970; Hu et al. 1994",
            "summit radius beta (sigma / beta 1e-4 - 1e-2)"),
        Key("composite_modulus", "number", "Pa", "the material's E*", "> 0", "Greenwood & Tripp 1970",
            "E' of the asperity contact"),
        Key("boundary_mu", "number", "-", MU_BOUNDARY, "0-1", "Hutchings 1992 table 3.2",
            "boundary friction coefficient of the asperity contact"))


class MixedPar(NamedTuple):
    """The compiled film and asperity parameters of one joint: film kind (0 short journal, 1 long
    journal, 2 ball, 3 ball in a worn socket, 4 / 5 short / long journal in a worn bearing),
    viscosity mu, radius R, length L, clearance c, floor qmin of the gap ratio,
    the asperity load A0 (4 - lam)^m with sigma, boundary mu_b, slip speed vs, and the index of the
    film-dissipation state in z."""
    kind: int
    mu: float
    R: float
    L: float
    c: float
    qmin: float
    A0: float
    m: float
    sigma: float
    mu_b: float
    vs: float
    film_state: int


class FilmOut(NamedTuple):
    """What the kernel leaves per workspace: the film's force F on body 2 at the journal / ball
    centre j, its torque T about j, rates edot and spin w (scratch), and res = [eps, W_a, U_a,
    P_film, S (the full-film shear integral), T_j]."""
    F: np.ndarray
    T: np.ndarray
    j: np.ndarray
    edot: np.ndarray
    w: np.ndarray
    res: np.ndarray


#: the film kinds of a ball (MixedPar.kind); the others are journals'
BALL_FILMS = (2, 3)


def asperity_prefactor(kind, sigma, eta, beta, E, R, L, c):
    """(A0, m) of the asperity load W_a = A0 (4 - lam)^m of a journal (kind 0, 1, 4, 5) or ball (2, 3)."""
    K = 16.0 * math.sqrt(2.0) / 15.0 * math.pi * (eta * beta * sigma) ** 2 * math.sqrt(sigma / beta) * E * F52_A
    if kind in BALL_FILMS:
        return K * 2.0 * math.pi * R * R * sigma / c / (F52_B + 1.0), F52_B + 1.0
    B = math.sqrt(math.pi) * math.gamma(F52_B + 1.0) / math.gamma(F52_B + 1.5)
    return K * L * R * math.sqrt(2.0 * sigma / c) * B, F52_B + 0.5


@njit(cache=True, inline="always")
def asperity(A0, m, sigma, h):
    """(W_a, U_a): the asperities' load and elastic energy at the minimum gap h (module doc)."""
    x = LAM_ONSET - h / sigma
    if x <= 0.0:
        return 0.0, 0.0
    W = A0 * x ** m
    return W, W * x * sigma / (m + 1.0)


@njit(cache=True, inline="always")
def contact_loads(bodies, laws, fr, ch, mp, fo, v, z, zdot):
    """The dry law beyond contact and the asperities before it, on the one radial channel: F2 (on
    body 2 at p2), the onset-speed and friction-state rates into zdot; returns their dissipated
    power. Slip and normal rates are computed at every state (the asperities and the film need
    them)."""
    delta, n, p1, p2, dd, vt, dd0 = ch.delta, ch.n, ch.p1, ch.p2, ch.dd, ch.vt, ch.dd0
    relative_velocity(bodies.J, bodies.idx1, bodies.idx2, v, n, p1, p2, dd, vt)
    for k in range(zdot.shape[0]):
        zdot[k] = 0.0
    dd0[0] = max(z[0], laws.vmin)
    loss = 0.0
    d = delta[0]
    if d > 0.0:
        f, fe = normal_force(laws.code[0], d, dd[0], dd0[0], laws.P0[0], laws.P1[0], laws.chi[0])
        ch.Fn[0], ch.Fel[0] = f, fe
        loss += (f - fe) * dd[0] + channel_friction(0, fr.code, fr.par, f, vt, n, ch.F2, z, zdot)
    else:
        ch.Fn[0] = ch.Fel[0] = 0.0
        ch.F2[0, 0] = ch.F2[0, 1] = ch.F2[0, 2] = 0.0
    W, U = asperity(mp.A0, mp.m, mp.sigma, -d)
    fo.res[1], fo.res[2] = W, U
    if W > 0.0:
        s2 = vt[0, 0] * vt[0, 0] + vt[0, 1] * vt[0, 1] + vt[0, 2] * vt[0, 2]
        g = mp.mu_b * W / (s2 + mp.vs * mp.vs) ** 0.5
        for i in range(3):
            ch.F2[0, i] += -W * n[0, i] - g * vt[0, i]
        loss += g * s2
    return loss


@njit(cache=True, inline="always")
def centre_rates(bodies, v, j, edot, w):
    """edot = the velocity of the journal / ball centre j relative to body 1's material point there,
    w = the relative spin (world axes)."""
    u0, u1, u2, u3, u4, u5 = body_twist(bodies.J, bodies.idx1, v)
    b0, b1, b2, b3, b4, b5 = body_twist(bodies.J, bodies.idx2, v)
    x, y, zz = j[0], j[1], j[2]
    edot[0] = (b0 + b4 * zz - b5 * y) - (u0 + u4 * zz - u5 * y)
    edot[1] = (b1 + b5 * x - b3 * zz) - (u1 + u5 * x - u3 * zz)
    edot[2] = (b2 + b3 * y - b4 * x) - (u2 + u3 * y - u4 * x)
    w[0], w[1], w[2] = b3 - u3, b4 - u4, b5 - u5


@njit(cache=True, inline="always")
def apply_loads(bodies, ch, fo, tau):
    """tau += the contact force F2 at (p1, p2) and the film's wrench: (F, T about j) on body 2, its
    opposite on body 1 about the same point (the film holds no momentum)."""
    add_wrenches(bodies.J, bodies.idx1, bodies.idx2, ch.F2, ch.p1, ch.p2, tau)
    F, T, j = fo.F, fo.T, fo.j
    m0 = j[1] * F[2] - j[2] * F[1] + T[0]
    m1 = j[2] * F[0] - j[0] * F[2] + T[1]
    m2 = j[0] * F[1] - j[1] * F[0] + T[2]
    add_body_wrench(bodies.J, bodies.idx2, F[0], F[1], F[2], m0, m1, m2, tau)
    add_body_wrench(bodies.J, bodies.idx1, -F[0], -F[1], -F[2], -m0, -m1, -m2, tau)


class FilmData(ClearanceData):
    """ClearanceData plus the film's buffers (FilmOut) and a zdot and tau of the Python path."""

    def __init__(self, nc, nfs):
        super().__init__(nc, nfs)
        self.fo = FilmOut(np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(6))
        self.zdot = np.zeros(nc + 2 + nfs)


class FilmJoint:
    """Mixin of the lubricated clearance types: a dry joint of the full clearance c (the next base
    class) plus the film and the asperities (module doc), all in one compiled kernel the subclass
    names (``film_kernel``: placements, geometry and loads; ``film_eval``: the loads at a geometry
    already in the data, for the Python path). z = [onset speeds | E_dissipated | friction states |
    film dissipation]."""

    film_kernel = None
    film_eval = None
    _data_class = FilmData

    def __init__(self, *args, viscosity, roughness, asperity_density, asperity_radius, composite_modulus,
                 boundary_mu, **kw):
        self.mu_oil, self.sigma = float(viscosity), float(roughness)
        self.eta, self.beta, self.E_asp, self.mu_b = (float(asperity_density), float(asperity_radius),
                                                      float(composite_modulus), float(boundary_mu))
        super().__init__(*args, **kw)

    @property
    def c_film(self):
        return self.c

    def _freeze(self):
        self.kind = type(self).kind          # the dry base may have set its own
        self.nz = self.nc + 2 + self.nfs
        self.film_state = self.nz - 1
        A0, m = asperity_prefactor(self.film_code, self.sigma, self.eta, self.beta, self.E_asp, self.R2,
                                   getattr(self, "L", 0.0), self.c)
        self.mixed = MixedPar(int(self.film_code), self.mu_oil, self.R2, float(getattr(self, "L", 0.0)), self.c,
                              FLOOR * self.sigma / self.c, A0, m, self.sigma, self.mu_b, V_SLIP,
                              int(self.film_state))
        super()._freeze()

    def _compiled_kernel(self):
        if self._geo is None or self._laws is None or self._friction is None:
            raise TypeError(f"{self.kind}: its dry law and friction law need compiled forms")
        return type(self).film_kernel

    def _kernel_args(self, ws, d):
        return (self._geo, self._frames(ws, d), self._bodies(ws), self._laws, self._friction, d.channels,
                self.mixed, d.fo)

    def record_layout(self):
        return None

    def record_kernel(self, mech, ws, d, z, zdot, row):
        return None

    def record(self, mech, ws, d, t, q, v, z, after_rhs):
        # the compiled force leaves its buffers at the last trial state: recompute at this one
        d.key = d.q_key = None
        pot = self.potential(mech, ws, d, q)
        return pot, self.power_loss(mech, ws, d, t, q, v, z), self.outputs(mech, ws, d, t, q, v, z)

    def _compute(self, ws, d, v, z):
        """The same compiled loads as the kernel, at the geometry of Pinocchio's placements."""
        d.key = d.q_key = None
        self._geometry(ws.data, d)
        M1 = ws.data.oMf[self.f1].homogeneous
        type(self).film_eval(self._bodies(ws), self._laws, self._friction, d.channels, self.mixed, d.fo,
                             np.ascontiguousarray(M1), v, z, d.zdot)
        np.greater(d.delta, 0.0, out=d.on)
        d.moving = True
        d.loss = float(d.zdot[self.nc])
        d.dzf[:] = d.zdot[self.nc + 1:self.film_state]
        d.film_loss = float(d.zdot[self.film_state])

    def potential(self, mech, ws, d, q):
        d.key = d.q_key = None
        self._geometry(ws.data, d)
        d.q_key = q.tobytes()
        W, U = asperity_py(self.mixed, -float(d.delta[0]))
        return float(np.sum(self._energy(d, d.delta))) + U

    def add_force(self, mech, ws, d, t, q, v, z, tau, zdot):
        self._eval(ws, d, t, q, v, z)
        zdot[:] = d.zdot
        add_wrench_py(self._bodies(ws), d.channels, d.fo, tau)

    def outputs(self, mech, ws, d, t, q, v, z):
        out = super().outputs(mech, ws, d, t, q, v, z)
        fo = d.fo
        eps, W, _, _, _, Tj = fo.res
        h = self.c - float(np.linalg.norm(self._eccentricity(d)))
        out.update(film_force=fo.F.copy(), film_torque=fo.T.copy() if self.film_code in BALL_FILMS else Tj,
                   eccentricity_ratio=float(eps), film_parameter=h / self.sigma, asperity_force=float(W),
                   film_dissipated=float(z[self.film_state]))
        return out

    def _eccentricity(self, d):
        return (d.delta[0] + self.c) * d.n[0]

    def describe(self):
        return {**super().describe(), "viscosity": self.mu_oil, "roughness": self.sigma, "asperity_density": self.eta,
                "asperity_radius": self.beta, "composite_modulus": self.E_asp, "boundary_mu": self.mu_b}


class WornFilmJoint(WornJoint):
    """Mixin of the lubricated joints on a worn surface (before the lubricated type in the bases):
    the dry law and the asperities on the least-distance gap, searched at every eccentricity (ray
    radius 0: a worn seat's rim can be nearer than the ray's point well inside c / 2); the film
    at its equivalent eccentricity on the line of centres, which the worn kernel leaves (continuous
    in e, where the nearest point can jump between the rims of a seat); one compiled kernel, the
    film's. Wear follows the load the surfaces carry, dry plus asperity (NAME.wear_load,
    contact.wear.wear_load), not the film's: a film that keeps lambda >= 4 wears nothing."""

    _data_class = FilmData
    ray_radius = 0.0
    _compiled_kernel = FilmJoint._compiled_kernel
    _kernel_args = FilmJoint._kernel_args
    record_layout = FilmJoint.record_layout
    record_kernel = FilmJoint.record_kernel

    def _slip(self, d):
        # the Archard integrand's slip wherever the surfaces touch: dry contact or asperities
        carried = d.Fn[0] > 0.0 or d.fo.res[1] > 0.0
        return float(np.linalg.norm(d.vt[0])) if (d.moving and carried) else 0.0

    def outputs(self, mech, ws, d, t, q, v, z):
        out = super().outputs(mech, ws, d, t, q, v, z)
        out["wear_load"] = float(out["fn"]) + float(out["asperity_force"])
        return out

    def describe(self):
        return {**super().describe(), "wear": {**self.wear_description(),
                                               "load": "dry + asperity (the film's wears nothing)"}}


def asperity_py(mp, h):
    """asperity() from Python: (W_a, U_a) of MixedPar mp at the gap h."""
    return asperity(mp.A0, mp.m, mp.sigma, h)


@njit(cache=True)
def add_wrench_py(bodies, ch, fo, tau):
    apply_loads(bodies, ch, fo, tau)


def refuse_removed(spec, file):
    """One line naming ``roughness`` for an entry holding a key the mixed model replaced."""
    from pinclear.core.errors import ContactSetupError

    for k in REMOVED:
        if k in spec:
            raise ContactSetupError(f"removed: the film carries load down to contact and the asperities share it by "
                                    f"the combined roughness 'roughness' (sigma, m; default {SIGMA_DEFAULT:g})",
                                    file=str(file), key=f"clearances.{spec.get('name', '?')}.{k}")


def film_spec(sp):
    """The FilmJoint keyword arguments of a lubricated entry (viscosity, roughness and the asperity
    model, read and checked) and the entry without them, for the dry parser of the full clearance."""
    c = sp.clearance()
    sigma = sp.number("roughness", SIGMA_DEFAULT)
    if not SIGMA_RANGE[0] <= sigma <= SIGMA_RANGE[1]:
        raise sp.error("roughness", f"must lie in [{SIGMA_RANGE[0]:g}, {SIGMA_RANGE[1]:g}] m, got {sigma:g}")
    if LAM_ONSET * sigma >= c:
        raise sp.error("roughness", f"4 x roughness = {LAM_ONSET * sigma:g} m must be below the clearance {c:g} m")
    beta = sp.number("asperity_radius", sigma / SIGMA_OVER_BETA)
    mu_b = sp.number("boundary_mu", MU_BOUNDARY, allow_zero=True)
    if mu_b > 1.0:
        raise sp.error("boundary_mu", f"must lie in [0, 1], got {mu_b:g}")
    film = dict(viscosity=sp.number("viscosity"), roughness=sigma, asperity_radius=beta,
                asperity_density=sp.number("asperity_density", ETA_BETA_SIGMA / (beta * sigma)),
                composite_modulus=sp.number("composite_modulus", sp.estar()), boundary_mu=mu_b)
    return film, key_names_without(sp, [k.name for k in KEYS])


def key_names_without(sp, keys):
    """A copy of Spec ``sp`` whose entry lacks ``keys`` (the dry parser takes the rest)."""
    dry = {k: v for k, v in sp.d.items() if k not in keys}
    sp_dry = type(sp).__new__(type(sp))
    sp_dry.__dict__.update(sp.__dict__, d=dry)
    return sp_dry
