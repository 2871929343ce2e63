"""`pinclear analyse bifurcation|poincare ...`: the command line of the analysis package."""
from __future__ import annotations

import argparse
import math
import re
import sys
from pathlib import Path

import numpy as np
import yaml

from pinclear.analysis.classify import classify
from pinclear.analysis.diagrams import bifurcation
from pinclear.analysis.plots import plot_bifurcation, plot_phase_portrait, plot_poincare
from pinclear.analysis.poincare import aligned_dt_out, poincare
from pinclear.analysis.signals import phase_portrait, series
from pinclear.core.errors import InputError, ModelFileError
from pinclear.core.safeio import write_text
from pinclear.core.version import write_provenance
from pinclear.io.sidecar import parse_assignments


def _values_arg(text):
    """'a:b:n' (n values from a to b) or a comma-separated list of YAML scalars."""
    if ":" in text and "," not in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise InputError(f"--values: expected 'start:stop:count', got {text!r}")
        from pinclear.analysis.sweeps import MAX_SWEEP_POINTS

        try:
            a, b, n = float(parts[0]), float(parts[1]), int(parts[2])
        except ValueError:
            raise InputError(f"--values: expected 'start:stop:count', got {text!r}") from None
        if not (np.isfinite(a) and np.isfinite(b)) or not 1 <= n <= MAX_SWEEP_POINTS:
            raise InputError(f"--values {text!r}: finite start and stop, 1 <= count <= {MAX_SWEEP_POINTS}")
        return list(np.linspace(a, b, n))
    from pinclear.io.sidecar import yaml_value

    try:
        return [yaml_value(v) for v in text.split(",")]
    except yaml.YAMLError as exc:
        raise InputError(f"--values {text!r}: not a comma-separated list of YAML scalars "
                         f"({' '.join(str(exc).split())})") from None


def _param_arg(items):
    """--param PATH or PATH*FACTOR (repeatable) -> a string or a mapping path -> factor."""
    par = {}
    for it in items:
        path, factor = it, 1.0
        if "*" in it.rpartition("]")[2]:          # a '*' inside [...] would be part of a name
            path, _, fac = it.rpartition("*")
            try:
                factor = float(fac)
            except ValueError:
                raise InputError(f"--param: factor in {it!r} is not a number") from None
        par[path] = factor
    return next(iter(par)) if len(par) == 1 and next(iter(par.values())) == 1.0 else par


def _kv(items, what):
    return parse_assignments(items, what)


def _tag(key):
    return re.sub(r"[^A-Za-z0-9_-]+", "_", key).strip("_")


def _period_of_speed(w):
    return 2 * math.pi / abs(float(w))


def build_parser():
    """The parser of `pinclear analyse bifurcation|poincare`."""
    from pinclear.cli.args import MECH_HELP, OneLineParser, add_mech_option, count, number, run_choices

    methods, integrators = run_choices()
    ap = OneLineParser(prog="pinclear analyse", description="phase portraits, Poincaré maps and bifurcation diagrams")
    sub = ap.add_subparsers(dest="cmd", required=True, metavar="{bifurcation,poincare}", parser_class=OneLineParser)
    b = sub.add_parser("bifurcation", help="Poincaré samples against a swept parameter (parallel runs)")
    b.add_argument("file", nargs="?", metavar="FILE",
                   help="mechanism sidecar (urdf/NAME.yaml, a bundled name or your own FILE.yaml); or give it as --mech")
    add_mech_option(b, "the mechanism sidecar to sweep, as FILE (either one)")
    b.add_argument("--param", action="append", required=True, metavar="PATH[*FACTOR]",
                   help="swept key: NAME.key of a clearance (S2.mu), a scene option or a sidecar path "
                        "(forces[spring].k, drives[crank1_drive].law.coeffs[1]); repeat to set several keys, "
                        "each to FACTOR*value")
    b.add_argument("--values", required=True, help="'start:stop:count' or a comma list")
    grp = b.add_mutually_exclusive_group(required=True)
    grp.add_argument("--period", type=number(unit="s"), help="driving period [s]")
    grp.add_argument("--period-from-speed", action="store_true",
                     help="the swept value is a driving speed w [rad/s]: period 2 pi / |w|")
    b.add_argument("--signal", action="append", required=True,
                   help="joint name, FRAME.x|y|z, ELEMENT.output[k] (e.g. S2.eccentricity[1]); repeatable")
    b.add_argument("--cycles", type=count(1), default=100, help="periods simulated per value")
    b.add_argument("--transient", type=count(0), default=20, help="first periods dropped as transient")
    b.add_argument("--phase", type=number("nonnegative", "s"), default=0.0, help="section phase [s] within the period")
    b.add_argument("--per-period", type=count(1), default=8, help="output samples per period")
    b.add_argument("--clearance", action="append", metavar="NAME", help="activate a clearance joint")
    b.add_argument("--set", action="append", metavar="NAME.KEY=VALUE", help="fixed override (repeatable)")
    b.add_argument("--option", action="append", metavar="KEY=VALUE", help="scene option (repeatable)")
    b.add_argument("--method", default="lagrange", choices=methods, help="forward-dynamics formulation")
    b.add_argument("--integrator", default="RK45", choices=integrators, help="time integrator")
    b.add_argument("--rtol", type=number(), default=1e-6, help="relative tolerance of the runs")
    b.add_argument("--max-cpu", type=number(unit="s"), default=None,
                   help="CPU seconds per run before it is stopped (default: no budget)")
    b.add_argument("--workers", type=count(1), default=None, help="worker processes (default: all cores)")
    b.add_argument("--out", default="out", help="output folder (created if missing)")
    p = sub.add_parser("poincare", help="phase portrait + Poincaré map of a saved run (trajectory.npz)")
    p.add_argument("trajectory", help="trajectory.npz written by `pinclear simulate`")
    add_mech_option(p, MECH_HELP)
    p.add_argument("--clearance", action="append", metavar="NAME",
                   help="clearance joints active in the run (only for a run that does not record them)")
    p.add_argument("--set", action="append", metavar="NAME.KEY=VALUE",
                   help="repeat an override the run recorded that a results file may not apply itself (code or a file)")
    p.add_argument("--option", action="append", metavar="KEY=VALUE", help="repeat a scene option the run recorded")
    p.add_argument("--trust", action="store_true",
                   help="trust the mechanism file given with --mech (docs/security.md); never a run's recorded file")
    p.add_argument("--period", type=number(unit="s"), required=True, help="driving period [s]")
    p.add_argument("--signal", action="append", required=True, help="as for bifurcation; repeatable")
    p.add_argument("--skip", type=count(0), default=0, help="transient periods to drop")
    p.add_argument("--phase", type=number("nonnegative", "s"), default=0.0, help="section phase [s] within the period")
    p.add_argument("--out", default="out", help="output folder (created if missing)")
    return ap


def cli_main(argv) -> int:
    """`pinclear analyse bifurcation|poincare ...` (see --help)."""
    import json

    ap = build_parser()
    args, extra = ap.parse_known_args(argv)
    sub = next(a for a in ap._actions if isinstance(a, argparse._SubParsersAction)).choices[args.cmd]
    if extra:       # named with the subcommand's own --help, not `pinclear analyse --help`
        sub.error(f"unrecognized arguments: {' '.join(extra)}")
    if args.cmd == "bifurcation":
        if args.file and args.mech and args.file != args.mech:
            sub.error(f"the mechanism given twice, {args.file} and --mech {args.mech}: give one")
        args.file = args.file or args.mech
        if not args.file:
            sub.error("the mechanism sidecar to sweep is missing: give --mech FILE.yaml (or FILE)")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    if args.cmd == "bifurcation":
        sim = dict(method=args.method, integrator=args.integrator, rtol=args.rtol)
        if args.max_cpu:
            sim["max_cpu"] = args.max_cpu
        load_kw = dict(clearances=args.clearance or None, options=_kv(args.option, "--option") or None,
                       overrides=_kv(args.set, "--set") or None)
        res = bifurcation(args.file, _param_arg(args.param), _values_arg(args.values),
                          period=_period_of_speed if args.period_from_speed else args.period,
                          signal=list(args.signal), cycles=args.cycles, transient=args.transient, phase=args.phase,
                          per_period=args.per_period, sim_options=sim,
                          load_options={k: v for k, v in load_kw.items() if v}, max_workers=args.workers,
                          progress=True)
        res.save(out / "bifurcation.npz")
        label = ", ".join(args.param)
        for key in res.signals:
            plot_bifurcation(res, signal=key, label=label, path=out / f"bifurcation_{_tag(key)}.png")
        table = {key: res.table(signal=key) for key in res.signals}
        write_text(out / "bifurcation.json", json.dumps(table, indent=2, default=str))
        write_provenance(out, command="analyse bifurcation", mech=args.file, param=args.param, values=args.values)
        for key in res.signals:
            print(f"{key}:")
            for row in table[key]:
                K = "" if row["K"] is None else f" K={row['K']:.2f}"
                print(f"  {row['value']!s:>12} {row['status']:8} {row['kind'] or '-'}{K}"
                      + ("" if row["status"] == "success" else f"  ({row['message']})"))
        print(f"wrote {out}/bifurcation.npz, bifurcation.json and the figures")
        return 0 if not res.failures else 1

    from pinclear.cli.view import load_run
    from pinclear.core.bounded import check_regular

    check_regular(args.trajectory, "path", "trajectory")     # a FIFO or a device would block or never end
    # one loader with plot and view: the run's recorded options, overrides and clearances (the ones
    # a results file may not apply, repeated with --set), a path recorded in the run never opened
    # (--mech, or the bundled mechanism it names), and the mechanism checked against the run's
    # record and digest: a mismatch is refused, one line
    traj, mech = load_run(args.trajectory, args.mech, trust=True if args.trust else None,
                          prog="pinclear analyse poincare", overrides=_kv(args.set, "--set"),
                          options=_kv(args.option, "--option"), clearances=args.clearance)
    report = {}
    for sig in args.signal:
        sec = poincare(traj, args.period, sig, phase=args.phase, skip_transient=args.skip, mech=mech)
        x, xd = phase_portrait(traj, sig, mech=mech, t_min=args.phase + args.skip * args.period)
        unit = series(traj, sig, mech).unit
        plot_phase_portrait(x, xd, section=sec, label=sig, path=out / f"phase_{_tag(sig)}.png", unit=unit)
        plot_poincare(sec, path=out / f"poincare_{_tag(sig)}.png", unit=unit)
        c = classify(sec)
        report[sig] = dict(c.as_dict(), samples=len(sec), interpolated=int(sec.interpolated.sum()))
        if report[sig]["interpolated"]:
            report[sig]["hint"] = _dt_out_hint(traj, args.period, args.phase, report[sig]["interpolated"], len(sec))
            print(f"pinclear: note: {sig}: {report[sig]['hint']}", file=sys.stderr)
    write_text(out / "poincare.json", json.dumps(report, indent=2, default=str))
    write_provenance(out, command="analyse poincare", run=str(args.trajectory), mech=args.mech,
                     run_versions=traj.meta.get("versions"))
    print(json.dumps(report, indent=2, default=str))
    return 0


def _dt_out_hint(traj, period, phase, n_interp, n):
    """Why a section was interpolated and the simulate option that makes it exact."""
    dt = aligned_dt_out(period, traj.t, phase)
    fix = (f"rerun `pinclear simulate` with --dt-out {dt:.6g} (period {period:g} s / "
           f"{round(period / dt)})" if dt is not None else
           f"rerun with --dt-out period/n and a --phase that is a multiple of it (phase {phase:g} s is not)")
    return (f"{n_interp} of {n} section samples fell between output samples and were interpolated (cubic "
            f"Hermite); {fix} so that every section time is an output sample of the integrator's dense output")


if __name__ == "__main__":
    try:
        sys.exit(cli_main(sys.argv[1:]))
    except (InputError, ModelFileError) as exc:
        print(f"pinclear: error: {exc}", file=sys.stderr)
        sys.exit(2)
