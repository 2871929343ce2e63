"""Closed-loop kinematics: frame kinematics for all closure frames at once, constraint rows,
assembly on the configuration manifold, consistent velocities, mobility and redundancy.
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin

from pinclear.core.errors import AssemblyError
from pinclear.model.frames import J_PRISMATIC, J_REVOLUTE, frame_kinematics, joint_placements
from pinclear.model.rows import Rows, constraint_rows_all


def supporting_dofs(model: pin.Model, fid: int) -> np.ndarray:
    """Velocity indices of the joints that move frame ``fid`` (the walk up the tree from its
    parent joint to the root; empty for a world-fixed frame). The one tree walk of pinclear."""
    idx = []
    j = model.frames[int(fid)].parentJoint
    while j > 0:
        jm = model.joints[j]
        idx.extend(range(jm.idx_v, jm.idx_v + jm.nv))
        j = model.parents[j]
    return np.array(sorted(idx), dtype=np.int64)


class FrameMotion:
    """World placement, LOCAL_WORLD_ALIGNED twist and classical acceleration of some frames
    along a trajectory (arrays indexed [sample, frame, ...])."""

    def __init__(self, n, F):
        self.p = np.empty((n, F, 3))          # origin position, world
        self.R = np.empty((n, F, 3, 3))       # rotation (frame axes in world)
        self.v = np.empty((n, F, 3))          # origin velocity, world axes
        self.w = np.empty((n, F, 3))          # angular velocity, world axes
        self.a = np.empty((n, F, 3))          # classical acceleration of the origin, world axes


def frame_motion(model: pin.Model, frames, q, v=None, a=None) -> FrameMotion:
    """Kinematics of ``frames`` (ids) at every sample of (q, v, a): one forward pass per sample
    for all frames (Pinocchio has no batched API). With v None only positions and rotations are
    filled (velocities and accelerations are zero); with a None the acceleration is the one at
    zero joint acceleration. The one place pinclear computes frame motion along a trajectory."""
    fids = [int(f) for f in frames]
    q = np.atleast_2d(np.asarray(q, float))
    n = len(q)
    out = FrameMotion(n, len(fids))
    data = model.createData()
    if v is None:
        for k in range(n):
            pin.framesForwardKinematics(model, data, q[k])
            for i, f in enumerate(fids):
                M = data.oMf[f]
                out.p[k, i], out.R[k, i] = M.translation, M.rotation
        out.v[:] = out.w[:] = out.a[:] = 0.0
        return out
    v = np.atleast_2d(np.asarray(v, float))
    a = np.zeros_like(v) if a is None else np.atleast_2d(np.asarray(a, float))
    LWA = pin.LOCAL_WORLD_ALIGNED
    for k in range(n):
        pin.forwardKinematics(model, data, q[k], v[k], a[k])
        for i, f in enumerate(fids):
            M = pin.updateFramePlacement(model, data, f)
            out.p[k, i], out.R[k, i] = M.translation, M.rotation
            tw = pin.getFrameVelocity(model, data, f, LWA)
            out.v[k, i], out.w[k, i] = tw.linear, tw.angular
            out.a[k, i] = pin.getFrameClassicalAcceleration(model, data, f, LWA).linear
    return out


_ONE_DOF = {"JointModelRX": (J_REVOLUTE, (1, 0, 0)), "JointModelRY": (J_REVOLUTE, (0, 1, 0)),
            "JointModelRZ": (J_REVOLUTE, (0, 0, 1)), "JointModelPX": (J_PRISMATIC, (1, 0, 0)),
            "JointModelPY": (J_PRISMATIC, (0, 1, 0)), "JointModelPZ": (J_PRISMATIC, (0, 0, 1))}


def joint_chain(model):
    """(parent, placement, kind, axis, q index) arrays of a tree of revolute and prismatic joints
    for the compiled placement kernel; None when the tree has other joints (spherical, free
    flyer, unbounded revolute), which then go through Pinocchio's data.oMi."""
    n = model.njoints
    parent = np.zeros(n, dtype=np.int64)
    jP = np.zeros((n, 4, 4))
    kind = np.zeros(n, dtype=np.int64)
    axis = np.zeros((n, 3))
    iq = np.zeros(n, dtype=np.int64)
    for j in range(1, n):
        jm = model.joints[j]
        name = jm.shortname()
        if name in _ONE_DOF:
            kind[j], ax = _ONE_DOF[name]
            axis[j] = ax
        elif name in ("JointModelRevoluteUnaligned", "JointModelPrismaticUnaligned"):
            kind[j] = J_REVOLUTE if "Revolute" in name else J_PRISMATIC
            axis[j] = np.asarray(jm.extract().axis, float)
        else:
            return None
        parent[j] = model.parents[j]
        jP[j] = model.jointPlacements[j].homogeneous
        iq[j] = jm.idx_q
    return parent, jP, kind, axis, iq


class FrameKinematics:
    """Positions, rotations, Jacobians, velocities and zero-acceleration biases of a fixed set of
    frames, computed from Pinocchio's whole-tree Jacobian ``data.J`` and its time derivative
    ``data.dJ`` (WORLD convention) without a Python loop over bodies.

    For a frame on joint j, its WORLD Jacobian is ``data.J`` masked to the dofs supporting j. The
    velocity of its origin p is v_o + w x p; the classical acceleration at zero ddq is
    a_o + alpha x p + w x v_p with (a_o; alpha) = (masked dJ) v. Linear rows are the origin's
    velocity in world axes (Pinocchio's LOCAL_WORLD_ALIGNED).
    """

    def __init__(self, model: pin.Model, frame_ids):
        self.fids = [int(f) for f in frame_ids]
        F, nv = len(self.fids), model.nv
        self.mask = np.zeros((F, nv))
        # the same dofs as lists (ascending), which the kernels walk: a frame's Jacobian entries
        # outside them are structural zeros, written once here
        self.fcols = np.zeros((F, nv), dtype=np.int64)
        self.nfcols = np.zeros(F, dtype=np.int64)
        for k, fid in enumerate(self.fids):
            dofs = supporting_dofs(model, fid)
            self.mask[k, dofs] = 1.0
            self.fcols[k, :len(dofs)], self.nfcols[k] = dofs, len(dofs)
        # placements come from the distinct parent joints (one Python access each) and the
        # frames' constant offsets: frames sharing a body cost nothing extra
        parents = [model.frames[fid].parentJoint for fid in self.fids]
        self.joints = sorted(set(parents))
        self.jidx = np.array([self.joints.index(j) for j in parents], dtype=np.int64)
        self.jMf = np.array([model.frames[fid].placement.homogeneous for fid in self.fids]).reshape(F, 4, 4)
        self.Hj = np.zeros((len(self.joints), 4, 4))
        self.H = np.zeros((F, 4, 4))
        self.P, self.R = self.H[:, :3, 3], self.H[:, :3, :3]
        self.Jv, self.Jw = np.zeros((F, 3, nv)), np.zeros((F, 3, nv))
        self.V, self.W, self.A, self.Al = (np.zeros((F, 3)) for _ in range(4))

        self.chain = joint_chain(model)
        if self.chain is not None:
            self._O = np.zeros((model.njoints, 4, 4))
            self._want = np.array(self.joints, dtype=np.int64)

    def placement_args(self, q):
        """Arguments of the compiled placement kernel (_kernels.joint_placements) at q, for a
        tree of 1-dof joints (``chain`` not None)."""
        return self.chain + (q, self._O, self._want, self.Hj)

    def load_placements(self, data, q):
        """Placements of the parent joints at q: computed in one compiled call for trees of
        1-dof joints, else copied out of data.oMi (one Python access per joint)."""
        if self.chain is not None and q is not None:
            joint_placements(*self.placement_args(q))
            return
        oMi, Hj = data.oMi, self.Hj
        for k, j in enumerate(self.joints):
            Hj[k] = oMi[j].homogeneous

    def update(self, data, v, q=None):
        """Standalone use: ``data`` must hold joint placements, data.J and data.dJ at (q, v)."""
        self.load_placements(data, q)
        frame_kinematics(self.Hj, self.jidx, self.jMf, self.H, self.fcols, self.nfcols, data.J, data.dJ, v, self.Jv,
                         self.Jw, self.V, self.W, self.A, self.Al)
        return self


def update(mech, ws, q, v, mass=True):
    """One kinematic/dynamic pass at (q, v): the only place the right-hand side calls Pinocchio's
    tree algorithms. Afterwards data.M (upper triangle), data.nle, data.oMi, data.J, data.dJ,
    data.v and data.a (joint accelerations at zero ddq) are valid, and data.oMf when the
    mechanism has force elements (the only readers of frame placements on this path).
    ``mass=False`` skips crba for a caller that already holds M at this q."""
    model, data = mech.model, ws.data
    pin.computeJointJacobiansTimeVariation(model, data, q, v)
    if mech.forces:          # closures read joint placements; only force elements read data.oMf
        pin.updateFramePlacements(model, data)
    if mass:
        pin.crba(model, data, q)
    pin.nonLinearEffects(model, data, q, v)
    ws.fk.load_placements(data, q)


def update_placements(mech, ws, q):
    """The placements of ``ws.fk``'s frames at q, nothing else: one compiled call for trees of
    1-dof joints (no Pinocchio call), else a position-level update."""
    if ws.fk.chain is not None:
        ws.fk.load_placements(ws.data, q)
    else:
        update_positions(mech, ws, q)


def update_positions(mech, ws, q):
    """Position-level update for assembly: placements and Jacobians only."""
    model, data = mech.model, ws.data
    zero = ws.zero_v
    pin.computeJointJacobiansTimeVariation(model, data, q, zero)
    pin.updateFramePlacements(model, data)
    ws.fk.load_placements(data, q)


def constraint_rows(mech, ws, t, q, v, baumgarte=None):
    """Fill ws.phi, ws.J, ws.dphi, ws.bias, ws.gamma (closures then drives) at (t, q, v), after
    :func:`update` (or :func:`update_positions` with v = 0) at the same q.

    gamma is the right-hand side of J a = gamma; with ``baumgarte=(alpha, beta)`` it includes
    -2 alpha dPhi - beta^2 Phi (the papers' stabilisation)."""
    alpha, beta = baumgarte if baumgarte is not None else (0.0, 0.0)
    constraint_rows_all(row_buffers(mech, ws), float(alpha), float(beta), np.ascontiguousarray(q, float),
                        np.ascontiguousarray(v, float), mech.driverows.values(t, ws.drive_data))


def row_buffers(mech, ws) -> Rows:
    """The buffers the compiled constraint kernels read and write (pinclear.model.rows.Rows); all
    are views that stay valid for the workspace's life (data.J etc. view Pinocchio's memory), so
    a formulation builds them once and binds them into its stages."""
    fk, mc, dr = ws.fk, mech.compiled, mech.driverows
    if ws.support is None:
        ws.support = row_support(mech, fk.mask, ws.parent)
    cols, ncols = ws.support
    # ws.J6: Pinocchio hands back (6,) for a 1-dof tree, the workspace views it as (6, nv)
    return Rows(fk.Hj, fk.jidx, fk.jMf, fk.H, fk.fcols, fk.nfcols, ws.J6, ws.dJ6, mc.table, mc.E, mc.L, dr.iq, dr.iv,
                fk.Jv, fk.Jw, fk.V, fk.W, fk.A, fk.Al, ws.phi, ws.J, ws.bias, ws.dphi, ws.gamma, cols, ncols)


def row_support(mech, mask, parent):
    """(cols, ncols): each constraint row's support, the dofs that can move it, ascending in
    cols[r, :ncols[r]]: a closure primitive's rows are moved by the dofs under either of its two
    frames (mask), a drive row by its own dof; each set is closed under ``parent`` (the tree's
    parent dof), so L^-T of M = L^T L fills nothing outside it (pinclear.core.tree_solve.scaled_rows).
    Outside it J and J L^-1 are exact zeros: the kernels skip them, which changes no bit of a
    sum (RBDA sec. 6.5: the branch-induced sparsity of M carried to the rows)."""
    nv = mask.shape[1]
    mc, dr = mech.compiled, mech.driverows
    m = mc.m + len(dr.iv)
    on = np.zeros((m, nv), dtype=bool)
    # the primitives' rows tile 0..mc.m in the order of their first rows
    table = mc.table[np.argsort(mc.table[:, 3], kind="stable")]
    ends = np.append(table[1:, 3], mc.m)
    for (i1, i2, r0), r1 in zip(table[:, 1:4].tolist(), ends.tolist()):
        on[r0:r1] = (mask[i1] != 0.0) | (mask[i2] != 0.0)
    on[np.arange(mc.m, m), dr.iv] = True
    # anc[k, j]: dof j is k or an ancestor of k (parent[k] < k: one pass, roots first)
    anc = np.eye(nv, dtype=bool)
    for k in range(nv):
        if parent[k] >= 0:
            anc[k] |= anc[parent[k]]
    on = (on.astype(np.int64) @ anc.astype(np.int64)) > 0
    ncols = on.sum(axis=1).astype(np.int64)
    # each row's columns ascending, first: a stable sort puts the True entries before the False
    cols = np.argsort(~on, axis=1, kind="stable").astype(np.int64)
    cols[np.arange(nv)[None, :] >= ncols[:, None]] = 0
    return cols, ncols


def closure_residual(mech, ws, q, t=0.0, with_drives=False):
    """Residual vector Phi(q, t) of the closures (and drives)."""
    update_positions(mech, ws, q)
    constraint_rows(mech, ws, t, q, ws.zero_v)
    return (ws.phi if with_drives else ws.phi[: mech.compiled.m]).copy()


def jacobian(mech, ws, q, t=0.0, with_drives=False):
    update_positions(mech, ws, q)
    constraint_rows(mech, ws, t, q, ws.zero_v)
    return (ws.J if with_drives else ws.J[: mech.compiled.m]).copy()


def rank_analysis(J, names, tol=None):
    """Rank of J and the names of rows that depend on earlier ones (QR with column pivoting on J^T)."""
    from scipy.linalg import qr

    m = J.shape[0]
    if m == 0:
        return 0, [], []
    _, Rr, piv = qr(J.T, mode="economic", pivoting=True)
    d = np.abs(np.diag(Rr))
    if tol is None:
        tol = max(J.shape) * np.finfo(float).eps * max(d[0], 1.0) * 1e3
    rank = int(np.sum(d > tol))
    independent = sorted(piv[:rank].tolist())
    redundant = sorted(piv[rank:].tolist())
    return rank, independent, [names[i] for i in redundant]


def mobility(mech, q, ws=None):
    """Degrees of freedom of the closed chain (closures only, drives excluded) at q.

    Returns dict(mobility, rank, rows, redundant_rows (names), condition)."""
    ws = ws or mech.workspace()
    J = jacobian(mech, ws, q)
    rank, indep, redundant = rank_analysis(J, mech.compiled.row_names)
    sv = np.linalg.svd(J, compute_uv=False) if J.size else np.array([1.0])
    cond = float(sv[0] / sv[rank - 1]) if rank else 1.0
    return {"mobility": mech.model.nv - rank, "rank": rank, "rows": J.shape[0],
            "redundant_rows": redundant, "independent": indep, "condition": cond}


def assemble(mech, q_guess=None, t=0.0, tol=1e-12, max_iter=100, with_drives=True, ws=None):
    """Solve Phi(q, t) = 0 from a guess, moving on the configuration manifold (pin.integrate).

    Gauss-Newton with minimum-norm steps (lstsq), so redundant rows and extra freedoms are
    handled; raises AssemblyError with the final residual when the loop cannot close."""
    ws = ws or mech.workspace()
    q = np.array(mech.q0 if q_guess is None else q_guess, float)
    model = mech.model
    last = np.inf
    for it in range(max_iter):
        update_positions(mech, ws, q)
        constraint_rows(mech, ws, t, q, ws.zero_v)
        m = mech.compiled.m + (len(mech.drives) if with_drives else 0)
        phi, J = ws.phi[:m], ws.J[:m]
        res = float(np.linalg.norm(phi, np.inf)) if m else 0.0
        if res < tol:
            return q
        dq = np.linalg.lstsq(J, -phi, rcond=1e-10)[0]
        # damp steps that would go far: Newton from a poor guess overshoots around loops
        step = np.linalg.norm(dq, np.inf)
        if step > 0.5:
            dq *= 0.5 / step
        q = pin.integrate(model, q, dq)
        if it > 20 and res > 0.99 * last and res > 1e-6:
            break
        last = min(last, res)
    update_positions(mech, ws, q)
    constraint_rows(mech, ws, t, q, ws.zero_v)
    m = mech.compiled.m + (len(mech.drives) if with_drives else 0)
    res = float(np.linalg.norm(ws.phi[:m], np.inf)) if m else 0.0
    if res < max(tol, 1e-10):
        return q
    worst = int(np.argmax(np.abs(ws.phi[:m])))
    names = mech.row_names(with_drives)
    raise AssemblyError(
        f"{mech.path or mech.name}: loop closures cannot be assembled from the given guess: residual "
        f"{res:.3e} after {max_iter} iterations (worst row {names[worst]!r}); check the geometry "
        "or give a better initial guess under 'initial: q:'", residual=res, q=q)


def consistent_velocity(mech, q, v_guess=None, t=0.0, ws=None):
    """Velocity closest to the guess (in the mass metric) that satisfies J v = -Phi_t."""
    ws = ws or mech.workspace()
    v0 = np.zeros(mech.model.nv) if v_guess is None else np.asarray(v_guess, float)
    update_positions(mech, ws, q)
    constraint_rows(mech, ws, t, q, ws.zero_v)
    m = mech.compiled.m + len(mech.drives)
    if m == 0:
        return v0.copy()
    J = ws.J[:m].copy()
    target = -ws.dphi[:m]        # at v = 0 dphi = Phi_t (only drives depend on t)
    M = pin.crba(mech.model, ws.data, q)
    M = np.triu(M) + np.triu(M, 1).T
    # min (v - v0)^T M (v - v0)  s.t. J v = target
    K = np.block([[M, J.T], [J, np.zeros((m, m))]])
    rhs = np.concatenate([M @ v0, target])
    sol = np.linalg.lstsq(K, rhs, rcond=1e-12)[0]
    return sol[: mech.model.nv]


#: the start states of a run (simulate(..., start=...), pinclear simulate --start)
STARTS = ("ideal", "rest", "least-energy", "state")


def ideal_mechanism(mech):
    """``mech`` with its clearance joints ideal again: the closures the loader replaced by
    clearance elements restored, the clearance elements removed (other forces kept). The
    mechanism itself when it has no clearance."""
    if not mech.replaced_closures:
        return mech
    return mech.replace(closures=list(mech.closures) + list(mech.replaced_closures.values()),
                        forces=[f for f in mech.forces if not f.is_clearance], replaced_closures={})


def start_state(mech, start="ideal", q_guess=None, v_guess=None, t=0.0, ws=None):
    """(q, v) a run starts from at time t, by the named ``start`` (one of STARTS):

    - ideal: the ideal mechanism's assembled state and velocity (:func:`ideal_mechanism`; the
      velocity nearest ``v_guess`` in the mass metric on its constraints): every clearance
      journal, ball or slider centred with zero relative velocity: where the papers' clearance
      studies start, from the ideal joint's motion (docs/papers.md; paper 002's runs start at the
      ideal mechanism's initial positions). Without clearances: the mechanism's own assembled,
      consistent state.
    - rest: the ideal assembly with every joint at rest (v = 0); refused when a drive moves at t.
    - least-energy: the ideal assembly with the velocity of least kinetic energy (nearest
      ``v_guess``) on the clearance mechanism's own constraints, which leaves the clearance's
      relative velocity free: a start-up impact that is not in the papers.
    - state: q_guess and v_guess as given (simulate requires both), assembled onto the clearance
      mechanism's own constraints only (an off-centre journal stays off centre).

    The assembly of a freed joint is solved with the rest of the mechanism (all starts but
    'state'), so a sidecar written at a home pose needs no pasted q."""
    from pinclear.core.errors import InputError

    if start not in STARTS:
        raise InputError(f"unknown start {start!r}", key="start", choices=STARTS)
    if start == "state":
        q = assemble(mech, q_guess, t=t, ws=ws)
        return q, consistent_velocity(mech, q, v_guess, t=t, ws=ws)
    ideal = ideal_mechanism(mech)
    ws_ideal = ws if ideal is mech else None
    q = assemble(ideal, q_guess, t=t, ws=ws_ideal)
    if start == "ideal":
        return q, consistent_velocity(ideal, q, v_guess, t=t, ws=ws_ideal)
    if start == "least-energy":
        return q, consistent_velocity(mech, q, v_guess, t=t, ws=ws)
    # rest: v = 0 satisfies J v = -Phi_t only if no row moves with time (the drives at rest)
    ws = ws or mech.workspace()
    update_positions(mech, ws, q)
    constraint_rows(mech, ws, t, q, ws.zero_v)
    rate = ws.dphi[:mech.m]
    if mech.m and np.max(np.abs(rate)) > 1e-12:
        k = int(np.argmax(np.abs(rate)))
        raise InputError(f"'rest' needs every drive at rest at t = {t:g} s, but {mech.row_names()[k]!r} moves (rate "
                         f"{-rate[k]:.3g} rad/s or m/s); use 'ideal' (the default)", key="start", choices=STARTS)
    return q, np.zeros(mech.nv)
