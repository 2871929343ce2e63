"""MuJoCo as an independent engine on pinclear's chart: the same URDF tree + YAML sidecar,
translated to MJCF, simulated by MuJoCo, its final state mapped back to Pinocchio's q layout.

Translation (from ``pinclear.load(path).model``, not from MuJoCo's URDF importer, so that the
tree, the merged inertias and the joint placements are exactly the ones pinclear integrates):

* one MJCF body per Pinocchio joint, placed at ``model.jointPlacements[j]`` in its parent's
  body, carrying ``model.inertias[j]`` (mass, centre of mass, full inertia about it);
  revolute (aligned or not) -> hinge, prismatic -> slide, spherical -> ball, free-flyer -> free;
* closures -> MuJoCo equality constraints between sites placed at the closure frames:
  ``spherical`` -> connect; ``weld`` -> weld; ``revolute`` -> two connects (frame origins and
  points one length unit along the common z axis: 6 rows for 5, one redundant, which MuJoCo's
  regularised solver takes); ``planar_point`` -> connect whose second site is shifted along the
  plane normal by the initial out-of-plane offset (the third row is then an identity of the
  planar motion). Other closure types have no MuJoCo equality and are refused;
* drives (a joint coordinate following a time law q_j = f(t)) -> a joint equality
  ``q_j = y(s)`` on a "clock" slide joint s with s = 0, ds/dt = 1 reset at every step, y a
  quartic in s refreshed every step (MuJoCo's polycoef has 5 coefficients). Because the
  constraint involves s, MuJoCo evaluates the law at RK4's stage times and its velocity error
  is q_j' - f'(t). y adds to the law the lag of MuJoCo's reference spring-damper (see
  ``MujocoScene._drive_poly``), so q_j = f(t) solves MuJoCo's constraint dynamics exactly;
  what is left is the O(h^4) of the quartic fit. The clock carries a large armature, so the
  constraint's reaction on it moves it by a negligible amount within a step;
* gravity from the model; contacts disabled (the scenes have ideal joints only).

Soft-constraint setting: solref = (2 h, 1) (time constant twice the step, the stiffest
MuJoCo's ``refsafe`` allows, critically damped) and solimp = (0.9999, 0.9999, ...) (the
largest impedance MuJoCo accepts, constant in the violation). MuJoCo then drives a
constraint's acceleration J qacc to -(2/tc) J v - (1/tc^2) r, so a closure violation decays
within a few steps; its steady value ~ tc^2 (dJ/dt v) (MuJoCo's constraint acceleration is
J qacc, without dJ/dt v) is O(h^2): the error the convergence study in run_peers.py measures.

Cost of the drive choice (four_ups_upu, RK4): |q_P - f(t)| = 4.1e-7 at h = 2e-3, 1.0e-7 at 1e-3,
O(h^2) like the closures (with tc proportional to h the constraint modes have a fixed h/tc, so
RK4's relative error on them does not vanish); 9x smaller than the same polynomial without the
lag compensation; about 5 us of Python per step for the law and the coefficients.

Accuracy knob: the time step h (``tol``, shortened to divide t_end); integrator RK4 (peer name
"mujoco") or implicitfast ("mujoco_implicitfast", first order). MuJoCo silently resets a state
that blew up and carries on; ``MujocoScene.unstable`` reads its warning counters so that such a
run is reported failed ("non-finite"), not as a result.
"""
from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pinocchio as pin

from pinclear.model import kinematics
from pinclear.core.errors import InputError
from pinclear.io.export_mjcf import CLOCK_ARMATURE, DMAX, SUPPORTED_CLOSURES, mjcf  # noqa: F401  (the translation)

SCENES = {"four_bar", "a02_nfourbar_2", "four_ups_upu"}
TOLS = [2e-3, 1e-3, 5e-4, 2.5e-4, 1e-4, 5e-5, 2.5e-5]
INTEGRATORS = ("RK4", "implicitfast", "Euler", "implicit")


def _mujoco():
    try:
        import mujoco
    except ImportError as exc:  # pragma: no cover - exercised without the extra
        raise InputError("the MuJoCo peer needs the 'mujoco' package: pip install \"pinclear[peers]\"") from exc
    return mujoco


class QMap:
    """Pinocchio (q, v) <-> MuJoCo (qpos, qvel), joint by joint.

    Quaternions: Pinocchio stores (x, y, z, w), MuJoCo (w, x, y, z). Free joints: Pinocchio's
    v is (linear, angular) both in the body frame, MuJoCo's qvel is (linear in the world frame,
    angular in the body frame)."""

    def __init__(self, pmodel, mjmodel, names, kinds):
        import mujoco

        self.pmodel = pmodel
        self.entries = []
        for j in range(1, pmodel.njoints):
            jid = mujoco.mj_name2id(mjmodel, mujoco.mjtObj.mjOBJ_JOINT, names[j])
            jm = pmodel.joints[j]
            self.entries.append((kinds[j], jm.idx_q, jm.idx_v, int(mjmodel.jnt_qposadr[jid]),
                                 int(mjmodel.jnt_dofadr[jid])))
        self.nq_mj, self.nv_mj = mjmodel.nq, mjmodel.nv

    def to_mujoco(self, q, v, qpos, qvel):
        for kind, iq, iv, aq, av in self.entries:
            if kind == "1":
                qpos[aq], qvel[av] = q[iq], v[iv]
            elif kind == "ball":
                x, y, z, w = q[iq:iq + 4]
                qpos[aq:aq + 4] = (w, x, y, z)
                qvel[av:av + 3] = v[iv:iv + 3]
            else:  # free
                x, y, z, w = q[iq + 3:iq + 7]
                qpos[aq:aq + 3] = q[iq:iq + 3]
                qpos[aq + 3:aq + 7] = (w, x, y, z)
                R = pin.Quaternion(w, x, y, z).normalized().toRotationMatrix()
                qvel[av:av + 3] = R @ v[iv:iv + 3]
                qvel[av + 3:av + 6] = v[iv + 3:iv + 6]

    def to_pinocchio(self, qpos, qvel):
        q = np.zeros(self.pmodel.nq)
        v = np.zeros(self.pmodel.nv)
        for kind, iq, iv, aq, av in self.entries:
            if kind == "1":
                q[iq], v[iv] = qpos[aq], qvel[av]
            elif kind == "ball":
                w, x, y, z = qpos[aq:aq + 4] / np.linalg.norm(qpos[aq:aq + 4])
                q[iq:iq + 4] = (x, y, z, w)
                v[iv:iv + 3] = qvel[av:av + 3]
            else:
                w, x, y, z = qpos[aq + 3:aq + 7] / np.linalg.norm(qpos[aq + 3:aq + 7])
                q[iq:iq + 3] = qpos[aq:aq + 3]
                q[iq + 3:iq + 7] = (x, y, z, w)
                R = pin.Quaternion(w, x, y, z).toRotationMatrix()
                v[iv:iv + 3] = R.T @ qvel[av:av + 3]
                v[iv + 3:iv + 6] = qvel[av + 3:av + 6]
        return q, v


class MujocoScene:
    """One mechanism translated to MuJoCo at time step ``h``.

    ``tc_factor`` sets solref's time constant tc = tc_factor * h (2: the stiffest MuJoCo allows
    without disabling its ``refsafe`` clamp)."""

    def __init__(self, mech, h, integrator="RK4", tc_factor=2.0, q0=None, v0=None):
        mujoco = _mujoco()
        if integrator not in INTEGRATORS:
            raise InputError(f"MuJoCo peer: integrator {integrator!r} unknown; choose one of {list(INTEGRATORS)}")
        if not (np.isfinite(h) and h > 0):
            raise InputError(f"MuJoCo peer: time step must be positive and finite, got {h!r}")
        if mech.forces:
            raise InputError(f"MuJoCo peer: {mech.name} has force elements {[f.name for f in mech.forces]}; "
                             "the translation covers ideal joints, closures, drives and gravity only")
        self.mech, self.h, self.integrator = mech, float(h), integrator
        self.tc = tc_factor * self.h
        model = mech.model
        if q0 is None:
            ws = mech.workspace()
            q0 = kinematics.assemble(mech, mech.q0, t=0.0, ws=ws)
            v0 = kinematics.consistent_velocity(mech, q0, mech.v0, t=0.0, ws=ws)
        self.q0, self.v0 = np.asarray(q0, float), np.asarray(v0, float)
        self.xml, self.names, kinds = self._mjcf(mech)
        try:
            self.m = mujoco.MjModel.from_xml_string(self.xml)
        except ValueError as exc:
            raise InputError(f"MuJoCo peer: MuJoCo refused the translation of {mech.name}: {exc}") from exc
        self.d = mujoco.MjData(self.m)
        self.warnings = []
        self.qmap = QMap(model, self.m, self.names, kinds)
        self.drive_dofs = []
        if mech.drives:
            self.clock_q = int(self.m.jnt_qposadr[mujoco.mj_name2id(self.m, mujoco.mjtObj.mjOBJ_JOINT, "pinclear_clock")])
            self.clock_v = int(self.m.jnt_dofadr[mujoco.mj_name2id(self.m, mujoco.mjtObj.mjOBJ_JOINT, "pinclear_clock")])
            self.eq_drive = np.array([mujoco.mj_name2id(self.m, mujoco.mjtObj.mjOBJ_EQUALITY, f"drive_{d.name}")
                                      for d in mech.drives])
            # quartic p(s) with p, p', p'' at s = 0 and p, p' at s = h: coefficients = H @ data
            hh = self.h
            A = np.array([[1, 0, 0, 0, 0], [0, 1, 0, 0, 0], [0, 0, 2, 0, 0],
                          [1, hh, hh ** 2, hh ** 3, hh ** 4], [0, 1, 2 * hh, 3 * hh ** 2, 4 * hh ** 3]], float)
            H = np.linalg.inv(A)
            # derivative in the monomial basis: (D c)_k = (k + 1) c_(k+1)
            D = np.diag(np.arange(1.0, 5.0), 1)
            D2 = D @ D
            tc = self.tc
            self.G = (np.eye(5) + tc ** 2 * (D2 - 2 * tc * D2 @ D + 3 * tc ** 2 * D2 @ D2)) @ H
            self.drive_data = mech.driverows.create_data()
        self.reset()

    # ------------------------------------------------------------------ translation
    def _mjcf(self, mech):
        xml, names, kinds, _ = mjcf(mech, self.q0, self.h, self.tc, self.integrator, drives="clock", strict=True)
        return xml, names, kinds

    # ------------------------------------------------------------------ stepping
    def reset(self, q=None, v=None):
        mujoco = _mujoco()
        mujoco.mj_resetData(self.m, self.d)
        self.qmap.to_mujoco(self.q0 if q is None else q, self.v0 if v is None else v, self.d.qpos, self.d.qvel)
        self.d.time = 0.0
        if self.mech.drives:
            self._fn = self._law(0.0)
            self._drive_poly(0.0)
        mujoco.mj_forward(self.m, self.d)

    def _law(self, t):
        return self.mech.driverows.values(t, self.drive_data).copy()

    def _drive_poly(self, t):
        """Set every drive's quartic y(s), s in [0, h], and reset the clock (s = 0, s' = 1).

        MuJoCo's reference dynamics of the joint equality e = q_j - y(s) are
        q_j'' = -(2/tc) e' - (1/tc^2) e (impedance d = dmax cancels in the blend), so q_j = f
        needs y = f + tc^2 (1 + tc D)^-2 D^2 f = f + tc^2 (D^2 - 2 tc D^3 + 3 tc^2 D^4) f, exact
        for the quartic fit p of f (p, Dp, D^2p at t and p, Dp at t + h): y = G (data)."""
        f1 = self._law(t + self.h)
        X = np.concatenate((self._fn, f1[:2]))
        self._fn = f1
        # MuJoCo's joint equality reads y - y0 = poly(x - x0) with qpos0 = 0 for both joints
        self.m.eq_data[self.eq_drive, :5] = (self.G @ X).T
        self.d.qpos[self.clock_q] = 0.0
        self.d.qvel[self.clock_v] = 1.0

    def run(self, t_end, samples=0, monitor=None):
        """Step to t_end (h must divide t_end) and return (q, v) in Pinocchio's layout, the step
        count and the CPU seconds of the stepping alone. With ``samples`` > 0, ``monitor(t, q, v)``
        is called at that many evenly spaced instants, outside the CPU clock."""
        mujoco = _mujoco()
        n = max(int(round(t_end / self.h)), 1)
        if abs(n * self.h - t_end) > 1e-9 * self.h:
            raise InputError(f"MuJoCo peer: t_end {t_end} is not a multiple of the step {self.h}; "
                             "build the scene with h = t_end / n")
        m, d = self.m, self.d
        marks = np.unique(np.linspace(0, n, samples + 1).round().astype(int)) if samples else np.array([0, n])
        cpu, k = 0.0, 0
        # MuJoCo's default warning handler appends to MUJOCO_LOG.TXT in the working directory:
        # collect the messages instead (reported by the peer), restore the handler afterwards
        previous = mujoco.get_mju_user_warning()
        mujoco.set_mju_user_warning(self.warnings.append)
        try:
            cpu, k = self._steps(mujoco, m, d, marks, monitor)
        finally:
            mujoco.set_mju_user_warning(previous)
        q, v = self.state()
        return q, v, n, cpu

    def _steps(self, mujoco, m, d, marks, monitor):
        cpu, k = 0.0, 0
        for stop in marks[1:]:
            t0 = time.process_time()
            if self.mech.drives:
                while k < stop:
                    if k:
                        self._drive_poly(k * self.h)
                    mujoco.mj_step(m, d)
                    k += 1
            else:
                mujoco.mj_step(m, d, int(stop - k))
                k = int(stop)
            cpu += time.process_time() - t0
            if self.unstable():
                break
            if monitor is not None:
                monitor(k * self.h, *self.state())
        return cpu, k

    def unstable(self):
        """True once MuJoCo met a non-finite or huge state: it then resets the data by itself and
        goes on from the initial state, so a run must be checked, not trusted."""
        mujoco = _mujoco()
        W = mujoco.mjtWarning
        return any(self.d.warning[w].number for w in (W.mjWARN_BADQPOS, W.mjWARN_BADQVEL, W.mjWARN_BADQACC))

    def state(self):
        return self.qmap.to_pinocchio(self.d.qpos, self.d.qvel)


def energy(model, q, v):
    """Kinetic + gravity potential (Pinocchio, on the mapped state)."""
    data = model.createData()
    return float(pin.computeKineticEnergy(model, data, q, v) + pin.computePotentialEnergy(model, data, q))


def closure_residual(mech, q):
    ws = mech.workspace()
    return float(np.max(np.abs(kinematics.closure_residual(mech, ws, q)))) if mech.compiled.m else 0.0


class MujocoPeer:
    """The atlas peer (see the atlas/peer interface): ``tol`` is MuJoCo's time step in seconds."""

    scenes = set(SCENES)
    tols = list(TOLS)

    def __init__(self, integrator="RK4", tc_factor=2.0, samples=200):
        if integrator not in INTEGRATORS:
            raise InputError(f"MuJoCo peer: integrator {integrator!r} unknown; choose one of {list(INTEGRATORS)}")
        # 200 monitored samples, as the atlas's cells: energy drift and residual are maxima over them
        self.integrator, self.tc_factor, self.samples = integrator, tc_factor, samples
        # the atlas's method label: "mujoco" for the default RK4, else "mujoco_<integrator>"
        self.name = "mujoco" if integrator == "RK4" else f"mujoco_{integrator}"
        self._mechs = {}

    def mech(self, sidecar_path):
        import pinclear

        key = str(Path(sidecar_path).resolve())
        if key not in self._mechs:
            self._mechs[key] = pinclear.load(sidecar_path)
        return self._mechs[key]

    def run(self, sidecar_path, t_end, tol):
        mech = self.mech(sidecar_path)
        try:
            tol = float(tol)
        except (TypeError, ValueError):
            tol = float("nan")
        if not (np.isfinite(tol) and tol > 0):
            raise InputError(f"MuJoCo peer: tol is the time step in seconds, a positive number; got {tol!r}")
        # the largest step <= tol that divides t_end
        h = t_end / max(int(np.ceil(t_end / tol - 1e-9)), 1)
        try:
            scene = MujocoScene(mech, h, self.integrator, self.tc_factor)
        except InputError as exc:
            return {"status": "failed", "reason": "other", "message": str(exc), "q_final": None,
                    "cpu_s": 0.0, "rhs_evals": 0, "steps": 0}
        model, data = mech.model, mech.model.createData()
        hist = {"E": [], "K": [], "res": []}

        def monitor(t, q, v):
            K = pin.computeKineticEnergy(model, data, q, v)
            hist["K"].append(K)
            hist["E"].append(K + pin.computePotentialEnergy(model, data, q))
            hist["res"].append(closure_residual(mech, q) if np.all(np.isfinite(q)) else np.inf)

        monitor(0.0, scene.q0, scene.v0)
        q, v, n, cpu = scene.run(t_end, samples=self.samples, monitor=monitor)
        rk = n * (4 if self.integrator == "RK4" else 1)
        if scene.unstable() or not (np.all(np.isfinite(q)) and np.all(np.isfinite(v))):
            return {"status": "failed", "reason": "non-finite",
                    "message": f"MuJoCo met a non-finite or huge state (h = {h:.4g} s) and reset itself: "
                               + "; ".join(scene.warnings[:2]),
                    "q_final": None, "cpu_s": cpu, "rhs_evals": rk, "steps": n}
        res = {"status": "success", "reason": "", "message": f"MuJoCo {self.integrator}, h = {h:.4g} s, {n} steps",
               "q_final": q, "v_final": v, "cpu_s": cpu, "steps": n, "rhs_evals": rk,
               "max_residual": float(np.max(hist["res"]))}
        if mech.conservative:
            E = np.array(hist["E"])
            res["energy_drift"] = float(np.max(np.abs(E - E[0])) / max(abs(E[0]), max(hist["K"]), 1e-300))
        return res


def make_peer(integrator="RK4", tc_factor=2.0):
    return MujocoPeer(integrator=integrator, tc_factor=tc_factor)
