"""Cassie's leg loops: pinclear's formulations against Pinocchio's own constrained dynamics
(pin.constraintDynamics, pin.lcaba) and its ADMM / PGS constraint solvers, in one process, on
the same model and the same states.

    python benchmarks/bench_cassie.py [--variant cassie_v2] [--states 20] [--out benchmarks]

Model: example-robot-data's Cassie (``pinclear.mechanisms.cassie``), pelvis welded to the world,
the four ball-joint loops as spherical closures (12 rows, 2 of them redundant: the plantar loops
are planar), joint springs and dampers. States: the samples of a passive swing under gravity
(lagrange + RK45, rtol 1e-10), so every state is assembled to ~1e-12 and velocity-consistent.
Every solver gets the same applied forces (the springs and dampers at that state).

Per solver and state: the joint accelerations a; reported per solver: the mean cost of one
evaluation (best of 3 passes over all states) and its ratio to pin.constraintDynamics, the
constraint residual max |J a + dJ v| over all 12 closure rows (world axes, pinclear's rows), and
the agreement max |a - a_lagrange| / max |a_lagrange| with pinclear's lagrange. Pinocchio's
constraintDynamics and lcaba are run at their documented settings and at a converged one; the
ADMM and PGS solvers get the dense Delassus problem G = J M^-1 J^T, g = J a_free + dJ v of the
same rows (bilateral point anchors), and a = a_free + M^-1 J^T lambda.
Writes OUT/bench_cassie.json and OUT/bench_cassie.md.
"""
from __future__ import annotations

import argparse
import json
import platform
import sys
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin

import pinclear
from pinclear.dynamics import formulations
from pinclear.model import kinematics
from pinclear.studies.bench.rhs import _best_mean
from pinclear.core.errors import PinclearError
from pinclear.dynamics.formulations.pinocchio_cd import rigid_constraints
from pinclear.dynamics.simulate import simulate
from pinclear.dynamics.stepping.build import Evaluation


def states(mech, n, t_end=0.3):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        run = simulate(mech, t_end, rtol=1e-10, dt_out=t_end / n)
    return run.t[1:], run.q[1:], run.v[1:], run.z[1:]


def applied_and_rows(mech, T, Q, V, Z):
    """Per state: applied forces tau, rows J and dJ v (all closure rows, world axes), M, a_free."""
    ws = mech.workspace()
    data = mech.model.createData()
    out = []
    for t, q, v, z in zip(T, Q, V, Z):
        kinematics.update(mech, ws, q, v)
        kinematics.constraint_rows(mech, ws, t, q, v)
        tau = np.zeros(mech.nv)
        for f, d in zip(mech.forces, ws.force_data):
            f.add_force(mech, ws, d, t, q, v, z, tau, np.zeros(f.nz))
        M = pin.crba(mech.model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        a_free = pin.aba(mech.model, data, q, v, tau).copy()
        m = mech.compiled.m
        out.append({"tau": tau, "J": ws.J[:m].copy(), "b": ws.bias[:m].copy(), "M": M, "a_free": a_free})
    return out


#: what the table cannot show: why method 'pinocchio' is refused, and the gearbox variant's diagnosis
#: (measured by tests/io/test_cassie.py and the SVDs quoted)
NOTES = """Method `pinocchio` is refused before a run (one line, naming the rows and the methods that work) when
closure rows are redundant at the start: Pinocchio's rigid constraints take a ball closure's three rows whole,
and at pinclear's settings (mu 1e-12, 50 iterations) its proximal solver does not meet its stopping test on
them (pin.constraintDynamics above: 50 of 50 iterations at every state; as a run it stopped at t = 0 with
Pinocchio's residual 7.5). On cassie_reduced and cassie_simple, whose plantar loops are not planar (no
redundant row), the method runs and ends where lagrange does (tests/io/test_cassie.py).

The gearbox variant `cassie` (cassie.sdf) runs with manifold. lagrange and projection stop at
t = 0 and name the rows: after the rank test on J (tolerance 7e-12 of its scale) drops 8 of the 32 rows, the
right shin-spring closure (a prismatic cut joint) keeps rows x and ry whose combination is independent of the
others by 2.2e-7 of J's scale only (smallest singular value 3.2e-7 against 1.44; the SDF's rounded poses).
The Schur complement J M^-1 J^T squares that: condition 1.2e14, above pinclear's 1e12. The rotors' small
inertias (diagonal of M down to 1.0e-5) add only a factor 2.5 (condition of J L^-T, M = L L^T: 1.1e7, of J:
4.5e6). The stop is right: that weak row alone locks the right shin triangle (planar Grubler count 0).
Dropping it (a rank test at 1e-6, tried) lets lagrange run but frees the right knee-shin joint (7e-4 rad in
0.1 s); manifold keeps both at rest with every row to 4e-16. proximal, which used to run and free both (residual
2e-8, knee rotors 1.2e-2 rad off manifold's), is refused at the start: both locks have an eigenvalue of
J M^-1 J^T ~1e-9 of its regularisation (docs/import_export.md, docs/singular_passages.md)."""


def pinclear_solvers(mech, T, Q, V, Z, independent):
    res = {}
    for name in formulations.METHODS:
        try:
            form = formulations.get(name)(mech)
            form.use_rows(independent)
            ev = Evaluation(form)
            X = [ev.pack(Q[k], V[k], Z[k]) for k in range(len(T))]
            A = []
            for k in range(len(T)):
                ev(T[k], X[k])
                if not np.all(np.isfinite(form.ws.a)) or ev.code < 0:
                    raise PinclearError(f"evaluation failed at state {k} (stage code {ev.code}: rank loss, or "
                                        "Pinocchio's proximal solver stopped at its iteration limit)")
                A.append(form.ws.a.copy())

            def run(ev=ev, X=X):
                for k in range(len(T)):
                    ev(T[k], X[k])
            res[f"pinclear {name}"] = {"A": np.array(A), "time": _best_mean(run, 3) / len(T)}
        except PinclearError as exc:
            res[f"pinclear {name}"] = {"skipped": " ".join(str(exc).split())[:300]}
    return res


def pinocchio_solvers(mech, Q, V, R):
    """pin.constraintDynamics and pin.lcaba (documented and converged settings), ADMM, PGS."""
    model = mech.model
    res = {}
    cms = pin.StdVec_RigidConstraintModel()
    for c in rigid_constraints(mech):
        cms.append(c)
    cds = pin.StdVec_RigidConstraintData()
    for c in cms:
        cds.append(c.createData())
    data = model.createData()
    pin.initConstraintDynamics(model, data, cms, cds)
    for label, fn, mu, it in (("pin.constraintDynamics (mu 1e-12, 50 it.: pinclear's 'pinocchio')",
                               pin.constraintDynamics, 1e-12, 50),
                              ("pin.constraintDynamics (mu 1e-4, 1000 it.)", pin.constraintDynamics, 1e-4, 1000),
                              ("pin.lcaba (mu 1e-6, 50 it.)", pin.lcaba, 1e-6, 50),
                              ("pin.lcaba (mu 1e-4, 1000 it.)", pin.lcaba, 1e-4, 1000)):
        d = model.createData()
        pin.initConstraintDynamics(model, d, cms, cds)
        if fn is pin.lcaba:
            pin.computeJointMinimalOrdering(model, d, cms)
        prox = pin.ProximalSettings(1e-12, mu, it)
        iters = []

        def one(k, d=d, prox=prox, fn=fn):
            a = fn(model, d, Q[k], V[k], R[k]["tau"], cms, cds, prox)
            return a

        A = []
        for k in range(len(Q)):
            A.append(np.array(one(k)))
            iters.append(prox.iter)

        def run(one=one):
            for k in range(len(Q)):
                one(k)
        res[label] = {"A": np.array(A), "time": _best_mean(run, 3) / len(Q),
                      "iterations": f"{min(iters)}-{max(iters)}"}
    gms = pin.StdVec_ConstraintModel()
    for c in cms:
        gms.append(pin.ConstraintModel(pin.PointAnchorConstraintModel(model, c.joint1_id, c.joint1_placement,
                                                                      c.joint2_id, c.joint2_placement)))
    gds = pin.StdVec_ConstraintData()
    for c in gms:
        gds.append(c.createData())
    m = R[0]["J"].shape[0]
    for label, Solver, Settings, Result in (("pin.ADMMConstraintSolver (dense Delassus)", pin.ADMMConstraintSolver,
                                             pin.ADMMSolverSettings, pin.ADMMSolverResult),
                                            ("pin.PGSConstraintSolver (dense Delassus)", pin.PGSConstraintSolver,
                                             pin.PGSSolverSettings, pin.PGSSolverResult)):
        solver, st, result = Solver(m), Settings(), Result()
        st.max_iterations = 1000
        st.absolute_feasibility_tol = st.relative_feasibility_tol = 1e-12
        iters, conv = [], []

        def one(k, solver=solver, st=st, result=result):
            r = R[k]
            Minv = np.linalg.inv(r["M"])
            G = r["J"] @ Minv @ r["J"].T
            g = r["J"] @ r["a_free"] + r["b"]
            ok = solver.solve(pin.DelassusOperatorDense(G), g, gms, gds, st, result)
            lam = np.asarray(result.retrieveConstraintImpulses()).ravel()
            return r["a_free"] + Minv @ (r["J"].T @ lam), ok

        A = []
        for k in range(len(Q)):
            a, ok = one(k)
            A.append(a)
            iters.append(result.iterations)
            conv.append(bool(ok))

        def run(one=one):
            for k in range(len(Q)):
                one(k)
        res[label] = {"A": np.array(A), "time": _best_mean(run, 3) / len(Q),
                      "iterations": f"{min(iters)}-{max(iters)}", "converged": f"{sum(conv)} of {len(conv)}",
                      "note": "includes forming G and g with numpy (M^-1 by inversion) at every state"}
    return res


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--variant", default="cassie_v2")
    p.add_argument("--states", type=int, default=20)
    p.add_argument("--out", default=str(Path(__file__).parent))
    args = p.parse_args(argv)
    mech = pinclear.load(args.variant)
    T, Q, V, Z = states(mech, args.states)
    R = applied_and_rows(mech, T, Q, V, Z)
    # the rows a run keeps: those independent at the assembled start (as simulate chooses them)
    mob = kinematics.mobility(mech, kinematics.assemble(mech))
    res = pinclear_solvers(mech, T, Q, V, Z, mob["independent"])
    res.update(pinocchio_solvers(mech, Q, V, R))
    ref = res["pinclear lagrange"]["A"]
    scale = np.abs(ref).max()
    base = res["pin.constraintDynamics (mu 1e-12, 50 it.: pinclear's 'pinocchio')"]["time"]
    rows = []
    for label, r in res.items():
        if "skipped" in r:
            rows.append({"solver": label, "skipped": r["skipped"]})
            continue
        resid = max(float(np.abs(R[k]["J"] @ r["A"][k] + R[k]["b"]).max()) for k in range(len(T)))
        rows.append({"solver": label, "time_us": r["time"] * 1e6, "ratio": r["time"] / base, "residual": resid,
                     "agreement": float(np.abs(r["A"] - ref).max() / scale),
                     **{k: r[k] for k in ("iterations", "converged", "note") if k in r}})
    out = {"mechanism": args.variant, "nv": mech.nv, "closure_rows": mech.compiled.m, "rank": mob["rank"],
           "redundant_rows": mob["redundant_rows"], "states": len(T), "max_abs_a": float(scale),
           "python": sys.version.split()[0], "pinocchio": pin.__version__, "machine": platform.machine(),
           "rows": rows}
    Path(args.out, "bench_cassie.json").write_text(json.dumps(out, indent=2) + "\n")
    md = [f"# Cassie's leg loops: pinclear vs Pinocchio's solvers ({args.variant})", "",
          f"`python benchmarks/bench_cassie.py --variant {args.variant} --states {args.states}` (one process; "
          f"Pinocchio {pin.__version__}). nv = {mech.nv}, {mech.compiled.m} closure rows of rank {mob['rank']} "
          f"(redundant: {', '.join(mob['redundant_rows'])}), {len(T)} states of a passive swing, max |a| = "
          f"{scale:.4g}. Residual: max |J a + dJ v| over all closure rows [m/s^2]; agreement: max |a - a_lagrange| / "
          "max |a_lagrange|; ratio: cost per evaluation over pin.constraintDynamics at pinclear's settings. "
          "pinclear's rows time its whole right-hand side (springs, dampers, the passes, the solve: what a run "
          "calls); Pinocchio's rows time the dynamics call alone with the applied forces given.", "",
          "| solver | us / evaluation | ratio | residual | agreement | iterations | note |",
          "|---|---|---|---|---|---|---|"]
    for r in rows:
        if "skipped" in r:
            md.append(f"| {r['solver']} | - | - | - | - | - | cannot run: {r['skipped']} |")
        else:
            conv = f"converged {r['converged']}" if "converged" in r else ""
            note = "; ".join(x for x in (conv, r.get("note", "")) if x)
            md.append(f"| {r['solver']} | {r['time_us']:.1f} | {r['ratio']:.2f} | {r['residual']:.1e} | "
                      f"{r['agreement']:.1e} | {r.get('iterations', '-')} | {note} |")
    md += ["", NOTES]
    Path(args.out, "bench_cassie.md").write_text("\n".join(md) + "\n")
    print("\n".join(md))


if __name__ == "__main__":
    main()
