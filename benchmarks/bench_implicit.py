"""pinclear's implicit integrator ROS34PW2 against the explicit ones and SciPy's implicit ones.

    nice python benchmarks/bench_implicit.py [--parts odes,choice,scenes,floor,friction,policy]
                                             [--t-end 0.3] [--max-cpu 60] [--json out.json]

Everything in one process; CPU is the integration's (process time, kernels compiled or loaded
by a warm-up run first, set-up excluded), ratios are against a baseline run in the same process.

1. odes: the IVP Test Set's VDPOL (eps = 1e-6, t = 2) and ROBER (t = 1e11; t = 40 for the
   explicit methods, which a stiff problem holds to steps of its stability bound), compiled
   right-hand sides, every integrator through the same step logic (SciPy's Radau and LSODA step
   through pinclear.dynamics.stepping.external's callbacks). Error against the Test Set's reference
   (ROBER at 40: against Radau at rtol 1e-12).
2. choice: why ROS34PW2: evaluations to the same problems with ROS3PW (a 3-stage W-method of
   order 2 only), RODASP (order 4, needs the exact Jacobian: one every step) and ROS34PW2 with a
   Jacobian every step (what reuse saves).
3. scenes: the bundled clearance scenes (pinclear.studies.bench.rhs.scenes()), rtol 1e-6, --t-end s: CPU,
   evaluations, steps, Jacobians, energy audit; CPU ratio to RK45.
4. floor: us per evaluation inside those runs over the Pinocchio floor
   (pinclear.studies.bench.rhs.pinocchio_floor at the run's samples), method lagrange: target <= 3.
5. friction: stiff contact: three scenes with regularised Coulomb friction (v_eps = 1e-6 m/s:
   a sticking contact's friction is a damper of mu F_n / v_eps), rtol 1e-4 and 1e-6, 0.1 s.
6. policy: the Jacobian and error-estimate choices of pinclear.dynamics.stepping.rosenbrock on the
   clearance scenes over 0.05 s: the default, a Jacobian every step, a looser and a tighter
   secant test, no dense-output test (events located on an unchecked interpolant).
"""
from __future__ import annotations

import argparse
import json
import sys
import time
import types
import warnings
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

import pinclear
from pinclear.studies.bench.rhs import pinocchio_floor, scenes
from pinclear.core.models import model_path
from pinclear.dynamics.stepping import INTEGRATORS, chunk as C, rosenbrock as R, rosenbrock_peers as peers
from pinclear.dynamics.stepping.base import MethodState
from pinclear.dynamics.stepping.checks import reset_monitor
from pinclear.dynamics.stepping.run import STALL_STEPS
from pinclear.dynamics.stepping.state import ATOL, H_STALL, MAX_STEP, NJAC, RTOL, STEPS, T, T_BOUND, new_steps
from pinclear.dynamics.stepping.system import ode_system

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from stiff_odes import ROBER_REF, VDPOL_REF, rober, vdpol  # noqa: E402  (the tests' problems)


# ----------------------------------------------------------------------------- stiff ODEs
def _rober_py(t, y):
    return [-0.04 * y[0] + 1e4 * y[1] * y[2], 0.04 * y[0] - 1e4 * y[1] * y[2] - 3e7 * y[1] ** 2, 3e7 * y[1] ** 2]


class Ode:
    """A System around a callback reading x from the head of one buffer and writing its rates
    after it (the first nc states have dc/dt = v)."""

    def __init__(self, stage, n, nc):
        self.n, self.nc = n, nc
        self.sys, self.buf = ode_system(stage.address, n, nc)

    def run(self, name, y0, t1, rtol, atol, max_evals=5e7, method=None):
        """Integrate with integrator ``name`` (or the Rosenbrock ``method``); a dict of the
        figures. Explicit methods stop after max_evals evaluations."""
        method = method or INTEGRATORS[name]
        st = new_steps(self.n, 0, [t1], method.rows, 0, C.SEARCH_STATE, STALL_STEPS)
        st.r[T_BOUND], st.r[MAX_STEP], st.r[H_STALL], st.r[RTOL] = t1, np.inf, 0.0, rtol
        st.V[ATOL] = atol
        reset_monitor(st.r)
        run = types.SimpleNamespace(system=self.sys, st=st, errors=[], mech=None)
        if isinstance(method, R.Rosenbrock):
            own = MethodState(R.rosenbrock_tableau(method.coeffs),
                              R.work_array(self.n, self.nc, False, (), method.max_age, method.secant, method.filtered,
                                           method.dense))
        else:
            own = method.setup(run)
        run.st = st = st._replace(W=own.W)
        self.sys.count[0] = 0
        t0 = time.process_time()
        C.start(self.sys, own.tab, st, 0.0, np.asarray(y0, float), -1.0, -1)
        method.restart(own, st, 0.0, y0, None)
        run.tab = own.tab
        status = "success"
        while True:
            code = C.advance(self.sys, run.tab, run.st, 1000)
            if code == C.FINISHED:
                break
            if code != C.QUIET:
                status = f"failed ({code})"
                break
            if self.sys.count[0] > max_evals:
                status = f"capped at t = {run.st.r[T]:.3g}"
                break
        cpu = time.process_time() - t0
        return {"status": status, "steps": int(run.st.i[STEPS]), "evals": int(self.sys.count[0]),
                "jacobians": int(run.st.i[NJAC]), "cpu": cpu, "y": run.st.samples[-1].copy()}


ODE_METHODS = ("ROS34PW2", "RK45", "DOP853", "Radau", "LSODA")


def ode_problems():
    rober40 = solve_ivp(_rober_py, (0.0, 40.0), [1.0, 0.0, 0.0], method="Radau", rtol=1e-12,
                        atol=[1e-18, 1e-24, 1e-18]).y[:, -1]
    return [("VDPOL t=2", Ode(vdpol, 2, 1), [2.0, 0.0], 2.0, VDPOL_REF, lambda r: r),
            ("ROBER t=40", Ode(rober, 3, 0), [1.0, 0.0, 0.0], 40.0, rober40, _rober_atol),
            ("ROBER t=1e11", Ode(rober, 3, 0), [1.0, 0.0, 0.0], 1e11, ROBER_REF, _rober_atol)]


def _rober_atol(rtol):
    """The Test Set's scaling of ROBER's absolute tolerances (y2 runs from 1e-5 to 1e-13)."""
    return np.array([1e-6, 1e-12, 1e-6]) * rtol


def _err(y, ref, rtol, atol):
    """The error in units of the tolerance: max_i |y_i - ref_i| / (rtol |ref_i| + atol_i)."""
    return float(np.max(np.abs(y - ref) / (rtol * np.abs(ref) + atol)))


def bench_odes(rtols=(1e-4, 1e-6, 1e-8)):
    rows = []
    for label, ode, y0, t1, ref, atolf in ode_problems():
        for rtol in rtols:
            base = None
            for name in ODE_METHODS:
                if name in ("RK45", "DOP853") and "1e11" in label:
                    continue                      # stability-bound steps: ~1e14 of them
                ode.run(name, y0, min(t1, 1e-3), rtol, atolf(rtol))          # warm-up
                res = ode.run(name, y0, t1, rtol, atolf(rtol))
                res.update(problem=label, rtol=rtol, method=name,
                           err=_err(res["y"], ref, rtol, atolf(rtol)) if res["status"] == "success" else None)
                base = base or res
                res["cpu_ratio"] = res["cpu"] / base["cpu"]
                rows.append(res)
    return rows


CHOICES = [("ROS34PW2", R.ROS34PW2),
           ("ROS34PW2, Jacobian every step", R.Rosenbrock("ROS34PW2", R.ROS34PW2_COEFFS, max_age=1)),
           ("ROS3PW (W-order 2)", R.Rosenbrock("ROS3PW", peers.ROS3PW_COEFFS)),
           ("RODASP (Jacobian every step)", R.Rosenbrock("RODASP", peers.RODASP_COEFFS, max_age=1))]
#: clearance scenes without drives (autonomous: RODASP needs no df/dt there) for the choice
CHOICE_SCENES = (("clr_planar_pendulum", "A"), ("clr_pendulum", "S"), ("clr_hinge", "R"), ("clr_slider", "P"))


def bench_choice(rtol=1e-6, t_end=0.05, max_cpu=60.0):
    """Evaluations and CPU of alternative Rosenbrock methods, the same step logic and policy
    where it applies, on the ODEs and on autonomous clearance scenes (plain, and with the stiff
    friction of bench_friction)."""
    rows = []
    for label, ode, y0, t1, ref, atolf in ode_problems():
        base = None
        for name, meth in CHOICES:
            ode.run(None, y0, min(t1, 1e-3), rtol, atolf(rtol), method=meth)
            res = ode.run(None, y0, t1, rtol, atolf(rtol), method=meth)
            res.update(problem=label, rtol=rtol, method=name, err=_err(res["y"], ref, rtol, atolf(rtol)))
            base = base or res
            res["cpu_ratio"] = res["cpu"] / base["cpu"]
            rows.append(res)
    keep = INTEGRATORS["ROS34PW2"]
    try:
        for scene, clr in CHOICE_SCENES:
            for over in (None, {f"{clr}.friction_law": {"type": "coulomb", "mu": 0.3, "v_eps": 1e-6}}):
                mech = pinclear.load(scene, clearances=[clr], overrides=over)
                assert not mech.drives
                base = None
                for name, meth in CHOICES:
                    INTEGRATORS.replace(meth)
                    _quiet(mech, 1e-3, integrator="ROS34PW2", rtol=rtol)
                    tr = _quiet(mech, t_end, integrator="ROS34PW2", rtol=rtol, max_cpu=max_cpu)
                    res = {"problem": f"{scene}+{clr}" + (" coulomb v_eps=1e-6" if over else "") + f" {t_end} s",
                           "rtol": rtol, "method": name, "status": tr.status, "steps": tr.stats["steps"],
                           "evals": tr.stats["rhs_evals"], "jacobians": tr.stats["jacobians"], "cpu": _cpu(tr),
                           "err": None, "energy_ok": tr.summary()["energy_balance"]["ok"]}
                    base = base or res
                    res["cpu_ratio"] = res["cpu"] / base["cpu"]
                    rows.append(res)
    finally:
        INTEGRATORS.replace(keep)
    return rows


# ----------------------------------------------------------------------------- mechanisms
def _quiet(mech, t_end, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return pinclear.simulate(mech, t_end, **kw)


def _cpu(tr):
    return tr.stats["cpu_s"] - tr.stats["setup_cpu_s"]


def _row(label, integ, tr):
    eb = tr.summary()["energy_balance"]
    return {"scene": label, "integrator": integ, "status": tr.status, "t": float(tr.t[-1]) if len(tr.t) else 0.0,
            "cpu": _cpu(tr), "evals": tr.stats["rhs_evals"], "steps": tr.stats["steps"],
            "jacobians": tr.stats.get("jacobians"), "events": len(tr.stats["events"]),
            "energy_ok": bool(eb["ok"]), "energy_error": float(eb["error"])}


def clearance_scenes():
    return [(label, path, clr) for label, path, clr in scenes() if "+" in label]


def bench_scenes(t_end, max_cpu, rtol=1e-6, integrators=("RK45", "DOP853", "ROS34PW2", "Radau", "LSODA"),
                 overrides=None, which=None, progress=print):
    """Every integrator on the clearance scenes; with the ROS34PW2 runs' us per evaluation over
    the Pinocchio floor."""
    rows = []
    for label, path, clr in which or clearance_scenes():
        mech = pinclear.load(path, clearances=clr or None, overrides=overrides)
        base = None
        for integ in integrators:
            _quiet(mech, 1e-3, integrator=integ, rtol=rtol, max_cpu=max_cpu)
            tr = _quiet(mech, t_end, integrator=integ, rtol=rtol, max_cpu=max_cpu, dt_out=t_end / 100)
            row = _row(label, integ, tr)
            row["rtol"] = rtol
            base = base or row
            row["cpu_ratio"] = row["cpu"] / base["cpu"]
            if integ in ("RK45", "ROS34PW2") and len(tr.t):
                floor = pinocchio_floor(mech, tr.q, tr.v, repeat=5)
                row["us_per_eval"] = 1e6 * row["cpu"] / max(row["evals"], 1)
                row["floor_us"] = 1e6 * floor
                row["over_floor"] = row["us_per_eval"] / row["floor_us"]
            rows.append(row)
            if progress:
                progress(f"  {label} {integ}: {row['status']} cpu {row['cpu']:.3f} evals {row['evals']}")
    return rows


FRICTION_SCENES = (("clr_planar_pendulum", "A"), ("clr_hinge", "R"), ("nine_bar", "A"))


def bench_friction(max_cpu, t_end=0.1, v_eps=1e-6):
    rows = []
    for scene, clr in FRICTION_SCENES:
        path = model_path(scene)
        over = {f"{clr}.friction_law": {"type": "coulomb", "mu": 0.3, "v_eps": v_eps}}
        for rtol in (1e-4, 1e-6):
            rows += bench_scenes(t_end, max_cpu, rtol=rtol, overrides=over, progress=None,
                                 which=[(f"{scene}+{clr} coulomb v_eps={v_eps:g}", path, [clr])])
    return rows


POLICIES = {"default (secant 1, filtered, dense test)": {},
            "Jacobian every step": {"max_age": 1},
            "secant 0.3": {"secant": 0.3},
            "no secant test (rejections only)": {"secant": np.inf},
            "no dense-output test": {"dense": False}}


def bench_policy(max_cpu, t_end=0.05, rtol=1e-6):
    rows = []
    keep = INTEGRATORS["ROS34PW2"]
    try:
        for label, path, clr in clearance_scenes():
            mech = pinclear.load(path, clearances=clr or None)
            ref = _quiet(mech, t_end, integrator="DOP853", rtol=1e-10, max_cpu=max_cpu)
            for name, kw in POLICIES.items():
                INTEGRATORS.replace(R.Rosenbrock("ROS34PW2", R.ROS34PW2_COEFFS, **kw))
                tr = _quiet(mech, t_end, integrator="ROS34PW2", rtol=rtol, max_cpu=max_cpu)
                row = _row(label, name, tr)
                row["same_events"] = ([e["event"] for e in tr.stats["events"]] ==
                                      [e["event"] for e in ref.stats["events"]])
                rows.append(row)
    finally:
        INTEGRATORS.replace(keep)
    return rows


# ----------------------------------------------------------------------------- tables
def table_odes(rows):
    out = ["| problem | rtol | integrator | status | steps | evals | Jacobians | CPU ms | x ROS34PW2 | error / tol |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        err = "" if r["err"] is None else f"{r['err']:.2g}"
        out.append(f"| {r['problem']} | {r['rtol']:g} | {r['method']} | {r['status']} | {r['steps']} | {r['evals']} | "
                   f"{r['jacobians']} | {1e3 * r['cpu']:.2f} | {r.get('cpu_ratio', float('nan')):.2f} | {err} |")
    return "\n".join(out)


def table_scenes(rows, floor=False):
    head = "| scene | rtol | integrator | status | CPU s | x first | evals | steps | Jacobians | events | energy |"
    out = [head, "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        out.append(f"| {r['scene']} | {r['rtol']:g} | {r['integrator']} | {r['status']} | {r['cpu']:.3f} | "
                   f"{r['cpu_ratio']:.2f} | {r['evals']} | {r['steps']} | {r['jacobians'] or ''} | {r['events']} | "
                   f"{'ok' if r['energy_ok'] else 'FAILED'} |")
    if floor:
        out += ["", "| scene | integrator | us / eval | floor us | ratio |", "|---|---|---|---|---|"]
        for r in rows:
            if "over_floor" in r:
                out.append(f"| {r['scene']} | {r['integrator']} | {r['us_per_eval']:.2f} | {r['floor_us']:.2f} | "
                           f"{r['over_floor']:.2f} |")
    return "\n".join(out)


def table_policy(rows):
    out = ["| scene | policy | status | evals | steps | Jacobians | events as DOP853 1e-10 | energy |",
           "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        same, energy = "yes" if r["same_events"] else "no", "ok" if r["energy_ok"] else "FAILED"
        out.append(f"| {r['scene']} | {r['integrator']} | {r['status']} | {r['evals']} | {r['steps']} | "
                   f"{r['jacobians']} | {same} | {energy} |")
    by = {}
    for r in rows:
        by.setdefault(r["integrator"], []).append(r["evals"])
    base = np.array(by[next(iter(POLICIES))], float)
    out.append("")
    for name, ev in by.items():
        out.append(f"* {name}: evaluations, geometric mean over the scenes, "
                   f"{np.exp(np.mean(np.log(np.array(ev) / base))):.2f} x the default")
    return "\n".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--parts", default="odes,choice,scenes,friction,policy")
    ap.add_argument("--t-end", type=float, default=0.3)
    ap.add_argument("--max-cpu", type=float, default=60.0)
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    parts = a.parts.split(",")
    res = {}
    if "odes" in parts:
        res["odes"] = bench_odes()
        print("## Stiff ODEs (IVP Test Set)\n\n" + table_odes(res["odes"]) + "\n", flush=True)
    if "choice" in parts:
        res["choice"] = bench_choice(max_cpu=a.max_cpu)
        print("## Method choice (rtol 1e-6; x ROS34PW2: CPU over ROS34PW2's on the same problem)\n\n"
              + table_odes(res["choice"]) + "\n", flush=True)
    if "scenes" in parts or "floor" in parts:
        res["scenes"] = bench_scenes(a.t_end, a.max_cpu)
        print(f"## Clearance scenes, rtol 1e-6, {a.t_end} s (x first: CPU over RK45's)\n\n"
              + table_scenes(res["scenes"], floor=True) + "\n", flush=True)
    if "friction" in parts:
        res["friction"] = bench_friction(a.max_cpu)
        print("## Stiff contact: regularised Coulomb friction, v_eps = 1e-6 m/s, 0.1 s\n\n"
              + table_scenes(res["friction"], floor=True) + "\n", flush=True)
    if "policy" in parts:
        res["policy"] = bench_policy(a.max_cpu)
        print("## ROS34PW2's Jacobian and error-estimate policy (rtol 1e-6, 0.05 s)\n\n"
              + table_policy(res["policy"]) + "\n", flush=True)
    if a.json:
        for rows in res.values():
            for r in rows:
                r.pop("y", None)
        with open(a.json, "w") as f:
            json.dump(res, f, indent=1, default=float)


if __name__ == "__main__":
    main()
