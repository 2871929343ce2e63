"""Force elements: anything that adds a generalized force computed from the state.

Springs, applied joint forces and clearance contacts share one contract, so the formulations
and the simulator never special-case them. The compiled building blocks the elements share
(their frames' placements from the workspace's frame kinematics, velocities of material points
and their forces' generalized force through Pinocchio's WORLD joint Jacobian) live here too.
"""
from __future__ import annotations

import abc
import math
from typing import NamedTuple

import numpy as np

from pinclear.core.jit import njit
from pinclear.core.registry import Key, PluginType
from pinclear.core.stage import T
from pinclear.model.kinematics import supporting_dofs
from pinclear.model.timelaws import TimeLaw, eval_laws, law_table


class ForceElement(abc.ABC):
    """Base class of every force element.

    The contract (the simulator and the formulations rely on nothing else):

    1. An element is an immutable description. After ``__init__`` no method writes to ``self``;
       everything an evaluation writes (buffers, caches, contact modes) lives in the object
       returned by :meth:`create_data`, one per workspace (``ws.force_data[i]`` for element i of
       ``mech.forces``). Two workspaces may evaluate one element in two threads.
    2. ``nz`` internal states (LuGre bristles, impact speeds, dissipated energy) are integrated
       with q and v; :meth:`z0` gives their initial value.
    3. Every evaluation method receives ``(mech, ws, d, ...)``: the mechanism, the workspace and
       this element's data ``d``. Before any call the caller ran ``kinematics.update(mech, ws, q,
       v)`` at the same (q, v): ``ws.data`` holds placements, frame placements, joint Jacobians
       and their time derivative, and ``ws.fk`` the joint placements its ``kinematic_frames``
       need (item 8). Elements never call Pinocchio's tree algorithms themselves.
    4. :meth:`add_force` ADDS the element's generalized force into ``tau`` (nv) and WRITES the
       rates of its internal states into ``zdot`` (nz).
    5. :meth:`potential` is the stored elastic energy, :meth:`power_loss` the dissipated power
       (negative when the element injects energy): the energy balance of a run closes with them.
    6. ``conservative`` says whether the element neither dissipates nor injects energy.
       ``dissipation_state`` is the index (in the element's z) of a state integrating the
       dissipated energy (the integral of :meth:`power_loss`), or None: the energy audit
       (pinclear.dynamics.energy) then integrates the power loss over the output samples.
    7. Events: ``events`` is a tuple of ``(name, direction)`` channels (direction +1: rising
       zero crossings only, -1 falling, 0 both). :meth:`event_values` returns all channels'
       values at once; the simulator locates crossings and calls :meth:`handle_event` with the
       channel index, which returns the new internal state. Event values are functions of
       position: before :meth:`event_values` the caller runs only
       ``kinematics.update_positions`` (placements, frame placements, joint Jacobians), or,
       when the element declares ``event_level = "placements"``, only
       ``kinematics.update_placements`` (the placements of its ``kinematic_frames`` in ``ws.fk``).
    8. ``is_clearance`` is True for clearance joints: the one way code tells them apart.
       ``kinematic_frames`` names the frames whose placements a compiled evaluation reads from
       ``ws.fk`` (joint placements of the compiled chain times the frames' offsets).
    9. :meth:`outputs` returns the per-sample records (arrays) a trajectory keeps, named
       ``"<element>.<key>"`` there. A trajectory asks for a sample's potential, power loss and
       outputs in one :meth:`record` call, which may reuse what :meth:`add_force` left in ``d``.
    10. Compiled evaluation is declared: :meth:`force_kernel` returns ``(kernel, args)``, a
        compiled function that does what :meth:`add_force` does (ADD the force into ``ws.tau``,
        WRITE the state rates into ``zdot``), and :meth:`event_kernel` one that writes what
        :meth:`event_values` returns into ``g``; ``args`` are the kernel's arguments: buffers
        that keep their address for the workspace's life (workspace arrays and views, the
        element data's arrays, frozen parameters), numbers, NamedTuples of those, and
        ``pinclear.core.stage.T`` where the time goes. The state is read from the
        workspace's state buffer (``ws.q``, ``ws.v`` and the element's ``z``), which a run fills
        before the stages run; Pinocchio's passes (contract 3) have run on ``ws.data``. None
        (the default): the run calls the Python method through a Python stage, at Python's cost.
        The Python method and the kernel give the same numbers (tests compare them).
    11. Compiled outputs are declared: :meth:`record_layout` names the outputs and their sizes,
        :meth:`record_kernel` returns ``(kernel, args)`` writing one sample's [potential, power
        loss, outputs] into a row, the numbers :meth:`record` returns (pinclear.dynamics.stepping.outputs).
    """

    name: str = ""
    nz: int = 0
    conservative: bool = True
    dissipation_state = None
    events: tuple = ()
    is_clearance: bool = False
    #: frames whose placements the element reads from the workspace's compiled frame kinematics
    #: (``ws.fk``, from slot ``mech.force_frame_slot[i]`` on) instead of Pinocchio's data.oMf
    kinematic_frames: tuple = ()
    #: what event_values needs (contract 7): "positions" or "placements"
    event_level: str = "positions"

    def create_data(self, mech):
        """Per-workspace data of this element (None when it writes nothing)."""
        return None

    def frame_slot(self, mech) -> int:
        """The slot of this element's first ``kinematic_frames`` entry in the workspace's frame
        kinematics (``ws.fk``) of ``mech``."""
        return mech.force_frame_slot[[f is self for f in mech.forces].index(True)]

    def z0(self, mech, ws, d, q, v) -> np.ndarray:
        return np.zeros(self.nz)

    @abc.abstractmethod
    def add_force(self, mech, ws, d, t, q, v, z, tau, zdot) -> None:
        """Add the generalized force into ``tau``; write internal-state rates into ``zdot``."""

    def force_kernel(self, mech, ws, d, z, zdot):
        """(kernel, args) of the compiled add_force (contract 10): z and zdot are this element's
        views of the state buffer and of ws.zdot. None: Python only."""
        return None

    def event_kernel(self, mech, ws, d, g):
        """(kernel, args) writing every event channel's value into g (contract 10), after the
        placements of ``kinematic_frames`` (event_level "placements") or the position passes
        were computed. None: Python only."""
        return None

    def potential(self, mech, ws, d, q) -> float:
        return 0.0

    def power_loss(self, mech, ws, d, t, q, v, z) -> float:
        return 0.0

    def outputs(self, mech, ws, d, t, q, v, z) -> dict:
        return {}

    def record_layout(self):
        """The outputs of :meth:`record` as ((name, size), ...) in the order a compiled record
        writes them (size 1: a scalar per sample); None when the element has no compiled record
        (contract 11)."""
        return None

    def record_kernel(self, mech, ws, d, z, zdot, row):
        """(kernel, args) of the compiled :meth:`record` (contract 11): after an evaluation at an
        output sample's state (the kinematics of the sample in ws, what :meth:`add_force` left in
        ``d``), it writes ``row`` = [potential, power loss, the outputs of :meth:`record_layout`
        flattened]. None: the run's outputs are made by the Python path."""
        return None

    def record(self, mech, ws, d, t, q, v, z, after_rhs) -> tuple:
        """(potential, power_loss, outputs) of one output sample. ``after_rhs``: the formulation
        has just evaluated the right-hand side at this very state (so :meth:`add_force` ran
        there and whatever it left in ``d`` may be reused)."""
        return (self.potential(mech, ws, d, q), self.power_loss(mech, ws, d, t, q, v, z),
                self.outputs(mech, ws, d, t, q, v, z))

    def event_values(self, mech, ws, d, t, q, v, z) -> np.ndarray:
        return np.zeros(0)

    def handle_event(self, k, mech, ws, d, t, q, v, z) -> np.ndarray:
        return z

    def describe(self) -> dict:
        return {"name": self.name, "type": type(self).__name__}

    def __setattr__(self, key, value):
        if getattr(self, "_frozen", False):
            raise AttributeError(f"{type(self).__name__} {self.name!r} is immutable: per-evaluation "
                                 f"state belongs in its create_data() object (tried to set {key!r})")
        object.__setattr__(self, key, value)

    def _freeze(self):
        """Called at the end of a subclass ``__init__``: later writes raise."""
        object.__setattr__(self, "_frozen", True)


# ------------------------------------------------------------------ compiled building blocks
# Shared by the compiled force elements here and in pinclear.contact: the placements of an
# element's frames from the workspace's frame kinematics, and the rigid-body kinematics and
# statics of material points through Pinocchio's WORLD joint Jacobian (ws.J6, valid after the
# passes) restricted to the dofs that move each body.


class Frames(NamedTuple):
    """Where an element's ``kinematic_frames`` come from: the joint placements ``Hj`` of the
    workspace's FrameKinematics, each frame's joint ``jidx`` and offset ``jMf`` there, the
    element's first slot, and ``M`` (k, 4, 4) receiving the k frames' placements."""
    Hj: np.ndarray
    jidx: np.ndarray
    jMf: np.ndarray
    slot: int
    M: np.ndarray


class Bodies(NamedTuple):
    """Pinocchio's WORLD joint Jacobian (6, nv) and the dofs moving body 1 and body 2."""
    J: np.ndarray
    idx1: np.ndarray
    idx2: np.ndarray


@njit(cache=True, inline="always")
def frame_placement(Hj, jidx, jMf, k, M):
    """M = oMi[parent of frame k] * jMf[k] (4x4), frame k of a FrameKinematics."""
    Hp = Hj[jidx[k]]
    for r in range(3):
        for col in range(4):
            acc = Hp[r, 3] if col == 3 else 0.0
            for i in range(3):
                acc += Hp[r, i] * jMf[k, i, col]
            M[r, col] = acc
    M[3, 0] = M[3, 1] = M[3, 2] = 0.0
    M[3, 3] = 1.0


@njit(cache=True, inline="always")
def place_frames(fr):
    """fr.M[i] = placement of the element's frame i (slots fr.slot + i)."""
    # the tuple's fields once, out of the loop: reading them inside it reference-counts them
    Hj, jidx, jMf, slot, M = fr.Hj, fr.jidx, fr.jMf, fr.slot, fr.M
    for i in range(M.shape[0]):
        frame_placement(Hj, jidx, jMf, slot + i, M[i])


# Twists and wrenches are six scalars, not lists: a list is allocated on the heap at every call
# (four per evaluation cost more than the rest of a spring's kernel).


@njit(cache=True, inline="always")
def body_twist(J, idx, v):
    """(v_o; w) of a body, world axes at the world origin: the WORLD Jacobian's columns idx
    (the dofs moving it) times v."""
    a0 = a1 = a2 = a3 = a4 = a5 = 0.0
    for i in idx:
        vi = v[i]
        a0 += J[0, i] * vi
        a1 += J[1, i] * vi
        a2 += J[2, i] * vi
        a3 += J[3, i] * vi
        a4 += J[4, i] * vi
        a5 += J[5, i] * vi
    return a0, a1, a2, a3, a4, a5


@njit(cache=True, inline="always")
def add_body_wrench(J, idx, w0, w1, w2, w3, w4, w5, tau):
    """tau[idx] += J[:, idx]^T w, w a wrench (force; moment about the world origin)."""
    for i in idx:
        tau[i] += J[0, i] * w0 + J[1, i] * w1 + J[2, i] * w2 + J[3, i] * w3 + J[4, i] * w4 + J[5, i] * w5


@njit(cache=True)
def relative_velocity(J, idx1, idx2, v, n, p1, p2, dd, vt):
    """dd[k] = n_k . (v2(p2_k) - v1(p1_k)), vt[k] = the tangential rest, for material points p1_k
    on body 1 and p2_k on body 2 (velocities v_o + w x p from WORLD Jacobian columns idx)."""
    u0, u1, u2, u3, u4, u5 = body_twist(J, idx1, v)
    b0, b1, b2, b3, b4, b5 = body_twist(J, idx2, v)
    for k in range(n.shape[0]):
        x2, y2, z2 = p2[k, 0], p2[k, 1], p2[k, 2]
        x1, y1, z1 = p1[k, 0], p1[k, 1], p1[k, 2]
        r0 = (b0 + b4 * z2 - b5 * y2) - (u0 + u4 * z1 - u5 * y1)
        r1 = (b1 + b5 * x2 - b3 * z2) - (u1 + u5 * x1 - u3 * z1)
        r2 = (b2 + b3 * y2 - b4 * x2) - (u2 + u3 * y1 - u4 * x1)
        d = n[k, 0] * r0 + n[k, 1] * r1 + n[k, 2] * r2
        dd[k] = d
        vt[k, 0] = r0 - d * n[k, 0]
        vt[k, 1] = r1 - d * n[k, 1]
        vt[k, 2] = r2 - d * n[k, 2]


@njit(cache=True)
def add_wrenches(J, idx1, idx2, F2, p1, p2, tau):
    """tau += J2^T (f; sum p2 x F2) + J1^T (-f; -sum p1 x F2): forces F2 on body 2 at p2, their
    reactions on body 1 at p1, as wrenches about the world origin (WORLD Jacobians)."""
    f0 = f1 = f2 = m0 = m1 = m2 = r0 = r1 = r2 = 0.0
    for k in range(F2.shape[0]):
        fx, fy, fz = F2[k, 0], F2[k, 1], F2[k, 2]
        f0 += fx
        f1 += fy
        f2 += fz
        m0 += p2[k, 1] * fz - p2[k, 2] * fy
        m1 += p2[k, 2] * fx - p2[k, 0] * fz
        m2 += p2[k, 0] * fy - p2[k, 1] * fx
        r0 -= p1[k, 1] * fz - p1[k, 2] * fy
        r1 -= p1[k, 2] * fx - p1[k, 0] * fz
        r2 -= p1[k, 0] * fy - p1[k, 1] * fx
    add_body_wrench(J, idx2, f0, f1, f2, m0, m1, m2, tau)
    add_body_wrench(J, idx1, -f0, -f1, -f2, r0, r1, r2, tau)


# ------------------------------------------------------------------ spring-damper
class SpringLaw(NamedTuple):
    """Stiffness k (N/m), damping c (N s/m) and free length L0 (m) of a spring-damper."""
    k: float
    c: float
    L0: float


@njit(cache=True, inline="always")
def spring_state(law, fr, bodies, v, state):
    """Length L = |p2 - p1| of the spring between the frames' origins, its rate dL/dt = n .
    (v2(p2) - v1(p1)) with n = (p2 - p1)/L, and its tension f = k (L - L0) + c dL/dt, pulling
    the bodies together: state = (L, dL/dt, f, n)."""
    place_frames(fr)
    M, J = fr.M, bodies.J
    x1, y1, z1 = M[0, 0, 3], M[0, 1, 3], M[0, 2, 3]
    x2, y2, z2 = M[1, 0, 3], M[1, 1, 3], M[1, 2, 3]
    e0, e1, e2 = x2 - x1, y2 - y1, z2 - z1
    L = math.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
    # coincident origins: no direction, no force (the tension's direction is undefined)
    inv = 1.0 / L if L > 0.0 else 0.0
    n0, n1, n2 = e0 * inv, e1 * inv, e2 * inv
    u0, u1, u2, u3, u4, u5 = body_twist(J, bodies.idx1, v)
    b0, b1, b2, b3, b4, b5 = body_twist(J, bodies.idx2, v)
    r0 = (b0 + b4 * z2 - b5 * y2) - (u0 + u4 * z1 - u5 * y1)
    r1 = (b1 + b5 * x2 - b3 * z2) - (u1 + u5 * x1 - u3 * z1)
    r2 = (b2 + b3 * y2 - b4 * x2) - (u2 + u3 * y1 - u4 * x1)
    Ldot = n0 * r0 + n1 * r1 + n2 * r2
    f = law.k * (L - law.L0) + law.c * Ldot
    state[0], state[1], state[2], state[3], state[4], state[5] = L, Ldot, f, n0, n1, n2


@njit(cache=True, inline="always")
def spring_force(law, fr, bodies, v, state, tau):
    """tau += the spring-damper's generalized force (ForceElement.force_kernel): -f n on body 2
    at p2, f n on body 1 at p1, as wrenches about the world origin."""
    spring_state(law, fr, bodies, v, state)
    M, J, f = fr.M, bodies.J, state[2]
    F0, F1, F2 = -f * state[3], -f * state[4], -f * state[5]
    x1, y1, z1 = M[0, 0, 3], M[0, 1, 3], M[0, 2, 3]
    x2, y2, z2 = M[1, 0, 3], M[1, 1, 3], M[1, 2, 3]
    add_body_wrench(J, bodies.idx2, F0, F1, F2, y2 * F2 - z2 * F1, z2 * F0 - x2 * F2, x2 * F1 - y2 * F0, tau)
    add_body_wrench(J, bodies.idx1, -F0, -F1, -F2, z1 * F1 - y1 * F2, x1 * F2 - z1 * F0, y1 * F0 - x1 * F1, tau)


@njit(cache=True)
def spring_record(law, fr, bodies, v, state, row):
    """One output sample of a spring-damper (SpringDamper.record): potential k (L - L0)^2 / 2,
    power loss c (dL/dt)^2, length, tension."""
    spring_state(law, fr, bodies, v, state)
    L, Ldot = state[0], state[1]
    row[0] = 0.5 * law.k * (L - law.L0) ** 2
    row[1] = law.c * Ldot * Ldot
    row[2] = L
    row[3] = state[2]


class SpringData:
    """One workspace's buffers of a spring-damper: its frames' slot and placements, and what
    :func:`spring_state` writes, (length, rate, tension, unit vector from frame 1 to frame 2)."""

    def __init__(self, slot):
        self.slot = slot
        self.M = np.zeros((2, 4, 4))
        self.state = np.zeros(6)
        self.args = None             # the kernels' arguments in this workspace, built once


def _readonly(a):
    a = np.array(a)
    a.flags.writeable = False
    return a


class SpringDamper(ForceElement):
    """Point-to-point spring-damper between two frames' origins: tension F = k (L - L0) + c dL/dt
    along the line joining them, L their distance.

    Compiled (contract 10): :func:`spring_force` reads the frames' placements from the
    workspace's frame kinematics (``kinematic_frames``) and the Jacobian columns from ws.J6;
    the Python methods call the same kernels."""

    def __init__(self, name, model, f1, f2, k, c=0.0, free_length=0.0):
        self.name, self.f1, self.f2 = name, int(f1), int(f2)
        self.k, self.c, self.L0 = float(k), float(c), float(free_length)
        self.law = SpringLaw(self.k, self.c, self.L0)
        self.conservative = self.c == 0.0
        self.idx1 = _readonly(supporting_dofs(model, self.f1))
        self.idx2 = _readonly(supporting_dofs(model, self.f2))
        self.kinematic_frames = (self.f1, self.f2)
        self._freeze()

    def create_data(self, mech):
        return SpringData(self.frame_slot(mech))

    def _args(self, ws, d):
        if d.args is None:
            fk = ws.fk
            d.args = (self.law, Frames(fk.Hj, fk.jidx, fk.jMf, d.slot, d.M), Bodies(ws.J6, self.idx1, self.idx2))
        return d.args

    def _state(self, ws, d, v):
        """(length, rate, tension) at the state of the last kinematics pass and velocity v."""
        spring_state(*self._args(ws, d), v, d.state)
        return d.state[:3]

    def force_kernel(self, mech, ws, d, z, zdot):
        return spring_force, self._args(ws, d) + (ws.v, d.state, ws.tau)

    def add_force(self, mech, ws, d, t, q, v, z, tau, zdot):
        spring_force(*self._args(ws, d), v, d.state, tau)

    def potential(self, mech, ws, d, q):
        L = self._state(ws, d, ws.zero_v)[0]
        return 0.5 * self.k * (L - self.L0) ** 2

    def power_loss(self, mech, ws, d, t, q, v, z):
        Ldot = self._state(ws, d, v)[1]
        return self.c * Ldot * Ldot

    def outputs(self, mech, ws, d, t, q, v, z):
        L, _, f = self._state(ws, d, v)
        return {"length": np.array(L), "force": np.array(f)}

    def record(self, mech, ws, d, t, q, v, z, after_rhs):
        L, Ldot, f = self._state(ws, d, v)
        return (0.5 * self.k * (L - self.L0) ** 2, self.c * Ldot * Ldot,
                {"length": np.array(L), "force": np.array(f)})

    def record_layout(self):
        return (("length", 1), ("force", 1))

    def record_kernel(self, mech, ws, d, z, zdot, row):
        return spring_record, self._args(ws, d) + (ws.v, d.state, row)

    def describe(self):
        return {"name": self.name, "type": "spring_damper", "k": self.k, "c": self.c, "free_length": self.L0}


def parse_spring_damper(f, ctx):
    """A ``spring_damper`` entry (keys checked) -> SpringDamper; ``ctx``: pinclear.io.sidecar.Context."""
    f1, _ = ctx.frame(f["frame1"], "frame1")
    f2, _ = ctx.frame(f["frame2"], "frame2")
    v = SPRING_DAMPER.value
    return SpringDamper(ctx.name, ctx.model, f1, f2, f["k"], v(f, "c"), v(f, "free_length"))


SPRING_DAMPER = PluginType(
    "spring_damper", parse=parse_spring_damper,
    doc="Point-to-point spring-damper between two frames' origins: tension F = k (L - L0) + c dL/dt along the "
        "line joining them, L their distance (forces.SpringDamper).",
    keys=(Key("frame1", "frame", doc="first end: a frame name or {parent, xyz, rpy | axis, name}"),
          Key("frame2", "frame", doc="second end, on another body"),
          Key("k", "number", "N/m", range="finite", source="F = k (L - L0) + c dL/dt", doc="stiffness"),
          Key("c", "number", "N s/m", 0.0, "finite", "F = k (L - L0) + c dL/dt", "damping"),
          Key("free_length", "number", "m", 0.0, "finite", "F = k (L - L0) + c dL/dt", "free length L0")))


# ------------------------------------------------------------------ joint force
@njit(cache=True)
def joint_force(table, t, idx, f, tau):
    """tau[idx] += the time law's value at t (its value and derivatives go to f (3, 1))."""
    eval_laws(table.codes, table.starts, table.P, t, table.cols, f)
    tau[idx] += f[0, 0]


@njit(cache=True)
def joint_force_record(table, t, idx, f, v, row):
    """One output sample of a joint force (JointForce.record): no potential, power loss -f v
    (negative: power injected), the force."""
    eval_laws(table.codes, table.starts, table.P, t, table.cols, f)
    row[0] = 0.0
    row[1] = -f[0, 0] * v[idx]
    row[2] = f[0, 0]


class JointForce(ForceElement):
    """Applied generalized force/torque on a 1-DoF joint following a time law.

    Compiled (contract 10) when the law has a compiled form (constant, sines, polynomial:
    ``TimeLaw.kernel_params()``): :func:`joint_force`. A law without one (a spline, a Python
    function: ``timelaws.Callable``) is evaluated by :meth:`add_force` in a Python stage of the
    run, at Python's cost (a few microseconds per evaluation)."""

    conservative = False

    def __init__(self, name, idx_v, law: TimeLaw):
        self.name, self.idx_v, self.law = name, int(idx_v), law
        self.table = law_table([law], [0]) if law.kernel_params() is not None else None
        self._freeze()

    def create_data(self, mech):
        return np.zeros((3, 1))          # the law's value and derivatives at the last time

    def _value(self, d, t):
        if self.table is None:
            return self.law.eval(t)[0]
        eval_laws(self.table.codes, self.table.starts, self.table.P, float(t), self.table.cols, d)
        return d[0, 0]

    def force_kernel(self, mech, ws, d, z, zdot):
        if self.table is None:
            return None
        return joint_force, (self.table, T, self.idx_v, d, ws.tau)

    def add_force(self, mech, ws, d, t, q, v, z, tau, zdot):
        if self.table is None:
            tau[self.idx_v] += self.law.eval(t)[0]
            return
        joint_force(self.table, float(t), self.idx_v, d, tau)

    def record_layout(self):
        return None if self.table is None else (("force", 1),)

    def record_kernel(self, mech, ws, d, z, zdot, row):
        if self.table is None:
            return None
        return joint_force_record, (self.table, T, self.idx_v, d, ws.v, row)

    def power_loss(self, mech, ws, d, t, q, v, z):
        # negative loss = power injected
        return -self._value(d, t) * v[self.idx_v]

    def outputs(self, mech, ws, d, t, q, v, z):
        return {"force": np.array(self._value(d, t))}

    def describe(self):
        return {"name": self.name, "type": "joint_force", "law": self.law.describe()}


def parse_joint_force(f, ctx):
    """A ``joint_force`` entry (keys checked) -> JointForce; ``ctx``: pinclear.io.sidecar.Context."""
    jm = ctx.joint(f["joint"], "joint", one_dof=True)
    return JointForce(ctx.name, jm.idx_v, ctx.law(f["law"], "law"))


JOINT_FORCE = PluginType(
    "joint_force", parse=parse_joint_force,
    doc="Applied generalized force or torque on a 1-DoF joint following a time law (forces.JointForce).",
    keys=(Key("joint", "joint name", range="a 1-DoF joint of the URDF", doc="the joint it acts on"),
          Key("law", "time law", "N or N m", range="a time law (below)", doc="the force (prismatic joint) or "
              "torque (revolute joint) over time")))
