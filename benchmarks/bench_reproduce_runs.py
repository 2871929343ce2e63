"""The integration of the paper reproductions' runs against a baseline tree, side by side
(issue 40, item 4: cheaper runs, the same trajectories bit for bit).

    python benchmarks/bench_reproduce_runs.py --base DIR [--repeat 5] [--cases 000,002]

DIR is another commit's tree with its compiled extension (e.g. ``git archive`` of main plus its
``pinclear/_passes*.so``). Each case is one bifurcation value of a reproduction, run as the
reproduction runs it (pinclear.analysis.bifurcation, in-process):

* 000: paper 000's 4UPS-UPU with the spherical clearance S2, mu = 0.05, lagrange + RK45 at the
  default rtol (1e-8), period 2 s, 2 transient + 8 recorded periods, the paper's output grid;
* 002: paper 002's nine-bar with revolute clearances A and B of 0.1 mm, mu = 0.3, lagrange +
  RK45 at rtol 1e-6, crank period 1 s, 2 + 8 cycles, 100 samples per cycle.

Each run is one process (PYTHONPATH = the tree), warmed by a one-period run of the same case
(kernels loaded), then timed; the trees alternate, ``repeat`` times. Printed per case: the
integration CPU (stats['cpu_s'], compilation excluded) of each tree, the ratios of the medians
and of the minima (this tree / base), evaluations and steps of both, and whether t, q and v at
every sample are bitwise equal (np.array_equal) to the base tree's."""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parents[1]


def _case_000(cycles, transient):
    from pinclear import analysis
    from pinclear.core.models import model_path
    from pinclear.studies.reproduce import paper000 as P
    s = P._settings(False, None)
    return analysis.bifurcation(
        str(model_path("four_ups_upu")), "S2.mu", [0.05], period=P.T, signal=P.SIGNALS, cycles=cycles,
        transient=transient, per_period=s["per_period"], keep_portrait=True, executor="serial",
        load_options={"clearances": ["S2"], "overrides": dict(s.get("overrides", {}))})


def _case_002(cycles, transient):
    from pinclear import analysis
    from pinclear.core.models import model_path
    from pinclear.studies.reproduce import paper002 as P
    s = P._settings(False)
    mu = {f"{j}.mu": s["mu (sec. 4)"] for j in P.JOINTS}
    return analysis.bifurcation(
        model_path("nine_bar"), {f"{j}.clearance": 1.0 for j in P.JOINTS}, [1e-4], period=1.0, signal=P.SIGNALS,
        cycles=cycles, transient=transient, per_period=100, keep_portrait=True, executor="serial",
        sim_options=dict(method="lagrange", integrator="RK45", rtol=P.RTOL),
        load_options=dict(clearances=list(P.JOINTS), overrides={**s.get("overrides", {}), **mu}))


CASES = {"000": _case_000, "002": _case_002}


def worker(case, out):
    """One warm run of ``case`` in this process's pinclear; its samples to ``out`` (npz), its
    figures as a JSON line."""
    warnings.simplefilter("ignore")
    from pinclear.dynamics.stepping import run as R
    kept = []
    integrate = R.Run.integrate

    def keep(self, *a, **k):
        res = integrate(self, *a, **k)
        kept.append(res)
        return res
    R.Run.integrate = keep
    CASES[case](1, 0)                                     # loads the compiled kernels
    kept.clear()
    res = CASES[case](8, 2)
    run = res.runs[0]
    s = kept[-1].samples
    np.savez(out, t=np.asarray(s.t), q=np.asarray(s.q), v=np.asarray(s.v))
    print(json.dumps({"cpu_s": run.stats["cpu_s"], "evals": run.stats["rhs_evals"], "steps": run.stats["steps"],
                      "status": run.status}), flush=True)


def _one(tree, case, out):
    env = dict(os.environ, PYTHONPATH=str(tree))
    res = subprocess.run([sys.executable, __file__, "--worker", case, "--out", str(out)], env=env,
                         capture_output=True, text=True, check=True, cwd=tree)
    return json.loads(res.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", help="the baseline tree (with its compiled extension)")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--cases", default="000,002")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    ap.add_argument("--out", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.worker:
        return worker(a.worker, a.out)
    if not a.base:
        ap.error("--base DIR is required")
    trees = {"base": Path(a.base).resolve(), "this": HERE}
    tmp = Path(tempfile.mkdtemp(prefix="bench_reproduce_runs_"))
    for case in a.cases.split(","):
        got = {k: [] for k in trees}
        for rep in range(a.repeat):
            for name, tree in trees.items():
                got[name].append(_one(tree, case, tmp / f"{case}_{name}.npz"))
        base, this = (np.load(tmp / f"{case}_{k}.npz") for k in ("base", "this"))
        equal = all(np.array_equal(base[k], this[k]) for k in ("t", "q", "v"))
        cpu = {k: [r["cpu_s"] for r in v] for k, v in got.items()}
        med = {k: statistics.median(v) for k, v in cpu.items()}
        low = {k: min(v) for k, v in cpu.items()}
        print(f"case {case}: integration CPU [s] base {[round(x, 3) for x in cpu['base']]}, "
              f"this {[round(x, 3) for x in cpu['this']]}")
        print(f"  median {med['this']:.3f} / {med['base']:.3f} = {med['this'] / med['base']:.3f}x, "
              f"min {low['this']:.3f} / {low['base']:.3f} = {low['this'] / low['base']:.3f}x")
        print(f"  evaluations {got['this'][0]['evals']} (base {got['base'][0]['evals']}), steps "
              f"{got['this'][0]['steps']} (base {got['base'][0]['steps']}), samples {len(this['t'])}, "
              f"t, q, v bitwise equal: {equal}", flush=True)


if __name__ == "__main__":
    main()
