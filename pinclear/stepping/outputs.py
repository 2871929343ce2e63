"""The outputs of a run's samples (docs/outputs.md): at every output sample the accelerations,
every row's multiplier and residual, the energies of the audit (pinclear.energy) and each force
element's record (ForceElement.record: potential, power loss, outputs).

One compiled pass over the samples (:func:`record_samples`) does it where the run's evaluation
is compiled and every force element declares a compiled record (ForceElement contract 11): per
sample, the projection onto the constraint manifold (formulations that project), one
evaluation (its accelerations and multipliers), then the *record stages* (:func:`record_stages`:
the passes again at the sample's own state where the evaluation moved it, the rows, the
energies, each element's record kernel) writing one row of a table. Python touches the table
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

from .. import kinematics, native
from .._jit import njit
from .._kernels import constraint_rows_all, joint_placements
from .call import ERROR, NONFINITE, run_stages
from .stage import bind
from .system import evaluate, project

#: the code a sample gets when its projection failed (the run raises the Python path's error)
PROJECTION_FAILED = -10.0


class Outputs(NamedTuple):
    """A run's outputs at its n samples, as whole arrays: ``core`` (n, nv + 2 m + 3) in the row
    layout of the module doc; ``elements``: per force element (potential (n,), power loss (n,),
    {output name: (n,) or (n, size)})."""
    core: np.ndarray
    elements: list


def core_size(mech):
    return mech.nv + 2 * mech.m + 3


# ------------------------------------------------------------------ the Python path (reference)
def sample_record(form, t, q, v, z):
    """One sample's (core row, [(potential, power loss, outputs) per element]) through the
    plug-ins' Python methods: the reference of the compiled pass (the path of every run before
    it), and the path of runs it does not serve (:func:`compiled_ready`)."""
    try:
        a = form.accelerations(t, q, v, z)
    except Exception:                # a failed sample keeps NaN; the run's message says why
        return finish_sample(form, t, q, v, z, None, None)
    return finish_sample(form, t, q, v, z, a, form.ws.lam)


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


def python_outputs(form, samples) -> Outputs:
    """The outputs of ``samples`` [(t, q, v, z)] sample by sample in Python (the reference)."""
    mech = form.mech
    core = np.zeros((len(samples), core_size(mech)))
    per = [([], [], {}) for _ in mech.forces]
    for i, (t, q, v, z) in enumerate(samples):
        core[i], recs = sample_record(form, t, q, v, z)
        for (pot, loss, outs), (P, L, O) in zip(recs, per):
            P.append(pot)
            L.append(loss)
            for k, val in outs.items():
                O.setdefault(k, []).append(np.asarray(val, float))
    return Outputs(core, [(np.array(P, float), np.array(L, float), {k: np.array(v) for k, v in O.items()})
                          for P, L, O in per])


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
    """Every row's Phi, J and J v + Phi_t at the sample (no stabilisation: gamma is not read)."""
    constraint_rows_all(R, 0.0, 0.0, q, v, fdrv)


@njit(cache=True)
def sample_energies(parent, jP, kind, axis, iq, q, O, want, Hj, mass, lever, g, M, v, lam, dphi, mc, phi, rec, off):
    """rec[off - m:off] = the rows' residuals; rec[off:off + 3] = the closure rows' power
    lam_c . dPhi_c/dt, the kinetic energy v^T M v / 2 (M: crba's upper triangle) and the
    gravity energy -sum_i m_i g . c_i (c_i: body i's centre of mass in the world, from the joint
    placements at q), Pinocchio's computeKineticEnergy and computePotentialEnergy in other
    words (the same sums up to rounding)."""
    m = phi.shape[0]
    for r in range(m):
        rec[off - m + r] = phi[r]
    p = 0.0
    for r in range(mc):
        p += lam[r] * dphi[r]
    rec[off] = p
    kin = 0.0
    nv = v.shape[0]
    for i in range(nv):
        acc = 0.5 * M[i, i] * v[i]
        for j in range(i + 1, nv):
            acc += M[i, j] * v[j]
        kin += v[i] * acc
    rec[off + 1] = kin
    joint_placements(parent, jP, kind, axis, iq, q, O, want, Hj)
    pot = 0.0
    for j in range(1, O.shape[0]):
        for r in range(3):
            c = O[j, r, 3] + O[j, r, 0] * lever[j, 0] + O[j, r, 1] * lever[j, 1] + O[j, r, 2] * lever[j, 2]
            pot -= mass[j] * g[r] * c
    rec[off + 2] = pot


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


def record_stages(form, errors, comp):
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
    again = not (form.fills_workspace and comp.mass)
    if again:
        # the evaluation moved the state (the manifold's projection): the passes at the sample's own
        from .build import placements_stage
        stages += [native.passes_stage(mech, ws, True, errors, False), placements_stage(mech, ws, errors)]
    if again or not form.fills_rows:
        stages.append(bind(sample_rows, (kinematics.row_buffers(mech, ws), ws.q, ws.v, ws.drive_data.f),
                           name="outputs: rows"))
    model = mech.model
    mass = np.array([I.mass for I in model.inertias])
    lever = np.array([I.lever for I in model.inertias]).reshape(-1, 3)
    g = np.array(model.gravity.linear, float)
    stages.append(bind(sample_energies, ws.fk.placement_args(ws.q) + (mass, lever, g, ws.data.M, ws.v, ws.lam,
                                                                       ws.dphi, mech.compiled.m, ws.phi, rec,
                                                                       nv + 2 * m), name="outputs: energies"))
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


def compiled_outputs(run, X, t_eval, samples) -> Outputs:
    """The outputs of the sample rows X (projected in place where the run projects) in one
    compiled pass; ``samples``: the (t, q, v, z) views of the rows."""
    form = run.form
    mech = form.mech
    if run.record is None:
        run.record = record_stages(form, run.errors, form.compiled())
    stages, rec, layouts = run.record
    n = len(X)
    out = np.zeros((n, len(rec)))
    codes = np.zeros(n)
    table = np.array([[s.fn, s.ctx] for s in stages], dtype=np.int64).reshape(len(stages), 2)
    done = record_samples(run.system, table, rec, np.ascontiguousarray(t_eval[:n]), X, out, codes,
                          np.zeros(X.shape[1]))
    if done < n:
        t, q, v, _ = samples[done]
        form.project(t, q, v)                # raises the Python path's error
        raise FloatingPointError(f"the projection of the output sample at t = {t:.9g} s failed")
    floor = form.monitor()[0]
    for k in np.flatnonzero((codes == ERROR) | ((codes < floor) & (codes != NONFINITE))):
        if codes[k] == ERROR and run.errors:
            run.errors.pop()                   # the failed sample keeps NaN, as on the Python path
        row, recs = finish_sample(form, *samples[k], None, None)
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
    return Outputs(out[:, :core_size(mech)], elements)
