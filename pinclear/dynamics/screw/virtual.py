"""Virtual-joint rules: how a limb with fewer than six screws is completed to six (paper 004,
sec. 2.1, the virtual-mechanism method).

The drive forces do not depend on the completion; only the virtual joints' own generalized forces
(the constraint limbs' reactions, reported as ``virtual`` and ``constraint_wrench``) and the
virtual columns of the influence coefficients do. A rule is chosen per limb in the sidecar
(``screw: virtual: {LIMB: RULE}``):

* ``complement`` (the default): the orthogonal complement of the real screws' span, kept
  continuous along a motion (see :meth:`pinclear.dynamics.screw.ScrewSystem.screws`);
* a name of :data:`VIRTUAL_RULES` (below);
* ``module:function`` naming a rule of the same signature.

A rule is ``f(real, base, platform) -> (6 - n, 6) array``: ``real`` the limb's n real screws
(paper order, WORLD, base to platform: tree joints then cut-joint screws), ``base`` the world
position of the limb's first joint, ``platform`` the platform joint's world placement (pin.SE3).
"""
from __future__ import annotations

from types import MappingProxyType

import numpy as np

from pinclear.dynamics.screw.algebra import cross, line_twist

#: the rule that needs no function: the orthogonal complement of the real screws
COMPLEMENT = "complement"


def line_normal(real, base, platform):
    """Two rotations for a four-screw limb whose first joint is a revolute (paper 004's choice for
    its UPR limb, sec. 2.1): S5 about the limb line l from the first joint's centre u to the
    platform joint's origin p', S6 = (s6; p' x s6) through p' with s6 = l x s2 / |l x s2| and
    s2 = e1 x l / |e1 x l|, e1 the first joint's axis. (For a U joint s2 is its second axis; the
    paper prints "s5 x l5", an extraction slip since s5 = l5; the order l x s2 reproduces the sign
    of its printed G_q^p.)"""
    if len(real) != 4:
        raise ValueError(f"the line_normal rule completes limbs of 4 real screws, this one has {len(real)}")
    pp = platform.translation
    ell = (pp - base) / np.linalg.norm(pp - base)
    s2 = cross(real[0, :3], ell)
    s2 /= np.linalg.norm(s2)
    s6 = cross(ell, s2)
    s6 /= np.linalg.norm(s6)
    return np.stack([line_twist(ell, base), line_twist(s6, pp)])


#: named geometric rules a sidecar may choose (read-only: rules of other modules are named
#: ``module:function`` in the sidecar instead of being registered here at run time)
VIRTUAL_RULES = MappingProxyType({"line_normal": line_normal})


def rule_choices() -> list[str]:
    return [COMPLEMENT, *VIRTUAL_RULES, "module:function"]
