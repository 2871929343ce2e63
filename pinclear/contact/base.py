"""Common machinery of the clearance joints: a set of contact channels between body 1 (socket,
bearing, guide: frame1 of the replaced closure) and body 2 (ball, journal, slider: frame2).

A subclass supplies the geometry of its channels, ``_geometry(data)``, which fills per channel
the penetration ``delta`` (m, > 0 in contact), the outward normal ``n`` (world, pointing from
body 1 towards the penetrating side of body 2) and the two material application points
``p1`` (on body 1) and ``p2`` (on body 2). The points are chosen so that
n . (v2(p2) - v1(p1)) is exactly d(delta)/dt; then the contact forces, applied at those points,
do work -Fn ddelta + Ft . vt and the energy balance closes to integration accuracy.

Everything else lives here:

* relative velocity of the material points, normal rate and slip velocity
  (paper 000 eqs. 10-16, paper 002 eqs. 4-5);
* normal law with the impact speed recorded at contact onset (event located; 002 eq. 9);
* friction law, with internal state where the law has one (LuGre);
* generalized force tau += J1^T w1 + J2^T w2 from Pinocchio's WORLD joint Jacobians
  ``data.J`` restricted to the dofs supporting each body (no hand-written dynamics), with
  w = (F; p x F) the contact wrench about the world origin;
* the dissipated energy as an integrated internal state: the work rate (Fn - F_elastic) dd of
  the normal law plus -Ft . vt of friction (for LuGre this includes the bristles' elastic
  energy, so the rate may dip below zero while they unload; the balance still closes).

The onset speed is floored at ``v_impact_min`` (default 0.1 mm/s) so grazing contacts do not get
an unbounded damping coefficient (the laws divide by it).

Internal state z (per element): ``[dd0 (nc) | E_dissipated (1) | friction states]``.
"""
from __future__ import annotations

import numpy as np

from pinclear.errors import ContactSetupError
from pinclear.forces import ForceElement

from .laws import NormalLaw

from . import _kernels


def supporting_dofs(model, fid):
    """Velocity indices of the joints that move frame ``fid`` (empty for a world-fixed frame)."""
    idx = []
    j = model.frames[int(fid)].parentJoint
    while j > 0:
        jm = model.joints[j]
        idx.extend(range(jm.idx_v, jm.idx_v + jm.nv))
        j = model.parents[j]
    return np.array(sorted(idx), dtype=int)


class ClearanceJoint(ForceElement):
    """Base class: ``nc`` contact channels between the frames f1 (body 1) and f2 (body 2)."""

    conservative = False
    kind = "clearance"
    #: event direction for every channel: +1 onset only; 0 onset and separation (when the force
    #: law changes with the set of touching channels, as in the prismatic joint)
    event_direction = 1

    def __init__(self, name, model, f1, f2, nc, friction, *, v_impact_min=1e-4,
                 max_initial_penetration=None, file="<spec>"):
        self.name = name
        self.model = model
        self.f1, self.f2 = int(f1), int(f2)
        self.nc = int(nc)
        self.friction = friction
        self.v_impact_min = float(v_impact_min)
        self.max_initial_penetration = max_initial_penetration
        self.file = file
        self.idx1 = supporting_dofs(model, f1)
        self.idx2 = supporting_dofs(model, f2)
        self.nfs = friction.nstate * self.nc
        self.nz = self.nc + 1 + self.nfs
        self.events = [(f"{name}.c{k}", self.event_direction) for k in range(self.nc)]
        # per-channel buffers (the subclass geometry writes into them)
        self.delta = np.zeros(self.nc)
        self.n = np.zeros((self.nc, 3))
        self.p1 = np.zeros((self.nc, 3))
        self.p2 = np.zeros((self.nc, 3))
        self._key = None
        self._c = {}
        self._nofs = np.zeros(0)
        self._fast = False

    # ------------------------------------------------------------------ subclass hooks
    def _geometry(self, data):
        raise NotImplementedError

    def _normal(self, delta, dd, dd0):
        """(Fn, F_elastic) per channel; one normal law ``self.law`` unless a subclass mixes laws."""
        return self.law.force(delta, dd, dd0), self.law.elastic(delta)

    def _energy(self, delta):
        return self.law.energy(delta)

    def _extra_outputs(self, c):
        return {}

    # ------------------------------------------------------------------ evaluation
    def _eval(self, mech, ws, t, q, v, z, full=False):
        """All channel quantities at the current state (cached per workspace and state);
        ``full`` insists on the velocities even without contact."""
        c = self._c
        if (self._key is not None and not (full and c["dd"] is None) and self._key == (id(ws), t) and np.array_equal(c["q"], q)
                and np.array_equal(c["v"], v) and np.array_equal(c["z"], z)):
            return c
        with np.errstate(over="ignore", invalid="ignore"):
            # rejected trial steps of explicit integrators may overflow; they are discarded anyway
            return self._compute(ws, t, q, v, z, (id(ws), t), full)

    def _compute(self, ws, t, q, v, z, key, full=False):
        data = ws.data
        self._geometry(data)
        delta, n, p1, p2 = self.delta, self.n, self.p1, self.p2
        nc = self.nc
        on = delta > 0.0
        if not (full or self.nfs or on.any()):
            # free flight: no force, nothing to integrate (the common case between impacts)
            zero = np.zeros(nc)
            c = self._c = {"q": q.copy(), "v": v.copy(), "z": z.copy(), "delta": delta.copy(), "n": n.copy(),
                           "p1": p1.copy(), "p2": p2.copy(), "dd": None, "Fn": zero, "Fel": zero,
                           "Ft": np.zeros((nc, 3)), "F2": None, "loss": 0.0, "dzf": self._nofs, "on": on}
            self._key = key
            return c
        dd = np.empty(nc)
        vt = np.empty((nc, 3))
        # v2(p2) - v1(p1), normal rate and slip velocity (paper 000 eqs. 10-15)
        _kernels.relative_velocity(data.J, self.idx1, self.idx2, v, n, p1, p2, dd, vt)
        dd0 = np.maximum(z[:nc], self.v_impact_min)
        fast = self._fast_path()
        if fast is not None:
            Fn, Fel, F2 = np.empty(nc), np.empty(nc), np.empty((nc, 3))
            loss = _kernels.contact_forces(delta, dd, vt, n, dd0, *fast, Fn, Fel, F2)
            Ft = None                                   # = F2 + Fn n, formed on demand (outputs)
            dzf = self._nofs
        else:
            Fn, Fel = self._normal(delta, dd, dd0)
            Fn = np.where(on, Fn, 0.0)
            Fel = np.where(on, Fel, 0.0)
            if self.nfs:
                dzf = np.zeros(self.nfs)
                # bristle states live in world axes; keep them and their force in the tangent plane,
                # which turns with the contact normal (else part of the force would work on dd)
                zs = z[nc + 1:].reshape(nc, -1)
                zs = zs - (zs * n).sum(axis=1)[:, None] * n
                Ft = self.friction.force(Fn, vt, zs, dzf.reshape(nc, -1))
                dzf.reshape(nc, -1)[~on] = 0.0
                Ft -= (Ft * n).sum(axis=1)[:, None] * n
            else:
                dzf = self._nofs
                Ft = self.friction.force(Fn, vt)
            F2 = Ft - Fn[:, None] * n                   # force on body 2 at p2; body 1 gets -F2 at p1
            loss = float((Fn - Fel) @ dd - (Ft * vt).sum())
        c = self._c = {"q": q.copy(), "v": v.copy(), "z": z.copy(), "delta": delta.copy(),
                       "n": n.copy(), "p1": p1.copy(), "p2": p2.copy(), "dd": dd, "vt": vt, "Fn": Fn,
                       "Fel": Fel, "Ft": Ft, "F2": F2, "loss": loss, "dzf": dzf, "on": on}
        self._key = key
        return c

    def _fast_path(self):
        """(K, e, chi, friction code, friction parameters) when every channel follows a damped power
        law and the friction law is memoryless: the compiled kernel then does the channel loop."""
        if self._fast is False:
            laws = self._channel_laws()
            fr = self.friction
            code = {"none": _kernels.F_NONE, "coulomb": _kernels.F_COULOMB,
                    "modified_coulomb": _kernels.F_MODIFIED, "stick_slip": _kernels.F_STICKSLIP}.get(fr.name)
            if laws is None or code is None or any(type(law) is not NormalLaw for law in laws):
                self._fast = None
            else:
                par = {"none": [], "coulomb": [getattr(fr, "mu", 0), getattr(fr, "v_eps", 0)],
                       "modified_coulomb": [getattr(fr, "mu", 0), getattr(fr, "v0", 0), getattr(fr, "v1", 0)],
                       "stick_slip": [getattr(fr, "mu_s", 0), getattr(fr, "mu_d", 0), getattr(fr, "Vs", 0),
                                      getattr(fr, "Vd", 0)]}[fr.name]
                self._fast = (np.array([law.K for law in laws]), np.array([law.n for law in laws]),
                              np.array([law.chi for law in laws]), code, np.array(par + [0.0], float))
        return self._fast

    def _channel_laws(self):
        """The normal law of each channel when fixed (None when it changes with the contact mode)."""
        law = getattr(self, "law", None)
        return None if law is None else [law] * self.nc

    # ------------------------------------------------------------------ ForceElement API
    def z0(self, mech, ws, q, v):
        z = np.zeros(self.nz)
        c = self._eval(mech, ws, 0.0, q, v, z)
        dmax = float(c["delta"].max())
        limit = self.max_initial_penetration
        if limit is not None and dmax > limit:
            k = int(np.argmax(c["delta"]))
            raise ContactSetupError(
                f"{self.file}: clearances.{self.name}: initial pose penetrates {dmax:.3e} m at contact "
                f"{k} (limit max_initial_penetration = {limit:.3e} m); start from an assembled pose "
                f"with the ball, journal or slider inside its clearance")
        # a contact present at t0 counts as an impact at the current normal speed
        if c["on"].any():
            z[:self.nc] = np.where(c["on"], np.abs(c["dd"]), 0.0)
        self._key = None
        return z

    def add_force(self, mech, ws, t, q, v, z, tau, zdot):
        c = self._eval(mech, ws, t, q, v, z)
        nc = self.nc
        zdot[:nc] = 0.0
        zdot[nc] = c["loss"]
        zdot[nc + 1:] = c["dzf"]
        if c["F2"] is None or not c["on"].any():
            return
        _kernels.add_wrenches(ws.data.J, self.idx1, self.idx2, c["F2"], c["p1"], c["p2"], tau)

    def potential(self, mech, ws, q):
        self._geometry(ws.data)
        return float(np.sum(self._energy(self.delta)))

    def power_loss(self, mech, ws, t, q, v, z):
        return self._eval(mech, ws, t, q, v, z)["loss"]

    #: penetrations closer to zero than this (m) count as exactly zero for event detection
    event_snap = 1e-13

    def event_value(self, k, mech, ws, t, q, v, z):
        # Channels that touch together (a symmetric journal's two ends, a slider face's corners)
        # cross zero at the same instant up to round-off; snapping keeps the restart after one
        # of them from re-detecting the others (handle_event records them all at once).
        d = float(self._eval(mech, ws, t, q, v, z)["delta"][k])
        return 0.0 if abs(d) < self.event_snap else d

    def event_values(self, mech, ws, t, q, v, z):
        """All channels' event values at once (one kinematics pass serves them all)."""
        d = self._eval(mech, ws, t, q, v, z)["delta"].copy()
        d[np.abs(d) < self.event_snap] = 0.0
        return d

    def handle_event(self, k, mech, ws, t, q, v, z):
        c = self._eval(mech, ws, t, q, v, z, full=True)
        z = np.array(z, float)
        dd = c["dd"]
        near = np.abs(c["delta"]) < 1e3 * self.event_snap
        near[k] = True
        onset = near & (dd > 0.0)
        # onset: the damping term of every dissipative law scales with this speed
        # (paper 000 eq. 17, paper 002 eq. 9); bristles start unloaded
        z[:self.nc][onset] = dd[onset]
        if self.nfs:
            z[self.nc + 1:].reshape(self.nc, -1)[onset] = 0.0
        self._key = None
        return z

    def outputs(self, mech, ws, t, q, v, z):
        c = self._eval(mech, ws, t, q, v, z)
        Fn, n = c["Fn"], c["n"]
        if c["Ft"] is None:
            c["Ft"] = c["F2"] + Fn[:, None] * n
        out = {
            "penetration": np.array(float(c["delta"].max())),
            "normal_force": -(Fn[:, None] * n).sum(axis=0),       # on body 2, world
            "friction_force": c["Ft"].sum(axis=0),
            "fn": np.array(float(Fn.sum())),
            "contact": np.array(float(c["on"].any())),
            "dissipated": np.array(float(z[self.nc])),
        }
        # eccentricity: frame2's origin (ball / journal / slider centre) in frame1 (socket /
        # bearing / guide) axes, paper 000 eq. 3
        M1, M2 = ws.data.oMf[self.f1], ws.data.oMf[self.f2]
        out["eccentricity"] = M1.rotation.T @ (M2.translation - M1.translation)
        out.update(self._extra_outputs(c))
        return out

    def describe(self):
        return {"name": self.name, "type": self.kind, "friction": self.friction.name}
