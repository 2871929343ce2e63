"""Normal-force and friction laws for clearance contacts.

All laws are vectorised over the contacts of one joint (numpy arrays of equal length) and
never allocate more than their result. ``NormalLaw`` and ``FrictionLaw`` state the contract.
Each law is written once: the damped power laws, the line law, the hysteresis term and the
friction laws (LuGre's as contact._kernels.lugre_channel) are the compiled functions of
``contact/channels.py``, which these classes call and the joints' channel loop calls too.
Sign conventions:

* ``delta`` penetration (m), > 0 in contact; ``ddelta`` its rate (m/s), > 0 while
  approaching; ``ddelta0`` the approach speed recorded at contact onset (> 0).
* Normal force ``Fn >= 0`` pushes the bodies apart; a law that would pull (adhesion, the
  damping term dominating while the bodies separate) is clipped to zero.
* Friction acts against the relative tangential velocity ``vt`` (k, 3):
  ``Ft = -mu(|vt|) Fn vt/|vt|`` for the memoryless laws.

Normal laws (``make_normal_law(spec)``; ``type`` chooses):

==================== ===========================================================================
hertz                F = K d^n                                         (elastic reference)
lankarani_nikravesh  F = K d^n [1 + 3(1-ce^2)/4 * dd/dd0]  paper 000 eq. 17, paper 002 eqs. 8-9
flores               F = K d^n [1 + 8(1-ce)/(5 ce) * dd/dd0]      Flores et al. 2011
hunt_crossley        F = K d^n [1 + 3(1-ce)/2 * dd/dd0]           Hunt & Crossley 1975 (via
                                                                   Lankarani-Nikravesh' chi)
gonthier             F = K d^n [1 + (1-ce^2)/ce * dd/dd0]         Gonthier et al. 2004
plane                F = E A d / l  [x the same hysteresis]       paper 003 eq. 4
line                 d(P) = P/(pi E* l) [1 - ln(P R/(pi E* l^3))] paper 003 eq. 6 (inverted for P)
==================== ===========================================================================

The onset speed in sustained contact (an explicit choice). The damped laws divide by ``ddelta0``,
the approach speed recorded at the channel's last contact onset. A contact that never separates
(paper 000's ball rides the socket wall for the whole study) keeps the ``ddelta0`` of its last
micro-landing, so its damping coefficient K chi / ddelta0 is set by whichever landing came last
(measured in paper 000: 123 -> 41 -> ... -> 1.83 mm/s, then held). pinclear's choice, stated:
``ddelta0 = max(recorded onset speed, v_impact_min)`` (the clearance key ``v_impact_min``,
default 0.1 mm/s, applied by contact/base.py and the compiled kernels): "held, with a floor".
A floor tied to the contact's scale is the same key set to that scale (e.g. the clearance over
the drive period, or the approach speed whose Hertz impact penetrates 1 % of the clearance);
floors that bind (10 and 100 mm/s, above the held 1.83 mm/s) lower the persistent contact's
damping and are measured against the default in docs/contact_models.md ("Persistent contact").
The default stays: no class of a row of papers 000 or 002 moves with the floor, though paper 002's
kind of motion at 0.01 mm and its steady-regime peaks do (same document).

Which law suits which restitution (see ``restitution_1dof`` and ``pinclear bench
restitution``): Lankarani-Nikravesh is derived for ce close to 1 and overestimates the
effective restitution badly below about 0.7; Flores et al. and Gonthier et al. track the
nominal ce over the whole range (Flores best at low ce); Hunt-Crossley (with the
Lankarani-Nikravesh chi) sits in between.

Friction laws (``make_friction_law(spec)``):

==================== ===========================================================================
none                 Ft = 0
coulomb              regularised Coulomb, mu |vt| / sqrt(|vt|^2 + v_eps^2)
modified_coulomb     mu * cd(|vt|), cd = 0 below v0, linear ramp to 1 at v1 (000 eq. 19, 002 eq. 10)
stick_slip           paper 003 eq. 3: mu_s sin(pi |V|/(2 Vs)) below Vs, cosine blend to mu_d at Vd
lugre                LuGre bristle model with internal state (Canudas de Wit et al. 1995),
                     normalised by Fn: Ft = -Fn (s0 z + s1 dz/dt + s2 vt)
==================== ===========================================================================
"""
from __future__ import annotations

import abc
import math
from types import MappingProxyType

import numpy as np
from scipy.integrate import solve_ivp

from pinclear.contact import force_laws
from pinclear.core.errors import ContactSetupError

# ============================================================================ materials
#: a few engineering materials (E in Pa, Poisson ratio), for ``material: steel`` in sidecars
MATERIALS = MappingProxyType({
    "steel": (207e9, 0.30),
    "steel_200": (200e9, 0.30),      # paper 003, Table 3
    "aluminium": (70e9, 0.33),
    "bronze": (110e9, 0.34),
    "cast_iron": (120e9, 0.26),
    "titanium": (110e9, 0.32),
})


def effective_modulus(E1, nu1, E2, nu2):
    """E* = 1/(sigma1 + sigma2), sigma = (1 - nu^2)/E (paper 000 eq. 17, paper 002 eq. 8)."""
    return 1.0 / ((1.0 - nu1 ** 2) / E1 + (1.0 - nu2 ** 2) / E2)


def hertz_stiffness(Estar, R_inner, R_outer, geometry="conformal"):
    """Hertz point-contact stiffness K = 4/3 E* sqrt(R_eff) for a ball (journal) of radius
    R_inner inside a socket (bearing) of radius R_outer.

    ``conformal``: R_eff = R_i R_o / (R_o - R_i), the curvature sum of an internal contact
    (concave socket): the physically right value.
    ``printed``: R_eff = R_i R_o / (R_o + R_i), as papers 000 (eq. 17) and 002 (eq. 8) print
    it (the external-contact formula); use it to reproduce their figures.
    """
    if geometry == "conformal":
        Reff = R_inner * R_outer / (R_outer - R_inner)
    elif geometry == "printed":
        Reff = R_inner * R_outer / (R_outer + R_inner)
    else:
        raise ContactSetupError(f"stiffness geometry {geometry!r} unknown", key="stiffness",
                                choices=["conformal", "printed"])
    return 4.0 / 3.0 * Estar * math.sqrt(Reff)


# ============================================================================ normal laws
#: hysteresis factor chi(ce) of the damped Hertz family F = K d^n (1 + chi dd/dd0)
HYSTERESIS = MappingProxyType({
    "hertz": lambda ce: 0.0,
    "lankarani_nikravesh": lambda ce: 3.0 * (1.0 - ce * ce) / 4.0,
    "flores": lambda ce: 8.0 * (1.0 - ce) / (5.0 * ce),
    "hunt_crossley": lambda ce: 1.5 * (1.0 - ce),
    "gonthier": lambda ce: (1.0 - ce * ce) / ce,
})
NORMAL_LAWS = tuple(HYSTERESIS) + ("plane", "line")


class _Immutable:
    """Laws are shared by every workspace of a mechanism: writing to one after ``__init__``
    raises (a law has no per-evaluation state; LuGre's bristles live in the joint's z)."""

    def __setattr__(self, key, value):
        if getattr(self, "_frozen", False):
            raise AttributeError(f"{type(self).__name__} is immutable (tried to set {key!r})")
        object.__setattr__(self, key, value)

    def _freeze(self):
        object.__setattr__(self, "_frozen", True)


def _vec(*arrays):
    """Float, C-contiguous 1-D copies of broadcast inputs (one compiled signature per kernel)."""
    out = np.broadcast_arrays(*[np.atleast_1d(np.asarray(a, float)) for a in arrays])
    return [np.ascontiguousarray(a.ravel()) for a in out]


class NormalLaw(_Immutable, abc.ABC):
    """Normal-force law of one contact channel (the joint applies it to each of its channels).

    The contract (the clearance joints rely on nothing else):

    1. Inputs are 1-D float arrays of equal length k (one entry per contact channel), in SI units:
       penetration ``d`` (m, > 0 in contact), its rate ``dd`` (m/s, > 0 while the bodies
       approach) and ``dd0`` the approach speed recorded at contact onset (m/s, > 0; the joint
       floors it at ``v_impact_min``).
    2. :meth:`force` returns the normal force F (N, shape (k,)), ``F >= 0`` pushing the bodies
       apart and exactly 0 where ``d <= 0``. A law that would pull (the damping term dominating
       while the bodies separate) is clipped to zero.
    3. The energy split: :meth:`elastic` is the conservative part F_el(d) (N, (k,), zero for
       d <= 0) and :meth:`energy` its potential, int_0^d F_el (J, (k,)). The power
       (F - F_el) dd is what the law dissipates; the joint integrates it, so the energy balance
       of a run closes whatever the clipping did.
    4. ``chi`` is the hysteresis factor of the damped family F = F_el (1 + chi dd/dd0): with it
       alone the effective restitution of an impact follows (``restitution_1dof``).
    5. A law has no internal state and is immutable after ``__init__``.
    6. :meth:`kernel_params` declares whether the joints' compiled channel loop can evaluate the
       law: ``(code, p0, p1, chi)`` with the codes of contact._kernels (N_POWER: (K, n) of a
       damped power law K d^n (1 + chi dd/dd0); N_LINE: (c, a) of the line law), None otherwise
       (the joint then calls :meth:`force` and :meth:`elastic`).
    """

    name: str = ""
    ce: float = 1.0
    chi: float = 0.0

    @abc.abstractmethod
    def elastic(self, d) -> np.ndarray:
        """Conservative force F_el(d), N."""

    @abc.abstractmethod
    def energy(self, d) -> np.ndarray:
        """Potential of :meth:`elastic`, J."""

    def force(self, d, dd, dd0) -> np.ndarray:
        """Normal force; zero where d <= 0."""
        fe, dd, dd0 = _vec(self.elastic(d), dd, dd0)
        F = np.empty_like(fe)
        force_laws.damped_forces(fe, dd, dd0, float(self.chi), F)
        return F

    def force_and_elastic(self, d, dd, dd0):
        """(F, F_el) in one call (the joints need both)."""
        return self.force(d, dd, dd0), self.elastic(d)

    def kernel_params(self):
        return None


class PowerLaw(NormalLaw):
    """Damped power law F = K d^n (1 + chi dd/dd0), clipped at zero; chi from the ``damping``
    hysteresis (default: the law's own name) and ce. ``plane`` is this law with n = 1 and
    K = E A / l. The elastic force is held constant beyond 0.1 m (never physical) so trial
    stages of a step stay finite."""

    def __init__(self, name, K, n=1.5, ce=1.0, damping=None):
        self.name, self.K, self.n, self.ce = name, float(K), float(n), float(ce)
        self.chi = float(HYSTERESIS[damping or name](self.ce))
        self._freeze()

    def elastic(self, d):
        (d,) = _vec(d)
        Fe = np.empty_like(d)
        force_laws.power_law_elastic(d, self.K, self.n, Fe)
        return Fe

    def energy(self, d):
        # the potential of elastic(), including its constant continuation beyond DELTA_CAP
        (d,) = _vec(d)
        U = np.empty_like(d)
        force_laws.power_law_energy(d, self.K, self.n, U)
        return U

    def force(self, d, dd, dd0):
        return self.force_and_elastic(d, dd, dd0)[0]

    def force_and_elastic(self, d, dd, dd0):
        d, dd, dd0 = _vec(d, dd, dd0)
        F, Fe = np.empty_like(d), np.empty_like(d)
        force_laws.power_law_forces(d, dd, dd0, self.K, self.n, self.chi, F, Fe)
        return F, Fe

    def kernel_params(self):
        return force_laws.N_POWER, self.K, self.n, self.chi

    def __repr__(self):
        return f"{self.name}(K={self.K:.4g}, n={self.n}, ce={self.ce}, chi={self.chi:.4g})"


class LineLaw(NormalLaw):
    """Cylindrical (line) contact of length l, paper 003 eq. 6 (Puttock & Thwaite):

        d(P) = P/(pi E* l) [1 - ln(P R / (pi E* l^3))]

    inverted for the load P by Newton iteration on log P (d is monotone in P below
    pi E* l^3 / R, far above any load of interest). Elastic energy = P d - int_0^P d dP,
    with int_0^P d dP = (3/4 P^2 - P^2/2 ln(a P)) / (pi E* l), a = R/(pi E* l^3).
    The same hysteresis factor as the Hertz family multiplies the elastic load.
    """

    def __init__(self, Estar, length, radius, ce=1.0, damping="lankarani_nikravesh"):
        self.name, self.ce = "line", float(ce)
        self.chi = float(HYSTERESIS[damping](self.ce))
        self.Estar, self.l, self.R = float(Estar), float(length), float(radius)
        self.c = 1.0 / (math.pi * self.Estar * self.l)          # d = c P (1 - ln(a P))
        self.a = self.R / (math.pi * self.Estar * self.l ** 3)
        self.Pmax = 1.0 / self.a                                 # d'(P) = -c ln(aP) > 0 below
        self._freeze()

    def deflection(self, P):
        P = np.asarray(P, float)
        out = np.zeros_like(P)
        m = P > 0
        out[m] = self.c * P[m] * (1.0 - np.log(self.a * P[m]))
        return out

    def elastic(self, d):
        (d,) = _vec(d)
        P = np.empty_like(d)
        force_laws.line_elastic_all(d, self.c, self.a, P)
        return P

    def energy(self, d):
        P = self.elastic(d)
        d = np.atleast_1d(np.asarray(d, float))
        out = np.zeros_like(P)
        m = P > 0
        Pm = P[m]
        comp = self.c * (0.75 * Pm ** 2 - 0.5 * Pm ** 2 * np.log(self.a * Pm))
        out[m] = Pm * d[m] - comp
        return out

    def force_and_elastic(self, d, dd, dd0):
        fe, dd, dd0 = _vec(self.elastic(d), dd, dd0)
        F = np.empty_like(fe)
        force_laws.damped_forces(fe, dd, dd0, self.chi, F)
        return F, fe

    def force(self, d, dd, dd0):
        return self.force_and_elastic(d, dd, dd0)[0]

    def kernel_params(self):
        return force_laws.N_LINE, self.c, self.a, self.chi

    def __repr__(self):
        return f"line(E*={self.Estar:.4g}, l={self.l}, R={self.R}, chi={self.chi:.4g})"


def make_normal_law(spec, *, file="<spec>", key="normal_law", K=None, line=None, plane=None):
    """Build a normal law from a dict ``{type, ce, K?, n?, damping?}``.

    ``K`` is the joint's stiffness from materials and radii (used when the spec gives none);
    ``line`` = (E*, length, radius) and ``plane`` = (E, area, thickness) for the prismatic kinds.
    """
    if isinstance(spec, str):
        spec = {"type": spec}
    spec = dict(spec)
    typ = spec.pop("type", None)
    if typ not in NORMAL_LAWS:
        raise _err(file, f"{key}.type", f"unknown normal law {typ!r}", NORMAL_LAWS)
    ce = float(spec.pop("ce", 1.0 if typ == "hertz" else 0.9))
    if not 0.0 < ce <= 1.0:
        raise _err(file, f"{key}.ce", f"restitution coefficient {ce} outside (0, 1]")
    damping = spec.pop("damping", "lankarani_nikravesh")
    if damping not in HYSTERESIS:
        raise _err(file, f"{key}.damping", f"unknown hysteresis {damping!r}", HYSTERESIS)
    if typ == "line":
        if line is None:
            raise _err(file, f"{key}.type", "the line law needs a line geometry (prismatic or revolute joint)")
        _no_extra(spec, file, key)
        return LineLaw(*line, ce=ce, damping=damping)
    if typ == "plane":
        if plane is None:
            raise _err(file, f"{key}.type", "the plane law needs a face geometry (prismatic joint)")
        E, A, thick = plane
        _no_extra(spec, file, key)
        return PowerLaw("plane", K=E * A / thick, n=1.0, ce=ce, damping=damping)
    Kv = spec.pop("K", K)
    n = float(spec.pop("n", 1.5))
    _no_extra(spec, file, key)
    if Kv is None or not float(Kv) > 0:
        raise _err(file, f"{key}.K", f"contact stiffness must be > 0, got {Kv}")
    if not n > 0:
        raise _err(file, f"{key}.n", f"exponent must be > 0, got {n}")
    return PowerLaw(typ, K=float(Kv), n=n, ce=ce)


# ============================================================================ friction laws
FRICTION_LAWS = ("none", "coulomb", "modified_coulomb", "stick_slip", "lugre")


class FrictionLaw(_Immutable, abc.ABC):
    """Tangential force law of the contact channels of one joint.

    The contract (the clearance joints rely on nothing else):

    1. :meth:`force` takes the normal forces ``Fn`` (N, shape (k,), >= 0) and the slip
       velocities ``vt`` (m/s, (k, 3), world axes: velocity of the body-2 contact point relative
       to the body-1 point, tangent to the contact) and returns the friction forces on body 2
       (N, (k, 3), world); body 1 gets their opposite.
    2. Friction opposes the slip: ``Ft . vt <= 0`` for the memoryless laws, which have the form
       ``Ft = -mu(|vt|) Fn vt/|vt|`` (:meth:`coefficient` is mu). The joint integrates the
       power -Ft . vt as dissipated energy.
    3. ``nstate`` internal states per contact (0 for memoryless laws, 3 for LuGre: a bristle
       deflection vector in world axes, m). For such a law :meth:`force` receives ``state``
       (k, nstate) and WRITES its rate into ``dstate`` (k, nstate); the states are integrated with
       q and v in the joint's z. The joint projects them and their force onto the tangent plane
       of each contact and resets them to zero at contact onset. For LuGre the power -Ft . vt then
       includes the bristles' elastic energy rate: the balance still closes.
    4. A law is immutable after ``__init__``: every evolving quantity lives in the states of 3.
    5. :meth:`kernel_params` declares whether the joints' compiled channel loop can evaluate the
       law: ``(code, parameters)`` with the codes of contact._kernels (the memoryless laws and
       LuGre), None otherwise (the joint then calls :meth:`force`).
    """

    name: str = ""
    nstate: int = 0

    @abc.abstractmethod
    def force(self, Fn, vt, state=None, dstate=None) -> np.ndarray:
        """Friction forces (k, 3) on body 2."""

    def kernel_params(self):
        return None


class MemorylessFriction(FrictionLaw):
    """Ft = -mu(|vt|) Fn vt/|vt|, mu given by the compiled coefficient of ``kernel_params()``."""

    @abc.abstractmethod
    def kernel_params(self):
        """(friction code, float parameter array)."""

    def coefficient(self, s):
        code, par = self.kernel_params()
        (s,) = _vec(s)
        mu = np.empty_like(s)
        force_laws.friction_coefficients(code, par, s, mu)
        return mu

    def force(self, Fn, vt, state=None, dstate=None):
        code, par = self.kernel_params()
        vt = np.ascontiguousarray(vt, dtype=float).reshape(-1, 3)
        (Fn,) = _vec(Fn)
        Ft = np.empty_like(vt)
        force_laws.memoryless_friction(code, par, np.ascontiguousarray(np.broadcast_to(Fn, len(vt))), vt, Ft)
        return Ft


def _params(*values):
    """Read-only parameter array of a compiled friction law (never empty: numba needs a dtype)."""
    par = np.array(list(values) + [0.0], float)
    par.flags.writeable = False
    return par


class NoFriction(MemorylessFriction):
    name = "none"

    def __init__(self):
        self._par = _params()
        self._freeze()

    def kernel_params(self):
        return force_laws.F_NONE, self._par


class Coulomb(MemorylessFriction):
    """Regularised Coulomb: mu |vt| / sqrt(|vt|^2 + v_eps^2)."""

    name = "coulomb"

    def __init__(self, mu, v_eps=1e-4):
        self.mu, self.v_eps = float(mu), float(v_eps)
        self._par = _params(self.mu, self.v_eps)
        self._freeze()

    def kernel_params(self):
        return force_laws.F_COULOMB, self._par


class ModifiedCoulomb(MemorylessFriction):
    """Papers 000 eqs. 18-19 and 002 eq. 10: no friction below v0 (numerical dead band),
    linear ramp of the correction cd between v0 and v1, full Coulomb above v1."""

    name = "modified_coulomb"

    def __init__(self, mu, v0=1e-4, v1=1e-2):
        self.mu, self.v0, self.v1 = float(mu), float(v0), float(v1)
        self._par = _params(self.mu, self.v0, self.v1)
        self._freeze()

    def kernel_params(self):
        return force_laws.F_MODIFIED, self._par


class StickSlip(MemorylessFriction):
    """Paper 003 eq. 3 (after Mostaghel & Davis): static peak mu_s reached at Vs along a sine,
    cosine blend down to the sliding value mu_d at Vd."""

    name = "stick_slip"

    def __init__(self, mu_s, mu_d, Vs=1e-3, Vd=1e-2):
        self.mu_s, self.mu_d, self.Vs, self.Vd = float(mu_s), float(mu_d), float(Vs), float(Vd)
        self._par = _params(self.mu_s, self.mu_d, self.Vs, self.Vd)
        self._freeze()

    def kernel_params(self):
        return force_laws.F_STICKSLIP, self._par


class LuGre(FrictionLaw):
    """LuGre bristle model per contact, normalised by the normal force:

        dz/dt = vt - s0 |vt| z / g(|vt|),  g = mu_c + (mu_s - mu_c) exp(-(|vt|/vs)^2)
        Ft = -Fn (s0 z + s1 dz/dt + s2 vt)

    z (m) is a tangent vector (3 world components per contact); it is integrated with q, v and
    reset to zero at each contact onset. s0 [1/m], s1 [s/m], s2 [s/m].
    """

    name = "lugre"
    nstate = 3

    def __init__(self, mu_s, mu_c, vs=1e-3, s0=1e5, s1=None, s2=0.0):
        self.mu_s, self.mu_c, self.vs = float(mu_s), float(mu_c), float(vs)
        self.s0 = float(s0)
        # Canudas de Wit et al.'s example (unit Coulomb force) pairs s0 with s1 = sqrt(s0)
        self.s1 = float(s1) if s1 is not None else math.sqrt(self.s0)
        self.s2 = float(s2)
        self._par = _params(self.mu_s, self.mu_c, self.vs, self.s0, self.s1, self.s2)
        self._freeze()

    def kernel_params(self):
        return force_laws.F_LUGRE, self._par

    def force(self, Fn, vt, state=None, dstate=None):
        vt = np.ascontiguousarray(vt, dtype=float).reshape(-1, 3)
        (Fn,) = _vec(Fn)
        state = np.ascontiguousarray(state, dtype=float).reshape(-1, 3)
        zd = np.empty_like(vt)
        Ft = np.empty_like(vt)
        force_laws.lugre_forces(self._par, np.ascontiguousarray(np.broadcast_to(Fn, len(vt))), vt, state, zd, Ft)
        if dstate is not None:
            dstate[:] = zd
        return Ft


def make_friction_law(spec, *, file="<spec>", key="friction_law", mu=None):
    """Build a friction law from ``{type, mu?, ...}``; ``mu`` is the joint-level coefficient."""
    if spec is None:
        spec = {"type": "none" if not mu else "modified_coulomb"}
    if isinstance(spec, str):
        spec = {"type": spec}
    spec = dict(spec)
    typ = spec.pop("type", None)
    if typ not in FRICTION_LAWS:
        raise _err(file, f"{key}.type", f"unknown friction law {typ!r}", FRICTION_LAWS)

    def num(name, default=None, positive=True):
        v = spec.pop(name, default)
        if v is None:
            raise _err(file, f"{key}.{name}", f"required for friction law {typ}")
        v = float(v)
        if v < 0 or (positive and v == 0):
            raise _err(file, f"{key}.{name}", f"must be {'> 0' if positive else '>= 0'}, got {v}")
        return v

    if typ == "none":
        law = NoFriction()
    elif typ == "coulomb":
        law = Coulomb(num("mu", mu, False), num("v_eps", 1e-4))
    elif typ == "modified_coulomb":
        law = ModifiedCoulomb(num("mu", mu, False), num("v0", 1e-4, False), num("v1", 1e-2))
        if not law.v1 > law.v0:
            raise _err(file, f"{key}.v1", f"must exceed v0 ({law.v0}), got {law.v1}")
    elif typ == "stick_slip":
        law = StickSlip(num("mu_s", mu, False), num("mu_d", None, False), num("Vs", 1e-3), num("Vd", 1e-2))
        if not law.Vd > law.Vs:
            raise _err(file, f"{key}.Vd", f"must exceed Vs ({law.Vs}), got {law.Vd}")
    else:
        mu_c = num("mu_c", mu, False)
        law = LuGre(num("mu_s", mu_c, False), mu_c, num("vs", 1e-3), num("s0", 1e5),
                    spec.pop("s1", None), num("s2", 0.0, False))
    _no_extra(spec, file, key)
    return law


# ============================================================================ 1-DOF reference
def restitution_1dof(law, v0=1.0, m=1.0, rtol=1e-12, atol=None):
    """Effective restitution of a mass m hitting a rigid wall through ``law`` at speed v0.

    m d'' = -F(d, d', v0), d(0) = 0, d'(0) = v0, integrated (DOP853) until d returns to 0
    (event located); returns -d'(end)/v0. For every law F = f(d) (1 + chi dd/dd0) the result
    depends on chi alone: with the elastic work W = int f dd as variable, m v dv/dW =
    -(1 + chi v/v0) does not contain f, m or K, and v/v0 scales out.
    """
    dd0 = np.array([v0])
    d_max = max_penetration(law, 0.5 * m * v0 * v0)

    def rhs(t, y):
        F = law.force(np.array([y[0]]), np.array([y[1]]), dd0)[0]
        return (y[1], -F / m)

    def back(t, y):
        return y[0]

    back.terminal, back.direction = True, -1
    sol = solve_ivp(rhs, (0.0, 1e3 * d_max / v0), [0.0, v0], method="DOP853", rtol=rtol,
                    atol=atol if atol is not None else [rtol * d_max, rtol * v0], events=back,
                    first_step=1e-3 * d_max / v0)
    if not sol.t_events[0].size:
        raise RuntimeError(f"1-DOF impact of {law!r} did not separate")
    return -sol.y_events[0][0][1] / v0


def max_penetration(law, energy):
    """Penetration at which the elastic energy of ``law`` equals ``energy`` (bisection in log)."""
    lo, hi = 1e-15, 1.0
    for _ in range(200):
        mid = math.sqrt(lo * hi)
        if law.energy(np.array([mid]))[0] < energy:
            lo = mid
        else:
            hi = mid
        if hi / lo < 1 + 1e-14:
            break
    return math.sqrt(lo * hi)


# ============================================================================ helpers
def _err(file, key, message, choices=None):
    return ContactSetupError(message, file=file, key=key, choices=choices)


def _no_extra(spec, file, key):
    if spec:
        bad = sorted(spec)[0]
        raise _err(file, f"{key}.{bad}", "unknown key")
