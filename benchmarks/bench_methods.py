"""Cost of one right-hand-side evaluation inside a real run, per bundled scene and formulation,
against lagrange's and against the Pinocchio floor, measured in the same process.

    python benchmarks/bench_methods.py [--scenes four_bar nine_bar+A] [--methods lagrange proximal]
                                       [--t-end 0.5] [--repeat 5] [--budget 2] [--json out.json]

Every scene of ``pinclear.studies.bench.rhs.scenes()`` (each sidecar with ideal joints and once per clearance
joint it declares) is run with RK45, rtol 1e-6, for ``t_end`` simulated seconds. An evaluation's
cost is the integration's CPU over its evaluations, ``(cpu_s - setup_cpu_s) / rhs_evals``: what
one evaluation costs in a run, step logic, events and output samples included, set-up not. Each
figure is the best of up to ``repeat`` runs (fewer once they spent ``budget`` CPU seconds): a
short run's milliseconds are at the mercy of the machine's other work, the minimum is the run's
own cost. The floor is ``pinclear.studies.bench.rhs.pinocchio_floor`` (computeAllTerms + frame placements)
over the run's own samples, in this process.

A run's cost per evaluation also carries the projections of the methods that project (after
every step and on every output sample: 101 here, as many as the evaluations of a smooth ideal
scene's 0.5 s). The column "rhs us" separates the right-hand side itself: the run's compiled
evaluation (pinclear.dynamics.stepping.system.evaluate on the run's System) timed alone in a compiled
loop over the run's samples, and "rhs / lagrange" its ratio to lagrange's at the same states.
Samples of a projecting method lie on the constraint manifold; the stage states an integrator
evaluates do not, and the manifold formulation's Gauss-Newton iterations grow with their
distance. "stages us" times the same compiled evaluation at the run's own stage states (every
state the run evaluated, recorded from the Python path, which takes the same steps), "stages /
lagrange" against lagrange's at its own run's stage states.

Targets: every (scene, method) within 3x the floor; proximal and manifold within 2x lagrange.
"""
from __future__ import annotations

import argparse
import json
import sys
import warnings

import numpy as np

import time
from unittest import mock

from pinclear.dynamics import formulations
from pinclear.model import kinematics
from pinclear import load
from pinclear.studies.bench.rhs import pinocchio_floor, scenes
from pinclear.dynamics.simulate import simulate
from pinclear.core.jit import njit
from pinclear.dynamics.stepping.build import Evaluation
from pinclear.dynamics.stepping.system import evaluate

METHODS = ("lagrange", "projection", "proximal", "manifold")


def _cost(tr):
    st = tr.stats
    return (st["cpu_s"] - st["setup_cpu_s"]) / max(st["rhs_evals"], 1)


def measure(mech, method, t_end, repeat, budget):
    """(best run, its seconds per evaluation, floor seconds per state) of one scene and method."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        # warm-up: kernels load from numba's cache (or compile) on a method's first run
        simulate(mech, min(t_end, 1e-3), method=method, rtol=1e-6, max_cpu=120.0)
        best, spent = None, 0.0
        for _ in range(repeat):
            tr = simulate(mech, t_end, method=method, rtol=1e-6, max_cpu=120.0, dt_out=t_end / 100)
            spent += tr.stats["cpu_s_total"]
            if best is None or _cost(tr) < _cost(best):
                best = tr
            if spent > budget:
                break
    floor = pinocchio_floor(mech, best.q, best.v, repeat=10) if len(best.t) else np.nan
    return best, _cost(best), floor


@njit(cache=False)
def _evaluate_all(system, T, X, dx, repeat):
    for _ in range(repeat):
        for k in range(T.shape[0]):
            evaluate(system, T[k], X[k], dx)


def stage_states(mech, method, t_end):
    """(t, q, v, z) of every evaluation of the run measure() times, in order: the same run on the
    Python path (the same steps: tests/test_fastloop.py), its formulation's accelerations
    wrapped to record the states they are called with. The trajectory's outputs evaluate the
    accelerations once more at every sample after the integration, and a failed run's last
    evaluation is not one of its counted evaluations: those calls are dropped."""
    cls = formulations.get(method)
    real, seen = cls.accelerations, []

    def record(self, t, q, v, z):
        seen.append((float(t), np.array(q), np.array(v), np.array(z)))
        return real(self, t, q, v, z)

    with warnings.catch_warnings(), mock.patch.object(cls, "accelerations", record):
        warnings.simplefilter("ignore")
        tr = simulate(mech, t_end, method=method, rtol=1e-6, max_cpu=120.0, dt_out=t_end / 100, loop="python")
    n = tr.stats["rhs_evals"]
    # a run that failed recorded the evaluation that failed too (not counted, not timed here)
    if len(seen) - len(tr.t) not in (n, n + (tr.status != "success")):
        raise RuntimeError(f"{mech.name} {method}: {len(seen)} evaluations recorded, expected the run's {n} and "
                           f"one per sample ({len(tr.t)})")
    return seen[:n]


def rhs_cost(mech, method, tr, repeat=5, inner=20, states=None):
    """Seconds per evaluation of the method's compiled right-hand side at the run's samples, or at
    ``states`` ((t, q, v, z) tuples: stage_states) (rows chosen at the first sample as simulate
    chooses them), in a compiled loop: best mean of ``repeat`` timings of ``inner`` sweeps."""
    form = formulations.get(method)(mech)
    J = kinematics.jacobian(mech, form.ws, tr.q[0], float(tr.t[0]), with_drives=True)
    form.use_rows(kinematics.rank_analysis(J, mech.row_names())[1])
    ev = Evaluation(form)
    if states is None:
        states = [(tr.t[k], tr.q[k], tr.v[k], tr.z[k]) for k in range(len(tr.t))]
    X = np.array([ev.pack(q, v, z) for _, q, v, z in states])
    T = np.array([t for t, _, _, _ in states], dtype=float)
    dx = np.empty(X.shape[1])
    _evaluate_all(ev.system, T, X, dx, 1)            # warm-up
    best = np.inf
    for _ in range(repeat):
        t0 = time.process_time()
        _evaluate_all(ev.system, T, X, dx, inner)
        best = min(best, (time.process_time() - t0) / (inner * len(T)))
    return best


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--scenes", nargs="*", help="scene labels (default: every bundled scene)")
    p.add_argument("--methods", nargs="*", default=list(METHODS))
    p.add_argument("--t-end", type=float, default=0.5)
    p.add_argument("--repeat", type=int, default=5)
    p.add_argument("--budget", type=float, default=2.0, help="CPU seconds of repeated runs per cell")
    p.add_argument("--json", help="write the rows to this file")
    a = p.parse_args(argv)
    rows = []
    print("| scene | method | status | loop | evals | us/eval | floor us | / floor | / lagrange | rhs us | rhs / lagrange "
          "| stages us | stages / lagrange |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for label, path, clr in scenes():
        if a.scenes and label not in a.scenes:
            continue
        mech = load(path, clearances=clr or None)
        ref = ref_rhs = ref_stages = None
        for method in a.methods:
            try:
                tr, cost, floor = measure(mech, method, a.t_end, a.repeat, a.budget)
            except Exception as exc:             # a method that refuses the scene says why
                row = {"scene": label, "method": method, "status": f"refused: {type(exc).__name__}: {exc}"}
                rows.append(row)
                print(f"| {label} | {method} | {row['status'][:60]} | | | | | | | | |", flush=True)
                continue
            rhs = rhs_cost(mech, method, tr) if len(tr.t) > 1 else np.nan
            stages = rhs_cost(mech, method, tr, states=stage_states(mech, method, a.t_end)) if len(tr.t) > 1 else np.nan
            if method == "lagrange":
                ref, ref_rhs, ref_stages = cost, rhs, stages
            loop = tr.stats["loop"]
            row = {"scene": label, "method": method, "status": tr.status, "t_reached": float(tr.t[-1]),
                   "loop": loop, "rhs_evals": tr.stats["rhs_evals"], "us_per_eval": 1e6 * cost,
                   "floor_us": 1e6 * floor, "over_floor": cost / floor,
                   "over_lagrange": cost / ref if ref else float("nan"), "rhs_us": 1e6 * rhs,
                   "rhs_over_lagrange": rhs / ref_rhs if ref_rhs else float("nan"), "stages_us": 1e6 * stages,
                   "stages_over_lagrange": stages / ref_stages if ref_stages else float("nan")}
            rows.append(row)
            status = tr.status if tr.status == "success" else f"{tr.status} at {tr.t[-1]:.3g}"
            print(f"| {label} | {method} | {status} | {'compiled' if loop == 'compiled' else 'python'} | "
                  f"{row['rhs_evals']} | {row['us_per_eval']:.1f} | {row['floor_us']:.1f} | "
                  f"{row['over_floor']:.2f} | {row['over_lagrange']:.2f} | {row['rhs_us']:.1f} | "
                  f"{row['rhs_over_lagrange']:.2f} | {row['stages_us']:.1f} | {row['stages_over_lagrange']:.2f} |",
                  flush=True)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1)
    return rows


if __name__ == "__main__":
    sys.exit(0 if main() is not None else 1)
