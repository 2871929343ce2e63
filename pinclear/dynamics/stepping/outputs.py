"""The outputs of a run's samples (docs/outputs.md): at every output sample the accelerations,
every row's multiplier and residual, the energies of the audit (pinclear.dynamics.energy) and each force
element's record (ForceElement.record: potential, power loss, outputs).

One compiled pass over the samples (:func:`record_samples`) does it where the run's evaluation
is compiled and every force element declares a compiled record (ForceElement contract 11): per
sample, the projection onto the constraint manifold (formulations that project), one
evaluation (its accelerations and multipliers), then the *record stages* (:func:`record_stages`:
the placements and joint Jacobian at the sample's own state where the evaluation moved it, the
rows, the energies, each element's record kernel) writing one row of a table. Python touches the table
as a whole (:func:`outputs_of`). Samples whose evaluation failed (a rank loss, an exception in a
Python stage) are finished by :func:`finish_sample` with NaN accelerations and multipliers, as
the per-sample Python path (:func:`sample_record`, the reference kept for tests and for runs the
compiled pass does not serve) leaves them.

A sample's row: [a (nv) | lam (m) | phi (m) | closure power | kinetic | potential | each
element's potential, power loss and outputs (ForceElement.record_layout)].
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
import pinocchio as pin

from pinclear.core.call import ERROR, NONFINITE, run_stages
from pinclear.core.errors import RankLossError
from pinclear.core.failures import Failure, FailureKind
from pinclear.core.jit import njit
from pinclear.core.stage import bind
from pinclear.dynamics.stepping.system import evaluate, project
from pinclear.model import kinematics
from pinclear.model.frames import joint_placements, joint_placements_jacobians
from pinclear.model.rows import constraint_rows_positions

#: the code a sample gets when its projection failed (the run raises the Python path's error)
PROJECTION_FAILED = -10.0


class Samples(NamedTuple):
    """A run's output samples as arrays (views of its sample rows): times (n,), q (n, nq),
    v (n, nv), z (n, nz)."""
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    z: np.ndarray


class Outputs(NamedTuple):
    """A run's outputs at its n samples, as whole arrays: ``core`` (n, nv + 2 m + 3) in the row
    layout of the module doc; ``elements``: per force element (potential (n,), power loss (n,),
    {output name: (n,) or (n, size)}); ``failures``: a pinclear.core.failures.Failure per sample whose
    evaluation failed (its accelerations and multipliers NaN, the rest recorded)."""
    core: np.ndarray
    elements: list
    failures: tuple = ()


#: what a sample's evaluation raises when it fails at that state (the formulations' rank loss,
#: a singular or indefinite matrix, a non-finite value): the sample keeps NaN accelerations and
#: multipliers and its Failure names why; anything else (a user function's exception, a bug)
#: ends the outputs, and the run keeps its samples (pinclear.dynamics.stepping.run.Run.integrate)
SAMPLE_FAILURES = (RankLossError, np.linalg.LinAlgError, ArithmeticError)


def sample_failure(exc, t) -> Failure:
    """The Failure of a sample whose evaluation raised ``exc`` (one of SAMPLE_FAILURES)."""
    kind = (FailureKind.RANK_LOSS if isinstance(exc, RankLossError) else
            FailureKind.SINGULAR if isinstance(exc, np.linalg.LinAlgError) else FailureKind.NONFINITE)
    return Failure(kind, t, f"output sample at t = {t:.9g} s: {exc}")


def core_size(mech):
    return mech.nv + 2 * mech.m + 3


# ------------------------------------------------------------------ the Python path (reference)
def sample_record(form, t, q, v, z):
    """One sample's (core row, [(potential, power loss, outputs) per element]) through the
    plug-ins' Python methods: the reference of the compiled pass (the path of every run before
    it), and the path of runs it does not serve (:func:`compiled_ready`); the sample's Failure
    (None when its evaluation succeeded) third."""
    try:
        a = form.accelerations(t, q, v, z)
    except SAMPLE_FAILURES as exc:
        return (*finish_sample(form, t, q, v, z, None, None), sample_failure(exc, t))
    return (*finish_sample(form, t, q, v, z, a, form.ws.lam), None)


def finish_sample(form, t, q, v, z, a, lam):
    """The rest of a sample after ``form.accelerations`` gave a and lam at it (None: it failed,
    they are NaN): the kinematics pass at (q, v) where the evaluation left another, the rows,
    the energies and the elements' records."""
    mech, ws = form.mech, form.ws
    nv, m, mc = mech.nv, mech.m, mech.compiled.m
    fresh = a is not None
    row = np.full(core_size(mech), np.nan)
    if fresh:
        row[:nv], row[nv:nv + m] = a, lam
    if not (fresh and form.fills_workspace):
        kinematics.update(mech, ws, q, v)
    # accelerations() ran the kinematics pass at (q, v); the rows only when it says so
    if not (fresh and form.fills_rows):
        kinematics.constraint_rows(mech, ws, t, q, v)
    row[nv + m:nv + 2 * m] = ws.phi
    row[nv + 2 * m] = float(row[nv:nv + mc] @ ws.dphi[:mc]) if mc else 0.0
    # from the joint velocities and placements the kinematics pass left in data
    row[nv + 2 * m + 1] = pin.computeKineticEnergy(mech.model, ws.data)
    row[nv + 2 * m + 2] = pin.computePotentialEnergy(mech.model, ws.data)
    recs = [f.record(mech, ws, d, t, q, v, z[sl], fresh) for f, d, sl in zip(mech.forces, ws.force_data, mech.z_slices)]
    return row, recs


def python_outputs(form, s: Samples) -> Outputs:
    """The outputs of the samples ``s`` sample by sample in Python (the reference)."""
    mech = form.mech
    core = np.zeros((len(s.t), core_size(mech)))
    per = [([], [], {}) for _ in mech.forces]
    failures = []
    for i, (t, q, v, z) in enumerate(zip(s.t.tolist(), s.q, s.v, s.z)):
        core[i], recs, failed = sample_record(form, t, q, v, z)
        if failed is not None:
            failures.append(failed)
        for (pot, loss, outs), (P, L, O) in zip(recs, per):
            P.append(pot)
            L.append(loss)
            for k, val in outs.items():
                O.setdefault(k, []).append(np.asarray(val, float))
    return Outputs(core, [(np.array(P, float), np.array(L, float), {k: np.array(v) for k, v in O.items()})
                          for P, L, O in per], tuple(failures))


# ------------------------------------------------------------------ the compiled pass
@njit(cache=True)
def copy_core(a, lam, rec):
    """rec = [a | lam | ...]: what the sample's evaluation solved for."""
    nv = a.shape[0]
    for i in range(nv):
        rec[i] = a[i]
    for i in range(lam.shape[0]):
        rec[nv + i] = lam[i]


@njit(cache=True)
def sample_rows(R, q, v, fdrv):
    """Every row's Phi and J at the sample and J v + Phi_t (closure rows: J v; no
    accelerations: the joint Jacobian's time derivative is not needed)."""
    constraint_rows_positions(R, q, v, fdrv)
    Jc, dphi = R.Jc, R.dphi
    for r in range(dphi.shape[0] - R.iq.shape[0]):
        acc = 0.0
        for c in range(v.shape[0]):
            acc += Jc[r, c] * v[c]
        dphi[r] = acc


@njit(cache=True)
def sample_energies(parent, jP, kind, axis, iq, q, O, want, Hj, mass, lever, Ic, g, J, v, tw, lam, dphi, mc, phi,
                    rec, off):
    """rec[off - m:off] = the rows' residuals; rec[off:off + 3] = the closure rows' power
    lam_c . dPhi_c/dt, the kinetic energy and the gravity energy, body by body from the joint
    placements at q (``O``) and the WORLD joint Jacobian ``J``: body j's twist (v_o; w) =
    its parent's + J[:, iq[j]] v[iq[j]], its centre of mass c = O_j lever_j, T_j = (m |v_o + w x
    c|^2 + w_b . I_c w_b) / 2 with w_b = R_j^T w, V_j = -m g . c: the sums Pinocchio's
    computeKineticEnergy and computePotentialEnergy make (equal to rounding)."""
    m = phi.shape[0]
    for r in range(m):
        rec[off - m + r] = phi[r]
    p = 0.0
    for r in range(mc):
        p += lam[r] * dphi[r]
    rec[off] = p
    joint_placements(parent, jP, kind, axis, iq, q, O, want, Hj)
    kin = pot = 0.0
    tw[0, :] = 0.0
    for j in range(1, O.shape[0]):
        pj, c = parent[j], iq[j]
        for r in range(6):
            tw[j, r] = tw[pj, r] + J[r, c] * v[c]
        cx = O[j, 0, 3] + O[j, 0, 0] * lever[j, 0] + O[j, 0, 1] * lever[j, 1] + O[j, 0, 2] * lever[j, 2]
        cy = O[j, 1, 3] + O[j, 1, 0] * lever[j, 0] + O[j, 1, 1] * lever[j, 1] + O[j, 1, 2] * lever[j, 2]
        cz = O[j, 2, 3] + O[j, 2, 0] * lever[j, 0] + O[j, 2, 1] * lever[j, 1] + O[j, 2, 2] * lever[j, 2]
        pot -= mass[j] * (g[0] * cx + g[1] * cy + g[2] * cz)
        wx, wy, wz = tw[j, 3], tw[j, 4], tw[j, 5]
        vx = tw[j, 0] + wy * cz - wz * cy
        vy = tw[j, 1] + wz * cx - wx * cz
        vz = tw[j, 2] + wx * cy - wy * cx
        rot = 0.0
        for a in range(3):
            ba = O[j, 0, a] * wx + O[j, 1, a] * wy + O[j, 2, a] * wz
            acc = 0.0
            for b in range(3):
                acc += Ic[j, a, b] * (O[j, 0, b] * wx + O[j, 1, b] * wy + O[j, 2, b] * wz)
            rot += ba * acc
        kin += 0.5 * (mass[j] * (vx * vx + vy * vy + vz * vz) + rot)
    rec[off + 1] = kin
    rec[off + 2] = pot


def body_inertias(mech):
    """(mass (nj,), centre of mass in the joint frame (nj, 3), rotational inertia about it (nj, 3,
    3), gravity (3,)) of the model's bodies, for sample_energies."""
    model = mech.model
    return (np.array([I.mass for I in model.inertias]), np.array([I.lever for I in model.inertias]).reshape(-1, 3),
            np.array([I.inertia for I in model.inertias]).reshape(-1, 3, 3), np.array(model.gravity.linear, float))


def compiled_ready(run) -> str:
    """Why the compiled pass cannot make this run's outputs ("" when it can)."""
    mech, ws = run.mech, run.form.ws
    if run.built.why:
        return f"the evaluation runs in Python ({run.built.why})"
    if ws.fk.chain is None:
        return "the tree has joints other than 1-dof ones (the energies read the compiled joint chain)"
    for f in mech.forces:
        if f.record_layout() is None:
            return f"force element {f.name!r} has no compiled record"
    return ""


def record_stages(form):
    """(stages, the row buffer, [(element offset, layout)]) of the compiled pass (module doc)."""
    mech, ws = form.mech, form.ws
    nv, m = mech.nv, mech.m
    width = core_size(mech)
    layouts = []
    for f in mech.forces:
        lay = f.record_layout()
        layouts.append((width, lay))
        width += 2 + sum(size for _, size in lay)
    rec = np.zeros(width)
    stages = [bind(copy_core, (ws.a, ws.lam, rec), name="outputs: accelerations and multipliers")]
    if not form.fills_workspace:
        # the evaluation moved the state (the manifold's projection): the placements and the joint
        # Jacobian at the sample's own (what the rows, the energies and the elements read)
        stages.append(bind(joint_placements_jacobians, ws.fk.placement_args(ws.q) + (ws.J6,),
                           name="outputs: placements and joint Jacobian"))
    if not (form.fills_workspace and form.fills_rows):
        stages.append(bind(sample_rows, (kinematics.row_buffers(mech, ws), ws.q, ws.v, ws.drive_data.f),
                           name="outputs: rows"))
    stages.append(bind(sample_energies, ws.fk.placement_args(ws.q) + body_inertias(mech) + (
        ws.J6, ws.v, np.zeros((mech.model.njoints, 6)), ws.lam, ws.dphi, mech.compiled.m, ws.phi, rec, nv + 2 * m),
        name="outputs: energies"))
    for f, d, z, zdot, (off, lay) in zip(mech.forces, ws.force_data, ws.z_views, ws.zdot_views, layouts):
        kernel, args = f.record_kernel(mech, ws, d, z, zdot, rec[off:off + 2 + sum(s for _, s in lay)])
        stages.append(bind(kernel, args, name=f"outputs: {f.name}"))
    return stages, rec, layouts


@njit(cache=True)
def record_samples(sys, stages, rec, t_eval, X, out, codes, dx):
    """Each sample row X[k] at t_eval[k]: projected (where the run projects), evaluated, and its
    record stages' row copied into out[k]; codes[k] the evaluation's code. Returns the number of
    samples done (fewer when a projection failed: codes[k] = PROJECTION_FAILED)."""
    for k in range(X.shape[0]):
        x, t = X[k], t_eval[k]
        if sys.project.shape[0] and not project(sys, t, x) >= 0.0:
            codes[k] = PROJECTION_FAILED
            return k
        codes[k] = evaluate(sys, t, x, dx)
        for i in range(x.shape[0]):
            sys.x[i] = x[i]
        run_stages(stages, t)
        for j in range(rec.shape[0]):
            out[k, j] = rec[j]
    return X.shape[0]


def compiled_outputs(run, X, s: Samples) -> Outputs:
    """The outputs of the sample rows X (projected in place where the run projects) in one
    compiled pass; ``s``: the samples, views of the rows."""
    form = run.form
    mech = form.mech
    if run.record is None:
        run.record = record_stages(form)
    stages, rec, layouts = run.record
    n = len(X)
    out = np.zeros((n, len(rec)))
    codes = np.zeros(n)
    table = np.array([[s.fn, s.ctx] for s in stages], dtype=np.int64).reshape(len(stages), 2)
    done = record_samples(run.system, table, rec, np.ascontiguousarray(s.t), X, out, codes, np.zeros(X.shape[1]))
    if done < n:
        t = float(s.t[done])
        form.project(t, s.q[done], s.v[done])                # raises the Python path's error
        raise FloatingPointError(f"the projection of the output sample at t = {t:.9g} s failed")
    floor = form.monitor()[0]
    failures = []
    for k in np.flatnonzero((codes == ERROR) | ((codes < floor) & (codes != NONFINITE))):
        t = float(s.t[k])
        if codes[k] == ERROR and run.errors:
            exc = run.errors.pop()             # the failed sample keeps NaN, its Failure says why
            failures.append(sample_failure(exc, t) if isinstance(exc, SAMPLE_FAILURES) else
                            Failure(FailureKind.EXCEPTION, t, f"output sample at t = {t:.9g} s: a function raised "
                                                              f"{type(exc).__name__}: {exc}"))
        else:
            failures.append(Failure(FailureKind.RANK_LOSS, t, f"output sample at t = {t:.9g} s: the constraint "
                                                              f"rows lost rank (pivot code {codes[k]:.3g})"))
        row, recs = finish_sample(form, float(s.t[k]), s.q[k], s.v[k], s.z[k], None, None)
        out[k, :core_size(mech)] = row
        for (off, lay), (pot, loss, outs) in zip(layouts, recs):
            out[k, off:off + 2] = pot, loss
            a = off + 2
            for name, size in lay:
                out[k, a:a + size] = np.ravel(outs[name])
                a += size
    elements = []
    for off, lay in layouts:
        named, a = {}, off + 2
        for name, size in lay:
            named[name] = out[:, a] if size == 1 else out[:, a:a + size]
            a += size
        elements.append((out[:, off], out[:, off + 1], named))
    return Outputs(out[:, :core_size(mech)], elements, tuple(failures))
