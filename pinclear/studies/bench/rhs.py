"""Benchmarks: right-hand-side cost against a bare pin.constraintDynamics call on the same tree
(same process), and the work-precision chart (error at t_end vs CPU time)."""
from __future__ import annotations

import csv
import json
import time
from pathlib import Path

import numpy as np
import pinocchio as pin

from pinclear.core import safeio
from pinclear.core.errors import InputError, PinclearError
from pinclear.core.jit import njit
from pinclear.dynamics import formulations
from pinclear.dynamics.simulate import default_atol, simulate
from pinclear.dynamics.stepping.build import Evaluation
from pinclear.dynamics.stepping.system import evaluate as evaluate_rhs
from pinclear.mechanisms import bench_scenes
from pinclear.model.closures import PINOCCHIO_TYPES


def baseline_constraints(mech):
    """Pinocchio rigid constraints standing for the mechanism's closures: 6D for welds, 3D for
    every closure with a coincident point, 3D for the others too (the nearest Pinocchio type),
    so the baseline solves a constraint set of comparable size on the same tree."""
    cms = pin.StdVec_RigidConstraintModel()
    closures = list(mech.closures) + list(mech.replaced_closures.values())
    for c in closures:
        F1, F2 = mech.model.frames[c.f1], mech.model.frames[c.f2]
        kind = pin.ContactType.CONTACT_6D if PINOCCHIO_TYPES.get(c.type) == "CONTACT_6D" else pin.ContactType.CONTACT_3D
        cms.append(pin.RigidConstraintModel(kind, mech.model, F1.parentJoint, F1.placement, F2.parentJoint,
                                            F2.placement, pin.LOCAL))
    cds = pin.StdVec_RigidConstraintData()
    for cm in cms:
        cds.append(cm.createData())
    return cms, cds


def bench_rhs(mech, methods=None, t_end=None, n_states=200, repeat=3, rtol=1e-6):
    """Cost of one right-hand-side evaluation per formulation over the states and times of a
    real run, against a bare pin.constraintDynamics call at the same states (same process).

    The states are the samples of a run of ``mech`` (lagrange, RK45): each evaluation sees a new
    time and a new state, so no cache (drive laws, contact geometry) answers twice, as in a run.
    Reported: best-of-``repeat`` mean seconds per evaluation and its ratio to the baseline."""
    import warnings

    t_end = t_end or _natural_duration(mech)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = simulate(mech, t_end, rtol=rtol, dt_out=t_end / n_states)
    n = len(run.t)
    if n < 2:
        raise InputError(f"bench rhs: the reference run of {mech.name} failed at once ({run.message})")
    model = mech.model
    data = model.createData()
    cms, cds = baseline_constraints(mech)
    pin.initConstraintDynamics(model, data, cms, cds)
    prox = pin.ProximalSettings(1e-12, 1e-12, 50)
    tau = np.zeros(model.nv)
    Q, V, T, Z = run.q, run.v, run.t, run.z

    def baseline():
        for k in range(n):
            pin.constraintDynamics(model, data, Q[k], V[k], tau, cms, cds, prox)
    base = _best_mean(baseline, repeat) / n
    out = {"mechanism": mech.name, "nq": mech.nq, "nv": mech.nv, "closures": len(mech.closures),
           "closure_rows": mech.compiled.m, "drives": len(mech.drives), "forces": [f.name for f in mech.forces],
           "states": {"from": f"lagrange + RK45 run, rtol {rtol:g}, t in [0, {T[-1]:.4g}] s", "count": n},
           "baseline": {"call": "pin.constraintDynamics", "constraints": [str(c.type) for c in cms],
                        "rows": int(sum(c.residualSize() for c in cms)), "time_s": base}, "methods": {}}
    for name in methods or list(formulations.METHODS):
        try:
            form = formulations.get(name)(mech)
        except PinclearError as exc:  # a formulation that refuses this mechanism says why
            out["methods"][name] = {"skipped": str(exc)}
            continue
        sysf = Evaluation(form)
        X = [sysf.pack(Q[k], V[k], Z[k]) for k in range(n)]
        try:
            sysf(T[0], X[0])
        except PinclearError as exc:
            out["methods"][name] = {"skipped": f"{type(exc).__name__}: {exc}"}
            continue

        def evaluate():
            for k in range(n):
                sysf(T[k], X[k])
        try:
            t = _best_mean(evaluate, repeat) / n
        except PinclearError as exc:          # e.g. a rank loss the formulation cannot pass
            out["methods"][name] = {"skipped": f"{type(exc).__name__}: {exc}"}
            continue
        out["methods"][name] = {"time_s": t, "ratio": t / base}
    return out


def _natural_duration(mech):
    """One period of the slowest drive law if it has one, else 1 s."""
    return 1.0


def _best_mean(fn, repeat):
    fn()                                   # warm-up: compiled kernels, first-call caches
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


# ---------------------------------------------------------------------- work-precision
DEFAULT_COMBOS = [("lagrange", "RK45"), ("lagrange", "DOP853"), ("lagrange", "Radau"), ("lagrange", "BDF"),
                  ("lagrange", "LSODA"), ("projection", "RK45"), ("projection", "DOP853"),
                  ("proximal", "DOP853"), ("lagrange", "RK4")]


def work_precision(mech, t_end=2.0, combos=None, tols=(1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10),
                   out_dir="benchmarks", ref_rtol=1e-13, rk4_steps=(2e-3, 1e-3, 5e-4, 2.5e-4, 1.25e-4)):
    """Every formulation x integrator over a tolerance ladder: error of q(t_end) against a tight
    DOP853 reference (max abs over coordinates, on the manifold) vs CPU seconds. CSV + PNG."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    q_ref = reference_run(mech, t_end, rtol=ref_rtol).q[-1]
    rows = []
    for method, integ in combos or DEFAULT_COMBOS:
        ladder = rk4_steps if integ == "RK4" else tols
        for tol in ladder:
            tr = run_cell(mech, t_end, method, integ, tol, t_eval=[0.0, t_end])
            if tr.status != "success" or len(tr.t) < 2:
                rows.append({"method": method, "integrator": integ, "tol": tol, "error": np.nan,
                             "cpu_s": tr.stats["cpu_s"], "rhs_evals": tr.stats["rhs_evals"], "status": tr.status})
                continue
            rows.append({"method": method, "integrator": integ, "tol": tol, "error": q_error(mech.model, q_ref, tr.q[-1]),
                         "cpu_s": tr.stats["cpu_s"], "rhs_evals": tr.stats["rhs_evals"],
                         "max_residual": float(np.max(tr.residual)), "status": tr.status})
    csv_path = out_dir / f"work_precision_{mech.name}.csv"
    def write_csv(fh):
        w = csv.DictWriter(fh, fieldnames=["method", "integrator", "tol", "error", "cpu_s", "rhs_evals",
                                           "max_residual", "status"])
        w.writeheader()
        for r in rows:
            w.writerow(r)
    safeio.write_atomic(csv_path, write_csv, binary=False)
    png_path = out_dir / f"work_precision_{mech.name}.png"
    draw_chart(rows, png_path, f"{mech.name}: error at t = {t_end} s vs CPU time")
    best = {}
    for target in (1e-6, 1e-9):
        ok = [r for r in rows if np.isfinite(r["error"]) and r["error"] <= target]
        if ok:
            b = min(ok, key=lambda r: r["cpu_s"])
            best[f"{target:g}"] = {k: b[k] for k in ("method", "integrator", "tol", "error", "cpu_s")}
    return {"csv": str(csv_path), "png": str(png_path), "best": best, "rows": rows}


def reference_run(mech, t_end, rtol=1e-13, method="projection", integrator="DOP853", **kw):
    """The tight reference of the work-precision chart and the atlas: a formulation that keeps q on
    the manifold (projection), DOP853 at rtol 1e-13, atol 1e-2 rtol."""
    kw.setdefault("t_eval", [0.0, t_end])
    return simulate(mech, t_end, method=method, integrator=integrator, rtol=rtol, atol=default_atol(rtol), **kw)


def run_cell(mech, t_end, method, integrator, tol, **kw):
    """One point of a tolerance ladder: ``tol`` is rtol (atol 1e-2 rtol) for adaptive integrators
    and the fixed step h for RK4. A failed run is returned (status 'failed'), never raised."""
    import warnings

    kw = dict(kw, **({"h": tol, "rtol": 1e-6} if integrator == "RK4" else {"rtol": tol, "atol": default_atol(tol)}))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return simulate(mech, t_end, method=method, integrator=integrator, **kw)


def q_error(model, q_ref, q):
    """Largest coordinate of the Lie-group difference q - q_ref (rad or m)."""
    return float(np.max(np.abs(pin.difference(model, np.asarray(q_ref, float), np.asarray(q, float)))))


def draw_chart(rows, path, title, ax=None):
    """Error vs CPU seconds, one line per (method, integrator) of ``rows`` (failed points, error
    NaN, left out). With ``ax`` it draws there and the caller saves the figure."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    own = ax is None
    if own:
        fig, ax = plt.subplots(figsize=(8, 6))
    combos = sorted({(r["method"], r["integrator"]) for r in rows})
    # colour = integrator, marker and line = formulation; a peer (method == integrator) in black
    integs = sorted({i for m, i in combos if m != i})
    methods = sorted({m for m, i in combos if m != i})
    marks = ["o-", "s--", "^-.", "v:", "D-", "x--"]
    for m, i in combos:
        pts = [(r["cpu_s"], r["error"]) for r in rows if (r["method"], r["integrator"]) == (m, i)
               and np.isfinite(r["error"]) and r["error"] > 0]
        if pts:
            x, y = zip(*sorted(pts))
            if m == i:
                ax.loglog(x, y, "*-", color="black", ms=9, label=m)
            else:
                ax.loglog(x, y, marks[methods.index(m) % len(marks)], color=f"C{integs.index(i) % 10}",
                          label=f"{m} + {i}")
    ax.set_xlabel("CPU time [s]")
    ax.set_ylabel("max |q(t_end) - q_ref| [rad or m]")
    ax.set_title(title)
    ax.grid(True, which="both", alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7, ncol=2)
    if own:
        fig.tight_layout()
        safeio.savefig(fig, path, dpi=110)
        plt.close(fig)


# ---------------------------------------------------------------------- real runs
def scenes(files=None):
    """(label, sidecar path, clearances) of every scene (default: bench_scenes.catalogue(), the
    bundled mechanisms less the imported robots): each sidecar with ideal joints, and once more
    per clearance joint it declares, that joint active."""
    from pinclear.core.models import model_path
    from pinclear.io.sidecar import read_yaml

    out = []
    for f in files or bench_scenes.catalogue():
        path = model_path(f)
        doc = read_yaml(path) if path.suffix == ".yaml" else {}
        clr = [c["name"] for c in doc.get("clearances") or [] if isinstance(c, dict) and "name" in c]
        active = [c["name"] for c in doc.get("clearances") or [] if isinstance(c, dict) and c.get("active")]
        if not active:
            out.append((path.stem, path, []))
        out += [(f"{path.stem}+{c}", path, [c]) for c in clr if c not in active]
        if active:
            out.append((f"{path.stem}+{'+'.join(active)}", path, []))
    return out


def pinocchio_floor(mech, q, v, repeat=3):
    """Seconds per state of the Pinocchio work one right-hand side needs at least:
    computeAllTerms + updateFramePlacements, over the given states."""
    model, data = mech.model, mech.model.createData()

    def go():
        for k in range(len(q)):
            pin.computeAllTerms(model, data, q[k], v[k])
            pin.updateFramePlacements(model, data)
    return _best_mean(go, repeat) / len(q)


def _integration_cpu(tr):
    return tr.stats["cpu_s"] - tr.stats["setup_cpu_s"]


def check_run_names(methods, integrators, keys=("methods", "integrators")):
    """The method and integrator names of a benchmark, checked against the registries
    (pinclear.dynamics.formulations.METHODS, pinclear.dynamics.stepping.INTEGRATORS) before anything runs;
    ``keys`` name the arguments in the error (the command line passes its option names)."""
    from pinclear.dynamics import stepping as integ_mod

    methods, integrators = tuple(methods), tuple(integrators)
    adaptive = [k for k, v in integ_mod.INTEGRATORS.items() if v.adaptive]
    if not methods:
        raise InputError("give at least one method", key=keys[0], choices=formulations.METHODS)
    if not integrators:
        raise InputError("give at least one integrator", key=keys[1], choices=adaptive)
    for m in methods:
        if m not in formulations.METHODS:
            raise InputError(f"unknown method {m!r}", key=keys[0], choices=formulations.METHODS)
    for i in integrators:
        if i not in integ_mod.INTEGRATORS:
            raise InputError(f"unknown integrator {i!r}", key=keys[1], choices=integ_mod.INTEGRATORS)
        # every cell runs at one rtol: a fixed-step integrator has no rtol to run at
        if i not in adaptive:
            raise InputError(f"integrator {i!r} is fixed-step (h), and bench runs compares runs at one rtol",
                             key=keys[1], choices=adaptive)
    return methods, integrators


def _run_cell(mech, t_end, rtol, method, integrator, max_cpu, repeat):
    """Warm-up, then the best of up to ``repeat`` runs of one (scene, method, integrator) cell,
    and the Pinocchio floor at the run's samples measured once after each run and ten times at
    the end (the best of all: a phase of the machine that slows the runs slows the floor
    measured beside them); (None, None, reason) when the method or integrator refuses the scene."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            # warm-up: compiled kernels load from the cache (or compile) on a scene's first run
            simulate(mech, min(t_end, 1e-3), method=method, rtol=rtol, integrator=integrator, max_cpu=max_cpu)
        except PinclearError as exc:         # e.g. a closure type the method cannot express
            return None, None, f"{type(exc).__name__}: {' '.join(str(exc).split())}"
        # best of up to `repeat` runs (while they took under a CPU second together): a short
        # run's few hundred microseconds are at the mercy of the machine's other work
        tr, spent, floor = None, 0.0, np.inf
        for _ in range(repeat):
            run = simulate(mech, t_end, method=method, rtol=rtol, integrator=integrator, max_cpu=max_cpu,
                           dt_out=t_end / 100)
            spent += run.stats["cpu_s_total"]
            if tr is None or _integration_cpu(run) < _integration_cpu(tr):
                tr = run
            if len(run.t):
                floor = min(floor, pinocchio_floor(mech, run.q, run.v, repeat=1))
            if spent > 1.0:
                break
    if len(tr.t):
        floor = min(floor, pinocchio_floor(mech, tr.q, tr.v, repeat=10))
    return tr, floor, None


def bench_runs(files=None, t_end=0.5, rtol=1e-6, methods=("lagrange",), integrators=("RK45",), max_cpu=120.0,
               progress=None, repeat=20, integrator=None):
    """Simulate every scene for ``t_end`` simulated seconds with every (method, integrator) pair
    (default lagrange + RK45, rtol 1e-6: the clearance default) and report per cell: CPU s per
    simulated s, set-up CPU, right-hand-side evaluations, steps, events, us per evaluation
    inside the run (the integration's CPU over evaluations: integrator, events and output
    sampling included, set-up not) and its ratio over the Pinocchio floor measured at the run's
    own samples in the same process (after each run and at the end, the best). Each cell's
    figures come from the best of ``repeat`` runs, fewer once they used a CPU second; ``loop``
    says which integration loop ran. A cell whose method or integrator refuses the scene (a
    PinclearError before the run starts) is recorded with status ``skipped`` and the reason.
    ``integrator`` (one name) is the older spelling of ``integrators``. Result: ``scenes``, one
    row per cell (scene, method, integrator)."""
    from pinclear.io.sidecar import load

    if integrator is not None:
        integrators = (integrator,)
    methods, integrators = check_run_names(methods, integrators)
    rows = []
    for label, path, clr in scenes(files):
        mech = load(path, clearances=clr or None)
        for integ in integrators:
            for method in methods:
                if progress is not None:
                    progress(label if len(methods) * len(integrators) == 1 else f"{label} {method} + {integ}")
                row = {"scene": label, "method": method, "integrator": integ, "nv": mech.nv,
                       "closure_rows": mech.compiled.m, "drives": len(mech.drives),
                       "clearances": [f.name for f in mech.clearances]}
                tr, floor, why = _run_cell(mech, t_end, rtol, method, integ, max_cpu, repeat)
                if tr is None:
                    rows.append({**row, "status": "skipped", "reason": why})
                    continue
                st = tr.stats
                row.update({"status": tr.status, "t_reached": float(tr.t[-1]) if len(tr.t) else 0.0,
                            "cpu_s": st["cpu_s"], "rhs_evals": st["rhs_evals"], "steps": st["steps"],
                            "events": len(st["events"]), "loop": st["loop"]})
                sim_t = max(row["t_reached"], 1e-12)
                row["cpu_per_sim_s"] = st["cpu_s"] / sim_t
                # set-up (assembly, rank analysis, buffers) has its own target; an evaluation's cost
                # inside the run is the integration's CPU (integrator, events, samples) over evaluations
                row["setup_ms"] = 1e3 * st["setup_cpu_s"]
                row["us_per_eval"] = 1e6 * _integration_cpu(tr) / max(st["rhs_evals"], 1)
                row["us_per_eval_with_setup"] = 1e6 * st["cpu_s"] / max(st["rhs_evals"], 1)
                if len(tr.t):
                    row["floor_us"] = 1e6 * floor
                    row["ratio_over_floor"] = row["us_per_eval"] / row["floor_us"]
                if tr.status != "success":
                    row["message"] = tr.message
                rows.append(row)
    return {"t_end": t_end, "rtol": rtol, "methods": list(methods), "integrators": list(integrators),
            "max_cpu": max_cpu, "repeat": repeat, "scenes": rows}


def runs_table(res) -> str:
    """Markdown table of a bench_runs result (one row per cell; method and integrator columns
    when the result has more than one of either)."""
    many = len(res.get("methods", ())) > 1 or len(res.get("integrators", ())) > 1
    head = "| scene | " + ("method | integrator | " if many else "")
    lines = [head + "status | CPU s / sim s | set-up ms | rhs evals | steps | us / eval | floor us | ratio |",
             "|---|" + ("---|---|" if many else "") + "---|---|---|---|---|---|---|---|"]
    for r in res["scenes"]:
        lead = f"| {r['scene']} | " + (f"{r['method']} | {r['integrator']} | " if many else "")
        if r["status"] == "skipped":
            lines.append(lead + f"skipped: {r['reason'][:100]} | | | | | | | |")
            continue
        lines.append(lead + f"{r['status']} | {r['cpu_per_sim_s']:.3g} | {r['setup_ms']:.1f} | {r['rhs_evals']} | "
                     f"{r['steps']} | {r['us_per_eval']:.0f} | {r.get('floor_us', float('nan')):.1f} | "
                     f"{r.get('ratio_over_floor', float('nan')):.1f} |")
    return "\n".join(lines)


#: a cell costing more than this many times the Pinocchio floor per evaluation is counted
MATRIX_THRESHOLD = 3.0


def runs_matrix_table(res, threshold=MATRIX_THRESHOLD) -> str:
    """One markdown table per integrator of a bench_runs result: scenes as rows, methods as
    columns, each cell "ratio (us/eval)" (ratio over the Pinocchio floor); a failed run's cell
    is marked "failed:" before its figures, a skipped one "skipped". Then a summary line: the
    worst cell and how many cells exceed ``threshold`` times the floor (of the cells measured)."""
    methods, integs = res["methods"], res["integrators"]
    cells = {(r["scene"], r["method"], r["integrator"]): r for r in res["scenes"]}
    labels = list(dict.fromkeys(r["scene"] for r in res["scenes"]))
    out = []
    for integ in integs:
        out += [f"### {integ} (t_end {res['t_end']:g} s, rtol {res['rtol']:g}): ratio over the Pinocchio floor "
                "(us per evaluation)", "", "| scene | " + " | ".join(methods) + " |",
                "|---|" + "---|" * len(methods)]
        for label in labels:
            row = []
            for m in methods:
                r = cells.get((label, m, integ))
                if r is None:
                    row.append("-")
                elif r["status"] == "skipped":
                    row.append("skipped")
                elif "ratio_over_floor" not in r:
                    row.append(f"{r['status']}: no samples")
                else:
                    mark = "" if r["status"] == "success" else f"{r['status']}: "
                    row.append(f"{mark}{r['ratio_over_floor']:.1f} ({r['us_per_eval']:.0f})")
            out.append(f"| {label} | " + " | ".join(row) + " |")
        out.append("")
    measured = [r for r in res["scenes"] if "ratio_over_floor" in r]
    n_skip = sum(r["status"] == "skipped" for r in res["scenes"])
    n_fail = sum(r["status"] not in ("success", "skipped") for r in res["scenes"])
    if measured:
        w = max(measured, key=lambda r: r["ratio_over_floor"])
        over = sum(r["ratio_over_floor"] > threshold for r in measured)
        out.append(f"Summary: worst cell {w['scene']} / {w['method']} + {w['integrator']} at "
                   f"{w['ratio_over_floor']:.1f}x the floor ({w['us_per_eval']:.0f} us/eval, {w['status']}); "
                   f"{over} of {len(measured)} measured cells exceed {threshold:g}x; {n_fail} failed, "
                   f"{n_skip} skipped.")
    else:
        out.append(f"Summary: no cell measured; {n_fail} failed, {n_skip} skipped.")
    return "\n".join(out)


def main_rhs(path, methods=None, options=None, clearances=None, overrides=None):
    from pinclear.io.sidecar import load

    mech = load(path, options=options, clearances=clearances, overrides=overrides)
    return bench_rhs(mech, methods)


if __name__ == "__main__":  # pragma: no cover
    import sys

    print(json.dumps(main_rhs(sys.argv[1]), indent=2))


# ---------------------------------------------------------------------- outputs
#: the runs of the output benchmark: (bundled name, active clearances, method), the bundled scenes'
#: (pinclear.mechanisms.bench_scenes)
OUTPUT_CASES = bench_scenes.OUTPUT_CASES


@njit(cache=True)
def evaluate_all(system, T, X):
    """One evaluation at each state X[k], time T[k] (compiled loop: an evaluation's own cost)."""
    dx = np.zeros(X.shape[1])
    for k in range(X.shape[0]):
        evaluate_rhs(system, T[k], X[k], dx)


def bench_outputs(cases=OUTPUT_CASES, samples=(501, 5001, 20001), t_end=2.0, rtol=1e-6, repeat=3,
                  reference=(501, 5001), progress=None):
    """What a run costs outside its integration against its number of output samples, beside one evaluation's cost, all in this process: per case and sample count the
    best of ``repeat`` runs' CPU outside the integration (a whole simulate() less its cpu_s);
    the slope (per sample) and intercept (fixed cost) of a least-squares line through them, the
    slope in evaluations; the same for the per-sample Python path (outputs="python", the
    reference) at the ``reference`` counts."""
    import warnings

    from pinclear.io.sidecar import load

    out = {"t_end": t_end, "rtol": rtol, "cases": []}
    for name, clr, method in cases:
        mech = load(name, clearances=list(clr) or None)
        row = {"mechanism": name, "clearances": list(clr), "method": method, "compiled": {}, "python": {}}

        def outside(n, how):
            best, tr = np.inf, None
            for _ in range(repeat):
                c0 = time.process_time()
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    tr = simulate(mech, t_end, method=method, rtol=rtol, dt_out=t_end / (n - 1), outputs=how)
                best = min(best, time.process_time() - c0 - tr.stats["cpu_s"])
            return best, tr
        outside(samples[0], "compiled")               # warm-up: compiled kernels, first-call caches
        for how, counts in (("compiled", samples), ("python", reference)):
            for n in counts:
                cost, tr = outside(n, how)
                row[how][n] = {"outside_s": cost, "integration_s": tr.stats["cpu_s"], "steps": tr.stats["steps"],
                               "rhs_evals": tr.stats["rhs_evals"]}
                if progress:
                    progress(f"{name} {how} {n} samples: {cost * 1e3:.2f} ms outside, "
                             f"{tr.stats['cpu_s'] * 1e3:.1f} ms integrating")
        # one evaluation at the run's own sample states, compiled loop
        ev = Evaluation(formulations.get(method)(mech))
        X = np.array([ev.pack(q, v, z) for q, v, z in zip(tr.q, tr.v, tr.z)])
        T = np.array(tr.t)
        evaluate_all(ev.system, T[:2], X[:2])
        best = np.inf
        for _ in range(repeat):
            c0 = time.process_time()
            evaluate_all(ev.system, T, X)
            best = min(best, time.process_time() - c0)
        row["evaluation_s"] = best / len(T)
        for how in ("compiled", "python"):
            ns = np.array(sorted(row[how]), float)
            cost = np.array([row[how][int(n)]["outside_s"] for n in ns])
            slope, icpt = np.polyfit(ns, cost, 1)
            row[f"{how}_per_sample_s"], row[f"{how}_fixed_s"] = float(slope), float(icpt)
            row[f"{how}_per_sample_evaluations"] = float(slope / row["evaluation_s"])
        out["cases"].append(row)
    return out


def outputs_table(res) -> str:
    """The output benchmark as a Markdown table (docs/outputs.md)."""
    lines = ["| run | samples | integration | outside (compiled) | outside (Python path) |",
             "|---|---|---|---|---|"]
    for r in res["cases"]:
        label = f"{r['mechanism']}{' + ' + ','.join(r['clearances']) if r['clearances'] else ''}, {r['method']}"
        for n in sorted(set(r["compiled"]) | set(r["python"])):
            c, p = r["compiled"].get(n), r["python"].get(n)
            ms = ["" if x is None else f"{x['outside_s'] * 1e3:.2f} ms" for x in (c, p)]
            lines.append(f"| {label} | {n} | {(c or p)['integration_s'] * 1e3:.1f} ms | {ms[0]} | {ms[1]} |")
    lines += ["", "| run | one evaluation | per sample outside: compiled | = evaluations | fixed | "
              "per sample: Python path | = evaluations |", "|---|---|---|---|---|---|---|"]
    for r in res["cases"]:
        lines.append(f"| {r['mechanism']}, {r['method']} | {r['evaluation_s'] * 1e6:.2f} us | "
                     f"{r['compiled_per_sample_s'] * 1e6:.2f} us | {r['compiled_per_sample_evaluations']:.2f} | "
                     f"{r['compiled_fixed_s'] * 1e3:.2f} ms | {r['python_per_sample_s'] * 1e6:.2f} us | "
                     f"{r['python_per_sample_evaluations']:.2f} |")
    return "\n".join(lines)
