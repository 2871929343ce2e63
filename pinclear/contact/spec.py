"""Validation of the sidecar keys shared by all clearance joints (pinclear.contact.build)."""
from __future__ import annotations

import math
import numbers

from pinclear.contact.laws import (
    HYSTERESIS,
    MATERIALS,
    NORMAL_LAWS,
    effective_modulus,
    make_friction_law,
    make_normal_law,
)
from pinclear.core.errors import ContactSetupError
from pinclear.core.registry import REQUIRED, Key, key_names

#: the keys of every ``clearances:`` entry (pinclear.core.registry.CLEARANCE_TYPES' common keys); a
#: type's own keys are in its module's PluginType record
COMMON = (
    Key("name", "string", doc="the clearance joint's name (--clearance NAME, NAME.key=... overrides, outputs "
        "NAME.penetration, ...)"),
    Key("type", "string", range="a clearance type (below)", doc="the clearance type"),
    Key("closure", "closure name", range="a closure of closures: whose type the clearance type replaces",
        doc="the ideal closure it replaces when active: its frame1 is the socket / bearing / guide, frame2 the "
        "ball / journal / slider"),
    Key("active", "bool", "-", False, doc="active without --clearance NAME"),
    Key("notes", "string", "-", "", doc="free text"),
    Key("clearance", "number", "m", REQUIRED, "> 0", "paper 000 eq. 6, paper 002 eq. 6: c = R_outer - R_inner",
        "radial clearance c; prismatic: c or [c1, c2], the gaps across the guide (paper 003 sec. 2)"),
    Key("ce", "number", "-", 0.9, "(0, 1]", "paper 000 eq. 17, paper 002 eq. 9", "restitution coefficient of the "
        "normal law (unless the law gives its own)"),
    Key("mu", "number", "-", None, ">= 0", "paper 000 eq. 19, paper 002 eq. 10", "friction coefficient: sets the "
        "friction law's (mu_d of stick_slip, mu_c of lugre); given > 0 without friction_law, modified_coulomb"),
    Key("normal_law", "law name or mapping", "-", "lankarani_nikravesh", "a normal law (below)", "contact/laws.py",
        "normal contact force law: a name or {type, ce, K, n, damping}"),
    Key("friction_law", "law name or mapping", "-", "modified_coulomb if mu > 0, else none",
        "a friction law (below)", "contact/laws.py", "tangential force law: a name or {type, ...}"),
    Key("material", "name or {E, nu}", "Pa, -", "steel", "a material (below) or E > 0, -1 < nu < 0.5",
        "paper 000 eq. 17: E* = 1/(sigma1 + sigma2)", "both bodies' material"),
    Key("material1", "name or {E, nu}", "Pa, -", "material", "as material", doc="body 1's (socket, bearing, "
        "guide) material"),
    Key("material2", "name or {E, nu}", "Pa, -", "material", "as material", doc="body 2's (ball, journal, "
        "slider) material"),
    Key("stiffness", "conformal | printed | number", "N/m^n", "conformal", "conformal, printed or > 0",
        "contact/laws.py hertz_stiffness", "K of the normal law: conformal K = 4/3 E* sqrt(R_i R_o/(R_o - R_i)) "
        "(an internal contact); printed: R_i R_o/(R_o + R_i) as papers 000 eq. 17 and 002 eq. 8 print it; or a "
        "number (spherical, revolute types)"),
    Key("v_impact_min", "number", "m/s", 1e-4, "> 0", "contact/base.py", "floor of the impact speed the damping "
        "divides by (grazing contacts)"),
    Key("max_initial_penetration", "number or null", "m", "0.1 x clearance", ">= 0 or null (no check)",
        "contact/base.py ClearanceJoint.z0", "the start is refused when a channel penetrates more"),
)
COMMON_KEYS = key_names(COMMON)
DEFAULTS = {k.name: k.default for k in COMMON}

#: the keys of a normal law mapping ({type: ..., ...}; contact.laws.make_normal_law)
NORMAL_LAW_KEYS = (
    Key("type", "string", "-", "lankarani_nikravesh", ", ".join(NORMAL_LAWS), "contact/laws.py", "the law"),
    Key("ce", "number", "-", "the joint's ce (hertz: 1)", "(0, 1]", "paper 000 eq. 17", "restitution coefficient"),
    Key("K", "number", "N/m^n", "the joint's stiffness", "> 0", "F = K d^n (...)", "stiffness (power laws)"),
    Key("n", "number", "-", 1.5, "> 0", "Hertz: n = 3/2", "exponent (power laws)"),
    Key("damping", "string", "-", "lankarani_nikravesh", ", ".join(HYSTERESIS), "contact/laws.py HYSTERESIS",
        "hysteresis factor chi(ce) of the line and plane laws"),
)
#: friction law type -> the keys of its mapping besides ``type`` (contact.laws.make_friction_law)
FRICTION_LAW_KEYS = {
    "none": (),
    "coulomb": (Key("mu", "number", "-", "the joint's mu", ">= 0", "contact/laws.py Coulomb", "coefficient"),
                Key("v_eps", "number", "m/s", 1e-4, "> 0", "contact/laws.py Coulomb",
                    "regularisation: mu |vt| / sqrt(|vt|^2 + v_eps^2)")),
    "modified_coulomb": (Key("mu", "number", "-", "the joint's mu", ">= 0", "paper 000 eq. 19", "coefficient"),
                         Key("v0", "number", "m/s", 1e-4, ">= 0", "paper 002 eq. 10", "below: no friction"),
                         Key("v1", "number", "m/s", 1e-2, "> v0", "paper 002 eq. 10", "above: full friction")),
    "stick_slip": (Key("mu_s", "number", "-", "the joint's mu", ">= 0", "paper 003 eq. 3", "static coefficient"),
                   Key("mu_d", "number", "-", REQUIRED, ">= 0", "paper 003 eq. 3", "dynamic coefficient (the "
                       "joint's mu sets it)"),
                   Key("Vs", "number", "m/s", 1e-3, "> 0", "paper 003 eq. 3", "stiction speed"),
                   Key("Vd", "number", "m/s", 1e-2, "> Vs", "paper 003 eq. 3", "dynamic speed")),
    "lugre": (Key("mu_c", "number", "-", "the joint's mu", ">= 0", "Canudas de Wit et al. 1995", "Coulomb level "
                  "(the joint's mu sets it)"),
              Key("mu_s", "number", "-", "mu_c", ">= 0", "Canudas de Wit et al. 1995", "static level"),
              Key("vs", "number", "m/s", 1e-3, "> 0", "Canudas de Wit et al. 1995", "Stribeck speed"),
              Key("s0", "number", "1/m", 1e5, "> 0", "Canudas de Wit et al. 1995", "bristle stiffness per unit Fn"),
              Key("s1", "number", "s/m", "sqrt(s0)", "finite", "Canudas de Wit et al. 1995", "bristle damping"),
              Key("s2", "number", "s/m", 0.0, ">= 0", "Canudas de Wit et al. 1995", "viscous term")),
}


class Spec:
    """Typed access to one ``clearances:`` entry with errors naming file, key and choices."""

    def __init__(self, spec: dict, file, allowed: set):
        self.d = dict(spec)
        self.file = str(file)
        self.name = self.d.get("name", "?")
        bad = sorted(set(self.d) - allowed - COMMON_KEYS)
        if bad:
            raise self.error(bad[0], "unknown key", sorted(allowed | COMMON_KEYS))

    def error(self, key, message, choices=None):
        return ContactSetupError(message, file=self.file, key=f"clearances.{self.name}.{key}", choices=choices)

    def number(self, key, default=None, *, positive=True, allow_zero=False):
        v = self.d.get(key, default)
        if v is None:
            raise self.error(key, "required")
        if isinstance(v, bool) or not isinstance(v, numbers.Real):
            try:
                v = float(v)
            except (TypeError, ValueError):
                raise self.error(key, f"expected a number, got {v!r}") from None
        v = float(v)
        if not math.isfinite(v):
            raise self.error(key, f"expected a finite number, got {v}")
        if positive and (v < 0 or (v == 0 and not allow_zero)):
            raise self.error(key, f"must be {'>= 0' if allow_zero else '> 0'}, got {v}")
        return v

    def pair(self, key, default=None):
        v = self.d.get(key, default)
        if v is None:
            raise self.error(key, "required")
        if isinstance(v, numbers.Real) and not isinstance(v, bool):
            v = [v, v]
        if not isinstance(v, (list, tuple)) or len(v) != 2:
            raise self.error(key, f"expected a number or a pair [x, y], got {v!r}")
        try:
            out = [float(x) for x in v]
        except (TypeError, ValueError):
            raise self.error(key, f"expected a number or a pair [x, y], got {v!r}") from None
        if not all(math.isfinite(x) for x in out) or min(out) <= 0:
            raise self.error(key, f"must be > 0, got {v!r}")
        return out

    def clearance(self):
        c = self.d.get("clearance")
        if c is None:
            raise self.error("clearance", "required (radial clearance c = R_outer - R_inner, m)")
        c = self.number("clearance", positive=False)
        if c <= 0:
            raise self.error("clearance", f"must be > 0 (m), got {c}")
        return c

    def material(self, which):
        """(E, nu) of body 1 or 2: ``material1``/``material2`` or the shared ``material``."""
        key = f"material{which}" if f"material{which}" in self.d else "material"
        m = self.d.get(key, DEFAULTS["material"])
        if isinstance(m, str):
            if m not in MATERIALS:
                raise self.error(key, f"unknown material {m!r}", MATERIALS)
            return MATERIALS[m]
        if isinstance(m, dict) and set(m) == {"E", "nu"}:
            E, nu = float(m["E"]), float(m["nu"])
            if not (E > 0 and -1 < nu < 0.5):
                raise self.error(key, f"need E > 0 and -1 < nu < 0.5, got {m!r}")
            return E, nu
        raise self.error(key, f"expected a material name or {{E: Pa, nu: -}}, got {m!r}", MATERIALS)

    def estar(self):
        (E1, n1), (E2, n2) = self.material(1), self.material(2)
        return effective_modulus(E1, n1, E2, n2)

    def ce(self):
        ce = self.number("ce", DEFAULTS["ce"])
        if not 0 < ce <= 1:
            raise self.error("ce", f"restitution coefficient {ce} outside (0, 1]")
        return ce

    def normal_law(self, key="normal_law", default=DEFAULTS["normal_law"], **geom):
        spec = self.d.get(key, default)
        if isinstance(spec, str):
            spec = {"type": spec}
        if not isinstance(spec, dict):
            raise self.error(key, f"expected a law name or mapping, got {spec!r}")
        spec = dict(spec)
        if "ce" not in spec and spec.get("type") != "hertz":
            spec["ce"] = self.ce()
        return make_normal_law(spec, file=self.file, key=f"clearances.{self.name}.{key}", **geom)

    def choice(self, key, choices):
        """A string from ``choices``; the first is the default."""
        v = self.d.get(key, choices[0])
        if v not in choices:
            raise self.error(key, f"invalid value {v!r}", choices)
        return v

    def hysteresis(self, key, default):
        """Hysteresis factor chi of the damped family named by ``key`` (a law name or {type, ce,
        damping}), with the joint's ``ce``: for models that take only the damping of a law."""
        spec = self.d.get(key, default)
        if isinstance(spec, str):
            spec = {"type": spec}
        if not isinstance(spec, dict):
            raise self.error(key, f"expected a law name or mapping, got {spec!r}", sorted(HYSTERESIS))
        spec = dict(spec)
        typ = spec.pop("type", None)
        if typ not in HYSTERESIS:
            raise self.error(f"{key}.type" if key in self.d and isinstance(self.d[key], dict) else key,
                             f"this model takes only the damping of a law, got {typ!r}", sorted(HYSTERESIS))
        ce = spec.pop("ce", None)
        ce = self.ce() if ce is None else float(ce)
        if not 0 < ce <= 1:
            raise self.error(f"{key}.ce", f"restitution coefficient {ce} outside (0, 1]")
        damping = spec.pop("damping", typ)
        if damping not in HYSTERESIS:
            raise self.error(f"{key}.damping", f"unknown hysteresis {damping!r}", sorted(HYSTERESIS))
        if spec:
            raise self.error(f"{key}.{sorted(spec)[0]}", "unknown key", ["type", "ce", "damping"])
        return float(HYSTERESIS[damping](ce))

    def friction_law(self):
        spec = self.d.get("friction_law")
        mu = self.number("mu", 0.0, allow_zero=True) if "mu" in self.d else None
        if spec is None:
            spec = {"type": "modified_coulomb"} if mu else {"type": "none"}
        if isinstance(spec, str):
            spec = {"type": spec}
        if not isinstance(spec, dict):
            raise self.error("friction_law", f"expected a law name or mapping, got {spec!r}")
        spec = dict(spec)
        # the joint-level mu (CLI --set S2.mu=0.1) sets the law's coefficient
        if mu is not None:
            key = {"stick_slip": "mu_d", "lugre": "mu_c"}.get(spec.get("type"), "mu")
            spec[key] = mu
        return make_friction_law(spec, file=self.file, key=f"clearances.{self.name}.friction_law")

    def common(self, scale):
        """Keyword arguments of ClearanceJoint; ``scale`` = clearance for the penetration limit."""
        lim = self.d.get("max_initial_penetration", 0.1 * scale)
        return dict(v_impact_min=self.number("v_impact_min", DEFAULTS["v_impact_min"]),
                    max_initial_penetration=None if lim is None else float(lim), file=self.file)
