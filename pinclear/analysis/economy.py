"""Model economy: what a scene could drop without changing its answer.

Three questions, each answered from the mechanism itself, at the assembled configuration and
optionally along a run:

* which closure rows are redundant (named: closure, type, axis), see :func:`redundant_rows`;
* whether every body moves parallel to one plane, and how many closure rows and tree freedoms a
  planar model would need instead (:func:`planarity`);
* which bodies' inertia changes the drive forces by less than a threshold along the motion
  (:func:`inertia_influence`).

Plain functions on a :class:`~pinclear.model.mechanism.Mechanism` and a
:class:`~pinclear.dynamics.trajectory.Trajectory`; ``pinclear info FILE --along T_END`` prints
:func:`economy_report`.
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin

from pinclear.core.errors import InputError
from pinclear.model import kinematics
from pinclear.model.closures import CLOSURE_TYPES

#: fraction of the motion (twists, rotations weighted by the mechanism's size) allowed out of the
#: best plane before the mechanism counts as spatial; round-off of a planar tree is ~1e-15
PLANAR_TOL = 1e-6

_AXIS_WORDS = {
    "point": {"x": "translation along world x", "y": "translation along world y",
              "z": "translation along world z"},
    "plane": {"u": "in-plane translation along the plane's first axis",
              "v": "in-plane translation along the plane's second axis"},
    "dot": {"rz": "rotation about frame1's z axis", "rx": "rotation about frame1's x axis",
            "ry": "rotation about frame1's y axis", "rn": "angle between the axes z1 and z2 (kept at 90 deg)"},
    "perp": {"x": "translation along frame1's x axis", "y": "translation along frame1's y axis"},
    "distance": {"d": "distance |p1 - p2|"},
    "couple": {"c": "q(joint2) - ratio q(joint1) - offset (a gear or mimic coupling)"},
}


def _row_table(mech):
    """(closure, primitive, label) of every closure row, in row order."""
    out = []
    for c in mech.closures:
        for prim, _args, labels in CLOSURE_TYPES[c.type]:
            out.extend((c, prim, lab) for lab in labels)
    return out


def redundant_rows_along(mech, traj, samples=11, ws=None) -> list[dict]:
    """Redundant closure rows at ``samples`` evenly spaced samples of a run; one entry (t, count,
    rows) per change of their number, so a singular configuration crossed shows up (which rows
    of a dependent set are named may change with the pivoting; their number may not)."""
    out = []
    idx = np.unique(np.linspace(0, len(traj.t) - 1, min(samples, len(traj.t))).astype(int))
    for k in idx:
        if not np.all(np.isfinite(traj.q[k])):
            continue
        rows = [r["row"] for r in redundant_rows(mech, traj.q[k], ws)]
        if not out or len(rows) != out[-1]["count"]:
            out.append({"t": float(traj.t[k]), "count": len(rows), "rows": rows})
    return out


def describe_row(mech, row: int) -> str:
    """Human-readable name of closure row ``row``: mechanism, closure, type and axis."""
    c, prim, lab = _row_table(mech)[row]
    return f"{mech.name} closure {c.name!r} ({c.type}) {_AXIS_WORDS[prim][lab]}"


def redundant_rows(mech, q=None, ws=None, project=True) -> list[dict]:
    """Closure rows that depend on the others at q (default: the assembled configuration), by
    QR with column pivoting (:func:`pinclear.model.kinematics.mobility`). Which row of a dependent set
    is called redundant is the pivoting's choice; their number is not.

    A dependency among rows holds on the constraint manifold: a configuration off it by a
    residual r (an integrator's drift, ~1e-12) lifts the vanishing singular value to ~r, above
    any round-off threshold. So q is first put back on the closures (``project``), as a minimal
    Gauss-Newton correction (:func:`pinclear.model.kinematics.assemble`, drives left free)."""
    if q is None:
        q = kinematics.assemble(mech, ws=ws)
    elif project:
        q = kinematics.assemble(mech, np.asarray(q, float), tol=1e-14, with_drives=False, ws=ws)
    mob = kinematics.mobility(mech, q, ws)
    names = mech.compiled.row_names
    table = _row_table(mech)
    out = []
    for name in mob["redundant_rows"]:
        r = names.index(name)
        c, prim, lab = table[r]
        out.append({"row": name, "closure": c.name, "type": c.type, "axis": _AXIS_WORDS[prim][lab],
                    "name": describe_row(mech, r)})
    return out


# --------------------------------------------------------------------------- planarity
def _jacobian_world(model, data, j):
    """Joint j's WORLD Jacobian (6, nv): linear rows the velocity of the point at the world
    origin (Pinocchio hands back (6,) for a one-dof tree)."""
    return np.asarray(pin.getJointJacobian(model, data, j, pin.WORLD)).reshape(6, model.nv)


def _joint_twists_world(model, data, j):
    """World twists (v at the world origin; w) of joint j's motion subspace: (6, nv_j)."""
    jm = model.joints[j]
    return _jacobian_world(model, data, j)[:, jm.idx_v: jm.idx_v + jm.nv]


def _size(model, data, mech):
    """Centre and size of the mechanism (joint origins and closure frames): rotations are
    weighted by the size so that twists of metre-sized and millimetre-sized models compare."""
    pts = [data.oMi[j].translation for j in range(1, model.njoints)]
    pts += [data.oMf[int(f)].translation for f in mech.compiled.frames]
    pts = np.array(pts) if pts else np.zeros((1, 3))
    c = pts.mean(axis=0)
    L = float(np.max(np.linalg.norm(pts - c, axis=1))) if len(pts) > 1 else 1.0
    return c, (L if L > 0 else 1.0)


class _PlaneFit:
    """Accumulates body twists and finds the plane normal n minimising the out-of-plane part:
    sum (v_c . n)^2 + L^2 |w x n|^2 (v_c: velocity of the body point at the centre c). A motion
    is plane-parallel with normal n iff every w is parallel to n and every v_c normal to it."""

    def __init__(self, c, L):
        self.c, self.L = c, L
        self.A = np.zeros((3, 3))
        self.S = 0.0

    def add(self, V):
        """V: (6, k) world twists (linear at the world origin, angular)."""
        v, w = V[:3], V[3:]
        vc = v + np.cross(w.T, self.c).T            # velocity of the point at c
        wx, wy, wz = self.L * w
        zero = np.zeros_like(wx)
        # |w x n|^2 = |[w]x n|^2: stacking the cross-product matrices keeps an in-plane column
        # exactly zero for w parallel to the normal (|w|^2 I - w w^T would leave round-off there)
        X = np.concatenate([np.stack([zero, -wz, wy], 1), np.stack([wz, zero, -wx], 1),
                            np.stack([-wy, wx, zero], 1)])
        self.A += vc @ vc.T + X.T @ X
        self.S += float(np.sum(vc * vc) + np.sum(wx * wx + wy * wy + wz * wz))

    def result(self):
        if self.S == 0.0:
            return None, 0.0
        n = np.linalg.eigh(self.A)[1][:, 0]
        n = n * np.sign(n[np.argmax(np.abs(n))])   # one sign for one plane
        # the Rayleigh quotient is second-order accurate in n: a planar tree gives ~1e-16, where
        # the smallest eigenvalue itself carries round-off of order eps * |A| (sqrt: ~1e-8)
        return n, float(np.sqrt(max(float(n @ self.A @ n), 0.0) / self.S))


def _free_relative_twists(mech, c, data):
    """Relative motions closure c leaves free at the assembled configuration, as twists at the
    point of frame 2 (world axes), (6, k): rotations as (0; axis), translations as (dir; 0)."""
    M1, M2 = data.oMf[c.f1], data.oMf[c.f2]
    R1 = M1.rotation
    E = np.eye(3)

    def rot(a):
        return np.concatenate([np.zeros(3), a])

    def tr(d):
        return np.concatenate([d, np.zeros(3)])

    z1, z2 = R1[:, 2], M2.rotation[:, 2]
    if c.type == "spherical":
        cols = [rot(e) for e in E]
    elif c.type == "revolute":
        cols = [rot(z1)]
    elif c.type == "universal":
        cols = [rot(z1), rot(z2)]
    elif c.type == "prismatic":
        cols = [tr(z1)]
    elif c.type == "cylindrical":
        cols = [tr(z1), rot(z1)]
    elif c.type == "weld":
        cols = []
    elif c.type == "planar_point":
        n = np.asarray(c.normal, float) / np.linalg.norm(c.normal)
        cols = [tr(n)] + [rot(e) for e in E]
    elif c.type == "distance":
        d = M2.translation - M1.translation
        d = d / np.linalg.norm(d)
        cols = [rot(e) for e in E] + [tr(e) for e in np.linalg.svd(d[None])[2][1:]]
    else:                                          # pragma: no cover - sidecar checks types
        raise InputError(f"closure {c.name!r}: unknown type {c.type!r}", choices=sorted(CLOSURE_TYPES))
    return np.array(cols, float).T.reshape(6, len(cols))


def _planar_twists(n):
    """Basis of the plane-parallel twists with normal n at a point: rotation about n, two
    in-plane translations (6, 3)."""
    t = np.linalg.svd(n[None])[2][1:]
    return np.column_stack([np.concatenate([np.zeros(3), n]), np.concatenate([t[0], np.zeros(3)]),
                            np.concatenate([t[1], np.zeros(3)])])


def _rank(A, tol=1e-9):
    if A.size == 0:
        return 0
    s = np.linalg.svd(A, compute_uv=False)
    return int(np.sum(s > tol * max(1.0, s[0])))


def planar_model(mech, q, n, ws=None) -> dict:
    """Size of the planar model of ``mech`` in the plane normal to n, at q.

    Tree: joint j keeps the part of its motion subspace that is plane-parallel (a revolute about
    n: 1; about an in-plane axis: 0; a spherical: 1; a free flyer: 3). Closure c: a planar
    relative motion has 3 components (two translations, the rotation about n); the closure
    blocks 3 - dim(free(c) ∩ planar) of them (a revolute about n: 2 rows instead of 5, a
    spherical 2 instead of 3, a weld 3 instead of 6)."""
    model = mech.model
    data = model.createData()
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    t = np.linalg.svd(n[None])[2][1:]
    # non-planar components of a world twist: w . t1, w . t2, v_O . n (point independent)
    P = np.zeros((3, 6))
    P[0, 3:], P[1, 3:], P[2, :3] = t[0], t[1], n
    joints, blocks = [], []
    for j in range(1, model.njoints):
        S = _joint_twists_world(model, data, j)
        B = P @ S
        r = _rank(B)
        null = np.linalg.svd(B)[2][r:].T if B.size else np.zeros((S.shape[1], 0))
        blocks.append((model.joints[j].idx_v, null))
        joints.append({"joint": model.names[j], "nv": int(S.shape[1]), "planar_nv": int(null.shape[1])})
    nv_p = sum(b[1].shape[1] for b in blocks)
    Np = np.zeros((model.nv, nv_p))
    col = 0
    for i0, null in blocks:
        Np[i0:i0 + null.shape[0], col:col + null.shape[1]] = null
        col += null.shape[1]
    Pl = _planar_twists(n)
    closures = []
    for c in mech.closures:
        F = _free_relative_twists(mech, c, data)
        common = F.shape[1] + 3 - _rank(np.hstack([F, Pl]))
        closures.append({"closure": c.name, "type": c.type, "rows": c.nrows, "planar_rows": 3 - common})
    # rank of the closure rows on planar motions: the planar model's independent rows
    J = kinematics.jacobian(mech, ws or mech.workspace(), q)
    rank_p = _rank(J @ Np) if J.size and nv_p else 0
    rows_p = sum(c["planar_rows"] for c in closures)
    return {"normal": n.tolist(), "nv": model.nv, "planar_nv": nv_p, "rows": mech.compiled.m,
            "planar_rows": rows_p, "planar_redundant_rows": rows_p - rank_p, "planar_mobility": nv_p - rank_p,
            "saved_rows": mech.compiled.m - rows_p, "saved_dofs": model.nv - nv_p,
            "closures": closures, "joints": joints}


def planarity(mech, traj=None, q=None, tol=PLANAR_TOL, ws=None) -> dict:
    """Whether the mechanism moves parallel to one plane, and what a planar model would save.

    Tested on every motion the closures allow at q (default: the assembled configuration; a
    basis of the kernel of the closure Jacobian, drives excluded) and, with ``traj``, on the
    body twists at every sample of the run. ``deviation`` is the out-of-plane fraction of the
    twists (rotations weighted by the mechanism's size, see :class:`_PlaneFit`)."""
    model = mech.model
    ws = ws or mech.workspace()
    q = kinematics.assemble(mech, ws=ws) if q is None else np.asarray(q, float)
    data = model.createData()
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    c, L = _size(model, data, mech)
    Jc = kinematics.jacobian(mech, ws, q)
    if Jc.size:
        _, s, Vt = np.linalg.svd(Jc)
        rank = int(np.sum(s > max(Jc.shape) * np.finfo(float).eps * max(s[0], 1.0) * 1e3))
        N = Vt[rank:].T
    else:
        N = np.eye(model.nv)
    fit = _PlaneFit(c, L)
    for j in range(1, model.njoints):
        fit.add(_jacobian_world(model, data, j) @ N)
    n0, dev0 = fit.result()
    out = {"assembled": {"planar": bool(n0 is not None and dev0 <= tol), "deviation": dev0,
                         "normal": None if n0 is None else n0.tolist()}}
    n = n0
    planar = out["assembled"]["planar"]
    if traj is not None and len(traj.t):
        fr = _PlaneFit(c, L)
        d2 = model.createData()
        for qk, vk in zip(traj.q, traj.v):
            if not (np.all(np.isfinite(qk)) and np.all(np.isfinite(vk))):
                continue
            pin.forwardKinematics(model, d2, qk, vk)
            V = np.array([d2.oMi[j].act(d2.v[j]).vector for j in range(1, model.njoints)]).T
            fr.add(V)
        nr, devr = fr.result()
        out["along_run"] = {"planar": bool(nr is not None and devr <= tol), "deviation": devr,
                            "normal": None if nr is None else nr.tolist(), "samples": int(len(traj.t))}
        # one plane for both: a run in another plane than the assembly's motions is not planar
        planar = planar and out["along_run"]["planar"] and abs(float(nr @ n0)) > 1 - tol
    out["planar"] = bool(planar)
    out["deviation"] = max(dev0, out.get("along_run", {}).get("deviation", 0.0))
    out["normal"] = None if n is None else [float(x) for x in n]
    if planar and n is not None:
        out["planar_model"] = planar_model(mech, q, n, ws)
    return out


# --------------------------------------------------------------------------- inertia influence
def _body_names(model, j):
    """URDF links carried by joint j (Pinocchio merges links fixed to one another)."""
    names = [f.name for f in model.frames if f.type == pin.FrameType.BODY and f.parentJoint == j]
    return "+".join(names) if names else model.names[j]


def drives_prescribe_motion(mech, q, ws=None) -> bool:
    """True when closures and drives leave no freedom at q (rank of all rows = nv): then the
    motion does not depend on any inertia and the drive forces follow from inverse dynamics."""
    J = kinematics.jacobian(mech, ws or mech.workspace(), q, with_drives=True)
    return bool(J.size) and kinematics.rank_analysis(J, mech.row_names())[0] == mech.nv


def drive_force_change(mech, traj, joint_ids, ws=None):
    """Change of the drive forces along ``traj`` when the inertia (mass, first and second
    moments) of the bodies of ``joint_ids`` is set to zero: (n_samples, n_drives), the full
    model's forces minus the reduced one's.

    Inverse dynamics at the run's (q, v, a): M a + b - tau = J^T lam (closure and drive rows).
    Applied forces tau do not depend on inertia and rnea is linear in it, so the change solves
    J^T dlam = rnea_full - rnea_reduced; the drive part of dlam is unique whenever the drive rows
    are independent of the closure rows (redundant closure rows only move closure multipliers)."""
    model = mech.model
    reduced = model.copy()
    for j in joint_ids:
        reduced.inertias[int(j)] = pin.Inertia.Zero()
    d_full, d_red = model.createData(), reduced.createData()
    ws = ws or mech.workspace()
    mc = mech.m_closures
    out = np.full((len(traj.t), len(mech.drives)), np.nan)
    for k, (t, q, v, a) in enumerate(zip(traj.t, traj.q, traj.v, traj.a)):
        if not np.all(np.isfinite(a)):
            continue
        dtau = pin.rnea(model, d_full, q, v, a) - pin.rnea(reduced, d_red, q, v, a)
        J = kinematics.jacobian(mech, ws, q, t, with_drives=True)
        out[k] = np.linalg.lstsq(J.T, dtau, rcond=None)[0][mc:]
    return out


def inertia_influence(mech, traj, threshold=0.01, ws=None) -> dict:
    """For each moving body, the largest relative change of the drive forces along ``traj`` if
    its inertia were zero; bodies below ``threshold`` are listed as droppable with that error.

    Relative change of a body: max over drives of max_t |dlam_d(t)| / max_t |lam_d(t)| (each drive
    against its own peak over the run, lam from the run's multipliers). Dropping several bodies
    changes the forces by the sum of their changes (rnea is linear in the inertia), reported
    as ``droppable_together``."""
    if not (threshold > 0):
        raise InputError(f"threshold must be positive, got {threshold!r}", key="threshold")
    if not mech.drives:
        return {"applicable": False, "reason": "no drives: there are no drive forces to change", "bodies": [],
                "droppable": []}
    ws = ws or mech.workspace()
    ok = np.all(np.isfinite(traj.a), axis=1)
    if not np.any(ok):
        return {"applicable": False, "reason": "the run has no finite samples", "bodies": [], "droppable": []}
    if not drives_prescribe_motion(mech, traj.q[np.argmax(ok)], ws):
        return {"applicable": False, "bodies": [], "droppable": [],
                "reason": "the drives do not prescribe the motion (free or clearance freedoms): "
                          "zero inertia would change the run itself, not only its drive forces"}
    names = [d.name for d in mech.drives]
    lam = np.column_stack([np.asarray(traj.lam[n], float) for n in names])
    peak = np.nanmax(np.abs(lam[ok]), axis=0)
    model = mech.model
    bodies = []
    changes = {}
    for j in range(1, model.njoints):
        Y = model.inertias[j]
        if Y.mass == 0.0 and not np.any(Y.inertia):
            continue
        d = drive_force_change(mech, traj, [j], ws)
        changes[j] = d
        dmax = np.nanmax(np.abs(d[ok]), axis=0)
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.where(peak > 0, dmax / np.where(peak > 0, peak, 1.0), np.where(dmax > 0, np.inf, 0.0))
        bodies.append({"body": _body_names(model, j), "joint": model.names[j], "mass": float(Y.mass),
                       "max_rel_change": float(np.max(rel)),
                       "per_drive": {n: float(r) for n, r in zip(names, rel)},
                       "max_abs_change": {n: float(x) for n, x in zip(names, dmax)}})
    droppable = [b for b in bodies if b["max_rel_change"] < threshold]
    together = None
    if droppable:
        jids = [model.getJointId(b["joint"]) for b in droppable]
        tot = sum(changes[j] for j in jids)
        dmax = np.nanmax(np.abs(tot[ok]), axis=0)
        together = float(np.max(np.where(peak > 0, dmax / np.where(peak > 0, peak, 1.0), 0.0)))
    return {"applicable": True, "threshold": float(threshold), "drive_peaks": dict(zip(names, peak.tolist())),
            "bodies": sorted(bodies, key=lambda b: b["max_rel_change"]),
            "droppable": [{"body": b["body"], "joint": b["joint"], "error": b["max_rel_change"]} for b in droppable],
            "droppable_together": together}


def economy_report(mech, t_end=None, threshold=0.01, method="lagrange", integrator="RK45", rtol=1e-8,
                   **sim_kw) -> dict:
    """Redundant rows and planarity at the assembled configuration; with ``t_end``, a run from
    it (``pinclear.simulate``) on which planarity and the bodies' inertia influence are tested."""
    if not (threshold > 0):
        raise InputError(f"threshold must be positive, got {threshold!r}", key="threshold")
    if t_end is not None and not (t_end > 0):
        raise InputError(f"the run's end time must be positive, got {t_end!r}", key="along")
    ws = mech.workspace()
    q = kinematics.assemble(mech, ws=ws)
    rep = {"redundant_rows": redundant_rows(mech, q, ws)}
    traj = None
    if t_end is not None:
        from pinclear.dynamics.simulate import simulate

        traj = simulate(mech, t_end, method=method, integrator=integrator, rtol=rtol, **sim_kw)
        rep["run"] = {"t_end": float(t_end), "status": traj.status, "message": traj.message,
                      "samples": int(len(traj.t)), "method": method, "integrator": integrator, "rtol": rtol}
        rep["redundant_rows_along_run"] = redundant_rows_along(mech, traj, ws=ws)
    rep["planarity"] = planarity(mech, traj, q, ws=ws)
    if traj is not None:
        rep["inertia_influence"] = inertia_influence(mech, traj, threshold, ws)
    return rep
