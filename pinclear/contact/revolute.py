"""Revolute clearance joints: journal (frame2 of the replaced closure) in a bearing (frame1).

``planar_revolute`` (paper 002, sec. 1.1): e = r_journal - r_bearing (eq. 1) taken in the plane
normal to the bearing axis (frame1 z), n = e/|e| (eq. 2), delta = |e| - c, c = R_bearing -
R_journal (eq. 6), contact points r + R n (eq. 3), normal and tangential velocities of the
contact points (eqs. 4-5). Use it where the rest of the mechanism keeps the motion planar.

``revolute`` (spatial radial clearance): the journal, of length L along its own axis (frame2 z),
is checked at both ends against the bearing cylinder (two radial channels: they carry both the
radial load and the tilting moment), and its centre against the two thrust faces a distance
``axial_clearance`` away along the bearing axis (two axial channels). All five freedoms the
ideal revolute closure removed come back, held by contact.

For each radial channel the bearing point is taken at the journal point's axial station,
p1 = s + u a + R_bearing n, so n . (v2(p2) - v1(p1)) is exactly d(delta)/dt even when the
bearing axis turns (energy balance exact).
"""
from __future__ import annotations

import functools

import numpy as np

from pinclear.contact import channels, worn_geometry
from pinclear.contact.base import ClearanceJoint
from pinclear.contact.spherical import stiffness
from pinclear.contact.wear import WornData, WornJoint, spline_bounds, spline_coefficients
from pinclear.core.registry import ClearancePlot, Key, PluginType, key_names

_PLANAR = (Key("radius", "number", "m", 0.01, "> 0", "paper 002 eq. 6", "journal radius R_journal"),
           Key("bearing_radius", "number", "m", "radius + clearance", "radius + clearance", "paper 002 eq. 6",
               "bearing radius (a check: it must equal radius + clearance)"),
           Key("length", "number", "m", "2 x radius", "> 0", "paper 003 eq. 6", "journal length: the line law's "
               "contact length; revolute: the distance between its two radial channels"))
#: a worn bearing (contact/wear.py, docs/wear_lubrication.md): planar joints only
_WEAR = (Key("wear", "mapping", "-", None, "{model: archard, k, hardness, nodes, distribution}",
             "Archard 1953; contact/wear.py", "Archard wear of the bearing, reshaping its contact geometry "
             "(pinclear wear)"),)
_SPATIAL = _PLANAR + (Key("axial_clearance", "number", "m", "clearance", "> 0", "revolute.py",
                          "gap to each thrust face along the bearing axis"),)


class RevoluteClearance(ClearanceJoint):
    """Planar (``spatial=False``, one radial channel at the journal centre) or spatial."""

    #: geometry code of the planar joint (a worn bearing has its own: contact.wear)
    planar_geometry = channels.G_PLANAR_REVOLUTE

    def __init__(self, name, model, f1, f2, clearance, R_journal, law, friction, *, spatial=False,
                 length=None, axial_clearance=None, stiffness_note="given", **kw):
        nc = 4 if spatial else 1
        super().__init__(name, model, f1, f2, nc, friction, **kw)
        self.kind = "revolute" if spatial else "planar_revolute"
        self.geometry_code = channels.G_REVOLUTE if spatial else self.planar_geometry
        self.spatial = spatial
        self.c = float(clearance)
        self.R2 = float(R_journal)
        self.R1 = self.R2 + self.c
        self.law = law
        self.L = float(length) if length is not None else 2.0 * self.R2
        self.ca = float(axial_clearance) if axial_clearance is not None else self.c
        self.stiffness_note = stiffness_note
        self._freeze()

    def _channel_laws(self):
        return (self.law,) * self.nc

    def _geometry_params(self):
        return np.array([self.c, self.R1, self.R2, self.ca, self.L])

    def describe(self):
        return {**super().describe(), "clearance": self.c, "R_journal": self.R2, "R_bearing": self.R1,
                "length": self.L, "normal_law": repr(self.law), "stiffness": self.stiffness_note}


def check_bearing_radius(sp, R2, c):
    """An entry's optional bearing_radius must be the journal radius plus the (nominal) clearance."""
    if "bearing_radius" in sp.d:
        R1 = sp.number("bearing_radius")
        if R1 <= R2:
            raise sp.error("bearing_radius", f"bearing radius {R1} m must exceed the journal radius {R2} m")
        if abs((R1 - R2) - c) > 1e-12 * max(R1, 1.0):
            raise sp.error("bearing_radius", f"bearing_radius - radius = {R1 - R2} m differs from clearance {c} m")


def from_spec(sp, mech, closure, spatial):
    c = sp.clearance()
    R2 = sp.number("radius", _PLANAR[0].default)
    check_bearing_radius(sp, R2, c)
    R1 = R2 + c
    L = sp.number("length", 2.0 * R2)
    K, note = stiffness(sp, R2, R1)
    # line law (paper 003 eq. 6) for a journal: conformal curvature radius, contact length L
    Reff = R2 * R1 / c
    law = sp.normal_law(K=K, line=(sp.estar(), L, Reff))
    ca = sp.number("axial_clearance", c) if spatial else None
    args = (sp.name, mech.model, closure.f1, closure.f2, c, R2, law, sp.friction_law())
    kw = dict(spatial=spatial, length=L, axial_clearance=ca, stiffness_note=note, **sp.common(min(c, ca or c)))
    if sp.d.get("wear") is not None:
        from pinclear.contact import wear

        return WornRevoluteClearance(*args, wear=wear.parse(sp, R1, R2, L), **kw)
    return RevoluteClearance(*args, **kw)


_PLOT = ClearancePlot(across_axis=True, travel=False, boundary="circle", body="journal")
PLANAR_REVOLUTE = PluginType(
    "planar_revolute", parse=functools.partial(from_spec, spatial=False),
    replaces=("revolute", "planar_point", "spherical"),
    doc="A journal (frame2) in a bearing (frame1), eccentricity taken in the plane normal to the bearing axis "
        "(frame1 z): one channel at the journal centre. Use it where the rest of the mechanism keeps the motion "
        "planar (paper 002 sec. 1.1).", source="paper 002 eqs. 1-6", keys=_PLANAR + _WEAR, plot=_PLOT)
REVOLUTE = PluginType(
    "revolute", parse=functools.partial(from_spec, spatial=True), replaces=("revolute",),
    doc="Spatial radial clearance: the journal's two ends against the bearing cylinder and its centre against "
        "two thrust faces; all five freedoms the ideal revolute removed come back, held by contact.",
    source="paper 002 eqs. 1-6 per channel", keys=_SPATIAL, plot=_PLOT)
KEYS_PLANAR = key_names(_PLANAR + _WEAR)
KEYS_SPATIAL = key_names(_SPATIAL)


class WornRevoluteClearance(WornJoint, RevoluteClearance):
    """A planar revolute clearance whose bearing has worn ``depth`` (m, one value per wear node)."""

    _data_class = WornData
    planar_geometry = channels.G_WORN_PLANAR
    #: within ray_radius x c of the centre the kernel takes the ray's gap (worn_geometry)
    ray_radius = 0.5

    def _geometry_params(self):
        coef = spline_coefficients(self.depth)
        head = np.array([self.c, self.R1, self.R2, self.ca, self.L, float(self.wear.nodes), *spline_bounds(coef),
                         self.ray_radius])
        return np.concatenate([head, coef.ravel()])

    def profile(self, theta):
        """(w, dw/dtheta) of the worn profile at the angles theta (the kernel's spline)."""
        g = self._geo.gpar
        pairs = [worn_geometry.worn_depth(g, float(t)) for t in np.atleast_1d(theta)]
        return np.array(pairs).T

    def describe(self):
        return {**super().describe(), "wear": self.wear_description()}

    def wear_description(self):
        w = self.wear
        return {"model": "archard", "k": w.k, "hardness": w.hardness, "nodes": w.nodes, "distribution": w.distribution,
                "max_depth": float(self.depth.max())}
