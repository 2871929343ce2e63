"""Layer 2, contact: clearance joints: a sidecar ``clearances:`` entry replaces an ideal closure by a
contact force element. See laws.py (normal and friction laws), spherical.py, revolute.py,
prismatic.py (geometry per joint type) and base.py (forces, events, energy bookkeeping).

Sidecar keys: docs/keys.md, generated from the types' records (pinclear.core.registry.CLEARANCE_TYPES:
each type module declares its keys, parser, the closure types it replaces and its plot; the keys
of every type are contact.spec.COMMON). The prismatic type's two models: energy (default, a
Winkler foundation on each slider face, the exact gradient of its energy) and paper003 (the
paper's per-mode laws, not conservative; docs/contact_models.md).

Choosing a normal law by restitution (``pinclear bench restitution``): the effective
restitution of every damped law depends only on its hysteresis factor chi(ce).
Lankarani-Nikravesh (papers 000, 002, 003) and Hunt-Crossley are right for ce >= 0.8 and
overestimate below (LN: 0.68 / 0.76 / 0.91 for nominal 0.3 / 0.6 / 0.9); Flores et al.
(0.26 / 0.58 / 0.89) and Gonthier et al. (0.30 / 0.58 / 0.88) hold over the whole range, Flores
best for soft, low-restitution impacts. Hertz is the undamped reference.
"""
from __future__ import annotations

from pinclear.contact.base import ClearanceJoint
from pinclear.contact.mixed import refuse_removed
from pinclear.contact.laws import (
    FRICTION_LAWS,
    NORMAL_LAWS,
    FrictionLaw,
    NormalLaw,
    make_friction_law,
    make_normal_law,
    restitution_1dof,
)
from pinclear.contact.spec import Spec
from pinclear.core.errors import ContactSetupError
from pinclear.core.registry import CLEARANCE_TYPES

#: clearance type -> PluginType (its keys, parser, closure types it may replace, plot): the
#: registry is pinclear.core.registry.CLEARANCE_TYPES; one line there per type module
TYPES = CLEARANCE_TYPES
#: version of the contact models' forces (bump when a model's forces change): a wear checkpoint of
#: another version is refused (pinclear.analysis.wear_life)
MODEL_VERSION = 3      # 3: the worn socket's elastic foundation (contact.worn_foundation)
#: the types of the mixed-lubrication model (contact.mixed): the keys it replaced are refused by name
FILM_TYPES = ("lubricated_revolute", "lubricated_spherical")


def replacing(closure_type) -> list:
    """The clearance types that may replace a closure of ``closure_type``."""
    return [n for n in TYPES if closure_type in TYPES.get(n).replaces]


def build(spec: dict, mech, sidecar_path):
    """Validate one ``clearances:`` entry and return its ForceElement, built by its type's parser.

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
                                choices=TYPES.names())
    record = TYPES.get(typ)
    if typ in FILM_TYPES:
        refuse_removed(spec, file)
    sp = Spec(spec, file, set(TYPES.allowed(typ)))
    target = spec.get("closure")
    closures = {**{c.name: c for c in mech.closures}, **dict(mech.replaced_closures or {})}
    if target not in closures:
        raise sp.error("closure", f"no closure named {target!r}", sorted(closures))
    closure = closures[target]
    if closure.type not in record.replaces:
        fits = replacing(closure.type)
        hint = (f"; a {closure.type} closure takes type {' or '.join(fits)}" if fits else
                f"; no clearance type replaces a {closure.type} closure")
        raise sp.error("closure", f"a {typ} clearance cannot replace the {closure.type} closure {target!r}{hint}",
                       fits)
    return record.parse(sp, mech, closure)


__all__ = ["build", "TYPES", "replacing", "NORMAL_LAWS", "FRICTION_LAWS", "make_normal_law", "make_friction_law",
           "restitution_1dof", "ClearanceJoint", "NormalLaw", "FrictionLaw"]
