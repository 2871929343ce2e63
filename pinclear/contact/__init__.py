"""Clearance joints: a sidecar ``clearances:`` entry replaces an ideal closure by a
contact force element. See laws.py (normal and friction laws), spherical.py, revolute.py,
prismatic.py (geometry per joint type) and base.py (forces, events, energy bookkeeping).

Sidecar keys (all types): name, type, closure, active, clearance [m], ce, mu, normal_law,
friction_law, material | material1 + material2 (name or {E, nu}), stiffness
(conformal | printed | number), v_impact_min [m/s], max_initial_penetration [m], notes.
spherical: radius (ball), socket_radius. planar_revolute / revolute: radius (journal),
bearing_radius, length; revolute also axial_clearance. prismatic: section [a, b], clearance
[c1, c2] or c, length, model (energy | paper003; default energy: a Winkler foundation on each
slider face, the exact gradient of its energy; paper003: the paper's per-mode laws, not
conservative, see docs/contact_models.md), edge_radius, point_law, line_law, plane_law (the last
four are paper003's; the energy model takes its damping from normal_law).

Choosing a normal law by restitution (``pinclear bench restitution``): the effective
restitution of every damped law depends only on its hysteresis factor chi(ce).
Lankarani-Nikravesh (papers 000, 002, 003) and Hunt-Crossley are right for ce >= 0.8 and
overestimate below (LN: 0.68 / 0.76 / 0.91 for nominal 0.3 / 0.6 / 0.9); Flores et al.
(0.26 / 0.58 / 0.89) and Gonthier et al. (0.30 / 0.58 / 0.88) hold over the whole range, Flores
best for soft, low-restitution impacts. Hertz is the undamped reference.
"""
from __future__ import annotations

from types import MappingProxyType

from pinclear.errors import ContactSetupError

from . import prismatic, revolute, spherical
from .base import ClearanceJoint
from .laws import FRICTION_LAWS, NORMAL_LAWS, FrictionLaw, NormalLaw, make_friction_law, make_normal_law, restitution_1dof
from .spec import Spec

#: clearance type -> (allowed extra keys, closure types it may replace)
TYPES = MappingProxyType({
    "spherical": (spherical.KEYS, ("spherical",)),
    "planar_revolute": (revolute.KEYS_PLANAR, ("revolute", "planar_point", "spherical")),
    "revolute": (revolute.KEYS_SPATIAL, ("revolute",)),
    "prismatic": (prismatic.KEYS, ("prismatic",)),
})


def build(spec: dict, mech, sidecar_path):
    """Validate one ``clearances:`` entry and return its ForceElement.

    The closure named by ``closure`` must be one the loader removed (``mech.replaced_closures``)
    or still present in ``mech.closures``; its frame1 is the socket / bearing / guide, frame2
    the ball / journal / slider.
    """
    file = str(sidecar_path)
    if not isinstance(spec, dict) or "name" not in spec:
        raise ContactSetupError("each entry is a mapping with a 'name'", file=file, key="clearances")
    typ = spec.get("type")
    if typ not in TYPES:
        raise ContactSetupError(f"unknown clearance type {typ!r}", file=file, key=f"clearances.{spec['name']}.type",
                                choices=TYPES)
    keys, closure_types = TYPES[typ]
    sp = Spec(spec, file, set(keys))
    target = spec.get("closure")
    closures = {**{c.name: c for c in mech.closures}, **dict(mech.replaced_closures or {})}
    if target not in closures:
        raise sp.error("closure", f"no closure named {target!r}", sorted(closures))
    closure = closures[target]
    if closure.type not in closure_types:
        raise sp.error("closure", f"a {typ} clearance cannot replace the {closure.type} closure {target!r}",
                       closure_types)
    if typ == "spherical":
        return spherical.from_spec(sp, mech, closure)
    if typ in ("planar_revolute", "revolute"):
        return revolute.from_spec(sp, mech, closure, spatial=typ == "revolute")
    return prismatic.from_spec(sp, mech, closure)


__all__ = ["build", "TYPES", "NORMAL_LAWS", "FRICTION_LAWS", "make_normal_law", "make_friction_law",
           "restitution_1dof", "ClearanceJoint", "NormalLaw", "FrictionLaw"]
