"""Command line: `pinclear simulate|info|bench|view|plot|inverse-dynamics`.

Errors print one line (`pinclear: error: ...`) and exit 2; a failed integration writes what it
computed and exits 1."""
from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

import numpy as np

import yaml

from .errors import InputError, PinclearError


from .sidecar import parse_assignments as parse_kv


def _load(args):
    from .sidecar import load

    return load(args.file, options=parse_kv(getattr(args, "option", None), "--option"),
                overrides=parse_kv(getattr(args, "set", None), "--set"), clearances=getattr(args, "clearance", None))


def _add_model_args(p):
    p.add_argument("file", help="mechanism sidecar (urdf/NAME.yaml)")
    p.add_argument("--clearance", action="append", metavar="NAME", help="activate a clearance joint (repeatable)")
    p.add_argument("--set", action="append", metavar="NAME.KEY=VALUE",
                   help="override a clearance key or a scene option (repeatable)")
    p.add_argument("--option", action="append", metavar="KEY=VALUE", help="set a scene option (repeatable)")


def cmd_simulate(args):
    from .simulate import simulate

    mech = _load(args)
    kw = {}
    for k in ("alpha", "beta"):
        if getattr(args, k) is not None:
            kw[k] = getattr(args, k)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        traj = simulate(mech, args.t_end, method=args.method, integrator=args.integrator, rtol=args.rtol,
                        atol=args.atol, h=args.h, dt_out=args.dt_out, max_step=args.max_step or np.inf, **kw)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    traj.save(out / "trajectory.npz")
    summary = traj.summary()
    summary["mechanism"] = mech.name
    summary["file"] = str(args.file)
    # which clearance joints were active, with their law, stiffness form and sizes
    names = {c.get("name") for c in mech.sidecar.get("clearances") or [] if isinstance(c, dict)}
    summary["clearances"] = [f.describe() for f in mech.forces if f.name in names]
    summary["drive_force_peaks"] = {d.name: float(np.nanmax(np.abs(traj.lam[d.name]))) for d in mech.drives} \
        if len(traj.t) else {}
    (out / "summary.json").write_text(json.dumps(summary, indent=2))
    print(json.dumps({k: summary[k] for k in ("status", "mobility", "redundant_constraints", "max_closure_residual",
                                              "energy_drift_rel", "tracking_error", "rhs_evals", "cpu_s")
                      if k in summary}))
    if traj.status != "success":
        print(f"pinclear: integration failed: {traj.message}", file=sys.stderr)
        return 1
    return 0


def cmd_info(args):
    from . import kinematics

    mech = _load(args)
    q = kinematics.assemble(mech)
    mob = kinematics.mobility(mech, q)
    info = mech.describe()
    info.update({"mobility": mob["mobility"], "closure_rows": mob["rows"], "rank": mob["rank"],
                 "redundant_rows": mob["redundant_rows"], "condition": mob["condition"],
                 "parameters": mech.parameters, "q_assembled": q.tolist()})
    print(json.dumps(info, indent=2, default=str))
    return 0


def cmd_bench(args):
    from . import bench

    if args.what == "restitution":
        from .contact import bench as cbench

        return cbench.restitution_main(args.rest)
    if args.file is None:
        raise PinclearError(f"bench {args.what} needs a mechanism file")
    mech = _load(args)
    if args.what == "rhs":
        res = bench.bench_rhs(mech, methods=args.methods.split(",") if args.methods else None)
    else:
        res = bench.work_precision(mech, t_end=args.t_end, out_dir=args.out)
        res.pop("rows")
    print(json.dumps(res, indent=2, default=str))
    return 0


def _delegate(module, func):
    def run(args):
        import importlib

        return importlib.import_module(module).__getattribute__(func)(args.rest)
    return run


def build_parser():
    p = argparse.ArgumentParser(prog="pinclear", description="Dynamics of parallel mechanisms with joint clearance")
    sub = p.add_subparsers(dest="cmd", required=True)

    s = sub.add_parser("simulate", help="forward dynamics; writes OUT/trajectory.npz and OUT/summary.json")
    _add_model_args(s)
    s.add_argument("--t-end", type=float, required=True)
    s.add_argument("--method", default="lagrange", help="lagrange | projection | pinocchio | proximal")
    s.add_argument("--integrator", default="RK45", help="RK45 | DOP853 | Radau | BDF | LSODA | RK4")
    s.add_argument("--rtol", type=float, default=1e-8)
    s.add_argument("--atol", type=float, default=None)
    s.add_argument("--h", type=float, default=None, help="fixed step for RK4 [s]")
    s.add_argument("--max-step", type=float, default=None)
    s.add_argument("--dt-out", type=float, default=None, help="output interval [s]")
    s.add_argument("--alpha", type=float, default=None, help="Baumgarte alpha [1/s]")
    s.add_argument("--beta", type=float, default=None, help="Baumgarte beta [1/s]")
    s.add_argument("--out", default="out")
    s.set_defaults(func=cmd_simulate)

    s = sub.add_parser("info", help="assemble and print the mechanism: mobility, redundancy, parameters")
    _add_model_args(s)
    s.set_defaults(func=cmd_info)

    s = sub.add_parser("bench", help="bench rhs FILE | bench work-precision FILE | bench restitution")
    s.add_argument("what", choices=["rhs", "work-precision", "restitution"])
    s.add_argument("file", nargs="?")
    s.add_argument("--clearance", action="append", metavar="NAME")
    s.add_argument("--set", action="append", metavar="NAME.KEY=VALUE")
    s.add_argument("--option", action="append", metavar="KEY=VALUE")
    s.add_argument("--methods", default=None, help="comma-separated formulations (default: all)")
    s.add_argument("--t-end", type=float, default=2.0)
    s.add_argument("--out", default="benchmarks")
    s.add_argument("rest", nargs=argparse.REMAINDER)
    s.set_defaults(func=cmd_bench)

    for name, module, func, helptext in (
            ("view", "pinclear.viz.cli", "view_main", "meshcat viewer / standalone HTML of a mechanism or a run"),
            ("plot", "pinclear.viz.cli", "plot_main", "standard figures of a saved trajectory"),
            ("inverse-dynamics", "pinclear.screw", "cli_main", "screw-theory inverse dynamics (paper 004)"),
            ("analyse", "pinclear.analysis", "cli_main", "phase portraits, Poincare maps, bifurcation diagrams")):
        s = sub.add_parser(name, help=helptext, add_help=False)
        s.add_argument("rest", nargs=argparse.REMAINDER)
        s.set_defaults(func=_delegate(module, func))
    return p


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except PinclearError as exc:
        print(f"pinclear: error: {exc}", file=sys.stderr)
        return 2
    except (FileNotFoundError, PermissionError, IsADirectoryError) as exc:
        print(f"pinclear: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":
    sys.exit(main())
