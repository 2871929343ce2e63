"""Clearance benchmarks (issue 4).

    python benchmarks/bench_clearance.py [--scenes NAME ...] [--cpu 60] [--json out.json]

1. Right-hand-side cost of each paper scene with its clearances against the same mechanism with
   ideal joints (lagrange formulation, the full ODE right-hand side the integrator calls), at a
   state taken from a short run where the clearance is in contact, and at the assembled state
   (out of contact). Target: <= 1.5x.
2. CPU seconds per simulated second at rtol 1e-6 for an explicit (RK45, DOP853) and an implicit
   (Radau, BDF) integrator, over a window of each scene, each run capped at --cpu seconds (a run
   that hits the cap reports the rate over the simulated time it reached); max_step 1 ms for all
   (see pinclear.mechanisms.clearance_scenes.run).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
import warnings

import numpy as np

import pinclear
from pinclear.dynamics import formulations
from pinclear.model import kinematics
from pinclear.mechanisms import clearance_scenes as scenes
from pinclear.dynamics.stepping.build import Evaluation

#: simulated window per scene for the integrator comparison (s)
WINDOW = {"four_ups_upu_S2": 1.0, "nine_bar_A": 0.5, "nine_bar_B": 0.5, "nine_bar_AB": 0.5,
          "three_upru_up_P": 0.1}
INTEGRATORS = ("RK45", "DOP853", "Radau", "BDF")


def _time(fn, budget):
    """Seconds per call of fn, over repeated calls for about ``budget`` seconds."""
    fn()
    n, t0 = 0, time.perf_counter()
    while True:
        fn()
        n += 1
        dt = time.perf_counter() - t0
        if dt > budget:
            return dt / n


def rhs_time(mech, q, v, z):
    sysf = Evaluation(formulations.get("lagrange")(mech))
    x = sysf.pack(q, v, z)
    # the same state every call: the contact caches hit after the first (an upper bound on speed;
    # `pinclear bench runs` measures along real trajectories)
    return _time(lambda: sysf(0.0, x), 0.2)


def bench_rhs_scene(name):
    ideal, clr = scenes.load(name)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tr = pinclear.simulate(clr, 0.05 if "three" not in name else 0.01, rtol=1e-6, dt_out=1e-3)
    fn = sum(tr.outputs[f"{f.name}.fn"] for f in clr.clearances)
    i = int(np.argmax(fn > 0)) if np.any(fn > 0) else len(tr.t) - 1
    i = max(i, int(np.flatnonzero(fn > 0)[-1])) if np.any(fn > 0) else i
    q, v = tr.q[i], tr.v[i]
    # in contact since an onset at 1 cm/s (the value does not change the cost)
    zc = np.zeros(clr.nz)
    for k, f in enumerate(clr.forces):
        if f.is_clearance:
            zc[clr.z_slices[k]][: f.nc] = 0.01
    ws = clr.workspace()
    kinematics.update(clr, ws, q, v)
    touching = sum(int(np.sum(f.event_values(clr, ws, d, 0.0, q, v, zc[sl]) > 0))
                   for f, d, sl in zip(clr.forces, ws.force_data, clr.z_slices) if f.is_clearance)
    q0 = kinematics.assemble(ideal)
    v0 = kinematics.consistent_velocity(ideal, q0, ideal.v0)
    t_ideal = rhs_time(ideal, q0, v0, np.zeros(ideal.nz))
    t_free = rhs_time(clr, q0, v0, np.zeros(clr.nz))
    t_contact = rhs_time(clr, q, v, zc)
    return {"scene": name, "ideal_us": t_ideal * 1e6, "clearance_free_us": t_free * 1e6,
            "clearance_contact_us": t_contact * 1e6, "ratio_free": t_free / t_ideal,
            "ratio_contact": t_contact / t_ideal, "contact_channels": touching}


def bench_integrators(name, cpu):
    rows = []
    for integ in INTEGRATORS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = scenes.run(name, t_end=WINDOW[name], integrator=integ, rtol=1e-6, max_cpu=cpu, ideal=False)
        tr = res["clearance"]
        reached = float(tr.t[-1]) if len(tr.t) else 0.0
        rows.append({"scene": name, "integrator": integ, "status": tr.status, "t_reached": reached,
                     "cpu_s": res["cpu"], "cpu_per_sim_s": res["cpu"] / max(reached, 1e-12),
                     "rhs_evals": tr.stats["rhs_evals"], "steps": tr.stats["steps"],
                     "events": len(tr.stats["events"]), "message": tr.message})
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", default=list(scenes.SCENES), choices=list(scenes.SCENES))
    ap.add_argument("--cpu", type=float, default=60.0, help="CPU cap per integrator run, s")
    ap.add_argument("--skip-integrators", action="store_true")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    out = {"rhs": [], "integrators": []}
    print("right-hand side (lagrange, full ODE rhs), microseconds")
    print(f"{'scene':18s} {'ideal':>8s} {'clr free':>9s} {'clr contact':>12s} {'ratio free':>11s} {'ratio contact':>14s}")
    for name in a.scenes:
        r = bench_rhs_scene(name)
        out["rhs"].append(r)
        print(f"{name:18s} {r['ideal_us']:8.1f} {r['clearance_free_us']:9.1f} {r['clearance_contact_us']:12.1f} "
              f"{r['ratio_free']:11.2f} {r['ratio_contact']:14.2f}", flush=True)
    if not a.skip_integrators:
        print("\nCPU s per simulated s at rtol 1e-6 (window per scene; * = stopped at the CPU cap)")
        print(f"{'scene':18s} {'integrator':10s} {'window':>7s} {'reached':>8s} {'cpu s':>7s} {'s/s':>8s} "
              f"{'rhs':>8s} {'events':>7s}")
        for name in a.scenes:
            for r in bench_integrators(name, a.cpu):
                out["integrators"].append(r)
                star = "*" if r["status"] != "success" else " "
                rate = f"{r['cpu_per_sim_s']:7.1f}{star}" if r["t_reached"] > 1e-3 * WINDOW[name] else "  failed"
                print(f"{name:18s} {r['integrator']:10s} {WINDOW[name]:7.3g} {r['t_reached']:8.4f} {r['cpu_s']:7.1f} "
                      f"{rate} {r['rhs_evals']:8d} {r['events']:7d}"
                      + ("" if r["status"] == "success" else f"  [{r['message'][:90]}]"), flush=True)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(out, fh, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
