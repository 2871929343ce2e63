"""Force elements: anything that adds a generalized force computed from the state.

Springs, applied joint forces and clearance contacts share one contract, so the formulations
and the simulator never special-case them.
"""
from __future__ import annotations

import abc

import numpy as np

from .kinematics import supporting_dofs
from .timelaws import TimeLaw


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
       and their time derivative. Elements never call Pinocchio's tree algorithms themselves.
    4. :meth:`add_force` ADDS the element's generalized force into ``tau`` (nv) and WRITES the
       rates of its internal states into ``zdot`` (nz).
    5. :meth:`potential` is the stored elastic energy, :meth:`power_loss` the dissipated power
       (negative when the element injects energy): the energy balance of a run closes with them.
    6. ``conservative`` says whether the element neither dissipates nor injects energy.
       ``dissipation_state`` is the index (in the element's z) of a state integrating the
       dissipated energy (the integral of :meth:`power_loss`), or None: the energy audit
       (pinclear.energy) then integrates the power loss over the output samples.
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
        ``pinclear.stepping.stage.T`` where the time goes. The state is read from the
        workspace's state buffer (``ws.q``, ``ws.v`` and the element's ``z``), which a run fills
        before the stages run; Pinocchio's passes (contract 3) have run on ``ws.data``. None
        (the default): the run calls the Python method through a Python stage, at Python's cost.
        The Python method and the kernel give the same numbers (tests compare them).
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


def world_jacobian_columns(J, idx, p):
    """Linear rows at point p (world) of the WORLD joint Jacobian restricted to columns idx:
    v(p) = v_o + w x p = (Jv - [p]x Jw) v."""
    Jv, Jw = J[:3, idx], J[3:, idx]
    out = Jv.copy()
    # minus p x Jw column by column, written out: np.cross's axis handling costs ~20 us a call
    out[0] -= p[1] * Jw[2] - p[2] * Jw[1]
    out[1] -= p[2] * Jw[0] - p[0] * Jw[2]
    out[2] -= p[0] * Jw[1] - p[1] * Jw[0]
    return out


class _SpringData:
    __slots__ = ("Jd",)

    def __init__(self, nv):
        self.Jd = np.zeros((3, nv))


class SpringDamper(ForceElement):
    """Point-to-point spring-damper between two frames: F = k (|d| - L0) + c d|d|/dt along d."""

    def __init__(self, name, model, f1, f2, k, c=0.0, free_length=0.0):
        self.name, self.f1, self.f2 = name, int(f1), int(f2)
        self.k, self.c, self.L0 = float(k), float(c), float(free_length)
        self.conservative = self.c == 0.0
        self.idx1 = supporting_dofs(model, self.f1)
        self.idx2 = supporting_dofs(model, self.f2)
        self._freeze()

    def create_data(self, mech):
        return _SpringData(mech.nv)

    def _geometry(self, ws, d):
        """Length, unit direction (frame 1 - frame 2) and the Jacobian of p1 - p2."""
        data = ws.data
        p1, p2 = data.oMf[self.f1].translation, data.oMf[self.f2].translation
        dv = p1 - p2
        L = float(np.sqrt(dv @ dv))
        n = dv / L if L > 0 else np.zeros(3)
        J = data.J.reshape(6, -1)
        Jd = d.Jd
        Jd[:] = 0.0
        Jd[:, self.idx1] += world_jacobian_columns(J, self.idx1, p1)
        Jd[:, self.idx2] -= world_jacobian_columns(J, self.idx2, p2)
        return L, n, Jd

    def add_force(self, mech, ws, d, t, q, v, z, tau, zdot):
        L, n, Jd = self._geometry(ws, d)
        Ldot = float(n @ (Jd @ v))
        f = self.k * (L - self.L0) + self.c * Ldot       # tension
        tau -= f * (Jd.T @ n)

    def potential(self, mech, ws, d, q):
        L = np.linalg.norm(ws.data.oMf[self.f1].translation - ws.data.oMf[self.f2].translation)
        return 0.5 * self.k * (L - self.L0) ** 2

    def power_loss(self, mech, ws, d, t, q, v, z):
        L, n, Jd = self._geometry(ws, d)
        Ldot = float(n @ (Jd @ v))
        return self.c * Ldot * Ldot

    def outputs(self, mech, ws, d, t, q, v, z):
        L, n, Jd = self._geometry(ws, d)
        Ldot = float(n @ (Jd @ v))
        return {"length": np.array(L), "force": np.array(self.k * (L - self.L0) + self.c * Ldot)}

    def describe(self):
        return {"name": self.name, "type": "spring_damper", "k": self.k, "c": self.c, "free_length": self.L0}


class JointForce(ForceElement):
    """Applied generalized force/torque on a 1-DoF joint following a time law."""

    conservative = False

    def __init__(self, name, idx_v, law: TimeLaw):
        self.name, self.idx_v, self.law = name, int(idx_v), law
        self._freeze()

    def add_force(self, mech, ws, d, t, q, v, z, tau, zdot):
        tau[self.idx_v] += self.law.eval(t)[0]

    def power_loss(self, mech, ws, d, t, q, v, z):
        # negative loss = power injected
        return -self.law.eval(t)[0] * v[self.idx_v]

    def outputs(self, mech, ws, d, t, q, v, z):
        return {"force": np.array(self.law.eval(t)[0])}

    def describe(self):
        return {"name": self.name, "type": "joint_force", "law": self.law.describe()}
