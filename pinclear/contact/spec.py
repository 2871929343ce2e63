"""Validation of the sidecar keys shared by all clearance joints (pinclear.contact.build)."""
from __future__ import annotations

import numbers

from pinclear.errors import ContactSetupError

from .laws import HYSTERESIS, MATERIALS, effective_modulus, make_friction_law, make_normal_law

COMMON_KEYS = frozenset({"name", "type", "closure", "active", "notes", "clearance", "mu", "ce",
                         "normal_law", "friction_law", "material", "material1", "material2", "stiffness",
                         "v_impact_min", "max_initial_penetration"})


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
        out = [float(x) for x in v]
        if min(out) <= 0:
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
        m = self.d.get(key, "steel")
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
        ce = self.number("ce", 0.9)
        if not 0 < ce <= 1:
            raise self.error("ce", f"restitution coefficient {ce} outside (0, 1]")
        return ce

    def normal_law(self, key="normal_law", default="lankarani_nikravesh", **geom):
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
        return dict(v_impact_min=self.number("v_impact_min", 1e-4),
                    max_initial_penetration=None if lim is None else float(lim), file=self.file)
