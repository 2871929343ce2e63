"""`pinclear wear`: the command line of the long-horizon wear runs.
"""
from __future__ import annotations

import json
from dataclasses import asdict
from pathlib import Path

from pinclear.analysis.wear_life import SCHEMES, WearSettings, _tables, block_length, converged, plot, worn_joint
from pinclear.core import safeio
from pinclear.core.errors import InputError
from pinclear.core.version import provenance


def build_parser():
    from pinclear.cli.args import OneLineParser, count, number
    from pinclear.cli.commands import _add_model_args

    p = OneLineParser(prog="pinclear wear", description="Archard wear of revolute clearances over a "
                                "service life: the iterative scheme with the update factor chosen by a convergence "
                                "test (docs/wear_lubrication.md). Writes OUT/history.csv, OUT/profile.csv, "
                                "OUT/depth_vs_angle.png, OUT/growth.png, OUT/summary.json; rerun to resume.")
    _add_model_args(p)
    p.add_argument("--cycles", type=number(), required=True, help="service life in mechanism periods (e.g. 1e6)")
    p.add_argument("--period", type=number(unit="s"), required=True, help="the mechanism's period [s]")
    p.add_argument("--updates", type=count(1), default=4, help="factor scheme: reshapes of the first trial "
                   "(doubled until converged; default 4)")
    p.add_argument("--block-periods", type=count(1), default=1, help="periods simulated per reshape (default 1)")
    p.add_argument("--block-tol", type=number(), default=None, help="choose --block-periods instead: doubled from 1 "
                   "until doubling it changes each joint's largest mean nodal wear rate by at most this fraction, on "
                   "the new bearing (e.g. 0.025; at most --max-block-periods)")
    p.add_argument("--max-block-periods", type=count(1), default=16, help="the longest block --block-tol may choose "
                   "(default 16)")
    p.add_argument("--transient-periods", type=count(0), default=1, help="periods simulated first without wear "
                   "(default 1)")
    p.add_argument("--scheme", choices=SCHEMES, default="factor", help="factor: the same update factor for every "
                   "update (the updates doubled until converged); depth: each update's largest nodal increment "
                   "--step x the clearance (the step halved until converged); default factor")
    p.add_argument("--step", type=number(), default=0.01, help="depth scheme: largest nodal depth increment per "
                   "update as a fraction of the joint's radial clearance (first trial; default 0.01)")
    p.add_argument("--max-updates", type=count(1), default=2000, help="depth scheme: most updates of one trial "
                   "(default 2000; a trial that needs more stops there and is reported)")
    p.add_argument("--max-depth-fraction", type=number(), default=0.05, help="a trial whose depth passes this fraction "
                   "of the bearing's (socket's) radius ends as failed, naming the joint (default 0.05)")
    p.add_argument("--tol", type=number(), default=0.05, help="convergence: halving the update factor changes the "
                   "final depth by at most this (default 0.05)")
    p.add_argument("--max-rounds", type=count(1), default=5, help="most trials of the update factor (default 5)")
    p.add_argument("--rtol", type=number(), default=1e-6, help="relative tolerance of each block (default 1e-6)")
    p.add_argument("--dt-out", type=number(unit="s"), default=1e-4, help="sample interval of the wear quadrature "
                   "[s] (default 1e-4)")
    p.add_argument("--out", required=True, help="output folder (rerun into it to resume)")
    return p


def cli_main(argv=None) -> int:
    from pinclear.cli.commands import _load

    args = build_parser().parse_args(argv)
    if not args.clearance:
        raise InputError("name the worn clearance(s) with --clearance NAME", key="--clearance")
    if args.scheme == "factor" and args.cycles < args.updates * args.block_periods:
        # checked before the mechanism is loaded and any block is simulated
        raise InputError(f"{args.cycles:g} cycles are fewer than --updates x --block-periods = {args.updates} x "
                         f"{args.block_periods}: give more --cycles or fewer --updates", key="--cycles")
    mech = _load(args)
    s = WearSettings(cycles=float(args.cycles), period=float(args.period), updates=args.updates,
                     block_periods=args.block_periods, transient_periods=args.transient_periods, rtol=args.rtol,
                     dt_out=args.dt_out, scheme=args.scheme, step=args.step, max_updates=args.max_updates,
                     max_depth_fraction=args.max_depth_fraction)
    out = safeio.make_dirs(Path(args.out))
    block = None
    if args.block_tol is not None:
        n, ok, table = block_length(mech, args.clearance, s, tol=args.block_tol, max_periods=args.max_block_periods)
        s = WearSettings(**{**asdict(s), "block_periods": n})
        block = {"block_periods": n, "converged": ok, "table": table}
        print(f"wear: block of {n} periods" + ("" if ok else " (the longest allowed: its mean rate not converged)"),
              flush=True)
    with safeio.folder_lock(out):
        res = converged(mech, args.clearance, s, tol=args.tol, max_rounds=args.max_rounds, out=out,
                        progress=lambda k, n, d: print(f"wear: update {k} ({n}): max depth {d:.4g} m", flush=True))
        _tables(out, {n: worn_joint(res["mech"], n)[1].wear for n in res["depth"]}, res["depth"], res["history"])
        plot(res, out)
        fac = res["history"]["factor"]
        summary = {"converged": res["converged"], "failed": res.get("failed"), "scheme": args.scheme,
                   "rounds": res["rounds"], "mesh": res.get("mesh"),
                   "update_factor": [min(fac), max(fac)], "updates": len(fac), "block": block,
                   "max_depth_m": {n: float(d.max()) for n, d in res["depth"].items()},
                   "cpu_sim_s": float(sum(res["history"]["cpu_sim"])),
                   "cpu_update_s": float(sum(res["history"]["cpu_update"])), "versions": provenance()}
        safeio.write_text(out / "summary.json", json.dumps(summary, indent=1) + "\n")
    print(json.dumps(summary))
    return 0 if res["converged"] else 1
