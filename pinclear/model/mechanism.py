"""Mechanism (immutable description) and Workspace (per-evaluation buffers), after Pinocchio's
Model/Data split: many workspaces may serve one mechanism."""
from __future__ import annotations

import copy

import numpy as np
import pinocchio as pin

from pinclear.model.closures import Closure, CompiledClosures
from pinclear.model.drives import Drive, DriveRows
from pinclear.model.kinematics import FrameKinematics


class Mechanism:
    """A closed-loop mechanism: an open-chain Pinocchio tree plus closures, drives and forces.

    Treat as immutable; use :meth:`replace` to derive variants (drives released, clearance on...).
    """

    def __init__(self, model: pin.Model, name: str, closures: list[Closure], drives: list[Drive],
                 forces: list, q0=None, v0=None, path=None, platform_frame=None, platform_motion=None,
                 options=None, parameters=None, sidecar=None, replaced_closures=None,
                 visual_model=None, collision_model=None):
        self.model = model
        self.name = name
        self.path = path
        # tuples: a mechanism's elements are fixed; variants are made with replace()
        self.closures = tuple(closures)
        self.drives = tuple(drives)
        self.forces = tuple(forces)
        self.q0 = pin.neutral(model) if q0 is None else np.asarray(q0, float)
        self.v0 = np.zeros(model.nv) if v0 is None else np.asarray(v0, float)
        self.platform_frame = platform_frame
        self.platform_motion = platform_motion
        self.options = dict(options or {})
        self.parameters = list(parameters or [])
        self.sidecar = sidecar or {}
        self.replaced_closures = dict(replaced_closures or {})
        self.visual_model = visual_model
        self.collision_model = collision_model
        self.load_args = None        # set by pinclear.load: path, options, overrides, clearances
        self.compiled = CompiledClosures(list(self.closures))
        self.driverows = DriveRows(list(self.drives), model.nv)
        self.z_slices = []
        n = 0
        for f in self.forces:
            self.z_slices.append(slice(n, n + f.nz))
            n += f.nz
        # a work meter after the elements' states: the work of the drive rows, integrated with
        # the state (pinclear.dynamics.energy)
        self.n_work = 1 if self.drives else 0
        self.z_work = slice(n, n + self.n_work)
        self.nz = n + self.n_work
        # frames whose placements the compiled kernels compute from the joint chain: the closures'
        # frames, then those force elements evaluate in compiled code (``kinematic_frames``);
        # element i's frames start at slot force_frame_slot[i] of the workspace's FrameKinematics
        frames, slots = list(self.compiled.frames), []
        for f in self.forces:
            slots.append(len(frames))
            frames.extend(int(x) for x in f.kinematic_frames)
        self.kin_frames = tuple(frames)
        self.force_frame_slot = tuple(slots)
        self.euclidean = _is_euclidean(model)

    # ------------------------------------------------------------------ queries
    @property
    def nq(self):
        return self.model.nq

    @property
    def nv(self):
        return self.model.nv

    @property
    def m_closures(self):
        return self.compiled.m

    @property
    def m(self):
        return self.compiled.m + len(self.drives)

    def row_names(self, with_drives=True):
        names = list(self.compiled.row_names)
        if with_drives:
            names += [d.name for d in self.drives]
        return names

    def frame_id(self, name: str) -> int:
        if not self.model.existFrame(name):
            from pinclear.core.errors import ModelFileError

            raise ModelFileError(self.path or self.name, "frame", f"unknown frame {name!r}",
                                 choices=[f.name for f in self.model.frames])
        return self.model.getFrameId(name)

    @property
    def conservative(self) -> bool:
        return not self.drives and all(f.conservative for f in self.forces)

    @property
    def clearances(self) -> tuple:
        """The active clearance joints (force elements with ``is_clearance``)."""
        return tuple(f for f in self.forces if f.is_clearance)

    def workspace(self) -> "Workspace":
        """New per-evaluation data: Pinocchio's Data, constraint buffers, every element's data.
        One workspace per thread; any number may serve one mechanism."""
        return Workspace(self)

    def replace(self, **changes) -> "Mechanism":
        """A new Mechanism with some fields changed (closures, drives, forces, q0, ...)."""
        fields = dict(model=self.model, name=self.name, closures=self.closures, drives=self.drives,
                      forces=self.forces, q0=self.q0, v0=self.v0, path=self.path,
                      platform_frame=self.platform_frame, platform_motion=self.platform_motion,
                      options=self.options, parameters=self.parameters, sidecar=self.sidecar,
                      replaced_closures=self.replaced_closures, visual_model=self.visual_model,
                      collision_model=self.collision_model)
        fields.update(changes)
        for key in ("closures", "drives", "forces"):
            fields[key] = list(fields[key])
        new = Mechanism(**fields)
        new.load_args = self.load_args
        return new

    def copy_model(self) -> pin.Model:
        return copy.deepcopy(self.model)

    def describe(self) -> dict:
        return {
            "name": self.name, "path": str(self.path) if self.path else None, "nq": self.nq, "nv": self.nv,
            "joints": list(self.model.names)[1:],
            "closures": [{"name": c.name, "type": c.type, "frame1": c.frame1, "frame2": c.frame2,
                          "rows": c.nrows} for c in self.closures],
            "drives": [{"name": d.name, "joint": d.joint, "law": d.law.describe()} for d in self.drives],
            "forces": [f.describe() for f in self.forces],
            "gravity": self.model.gravity.linear.tolist(),
            "options": {k: v for k, v in self.options.items()},
        }

    def __repr__(self):
        return (f"Mechanism({self.name!r}, nq={self.nq}, nv={self.nv}, closures={len(self.closures)} "
                f"({self.compiled.m} rows), drives={len(self.drives)}, forces={len(self.forces)})")


def _is_euclidean(model) -> bool:
    """True when q moves by plain addition of v (no quaternions, unbounded angles, Euler charts):
    then integrating q directly is exact and no chart is needed."""
    if model.nq != model.nv:
        return False
    rng = np.random.default_rng(0)
    q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq)) if model.nq else np.zeros(0)
    v = rng.standard_normal(model.nv)
    return bool(np.allclose(pin.integrate(model, q, v), q + v, atol=1e-12)
                and np.allclose(pin.dIntegrate(model, q, v, pin.ARG1), np.eye(model.nv), atol=1e-12))


class Workspace:
    """Everything one evaluation thread writes: pin.Data, frame kinematics, constraint rows, the
    drives' law values and each force element's data (``force_data[i]`` for ``mech.forces[i]``)."""

    def __init__(self, mech: Mechanism):
        nv, m = mech.nv, mech.m
        self.data = mech.model.createData()
        self.parent = np.array(self.data.parents_fromRow, dtype=np.int64)   # parent dof, -1 at roots
        self.fk = FrameKinematics(mech.model, mech.kin_frames)
        # (6, nv) views of Pinocchio's joint Jacobian and its rate, valid for the data's life
        # (each attribute access builds a new view: ~1 us, so the hot path keeps these)
        self.J6 = self.data.J.reshape(6, nv)
        self.dJ6 = self.data.dJ.reshape(6, nv)
        self.phi = np.zeros(m)
        self.dphi = np.zeros(m)
        self.bias = np.zeros(m)
        self.gamma = np.zeros(m)
        self.J = np.zeros((m, nv))
        if mech.drives:
            self.J[mech.compiled.m:] = mech.driverows.J
        #: (cols, ncols) of pinclear.model.kinematics.row_support, made by the first row_buffers
        self.support = None
        self.tau = np.zeros(nv)
        self.zdot = np.zeros(mech.nz)
        # the state buffer x = [c, v, z] every compiled kernel reads (pinclear.dynamics.stepping.system):
        # c is q itself on a Euclidean tree, a chart around an anchor otherwise (q then has its
        # own buffer); a run copies each evaluation's state here before the stages run
        nc = mech.nq if mech.euclidean else nv
        self.x = np.zeros(nc + nv + mech.nz)
        self.q = self.x[:nc] if mech.euclidean else np.zeros(mech.nq)
        self.v = self.x[nc:nc + nv]
        self.z = self.x[nc + nv:]
        #: each force element's slice of z and of zdot (views)
        self.z_views = [self.z[sl] for sl in mech.z_slices]
        self.zdot_views = [self.zdot[sl] for sl in mech.z_slices]
        self.a = np.zeros(nv)         # accelerations, written by the formulation's solve
        self.zero_v = np.zeros(nv)
        self.lam = np.zeros(m)
        #: Gauss-Newton steps the last projection took (pinclear.dynamics.formulations.projection)
        self.gn_steps = np.zeros(1, dtype=np.int64)
        self.drive_data = mech.driverows.create_data()
        self.force_data = [f.create_data(mech) for f in mech.forces]

    def load_state(self, q, v, z):
        """Copy (q, v, z) into the state buffer (a no-op for its own views). z may stop before
        the drive work meter, which no kernel reads."""
        for dst, src in ((self.q, q), (self.v, v), (self.z, z)):
            if src is not dst:
                dst[:len(src)] = src
