"""Spherical clearance joint: ball (frame2 of the replaced closure) in a socket (frame1).

Paper 000, sec. 1: eccentricity e = P_ball - P_socket (eq. 3), n = e/|e| (eq. 5),
penetration delta = |e| - c with c = R_socket - R_ball (eq. 6), contact points
C = P_socket + R_socket n and D = P_ball + R_ball n (eqs. 8-9), relative normal and tangential
velocities of D with respect to C (eqs. 10-16). Replacing the ideal 3-row closure, the ball
gets its 3 relative translations back.
"""
from __future__ import annotations

import numpy as np

from pinclear.contact import channels, worn_geometry
from pinclear.contact.base import ClearanceJoint
from pinclear.contact.laws import hertz_stiffness
from pinclear.contact.spec import DEFAULTS
from pinclear.contact.wear import WornData, WornJoint
from pinclear.contact.wear_spherical import POLES, socket_gpar
from pinclear.core.registry import ClearancePlot, Key, PluginType, key_names

_RADIUS = Key("radius", "number", "m", 0.01, "> 0", "paper 000 eq. 6", "ball radius R_ball")


class SphericalClearance(ClearanceJoint):
    kind = "spherical"
    geometry_code = channels.G_SPHERICAL

    def __init__(self, name, model, f1, f2, clearance, R_ball, law, friction, *, stiffness_note="given", **kw):
        super().__init__(name, model, f1, f2, 1, friction, **kw)
        self.c = float(clearance)
        self.R2 = float(R_ball)
        self.R1 = self.R2 + self.c
        self.law = law
        self.stiffness_note = stiffness_note
        self._freeze()

    def _channel_laws(self):
        return (self.law,)

    def _geometry_params(self):
        return np.array([self.c, self.R1, self.R2, 0.0, 0.0])

    def describe(self):
        return {**super().describe(), "clearance": self.c, "R_ball": self.R2, "R_socket": self.R1,
                "normal_law": repr(self.law), "stiffness": self.stiffness_note}


def from_spec(sp, mech, closure):
    c = sp.clearance()
    R2 = sp.number("radius", _RADIUS.default)
    if "socket_radius" in sp.d:
        R1 = sp.number("socket_radius")
        if R1 <= R2:
            raise sp.error("socket_radius", f"socket radius {R1} m must exceed the ball radius {R2} m")
        if abs((R1 - R2) - c) > 1e-12 * max(R1, 1.0):
            raise sp.error("socket_radius", f"socket_radius - radius = {R1 - R2} m differs from clearance {c} m")
    R1 = R2 + c
    K, note = stiffness(sp, R2, R1)
    law = sp.normal_law(K=K)
    if sp.d.get("wear") is not None:
        from pinclear.contact import wear_spherical

        return WornSphericalClearance(
            sp.name, mech.model, closure.f1, closure.f2, c, R2, law, sp.friction_law(), stiffness_note=note,
            wear=wear_spherical.parse(sp, R1, R2), **sp.common(c))
    return SphericalClearance(sp.name, mech.model, closure.f1, closure.f2, c, R2, law, sp.friction_law(),
                              stiffness_note=note, **sp.common(c))


def stiffness(sp, R_in, R_out):
    """K from ``stiffness``: conformal (default) | printed | a number (N/m^n)."""
    st = sp.d.get("stiffness", DEFAULTS["stiffness"])
    if isinstance(st, str):
        if st not in ("conformal", "printed"):
            raise sp.error("stiffness", f"invalid value {st!r}", ["conformal", "printed", "<number N/m^n>"])
        return hertz_stiffness(sp.estar(), R_in, R_out, st), st
    return sp.number("stiffness"), "given"


SPHERICAL = PluginType(
    "spherical", parse=from_spec, replaces=("spherical",),
    doc="A ball (frame2 of the replaced closure) in a socket (frame1): one contact channel, penetration "
        "|e| - c (paper 000 sec. 1).", source="paper 000 eqs. 3-16",
    keys=(_RADIUS, Key("socket_radius", "number", "m", "radius + clearance", "radius + clearance", "paper 000 eq. 6",
                       "socket radius R_socket (a check: it must equal radius + clearance)"),
          Key("wear", "mapping", "-", None, "{model: archard, k, hardness, nodes, distribution, pole, contact, foundation_cell}",
              "Archard 1953; contact/wear_spherical.py", "Archard wear of the socket on a (theta, phi) mesh, "
              "reshaping its contact geometry (pinclear wear)")),
    plot=ClearancePlot(across_axis=False, travel=False, boundary="circle", body="ball"))
KEYS = key_names(SPHERICAL.keys)


# ------------------------------------------------------------------ the worn joint
class WornSphericalClearance(WornJoint, SphericalClearance):
    """A spherical clearance whose socket has worn ``depth`` (m, one value per mesh node, row by
    row). The kernel plumbing (force scaled by |grad delta|, record with the slip speed) is
    the worn joints' shared one (contact.wear.WornJoint)."""

    _data_class = WornData
    geometry_code = channels.G_WORN_SPHERICAL
    #: within ray_radius x c of the centre the kernel takes the ray's gap (worn_geometry): no
    #: contact is possible there, and the dry force needs none
    ray_radius = 0.5

    def _geometry_params(self):
        return socket_gpar(self.wear, self.c, self.ray_radius, self.depth, self.wear.subdivision)

    def profile(self, theta, phi):
        """(w, dw/dtheta, dw/dphi) of the worn socket at the mesh angles (the kernel's interpolant)."""
        g = self._geo.gpar
        return np.array([worn_geometry.worn_sphere_depth(g, float(t), float(p))
                         for t, p in zip(np.atleast_1d(theta), np.atleast_1d(phi))]).T

    def describe(self):
        return {**super().describe(), "wear": self.wear_description()}

    def wear_description(self):
        w = self.wear
        return {"model": "archard", "k": w.k, "hardness": w.hardness, "nodes": w.rows, "distribution": w.distribution,
                "pole": POLES[w.pole], "max_depth": float(self.depth.max())}
