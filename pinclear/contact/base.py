"""Common machinery of the clearance joints: a set of contact channels between body 1 (socket,
bearing, guide: frame1 of the replaced closure) and body 2 (ball, journal, slider: frame2).

A subclass supplies the geometry of its channels, ``_geometry(data, d)``, which fills per channel
of the element's data ``d`` the penetration ``delta`` (m, > 0 in contact), the outward normal ``n`` (world, pointing from
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

Compiled evaluation (ForceElement contract 10): when the joint's geometry and every law it uses
declare a compiled form (``geometry_code``, ``kernel_params()``: every built-in law does), its
force is one compiled call (contact._kernels.clearance_force, prismatic_force,
prismatic_energy_force) reading its frames' placements from the workspace's frame kinematics,
and its events another (event_penetrations). :meth:`ClearanceJoint.add_force` calls the same
kernel; the law-by-law Python evaluation (``_compute``) serves laws without a compiled form and
outputs at states no evaluation has visited.

Model and data: a joint is an immutable description (geometry, laws, the dofs moving each
body). Everything an evaluation writes lives in its :class:`ClearanceData`, one per workspace
(``ws.force_data[i]``), so two workspaces of one mechanism can run in two threads.
"""
from __future__ import annotations

import numpy as np

from pinclear.contact import channels
from pinclear.contact.channels import Channels, Friction, Geometry, Laws
from pinclear.core.errors import ContactSetupError
from pinclear.model.forces import Bodies, ForceElement, Frames, add_wrenches, relative_velocity
from pinclear.model.kinematics import supporting_dofs


def _readonly(a):
    a = np.array(a)
    a.flags.writeable = False
    return a


class ClearanceData:
    """What one workspace writes for one clearance joint: the channel geometry, velocities and
    forces at the last evaluated state, and that state itself.

    One right-hand side evaluates a joint several times at the same state (forces, then the
    dissipated power, the outputs, the event values): the state (t, q, v, z) is kept by value
    (its bytes) and a call at an identical state reuses the channel quantities instead of
    recomputing them.
    """

    def __init__(self, nc, nfs):
        self.delta = np.zeros(nc)            # penetration per channel, m
        self.n = np.zeros((nc, 3))           # outward normal, world
        self.p1 = np.zeros((nc, 3))          # material contact point on body 1, world
        self.p2 = np.zeros((nc, 3))          # on body 2
        self.on = np.zeros(nc, bool)         # delta > 0
        self.dd = np.zeros(nc)               # normal rate, m/s (valid when ``moving``)
        self.vt = np.zeros((nc, 3))          # slip velocity, m/s (valid when ``moving``)
        self.dd0 = np.zeros(nc)              # floored onset speeds
        self.Fn = np.zeros(nc)
        self.Fel = np.zeros(nc)
        self.F2 = np.zeros((nc, 3))          # force on body 2 at p2 (body 1 gets -F2 at p1)
        self.dzf = np.zeros(nfs)             # rates of the friction states
        self.loss = 0.0                      # dissipated power, W
        self.moving = False
        self.scratch = np.zeros((4, 3))      # work array of the compiled geometry
        self.M = np.zeros((2, 4, 4))         # placements of frame1 and frame2 (compiled path)
        self.slot = -1                       # their slot in ws.fk (compiled path)
        self.channels = Channels(self.delta, self.n, self.p1, self.p2, self.dd, self.vt, self.dd0, self.Fn,
                                 self.Fel, self.F2, self.scratch)
        self.args = None                     # the compiled force's buffers in this workspace, built once
        self.key = None                      # (t, q, v, z bytes) the quantities belong to
        self.q_key = None                    # q bytes the geometry belongs to


class ClearanceJoint(ForceElement):
    """Base class: ``nc`` contact channels between the frames f1 (body 1) and f2 (body 2)."""

    conservative = False
    is_clearance = True
    kind = "clearance"
    #: event direction for every channel: +1 onset only; 0 onset and separation (when the force
    #: law changes with the set of touching channels, as in the prismatic joint)
    event_direction = 1
    #: penetrations closer to zero than this (m) count as exactly zero for event detection
    event_snap = 1e-13
    #: geometry code of contact._kernels.channel_geometry when the subclass's ``_geometry`` has a
    #: compiled twin (None: Python geometry only)
    geometry_code = None

    def __init__(self, name, model, f1, f2, nc, friction, *, v_impact_min=1e-4,
                 max_initial_penetration=None, file="<spec>"):
        self.name = name
        self.f1, self.f2 = int(f1), int(f2)
        self.nc = int(nc)
        self.friction = friction
        self.v_impact_min = float(v_impact_min)
        self.max_initial_penetration = max_initial_penetration
        self.file = file
        self.idx1 = _readonly(supporting_dofs(model, f1))
        self.idx2 = _readonly(supporting_dofs(model, f2))
        self.nfs = friction.nstate * self.nc
        self.nz = self.nc + 1 + self.nfs
        self.dissipation_state = self.nc          # z = [dd0 (nc) | E_dissipated | friction states]
        self.events = tuple((f"{name}.c{k}", self.event_direction) for k in range(self.nc))

    def _freeze(self):
        # what has a compiled form: the geometry (event values from the joint chain's
        # placements), the laws, and so the whole force (one compiled call per evaluation)
        self._geo = None
        if self.geometry_code is not None:
            self._geo = Geometry(int(self.geometry_code), _readonly(self._geometry_params()))
            self.kinematic_frames = (self.f1, self.f2)
            self.event_level = "placements"
        fr = self.friction.kernel_params()
        self._friction = None if fr is None else Friction(int(fr[0]), fr[1])
        self._laws = self._compiled_laws()
        self._kernel = self._compiled_kernel()
        zero = _readonly(np.zeros(self.nc))
        self._no_laws = (_readonly(np.zeros(self.nc, dtype=np.int64)), zero, zero, zero)
        super()._freeze()

    _data_class = ClearanceData

    def _geometry_params(self):
        """gpar of contact._kernels.channel_geometry (subclasses with a ``geometry_code``)."""
        raise NotImplementedError

    def _compiled_laws(self):
        """Each channel's normal law as contact._kernels.Laws when every one declares a compiled
        form (``kernel_params()``) and the channels' laws are fixed; None otherwise."""
        laws = self._channel_laws()
        if laws is None:
            return None
        par = [law.kernel_params() for law in laws]
        if any(p is None for p in par):
            return None
        P0, P1, chi = (_readonly(np.array(x, float)) for x in list(zip(*par))[1:])
        return Laws(_readonly(np.array([p[0] for p in par], dtype=np.int64)), P0, P1, chi,
                    _readonly(np.ones(len(par))), self.v_impact_min)

    def _compiled_kernel(self):
        """The compiled force of contract 10 (None: Python only); its arguments are
        ``_kernel_args(ws, d)`` followed by (v, z, tau, zdot)."""
        if self._geo is None or self._laws is None or self._friction is None:
            return None
        return channels.clearance_force

    def _kernel_args(self, ws, d):
        return (self._geo, self._frames(ws, d), self._bodies(ws), self._laws, self._friction, d.channels)

    def _frames(self, ws, d):
        fk = ws.fk
        return Frames(fk.Hj, fk.jidx, fk.jMf, d.slot, d.M)

    def _bodies(self, ws):
        return Bodies(ws.J6, self.idx1, self.idx2)

    def _args(self, ws, d):
        """The compiled force's arguments before (v, z, tau, zdot), built once per workspace."""
        if d.args is None:
            d.args = self._kernel_args(ws, d)
        return d.args

    # ------------------------------------------------------------------ subclass hooks
    def _geometry(self, data, d):
        """Fill d.delta, d.n, d.p1, d.p2 from Pinocchio's frame placements in ``data``: the same
        compiled geometry as the compiled force, which takes its placements from the joint chain."""
        g, oMf = self._geo, data.oMf
        channels.channel_geometry(g.code, g.gpar, oMf[self.f1].homogeneous, oMf[self.f2].homogeneous, d.scratch,
                                  d.delta, d.n, d.p1, d.p2)

    def _channel_laws(self):
        """The normal law of each channel when fixed (None when it changes with the contact mode)."""
        return None

    def _normal(self, d, delta, dd, dd0):
        """(Fn, F_elastic) per channel; one normal law ``self.law`` unless a subclass mixes laws."""
        return self.law.force_and_elastic(delta, dd, dd0)

    def _energy(self, d, delta):
        return self.law.energy(delta)

    def _loaded(self, d, Fel):
        """Channels that carry force (boolean (nc,)): those in contact, unless a subclass's law
        spreads a load onto channels not themselves penetrating (the prismatic foundation)."""
        return d.on

    # ------------------------------------------------------------------ evaluation
    def create_data(self, mech):
        d = self._data_class(self.nc, self.nfs)
        if self._geo is not None:
            d.slot = self.frame_slot(mech)
        return d

    def _eval(self, ws, d, t, q, v, z):
        """All channel quantities at the state (t, q, v, z) in ``d`` (velocities only with
        contact or friction states)."""
        key = (t, q.tobytes(), v.tobytes(), z.tobytes())
        if d.key == key:
            return d
        with np.errstate(over="ignore", invalid="ignore"):
            # rejected trial steps of explicit integrators may overflow; they are discarded anyway
            self._compute(ws, d, v, z)
        d.key, d.q_key = key, key[1]
        return d

    def _compute(self, ws, d, v, z):
        data = ws.data
        d.key = d.q_key = None
        self._geometry(data, d)
        nc = self.nc
        on = np.greater(d.delta, 0.0, out=d.on)
        if not (self.nfs or on.any()):
            # free flight: no force, nothing to integrate (the common case between impacts)
            d.Fn[:] = 0.0
            d.Fel[:] = 0.0
            d.F2[:] = 0.0
            d.loss = 0.0
            d.moving = False
            return
        n, dd, vt = d.n, d.dd, d.vt
        # v2(p2) - v1(p1), normal rate and slip velocity (paper 000 eqs. 10-15)
        relative_velocity(ws.J6, self.idx1, self.idx2, v, n, d.p1, d.p2, dd, vt)
        d.moving = True
        np.maximum(z[:nc], self.v_impact_min, out=d.dd0)
        Fn, Fel = self._normal(d, d.delta, dd, d.dd0)
        on = self._loaded(d, Fel)
        Fn = np.where(on, Fn, 0.0)
        Fel = np.where(on, Fel, 0.0)
        if self.nfs:
            dzf = d.dzf.reshape(nc, -1)
            dzf[:] = 0.0
            # bristle states live in world axes; keep them and their force in the tangent plane,
            # which turns with the contact normal (else part of the force would work on dd)
            zs = z[nc + 1:].reshape(nc, -1)
            zs = zs - (zs * n).sum(axis=1)[:, None] * n
            Ft = self.friction.force(Fn, vt, zs, dzf)
            dzf[~on] = 0.0
            Ft -= (Ft * n).sum(axis=1)[:, None] * n
        else:
            Ft = self.friction.force(Fn, vt)
        d.Fn[:], d.Fel[:] = Fn, Fel
        np.subtract(Ft, Fn[:, None] * n, out=d.F2)
        d.loss = float((Fn - Fel) @ dd - (Ft * vt).sum())

    # ------------------------------------------------------------------ ForceElement API
    def z0(self, mech, ws, d, q, v):
        z = np.zeros(self.nz)
        self._eval(ws, d, 0.0, q, v, z)
        dmax = float(d.delta.max())
        limit = self.max_initial_penetration
        if limit is not None and dmax > limit:
            k = int(np.argmax(d.delta))
            raise ContactSetupError(
                f"initial pose penetrates {dmax:.3e} m at contact {k} (limit max_initial_penetration = "
                f"{limit:.3e} m); start from an assembled pose with the ball, journal or slider inside its "
                "clearance", file=self.file, key=f"clearances.{self.name}")
        # a contact present at t0 counts as an impact at the current normal speed
        if d.on.any():
            z[:self.nc] = np.where(d.on, np.abs(d.dd), 0.0)
        return z

    def force_kernel(self, mech, ws, d, z, zdot):
        if self._kernel is None:
            return None
        return self._kernel, self._args(ws, d) + (ws.v, z, ws.tau, zdot)

    def event_kernel(self, mech, ws, d, g):
        if self._geo is None:
            return None
        return channels.event_penetrations, (self._geo, self._frames(ws, d), d.channels, self.event_snap, g)

    def add_force(self, mech, ws, d, t, q, v, z, tau, zdot):
        if self._kernel is not None:
            touching = self._kernel(*self._args(ws, d), v, z, tau, zdot)
            self._kept(d, (t, q.tobytes(), v.tobytes(), z.tobytes()), zdot, touching)
            return
        self._eval(ws, d, t, q, v, z)
        nc = self.nc
        zdot[:nc] = 0.0
        zdot[nc] = d.loss
        zdot[nc + 1:] = d.dzf
        if d.on.any():
            add_wrenches(ws.J6, self.idx1, self.idx2, d.F2, d.p1, d.p2, tau)

    def _kept(self, d, key, zdot, touching):
        """After the compiled force at the state ``key``: its channel quantities stay in d for
        the calls at the same state (power loss, outputs, potential) as _eval leaves them
        (velocities only with contact, as in _compute's free flight)."""
        d.loss = float(zdot[self.nc])
        d.dzf[:] = zdot[self.nc + 1:]
        np.greater(d.delta, 0.0, out=d.on)
        d.moving = touching > 0
        d.key, d.q_key = key, key[1]

    def potential(self, mech, ws, d, q):
        # the geometry depends on q alone: an evaluation at this q already holds it
        qb = q.tobytes()
        if d.q_key != qb:
            d.key = None
            self._geometry(ws.data, d)
            d.q_key = qb
        return float(np.sum(self._energy(d, d.delta)))

    def power_loss(self, mech, ws, d, t, q, v, z):
        return self._eval(ws, d, t, q, v, z).loss

    def event_values(self, mech, ws, d, t, q, v, z):
        """Penetration of every channel (one kinematics pass serves them all).

        Channels that touch together (a symmetric journal's two ends, a slider face's corners)
        cross zero at the same instant up to round-off; snapping keeps the restart after one of
        them from re-detecting the others (handle_event records them all at once)."""
        if self._geo is not None:
            # penetrations are geometry alone: the event kernel's placements and channel geometry
            d.key = d.q_key = None
            channels.channel_penetrations(self._geo, self._frames(ws, d), d.channels, self.event_snap)
            return d.delta.copy()
        val = self._eval(ws, d, t, q, v, z).delta.copy()
        val[np.abs(val) < self.event_snap] = 0.0
        return val

    def _impact(self, ws, d, v):
        """Penetrations and normal rates at the last kinematics pass and velocity v: all an
        event's effect needs (geometry and relative velocities, not the laws)."""
        d.key = d.q_key = None
        self._geometry(ws.data, d)
        relative_velocity(ws.J6, self.idx1, self.idx2, v, d.n, d.p1, d.p2, d.dd, d.vt)

    def handle_event(self, k, mech, ws, d, t, q, v, z):
        self._impact(ws, d, v)
        z = np.array(z, float)
        dd = d.dd
        near = np.abs(d.delta) < 1e3 * self.event_snap
        near[k] = True
        onset = near & (dd > 0.0)
        # onset: the damping term of every dissipative law scales with this speed
        # (paper 000 eq. 17, paper 002 eq. 9); bristles start unloaded
        z[:self.nc][onset] = dd[onset]
        if self.nfs:
            z[self.nc + 1:].reshape(self.nc, -1)[onset] = 0.0
        return z

    def outputs(self, mech, ws, d, t, q, v, z):
        self._eval(ws, d, t, q, v, z)
        oMf = ws.data.oMf
        return self._record(d, z, oMf[self.f1].homogeneous, oMf[self.f2].homogeneous, self._no_laws)[1]

    def _record(self, d, z, M1, M2, laws):
        """(elastic energy, outputs) of the channel quantities in d, frames at M1 and M2, in one
        compiled call; ``laws`` = (code, p0, p1, weight) per channel (zero weights: no energy)."""
        row = np.empty(channels.RECORD_SIZE)
        channels.channel_record(d.delta, d.n, d.Fn, d.F2, M1, M2, float(z[self.nc]), *laws, row)
        return float(row[-1]), {name: (row[a] if size == 1 else row[a:a + size]) for name, a, size in channels.RECORD}

    def record(self, mech, ws, d, t, q, v, z, after_rhs):
        if not (after_rhs and self._kernel is not None):
            return super().record(mech, ws, d, t, q, v, z, after_rhs)
        # the compiled add_force of this very evaluation left every channel quantity in d
        pot, out = self._record(d, z, d.M[0], d.M[1], self._record_laws(d))
        return pot, d.loss, out

    def record_layout(self):
        if self._kernel is None:
            return None
        return tuple((name, size) for name, _, size in channels.RECORD)

    def record_kernel(self, mech, ws, d, z, zdot, row):
        if self._kernel is None:
            return None
        # the compiled force of this evaluation left every channel quantity and the frames in d
        return channels.clearance_record, (d.channels, d.M, z, zdot, self.nc, *self._record_laws(d),
                                           np.zeros(channels.RECORD_SIZE), row)

    def peak_kernel(self, mech, ws, d, z, zdot, out, k):
        """The stages putting this joint's total normal force at the state buffer into ``out[k]``
        (its contact-force peak, pinclear.dynamics.stepping.peaks), after the position-level placements and
        joint Jacobian; None: Python only. The force kernel writes ``ws.tau`` and ``zdot``, which
        every evaluation writes again."""
        made = self.force_kernel(mech, ws, d, z, zdot)
        if made is None:
            return None
        return made, (channels.total_normal_force, (d.Fn, out, k))

    def _record_laws(self, d):
        """(law code, p0, p1, weight) per channel, as the compiled force used them."""
        laws = self._laws
        return laws.code, laws.P0, laws.P1, laws.W

    def describe(self):
        return {"name": self.name, "type": self.kind, "friction": self.friction.name}
