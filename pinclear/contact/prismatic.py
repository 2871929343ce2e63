"""Prismatic clearance joint: rectangular slider (frame2 of the replaced closure) in a
rectangular guide (frame1), paper 003 sec. 2.

Guide frame: x1 = e1 (towards the "top" face, inner height a'), y1 = e2 (side faces, inner
width b'), z1 the sliding direction (the closure's slide axis). The slider is a box a x b x L
centred on frame2 (x2, y2, z2 likewise). Its 8 corners P1..P8 are expressed in the guide frame
(paper 003 eq. 1) and tested against the faces: R.e1 > a'/2 (top), R.e2 > b'/2 (side) and
their opposites. A corner can only reach the faces on its own side, so there are 16 channels
(corner k, direction x or y); the slider keeps its full 6-DOF pose relative to the guide.

Two normal-force models (sidecar key ``model``):

``energy`` (default): each slider side face rests on a linear elastic (Winkler) foundation
against the guide face it can reach, pressure p = kf delta(xi, eta) over the penetrated part of
the face, kf = E / l (the slider's thickness across that face, so a face pressed flat gives
paper 003 eq. 4, F = E A delta / l). The elastic force is the exact gradient of the face
energies kf/2 int delta^2 dA, continuous across every change of the touching corners: a
corner (F ~ delta^3), an edge (F ~ delta^2) and a face (F ~ delta) are limits of one law. The
pressure is lumped onto the corner channels by bilinear shape functions (virtual work, exact for
the affine penetration of a rigid slider). Damping multiplies each corner load by
(1 + chi dd/dd0) with the face's impact speed dd0, friction acts on the corner loads; neither
can inject energy. The compiled kernel is contact._kernels.prismatic_energy_force.

``paper003``: paper 003's per-mode laws, kept to reproduce its figures. It is NOT conservative:
at the same penetration a corner's force jumps when a neighbouring corner touches (point ->
line -> plane law), and a force that jumps with the contact set is not the gradient of any
potential, so mode changes can add energy (docs/contact_models.md). Per face, the touching
corners decide the contact kind and the force law (paper 003 sec. 2.2):

* one corner (or two diagonal ones): point contacts, Lankarani-Nikravesh with the Hertz
  stiffness of a corner of radius ``edge_radius`` on a flat (eq. 7);
* two corners sharing an edge: a line contact of that edge's length, cylindrical law (eqs. 5-6),
  half the line load at each end, each from its own penetration (a tilted edge carries more at
  the deeper end);
* three or four corners: plane contact F = E A delta / l (eq. 4) on the face area A, a quarter
  at each corner from its own penetration (the resultant and moment of a linear foundation).

The kinds of the four faces combine into the 15 modes of paper 003 Table 1 (``MODES``); any
other combination (possible with large tilts) is reported as mode 16 (both models report the
mode; only ``paper003`` switches laws with it). Because its force law changes with the mode,
``paper003`` raises an event per channel at contact onset and at separation; ``energy`` needs
only the onsets (the impact speed of its damping).
"""
from __future__ import annotations

import math
from types import MappingProxyType

import numpy as np

from pinclear.contact import channels, force_laws
from pinclear.contact.base import ClearanceData, ClearanceJoint, _readonly
from pinclear.contact.channels import Laws, channel_forces, channel_friction, free_flight, onset_speeds
from pinclear.contact.force_laws import damped
from pinclear.contact.prismatic_geometry import (
    Foundation,
    Modes,
    prismatic_foundation,
    prismatic_geometry,
    prismatic_laws,
    prismatic_mode,
)
from pinclear.core.jit import njit
from pinclear.core.registry import ClearancePlot, Key, PluginType, key_names
from pinclear.model.forces import add_wrenches, place_frames, relative_velocity

#: normal-force models of the ``model`` key; the first is the default. ``mode_laws``: each
#: contact mode's own law (corner points, edge lines, face planes; not conservative)
MODELS = ("energy", "mode_laws")
#: older names of the models, still accepted
MODEL_ALIASES = {"paper003": "mode_laws"}
_KEYS = (
    Key("section", "number or [a, b]", "m", [0.05, 0.05], "> 0", "paper 003 eq. 1", "slider section a x b"),
    Key("length", "number", "m", 0.1, "> 0", "paper 003 eq. 1", "slider length L along the guide"),
    Key("edge_radius", "number", "m", 1e-3, "> 0", "paper 003 eq. 7", "corner radius of the point and line laws"),
    Key("model", "string", "-", MODELS[0], " | ".join(MODELS), "docs/contact_models.md", "energy: a Winkler "
        "foundation on each face (conservative); mode_laws: each contact mode's own law, corners, edges or "
        "faces (not conservative; paper003 is an alias)"),
    Key("point_law", "law name or mapping", "-", "lankarani_nikravesh", "a normal law", "paper 003 eq. 7",
        "mode_laws model: corner contacts"),
    Key("line_law", "law name or mapping", "-", "line", "a normal law", "paper 003 eqs. 5-6",
        "mode_laws model: edge contacts"),
    Key("plane_law", "law name or mapping", "-", "plane", "a normal law", "paper 003 eq. 4",
        "mode_laws model: face contacts"),
)
KEYS = key_names(_KEYS)

#: paper 003 Table 1: (points, lines, planes) -> mode number
MODES = MappingProxyType({
    (1, 0, 0): 1, (2, 0, 0): 2, (3, 0, 0): 3, (4, 0, 0): 4,
    (1, 1, 0): 5, (1, 2, 0): 6, (2, 1, 0): 7,
    (0, 1, 0): 8, (0, 2, 0): 9, (0, 3, 0): 10, (0, 4, 0): 11,
    (0, 1, 1): 12, (0, 2, 1): 13, (0, 0, 1): 14, (0, 0, 2): 15,
})
MODE_NAMES = MappingProxyType({
    0: "free", 1: "single point", 2: "double points", 3: "three points", 4: "four points",
    5: "single point and single line", 6: "single point and double lines",
    7: "double points and single line", 8: "single line", 9: "double lines", 10: "three lines",
    11: "four lines", 12: "single line and single plane", 13: "double lines and single plane",
    14: "one plane", 15: "two planes", 16: "other combination",
})

# corner k has signs S[k] = (s1, s2, s3) (bit 2 -> s1, bit 1 -> s2, bit 0 -> s3)
SIGNS = np.array([[1 if k & 4 else -1, 1 if k & 2 else -1, 1 if k & 1 else -1] for k in range(8)], float)
SIGNS.flags.writeable = False


def _faces():
    """Channel bookkeeping: channel ch = 2 k + d (d = 0: x face, 1: y face).

    Returns face id per channel (0: +x, 1: -x, 2: +y, 3: -y), and per face the 4 channels in a
    fixed order with, for each pair of them, the edge they share (0: none (diagonal), 1: edge
    along the slide axis, 2: edge across the section)."""
    face_of = np.zeros(16, int)
    members = [[] for _ in range(4)]
    for k in range(8):
        s1, s2, _ = SIGNS[k]
        for d in (0, 1):
            f = (0 if s1 > 0 else 1) if d == 0 else (2 if s2 > 0 else 3)
            face_of[2 * k + d] = f
            members[f].append(2 * k + d)
    out = []
    for m in members:
        m = np.array(m)
        m.flags.writeable = False
        out.append(m)
    return face_of, tuple(out)


_, FACE_MEMBERS = _faces()
_MEMBERS = _readonly(np.array(FACE_MEMBERS, dtype=np.int64))
#: mode number by (points, lines, planes) for the compiled classification (16: other)
_MODE_TABLE = np.full((9, 5, 5), 16, dtype=np.int64)
_MODE_TABLE[0, 0, 0] = 0
for _c, _m in MODES.items():
    _MODE_TABLE[_c] = _m
_MODE_TABLE.flags.writeable = False
_KINDS = ("", "point", "points2", "line_long", "line_short", "plane")      # by contact._kernels K_* code
#: law slots of the compiled table, in contact._kernels.prismatic_laws' row order
_LAW_ROWS = ("point", "line_long", "line_x", "line_y", "plane_x", "plane_y")


def classify(touch):
    """Contact kind per face and the paper's mode from a boolean per channel (16,), by the
    compiled classification the joint uses (contact._kernels.prismatic_mode).

    Returns (mode, (points, lines, planes), kinds) with kinds[f] in
    {"", "point", "points2", "line_long", "line_short", "plane"}.
    """
    info = np.zeros(8, dtype=np.int64)
    prismatic_mode(np.where(np.asarray(touch, bool), 1.0, -1.0), _MEMBERS, _MODE_TABLE, info)
    return _from_info(info)


def _from_info(info):
    return int(info[0]), (int(info[1]), int(info[2]), int(info[3])), [_KINDS[k] for k in info[4:]]


class PrismaticData(ClearanceData):
    """ClearanceData plus the contact mode of the evaluated state (paper 003 Table 1)."""

    def __init__(self, *args):
        super().__init__(*args)
        self.mode = 0                       # Table 1 number (0 free, 16 other)
        self.counts = (0, 0, 0)             # (points, lines, planes)
        self.kinds = [""] * 4               # contact kind per face
        # compiled path: mode and face kinds as codes, each channel's law and weight (paper003)
        self.info = np.zeros(8, dtype=np.int64)
        self.lcode = np.zeros(16, dtype=np.int64)
        self.P0, self.P1, self.chi, self.W = (np.zeros(16) for _ in range(4))
        # energy model: elastic energy per face, clipped-polygon and corner scratch
        self.Uf = np.zeros(4)
        self.poly = np.zeros((7, 4))

    def mode_from_info(self):
        self.mode, self.counts, self.kinds = _from_info(self.info)


class PrismaticClearance(ClearanceJoint):
    kind = "prismatic"
    event_direction = 0
    geometry_code = channels.G_PRISMATIC
    _data_class = PrismaticData

    def __init__(self, name, model, f1, f2, section, clearance, length, laws, friction, *, contact_model="energy",
                 modulus=None, hysteresis=0.0, **kw):
        if contact_model not in MODELS:
            raise ValueError(f"contact_model {contact_model!r} not in {MODELS}")
        self.contact_model = contact_model
        # energy: only contact onsets matter (the damping's impact speed); paper003's law also
        # changes at separations
        self.event_direction = 1 if contact_model == "energy" else 0
        super().__init__(name, model, f1, f2, 16, friction, **kw)
        self.a, self.b = map(float, section)
        self.c1, self.c2 = map(float, clearance)
        self.L = float(length)
        self.ha = 0.5 * self.a + self.c1           # a'/2
        self.hb = 0.5 * self.b + self.c2           # b'/2
        # point, line_long, line_x, line_y, plane_x, plane_y (model paper003)
        self.laws = MappingProxyType(dict(laws))
        # energy model: foundation moduli of the x faces (slider thickness a across them) and the
        # y faces (thickness b), Pa/m, and the hysteresis factor of the corner loads
        self.modulus = None if modulus is None else float(modulus)
        self.kf = _readonly([0.0, 0.0] if modulus is None else [self.modulus / self.a, self.modulus / self.b])
        self.chi = float(hysteresis)
        self._freeze()

    def _freeze(self):
        # paper003's law table (contact._kernels.prismatic_laws' rows) when every law there has
        # a compiled form
        par = [self.laws[k].kernel_params() for k in _LAW_ROWS]
        self._rows = None if any(p is None for p in par) else _readonly(np.array(par, float))
        super()._freeze()

    def _geometry_params(self):
        return np.array([self.ha, self.hb, 0.5 * self.a, 0.5 * self.b, 0.5 * self.L])

    def _compiled_kernel(self):
        if self._friction is None:
            return None
        if self.contact_model == "energy":
            return prismatic_energy_force
        return None if self._rows is None else prismatic_force

    def _kernel_args(self, ws, d):
        modes = Modes(_MEMBERS, _MODE_TABLE, d.info)
        head = (self._geo, self._frames(ws, d), self._bodies(ws), modes)
        if self.contact_model == "energy":
            return head + (Foundation(self.kf, self.chi, self.v_impact_min, d.poly, d.Uf), self._friction,
                           d.channels)
        # the per-channel laws are written by the kernel (they change with the contact mode)
        return head + (self._rows, Laws(d.lcode, d.P0, d.P1, d.chi, d.W, self.v_impact_min), self._friction,
                       d.channels)

    def _kept(self, d, key, zdot, touching):
        super()._kept(d, key, zdot, touching)
        d.mode_from_info()                   # the kernel classified this pose (d.info)

    def record_layout(self):
        return None              # its outputs add the contact mode: made by the Python path

    def _record_laws(self, d):
        if self.contact_model == "energy":
            return self._no_laws                  # the face energies come from d.Uf (_record)
        return d.lcode, d.P0, d.P1, d.W

    # geometry -----------------------------------------------------------------
    def _geometry(self, data, dat):
        super()._geometry(data, dat)
        # the mode belongs to this pose (paper003: the touching corners decide each face's law)
        prismatic_mode(dat.delta, _MEMBERS, _MODE_TABLE, dat.info)
        dat.mode_from_info()

    def _apply(self, dat, fn):
        """Sum over faces of fn(law, weight, channel indices), for the mode of ``dat``'s pose
        (paper003)."""
        for f, kind in enumerate(dat.kinds):
            if not kind:
                continue
            ch = FACE_MEMBERS[f]
            if kind in ("point", "points2"):
                fn(self.laws["point"], 1.0, ch)
            elif kind.startswith("line"):
                if kind == "line_short":
                    law = self.laws["line_x" if f < 2 else "line_y"]
                else:
                    law = self.laws["line_long"]
                fn(law, 0.5, ch)
            else:
                fn(self.laws["plane_x" if f < 2 else "plane_y"], 0.25, ch)

    def _foundation(self, dat, delta):
        """Elastic corner loads (16,) of the energy model; the face energies go to dat.Uf."""
        Fel = np.zeros(16)
        prismatic_foundation(self._geo.gpar, self.kf, _MEMBERS, np.ascontiguousarray(delta, float), dat.poly,
                                      Fel, dat.Uf)
        return Fel

    def _normal(self, dat, delta, dd, dd0):
        if self.contact_model == "energy":
            Fel = self._foundation(dat, delta)
            F = np.empty(16)
            force_laws.damped_forces(Fel, np.ascontiguousarray(dd, float), np.ascontiguousarray(dd0, float), self.chi,
                                   F)
            return np.where(Fel > 0.0, F, 0.0), np.maximum(Fel, 0.0)
        Fn = np.zeros(16)
        Fel = np.zeros(16)

        def fn(law, w, ch):
            F, Fe = law.force_and_elastic(delta[ch], dd[ch], dd0[ch])
            Fn[ch] = w * F
            Fel[ch] = w * Fe

        self._apply(dat, fn)
        return Fn, Fel

    def _loaded(self, dat, Fel):
        # the foundation loads a corner that is itself still out of contact when part of its
        # face penetrates
        return Fel > 0.0 if self.contact_model == "energy" else dat.on

    def _energy(self, dat, delta):
        if self.contact_model == "energy":
            self._foundation(dat, delta)
            return dat.Uf.copy()
        E = np.zeros(16)

        def fn(law, w, ch):
            E[ch] = w * law.energy(delta[ch])

        self._apply(dat, fn)
        return E

    def _compute(self, ws, d, v, z):
        d.Uf[:] = 0.0
        super()._compute(ws, d, v, z)

    def z0(self, mech, ws, d, q, v):
        z = super().z0(mech, ws, d, q, v)
        if self.contact_model == "energy":
            # a face in contact at t0: its impact speed is its fastest touching corner's
            for ch in FACE_MEMBERS:
                z[ch] = z[ch].max()
        return z

    def handle_event(self, k, mech, ws, d, t, q, v, z):
        if self.contact_model != "energy":
            return super().handle_event(k, mech, ws, d, t, q, v, z)
        self._impact(ws, d, v)
        z = np.array(z, float)
        near = np.abs(d.delta) < 1e3 * self.event_snap
        near[k] = True
        onset = near & (d.dd > 0.0)
        inside = d.delta > 1e3 * self.event_snap
        for ch in FACE_MEMBERS:
            # a face whose first corners just touched: the impact speed of its damping (paper 003
            # uses the Lankarani-Nikravesh hysteresis of papers 000 eq. 17, 002 eq. 9)
            if onset[ch].any() and not inside[ch].any():
                z[ch] = d.dd[ch][onset[ch]].max()
                if self.nfs:
                    z[self.nc + 1:].reshape(self.nc, -1)[ch] = 0.0
        return z

    def _record(self, d, z, M1, M2, laws):
        pot, out = super()._record(d, z, M1, M2, laws)
        if self.contact_model == "energy":
            pot = float(d.Uf.sum())                         # both paths leave the face energies in d.Uf
        out["mode"] = np.array(float(d.info[0]))            # both paths leave the pose's mode in d.info
        out["kinds"] = d.info[1:4].astype(float)
        return pot, out

    def describe(self):
        out = {**super().describe(), "model": self.contact_model, "section": [self.a, self.b],
               "clearance": [self.c1, self.c2], "length": self.L}
        if self.contact_model == "energy":
            out.update(foundation_modulus=[float(k) for k in self.kf], chi=self.chi)
        else:
            out["laws"] = {k: repr(v) for k, v in self.laws.items()}
        return out


def from_spec(sp, mech, closure):
    default = {k.name: k.default for k in _KEYS}
    a, b = sp.pair("section", default["section"])
    c1, c2 = sp.pair("clearance")
    L = sp.number("length", default["length"])
    r = sp.number("edge_radius", default["edge_radius"])
    E1, _ = sp.material(1)
    E2, _ = sp.material(2)
    Es = sp.estar()
    # corner of radius r on a flat face: Hertz sphere-on-plane stiffness 4/3 E* sqrt(r)
    laws = {"point": sp.normal_law("point_law", default["point_law"], K=4.0 / 3.0 * Es * math.sqrt(r))}
    for key, length in (("line_long", L), ("line_x", b), ("line_y", a)):
        laws[key] = sp.normal_law("line_law", default["line_law"], line=(Es, length, r))
    E = min(E1, E2)                                   # the softer body sets the plane compliance
    laws["plane_x"] = sp.normal_law("plane_law", default["plane_law"], plane=(E, L * b, a))
    laws["plane_y"] = sp.normal_law("plane_law", default["plane_law"], plane=(E, L * a, b))
    model = sp.choice("model", MODELS + tuple(MODEL_ALIASES))
    model = MODEL_ALIASES.get(model, model)
    # energy model: the foundation modulus E / l of paper 003 eq. 4's plane law, the damping of
    # normal_law's hysteresis (point_law, line_law and plane_law are paper003's)
    return PrismaticClearance(sp.name, mech.model, closure.f1, closure.f2, (a, b), (c1, c2), L, laws,
                              sp.friction_law(), contact_model=model, modulus=E,
                              hysteresis=sp.hysteresis("normal_law", "lankarani_nikravesh"),
                              **sp.common(min(c1, c2)))


PRISMATIC = PluginType(
    "prismatic", parse=from_spec, replaces=("prismatic",),
    doc="A rectangular slider (frame2) in a rectangular guide (frame1), sliding along frame1's z: its 8 corners "
        "against the 4 guide faces, 16 channels; the slider keeps its full pose relative to the guide (paper 003 "
        "sec. 2).", source="paper 003 eqs. 1-7, Table 1", keys=_KEYS,
    plot=ClearancePlot(across_axis=True, travel=True, boundary="rectangle", body="slider"))


__all__ = ["PrismaticClearance", "PRISMATIC", "classify", "MODES", "MODE_NAMES", "SIGNS"]


@njit(cache=True, inline="always")
def prismatic_force(geo, frames, bodies, modes, rows, laws, fr, ch, v, z, tau, zdot):
    """The prismatic clearance's right-hand-side contribution in one call (model paper003):
    placements, corner geometry, the contact mode and each channel's law from the law table
    ``rows`` (into ``laws``' arrays), then channel_forces."""
    M, delta, members, info = frames.M, ch.delta, modes.members, modes.info
    place_frames(frames)
    prismatic_geometry(geo.gpar, M[0], M[1], delta, ch.n, ch.p1, ch.p2)
    prismatic_mode(delta, members, modes.table, info)
    prismatic_laws(info, members, rows, laws.code, laws.P0, laws.P1, laws.chi, laws.W)
    return channel_forces(bodies, laws, fr, ch, v, z, tau, zdot)


@njit(cache=True, inline="always")
def prismatic_energy_force(geo, frames, bodies, modes, found, fr, ch, v, z, tau, zdot):
    """The energy-consistent prismatic clearance's right-hand-side contribution in one call:
    placements, corner geometry, the paper's mode (an output only), the foundation's corner
    loads Fel, then per loaded corner the damping F = Fel (1 + chi dd/dd0) clipped at zero and
    friction from F, and the wrenches. zdot = (0 per channel, dissipated power (F - Fel) dd -
    Ft . vt, friction-state rates). Returns the number of faces in contact."""
    delta, n, p1, p2, dd, vt, dd0 = ch.delta, ch.n, ch.p1, ch.p2, ch.dd, ch.vt, ch.dd0
    Fn, Fel, F2 = ch.Fn, ch.Fel, ch.F2
    M, gpar, members = frames.M, geo.gpar, modes.members
    fcode, fpar, chi = fr.code, fr.par, found.chi
    place_frames(frames)
    prismatic_geometry(gpar, M[0], M[1], delta, n, p1, p2)
    prismatic_mode(delta, members, modes.table, modes.info)
    on = prismatic_foundation(gpar, found.kf, members, delta, found.poly, Fel, found.Uf)
    if on == 0:
        free_flight(zdot, Fn, Fel, F2)
        return 0
    relative_velocity(bodies.J, bodies.idx1, bodies.idx2, v, n, p1, p2, dd, vt)
    onset_speeds(z, found.vmin, dd0, zdot)
    loss = 0.0
    for k in range(delta.shape[0]):
        fe = Fel[k]
        if fe <= 0.0:
            Fn[k] = 0.0
            F2[k, 0] = F2[k, 1] = F2[k, 2] = 0.0
            continue
        f = damped(fe, dd[k], dd0[k], chi)
        Fn[k] = f
        loss += (f - fe) * dd[k] + channel_friction(k, fcode, fpar, f, vt, n, F2, z, zdot)
    zdot[delta.shape[0]] = loss
    add_wrenches(bodies.J, bodies.idx1, bodies.idx2, F2, p1, p2, tau)
    return on
