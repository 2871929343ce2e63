"""The energy audit of every bundled scene, without and with each of its clearances (markdown).

    nice -n 10 python3 benchmarks/energy_table.py [--t-end 0.5] [--t-end-clearance 0.2]
        [--rtol 1e-8] [--max-cpu 300] [SCENE ...]

One run per scene with its ideal joints, then one per clearance listed under ``clearances:`` in
its sidecar (activated alone, as ``pinclear simulate --clearance NAME``), from the sidecar's own
initial state, method lagrange, RK45. A run stopped by the CPU budget is audited over the
samples it kept (status ``failed``). Columns: the run's status and steps, the balance error
relative to the energy scale, the bound derived from rtol and the steps (pinclear.dynamics.energy), ok,
the scale (J) and where the error is largest.
"""
from __future__ import annotations

import argparse
import warnings

import pinclear
from pinclear.core.models import models_dir
from pinclear.io.sidecar import read_yaml


def runs(names):
    for path in sorted(models_dir().glob("*.yaml")):
        if names and path.stem not in names:
            continue
        yield path.stem, None
        for c in read_yaml(path).get("clearances") or []:
            yield path.stem, c["name"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scenes", nargs="*")
    ap.add_argument("--t-end", type=float, default=0.5, help="simulated time of the ideal runs [s]")
    ap.add_argument("--t-end-clearance", type=float, default=0.2, help="simulated time with a clearance [s]")
    ap.add_argument("--rtol", type=float, default=1e-8)
    ap.add_argument("--max-cpu", type=float, default=300.0, help="CPU budget per run [s]")
    args = ap.parse_args(argv)
    print(f"rtol {args.rtol:g}, method lagrange, RK45; ideal runs {args.t_end:g} s, clearance runs "
          f"{args.t_end_clearance:g} s, CPU budget {args.max_cpu:g} s per run\n")
    print("| scene | clearance | t_end [s] | status | steps | error | bound | ok | scale [J] | t of max [s] |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name, clr in runs(set(args.scenes)):
        t_end = args.t_end if clr is None else args.t_end_clearance
        try:
            mech = pinclear.load(name, clearances=[clr] if clr else None)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                tr = pinclear.simulate(mech, t_end, rtol=args.rtol, max_cpu=args.max_cpu)
        except pinclear.PinclearError as exc:
            print(f"| {name} | {clr or '-'} | {t_end:g} | error: {' '.join(str(exc).split())[:80]} | | | | | | |")
            continue
        b = tr.energy_balance()
        status = tr.status if tr.status == "success" else f"{tr.status} at {tr.t[-1]:.4g} s" if len(tr.t) else tr.status

        def g(x):
            return "-" if x is None else f"{x:.2e}"
        ok = {True: "yes", False: "**NO**", None: "-"}[b["ok"]]
        where = "-" if b["t"] is None else f"{b['t']:.4g}"
        print(f"| {name} | {clr or '-'} | {t_end:g} | {status} | {tr.stats['steps']} | {g(b['error'])} | "
              f"{g(b['bound'])} | {ok} | {g(b['scale'])} | {where} |", flush=True)


if __name__ == "__main__":
    main()
