"""Stability atlas: every scene x formulation x integrator x tolerance, each cell run
under a CPU budget, recorded as success or failure with its reason, its error against a reference
from an independent path, its energy drift (or energy-balance error), its closure residual and its
cost. Writes OUT/atlas.json, OUT/atlas.csv, OUT/heatmap_<scene>.png, OUT/work_precision_<scene>.png.

Peers (other simulators) join through a small object interface (see :func:`run_atlas`)."""
from __future__ import annotations

import csv
import io
import json
import math
import re
import time
import warnings
from pathlib import Path

import numpy as np
from scipy.integrate import simpson

from pinclear.core import safeio
from pinclear.core.errors import InputError, PinclearError
from pinclear.core.failures import FailureKind
from pinclear.dynamics import formulations
from pinclear.dynamics import stepping as integrators
from pinclear.dynamics.stepping.run import run_clock as _run_clock
from pinclear.mechanisms import bench_scenes as scenes
from pinclear.model import kinematics
from pinclear.studies.bench import rhs as bench

#: columns of atlas.csv, in order (the JSON rows carry the same keys)
COLUMNS = ["scene", "method", "integrator", "tol", "h", "status", "reason", "failure_kind", "message", "t_failed", "t_end", "error",
           "energy_drift", "energy_kind", "max_residual", "branch_spread", "cpu_s", "rhs_evals", "steps"]
REASONS = ("rank loss", "step-size collapse", "non-finite", "budget", "branch switch", "other")

#: the registry's integrators (pinclear.core.registry.INTEGRATORS), in its order
INTEGRATORS = integrators.INTEGRATORS
QUICK_INTEGRATORS = ("DOP853", "Radau", "RK4")
TOLS = (1e-4, 1e-6, 1e-8, 1e-10)
#: formulations of the default grid. ``manifold`` is run on the singular scenes only
#: (``--methods manifold`` with their files; benchmarks/atlas holds that run merged in): a
#: projection at every evaluation buys nothing on regular and clearance scenes, and it is the
#: costliest method there
DEFAULT_METHODS = tuple(m for m in formulations.METHODS if m != "manifold")
CLEARANCE_TOLS = (1e-4, 1e-6, 1e-8)
QUICK_TOLS = (1e-5, 1e-8)

#: simulated seconds of each bundled scene (full atlas, clearance scenes, quick atlas), their
#: references and branches: the scenes' own settings (pinclear.mechanisms.bench_scenes)
T_END, T_END_CLEARANCE, QUICK_T_END = scenes.ATLAS_T_END, scenes.ATLAS_T_END_CLEARANCE, scenes.ATLAS_QUICK_T_END
T_END_RIGID = 2.0
T_END_CLEARANCE_DEFAULT = 0.02
QUICK_T_END_RIGID = 0.5
QUICK_CLEARANCE_FACTOR = 0.25

#: RK4's fixed step for the k-th rung: its global error ~ C h^4, so h = H0 (tol / 1e-4)^(1/4) makes
#: the ladder fall with the same ratio per rung as the adaptive tolerances. Stiff contacts need
#: H0 near the contact period (~1e-4 s).
RK4_H0 = 1e-2
RK4_H0_CLEARANCE = 1e-4

BUDGET = 5.0              # CPU s per cell, rigid scenes
BUDGET_CLEARANCE = 4.0    # CPU s per cell, clearance scenes (short windows)
BUDGET_REFERENCE = 60.0
SAMPLES = 200             # output samples per cell: branch check, energy and residual histories

#: a crank more than this far from its parallel partner is on another branch: on the
#: anti-parallelogram branch the angles differ by O(1) rad away from the flat configuration, while a
#: run on the right branch keeps them equal to its closure residual over a crank length (<< 1e-2)
BRANCH_TOL = 1e-2


# ------------------------------------------------------------------------------------ branch
#: joints that stay parallel on a scene's branch of parallel cranks (None: the scene has none)
branch_joints = scenes.branch_joints


def branch_spread(mech, q):
    """Per sample, the largest angle between a crank and the first one (wrapped to (-pi, pi]):
    0 on the branch of parallel cranks, O(1) on the other branch. None if the scene has no such
    branch (:func:`branch_joints`). ``q``: (n, nq) or (nq,)."""
    joints = branch_joints(mech)
    if joints is None:
        return None
    q = np.atleast_2d(np.asarray(q, float))
    idx = [mech.model.joints[mech.model.getJointId(j)].idx_q for j in joints]
    th = q[:, idx]
    d = th - th[:, :1]
    return np.abs(np.arctan2(np.sin(d), np.cos(d))).max(axis=1)


# ------------------------------------------------------------------------------------ references
def reference(mech, label, t_end, max_cpu=BUDGET_REFERENCE):
    """(q_ref at t_end, description, CPU s) from a path independent of the cells where the scene
    declares one (pinclear.mechanisms.bench_scenes.reference: a closed form or a reduced model);
    else projection + DOP853 at rtol 1e-13 as
    pinclear.studies.bench.rhs.work_precision, falling back to a given first step, projection + Radau at rtol
    1e-12, then proximal + DOP853; the description says which. q_ref is None if all fail."""
    t0 = _run_clock()
    known = scenes.reference(mech, label, t_end)
    if known is not None:
        q, what = known
        return q, what, _run_clock() - t0
    notes = []
    # SciPy's initial-step selection can divide by zero at rtol 1e-13 on a stiff contact (retry
    # with a first step); explicit stages can overshoot into wild contact states (then Radau)
    for method, integ, rtol, first in (("projection", "DOP853", 1e-13, None), ("projection", "DOP853", 1e-13, 1e-7),
                                       ("projection", "Radau", 1e-12, None), ("proximal", "DOP853", 1e-13, None)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                tr = bench.reference_run(mech, t_end, rtol=rtol, method=method, integrator=integ, max_cpu=max_cpu,
                                         first_step=first)
            except PinclearError as exc:
                notes.append(f"{method} + {integ}: {exc}")
                continue
        what = f"{method} + {integ}, rtol {rtol:g}" + (f", first step {first:g} s" if first else "")
        if tr.status == "success":
            n_ev = len(tr.stats["events"])
            return tr.q[-1], (what + (f" (after: {'; '.join(notes)})" if notes else "")
                              + (f"; {n_ev} contact events in the window" if mech.clearances else "")), \
                _run_clock() - t0
        notes.append(f"{what}: {tr.message}")
    return None, "none: " + "; ".join(notes), _run_clock() - t0


# ------------------------------------------------------------------------------------ one cell
#: the atlas's reason for each kind of Trajectory.failure (the run's failure as data: no message
#: is parsed, so rewording a message cannot change an atlas)
REASON_OF = {FailureKind.NONFINITE: "non-finite", FailureKind.STEP_SIZE: "step-size collapse",
             FailureKind.BUDGET: "budget", FailureKind.RANK_LOSS: "rank loss", FailureKind.SINGULAR: "rank loss"}


def classify(traj, t_end):
    """(reason, t_failed, note) of a failed run from its ``failure`` (kind, t, detail).

    A rank loss raised at the stage state of a trial step (an explicit step overshooting into a
    stiff contact, rejected until the steps could not get past it) is told apart from a rank loss
    on the trajectory (located along an accepted step, samples kept up to it): its time lies more
    than two output intervals beyond the last sample kept. It stays 'rank loss' (what the
    formulation saw) with a note, and t_failed is the time the trajectory reached."""
    kind, t, _ = traj.failure
    reason = REASON_OF.get(kind, "other")
    kept = float(traj.t[-1]) if len(traj.t) else None
    if reason == "rank loss" and t is not None and kept is not None and t - kept > 2 * t_end / SAMPLES:
        return reason, kept, (f"at an integrator stage {t - kept:.3g} s beyond the last sample kept, "
                              "not on the computed trajectory")
    return reason, t if t is not None else kept, ""


def energy_error(traj, mech):
    """('drift', max |E - E0| / scale) for a conservative scene, else ('balance', max |E - E0 -
    int (P_drives - P_loss) dt| / scale). Kinetic and gravity energy are Pinocchio's at the returned
    (q, v) as the trajectory records them (every formulation fills the workspace it reads, see
    Formulation.fills_workspace); spring energy and contact losses are the force elements'
    records. Drive power: drive multipliers times the drive rows' J v (closure rows do no work).
    Simpson's rule over the output samples: a quadrature floor where impacts are shorter than the
    sample interval. Scale: max(|E0|, max kinetic energy), as Trajectory.summary."""
    n = len(traj.t)
    if n < 2:
        return ("drift" if mech.conservative else "balance"), float("nan")
    T = traj.energies["kinetic"]
    tot = T + traj.energies["potential"] + traj.energies["spring"]
    scale = max(abs(tot[0]), float(np.max(T)), 1e-300)
    if mech.conservative:
        return "drift", float(np.max(np.abs(tot - tot[0])) / scale)
    mc = mech.compiled.m
    p_drive = np.zeros(n)
    if mech.drives:
        ws = mech.workspace()
        lam = np.column_stack([traj.lam[d.name] for d in mech.drives])
        for i in range(n):
            Jd = kinematics.jacobian(mech, ws, traj.q[i], traj.t[i], with_drives=True)[mc:]
            p_drive[i] = lam[i] @ (Jd @ traj.v[i])
    net = p_drive - traj.energies["dissipated_power"]
    work = np.concatenate([[0.0], [simpson(net[: k + 1], x=traj.t[: k + 1]) for k in range(1, n)]])
    bal = tot - tot[0] - work
    return "balance", float(np.nanmax(np.abs(bal)) / scale)


def closure_residual(traj, mech):
    """Largest closure residual over the returned states (the trajectory's own record)."""
    if not len(traj.t):
        return float("nan")
    return float(np.nanmax(traj.residual)) if mech.compiled.m else 0.0


def run_cell(mech, label, t_end, method, integrator, tol, h, q_ref, max_cpu):
    """One atlas cell: run, classify, measure."""
    tr = bench.run_cell(mech, t_end, method, integrator, h if integrator == "RK4" else tol,
                        dt_out=t_end / SAMPLES, max_cpu=max_cpu)
    row = {"scene": label, "method": method, "integrator": integrator, "tol": tol,
           "h": h if integrator == "RK4" else None, "t_end": t_end, "message": tr.message,
           "cpu_s": tr.stats["cpu_s"], "rhs_evals": tr.stats["rhs_evals"], "steps": tr.stats["steps"]}
    if tr.status == "success":
        reason, t_failed = "", None
    else:
        reason, t_failed, note = classify(tr, t_end)
        row["failure_kind"] = str(tr.failure.kind)
        if note:
            row["message"] += f" [{note}]"
    spread = branch_spread(mech, tr.q) if len(tr.t) else None
    row["branch_spread"] = float(np.max(spread)) if spread is not None and len(spread) else None
    if spread is not None and len(spread) and np.max(spread) > BRANCH_TOL:
        t_sw = float(tr.t[np.argmax(spread > BRANCH_TOL)])
        if t_failed is None or t_sw < t_failed:
            reason, t_failed = "branch switch", t_sw
            row["message"] = (f"left its branch of parallel cranks by t = {t_sw:.6g} s (crank angles differ by "
                              f"{np.max(spread):.3g} rad > {BRANCH_TOL:g}); " + tr.message)
    ok = reason == ""
    row.update(status="success" if ok else "failed", reason=reason, t_failed=t_failed)
    row["error"] = bench.q_error(mech.model, q_ref, tr.q[-1]) if ok and q_ref is not None else float("nan")
    row["energy_kind"], row["energy_drift"] = energy_error(tr, mech)
    row["max_residual"] = closure_residual(tr, mech)
    return row


# ------------------------------------------------------------------------------------ the atlas
def scene_plan(label, clearances, quick=False):
    """(t_end, tolerances, RK4 H0, per-cell budget) of a scene."""
    if clearances or label in T_END_CLEARANCE:
        t = T_END_CLEARANCE.get(label, T_END_CLEARANCE_DEFAULT)
        if quick:
            return t * QUICK_CLEARANCE_FACTOR, QUICK_TOLS[:1], RK4_H0_CLEARANCE, BUDGET_CLEARANCE / 2
        return t, CLEARANCE_TOLS, RK4_H0_CLEARANCE, BUDGET_CLEARANCE
    if quick:
        return QUICK_T_END.get(label, QUICK_T_END_RIGID), QUICK_TOLS, RK4_H0, BUDGET / 2
    return T_END.get(label, T_END_RIGID), TOLS, RK4_H0, BUDGET


def rk4_step(tol, h0, t_end):
    return min(h0 * (tol / 1e-4) ** 0.25, t_end / 10)


def run_atlas(files=None, out="benchmarks/atlas", quick=False, peers=(), budget=None, progress=None,
              methods=None, integrators_=None, tols=None, t_end=None):
    """Run the atlas and write OUT/atlas.json, OUT/atlas.csv and the figures; return the JSON dict.

    files: sidecars (paths or bundled names; default every one in urdf/), each with its clearance
    variants (pinclear.studies.bench.rhs.scenes). quick: all scenes, DOP853/Radau/RK4, fewer tolerances, short
    windows. budget: CPU s per cell (default 5 rigid, 4 clearance). peers: objects with ``name``,
    ``scenes`` (sidecar stems), ``tols`` and ``run(sidecar_path, t_end, tol) -> dict`` (status, reason,
    message, q_final in Pinocchio's layout, cpu_s, rhs_evals or steps, optional energy_drift,
    max_residual, t_failed); their rows carry method = integrator = peer.name.
    methods / integrators_ / tols / t_end: restrict the grid (tests, focused studies)."""
    from pinclear.io.sidecar import load

    if budget is not None and not (np.isfinite(budget) and budget > 0):
        raise InputError(f"budget must be a positive number of CPU seconds per cell, got {budget!r}")
    for m in methods or []:
        formulations.get(m)
    for i in integrators_ or []:
        integrators.get(i)
    methods = list(methods or DEFAULT_METHODS)
    integ_names = list(integrators_ or (QUICK_INTEGRATORS if quick else INTEGRATORS))
    peers = list(peers)
    for p in peers:
        for attr in ("name", "scenes", "tols", "run"):
            if not hasattr(p, attr):
                raise InputError(f"peer {p!r} lacks {attr!r}", key="peers", choices=["name", "scenes", "tols", "run"])
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    wall0 = time.perf_counter()
    rows, info = [], {}
    for label, path, clr in bench.scenes(files):
        te, ladder, h0, cell_budget = scene_plan(label, clr, quick)
        te = t_end or te
        ladder = tuple(tols or ladder)
        cell_budget = budget or cell_budget
        if progress is not None:
            progress(f"{label}: t_end {te:g} s, reference")
        mech = load(path, clearances=clr or None)
        q_ref, ref_what, ref_cpu = reference(mech, label, te)
        scene = {"sidecar": str(path), "clearances": clr, "t_end": te, "tols": list(ladder), "budget_cpu_s": cell_budget,
                 "rk4_steps": {f"{t:g}": rk4_step(t, h0, te) for t in ladder}, "reference": ref_what,
                 "reference_cpu_s": ref_cpu, "conservative": mech.conservative,
                 "energy_kind": "drift" if mech.conservative else "balance", "skipped": {}, "peers": []}
        combos = []
        for m in methods:
            try:
                form = formulations.get(m)(mech)
            except PinclearError as exc:           # e.g. pinocchio refuses planar closures: say why
                scene["skipped"][m] = str(exc)
                continue
            for i in integ_names:
                if form.supports_projection and not integrators.get(i).corrects_state:
                    scene["skipped"][f"{m}+{i}"] = f"{m} projects the state after each step; {i} cannot absorb it"
                    continue
                combos.append((m, i))
        warm_up(mech, combos, min(te, 1e-3), h0)
        for m, i in combos:
            for tol in ladder:
                if progress is not None:
                    progress(f"{label}: {m} + {i} tol {tol:g}")
                rows.append(run_cell(mech, label, te, m, i, tol, rk4_step(tol, h0, te), q_ref, cell_budget))
        for p in peers:
            if path.stem not in p.scenes or clr:
                continue
            scene["peers"].append(p.name)
            for tol in p.tols:
                if progress is not None:
                    progress(f"{label}: peer {p.name} tol {tol:g}")
                rows.append(_peer_row(p, mech, label, path, te, tol, q_ref))
        info[label] = scene
        # after every scene: a killed atlas keeps what it computed
        res = {"created": time.strftime("%Y-%m-%d %H:%M:%S"), "quick": bool(quick),
               "wall_s": time.perf_counter() - wall0, "columns": COLUMNS, "reasons": list(REASONS),
               "branch_tol_rad": BRANCH_TOL, "samples_per_cell": SAMPLES, "scenes": info, "rows": rows}
        write(res, out, figures=[label])
    if not info:
        raise InputError("the atlas found no scene to run", key="files")
    return res


def warm_up(mech, combos, t_warm, h0):
    """A short run of every (method, integrator) the scene's cells use, before their clocks start:
    each loads (or, on a fresh machine, compiles) the kernels of its formulation, integrator and
    loop, so no cell waits for them. pinclear.simulate leaves compile time out of a run's CPU
    and budget in any case (stats['compile_s']); the warm-up keeps that time out of the cells'
    wall time and the progress lines too."""
    for m, i in combos:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                bench.run_cell(mech, t_warm, m, i, 1e-6 if i != "RK4" else min(h0, t_warm / 4),
                               t_eval=[0.0, t_warm], max_cpu=30.0)
            except PinclearError:
                pass


def warm_up_all(files=None, progress=None) -> dict:
    """Compile (or load) every kernel the given mechanisms' runs use -- by default every bundled
    mechanism, each scene of ``pinclear.studies.bench.rhs.scenes`` (ideal joints and each clearance), every
    method with every integrator it takes: what ``pinclear warmup`` runs. Returns the compile
    and total CPU seconds and the number of compilations (0 on a warm cache)."""
    from pinclear.core.jit import compile_count, compile_cpu
    from pinclear.io.sidecar import load

    c0, n0, t0 = compile_cpu(), compile_count(), time.process_time()
    for label, path, clr in bench.scenes(files):
        if progress is not None:
            progress(label)
        mech = load(path, clearances=clr or None)
        combos = []
        for m in formulations.METHODS:
            try:
                form = formulations.get(m)(mech)
            except PinclearError:
                continue
            combos += [(m, i) for i in integrators.INTEGRATORS
                       if not (form.supports_projection and not integrators.get(i).corrects_state)]
        warm_up(mech, combos, 1e-3, 1e-4)
    return {"compile_cpu_s": compile_cpu() - c0, "compilations": compile_count() - n0,
            "cpu_s": time.process_time() - t0}


def _peer_row(peer, mech, label, path, t_end, tol, q_ref):
    t0 = time.process_time()
    try:
        r = dict(peer.run(str(path), t_end, tol))
    except Exception as exc:      # a peer's crash is one failed cell, not the atlas's end
        r = {"status": "failed", "reason": "other", "message": f"{type(exc).__name__}: {exc}",
             "cpu_s": time.process_time() - t0}
    ok = r.get("status") == "success"
    reason = "" if ok else (r.get("reason") if r.get("reason") in REASONS else "other")
    err = float("nan")
    if ok and q_ref is not None and r.get("q_final") is not None:
        qf = np.asarray(r["q_final"], float)
        if qf.shape != (mech.model.nq,):
            ok, reason = False, "other"
            r["message"] = f"peer q_final has {qf.size} numbers, the Pinocchio model {mech.model.nq}"
        else:
            err = bench.q_error(mech.model, q_ref, qf)
    return {"scene": label, "method": peer.name, "integrator": peer.name, "tol": tol, "h": None,
            "status": "success" if ok else "failed", "reason": reason, "message": r.get("message", ""),
            "t_failed": r.get("t_failed"), "t_end": t_end, "error": err,
            "energy_drift": float(r.get("energy_drift", float("nan"))), "energy_kind": "peer",
            "max_residual": float(r.get("max_residual", float("nan"))), "branch_spread": None,
            "cpu_s": float(r.get("cpu_s", float("nan"))), "rhs_evals": r.get("rhs_evals", r.get("steps")),
            "steps": r.get("steps")}


# ------------------------------------------------------------------------------------ output
def _clean(x):
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, (np.floating, np.integer)):
        return _clean(x.item())
    return x


def load(path):
    """An atlas.json back as run_atlas returned it (null numbers as NaN)."""
    res = json.loads(Path(path).read_text())
    for r in res["rows"]:
        for k in ("error", "energy_drift", "max_residual", "cpu_s"):
            if r.get(k) is None:
                r[k] = float("nan")
    return res


def write(res, out, figures=None):
    """atlas.json (NaN as null), atlas.csv (NaN as empty), one heatmap and one work-precision chart
    per scene (only the scenes named in ``figures`` if given)."""
    from pinclear.dynamics.trajectory import atomic_write_text

    out = Path(out)
    rows = res["rows"]
    js = dict(res, rows=[{k: _clean(r.get(k)) for k in COLUMNS} for r in rows])
    atomic_write_text(out / "atlas.json", json.dumps(js, indent=1, default=str))
    buf = io.StringIO(newline="")
    w = csv.DictWriter(buf, fieldnames=COLUMNS)
    w.writeheader()
    for r in rows:
        w.writerow({k: ("" if _clean(r.get(k)) is None else r.get(k)) for k in COLUMNS})
    atomic_write_text(out / "atlas.csv", buf.getvalue())
    for label, sc in res["scenes"].items():
        srows = [r for r in rows if r["scene"] == label]
        if not srows or (figures is not None and label not in figures):
            continue
        heatmap(srows, out / f"heatmap_{_fname(label)}.png", label, sc)
        bench.draw_chart(srows, out / f"work_precision_{_fname(label)}.png",
                     f"{label}: error at t = {sc['t_end']:g} s vs CPU time (ref: {sc['reference'].split(':')[0].split(',')[0]})")


def _fname(label):
    return re.sub(r"[^A-Za-z0-9_.+-]", "_", label)


_REASON_STYLE = {"rank loss": ("#d62728", "rank"), "step-size collapse": ("#ff7f0e", "step"),
                 "non-finite": ("#8c564b", "nan"), "budget": ("#7f7f7f", "cpu"),
                 "branch switch": ("#e377c2", "branch"), "other": ("#000000", "other")}


def heatmap(rows, path, label, scene):
    """Rows = method + integrator (peers last), columns = tolerance rung; colour = log10 error of a
    success, a labelled colour per failure reason."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Patch, Rectangle

    keys = []
    for r in rows:
        k = (r["method"], r["integrator"])
        if k not in keys:
            keys.append(k)
    tols_by_key = {k: [] for k in keys}
    for r in rows:
        k = (r["method"], r["integrator"])
        if r["tol"] not in tols_by_key[k]:
            tols_by_key[k].append(r["tol"])
    ncol = max(len(v) for v in tols_by_key.values())
    grid = np.full((len(keys), ncol), np.nan)
    fails = []
    for r in rows:
        k = (r["method"], r["integrator"])
        i, j = keys.index(k), tols_by_key[k].index(r["tol"])
        if r["status"] == "success" and np.isfinite(r["error"]) and r["error"] > 0:
            grid[i, j] = math.log10(r["error"])
        elif r["status"] == "success":
            grid[i, j] = -16.0
        else:
            fails.append((i, j, r["reason"]))
    fig, ax = plt.subplots(figsize=(3.6 + 1.0 * ncol, 1.8 + 0.3 * len(keys)))
    im = ax.imshow(np.ma.masked_invalid(grid), cmap="viridis", aspect="auto", vmin=-13, vmax=0)
    def knob(i, j):         # a peer's own ladder value under its cell
        m, it = keys[i]
        return f"\n{tols_by_key[keys[i]][j]:g}" if m == it else ""

    for i, j, reason in fails:
        colour, short = _REASON_STYLE.get(reason, _REASON_STYLE["other"])
        ax.add_patch(Rectangle((j - 0.5, i - 0.5), 1, 1, color=colour))
        ax.text(j, i, short + knob(i, j), ha="center", va="center", color="white", fontsize=7)
    for i in range(len(keys)):
        for j in range(ncol):
            if np.isfinite(grid[i, j]):
                ax.text(j, i, f"{grid[i, j]:.1f}" + knob(i, j), ha="center", va="center", fontsize=7,
                        color="white" if grid[i, j] < -6 else "black")
    labels = []
    for m, i in keys:
        if m == i:
            labels.append(f"{m} (dt)")
        elif i == "RK4":
            labels.append(f"{m} + RK4 (h)")
        else:
            labels.append(f"{m} + {i}")
    ax.set_yticks(range(len(keys)), labels, fontsize=7)
    adaptive = [t for t in scene["tols"]]
    ax.set_xticks(range(ncol), [f"{adaptive[j]:g}" if j < len(adaptive) else f"#{j}" for j in range(ncol)], fontsize=7)
    ax.set_xlabel("rtol (RK4: h = " + ", ".join(f"{h:.2g}" for h in scene["rk4_steps"].values()) + " s; peers: their own ladder)",
                  fontsize=7)
    ax.set_title(f"{label}, t_end {scene['t_end']:g} s: log10 error / failure", fontsize=9)
    fig.colorbar(im, ax=ax, label="log10 max |q - q_ref|", fraction=0.05, pad=0.02)
    fig.legend(handles=[Patch(color=c, label=f"{s}: {r}") for r, (c, s) in _REASON_STYLE.items()],
               fontsize=6, loc="lower center", ncol=3, frameon=False)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    safeio.savefig(fig, path, dpi=100)
    plt.close(fig)


def table(res, label) -> str:
    """Markdown table of a scene: one line per method + integrator, one column per rung (log10
    error or the failure reason with its time)."""
    rows = [r for r in res["rows"] if r["scene"] == label]
    keys = list(dict.fromkeys((r["method"], r["integrator"]) for r in rows))
    tols = res["scenes"][label]["tols"]
    head = "| method + integrator | " + " | ".join(f"{t:g}" for t in tols) + " | CPU s (sum) |"
    lines = [head, "|---" * (len(tols) + 2) + "|"]
    for k in keys:
        cells = []
        rk = [r for r in rows if (r["method"], r["integrator"]) == k]
        for r in rk[: max(len(tols), len(rk))]:
            if r["status"] == "success":
                e = r["error"]
                cells.append(f"{math.log10(e):.1f}" if e is not None and np.isfinite(e) and e > 0 else "ok")
            else:
                tf = r["t_failed"]
                cells.append(f"**{r['reason']}**" + (f" @{tf:.3g}" if tf is not None else ""))
        name = k[0] if k[0] == k[1] else f"{k[0]} + {k[1]}"
        lines.append(f"| {name} | " + " | ".join(cells) + f" | {sum(r['cpu_s'] or 0 for r in rk):.2f} |")
    return "\n".join(lines)


def summary_table(res) -> str:
    """Markdown: per scene, cells, successes, failures by reason, and the cheapest success reaching
    error <= 1e-6 (method + integrator, tol, CPU s)."""
    lines = ["| scene | t_end s | reference | cells | ok | " + " | ".join(REASONS) + " | cheapest to 1e-6 |",
             "|---" * (6 + len(REASONS)) + "|"]
    for label, sc in res["scenes"].items():
        rows = [r for r in res["rows"] if r["scene"] == label]
        ok = [r for r in rows if r["status"] == "success"]
        counts = [sum(r["reason"] == k for r in rows) for k in REASONS]
        good = [r for r in ok if r["error"] is not None and np.isfinite(r["error"]) and r["error"] <= 1e-6]
        best = min(good, key=lambda r: r["cpu_s"]) if good else None
        bs = (f"{best['method']} + {best['integrator']} {best['tol']:g} ({best['cpu_s']:.3g} s)" if best else "-")
        ref = sc["reference"].split(":")[0].split(",")[0].split(" (")[0]
        lines.append(f"| {label} | {sc['t_end']:g} | {ref} | {len(rows)} | {len(ok)} | "
                     + " | ".join(str(c) if c else "" for c in counts) + f" | {bs} |")
    return "\n".join(lines)


def method_table(res) -> str:
    """Markdown: per method + integrator over all scenes, successes and failures by reason."""
    keys = list(dict.fromkeys((r["method"], r["integrator"]) for r in res["rows"]))
    lines = ["| method + integrator | cells | ok | " + " | ".join(REASONS) + " | CPU s (sum) |",
             "|---" * (4 + len(REASONS)) + "|"]
    for k in keys:
        rows = [r for r in res["rows"] if (r["method"], r["integrator"]) == k]
        counts = [sum(r["reason"] == x for r in rows) for x in REASONS]
        lines.append(f"| {k[0] if k[0] == k[1] else ' + '.join(k)} | {len(rows)} | "
                     f"{sum(r['status'] == 'success' for r in rows)} | " + " | ".join(str(c) if c else "" for c in counts)
                     + f" | {sum(r['cpu_s'] or 0 for r in rows):.1f} |")
    return "\n".join(lines)
