"""The source papers' studies, run end to end, with our results beside the paper's own numbers:
``pinclear reproduce PAPER [--quick] [--bands [--budget CPU_S]] [--out DIR] [--workers N]
[--scheduler ADDRESS]`` writes the figures, report.md, report.html (figures inline) and
report.json. Every compared number gets a class (pinclear.reproduce.verdicts: calibration, not
comparable, contradicted, reproduced, undecided) and the command prints the count of each.

Available: 000 (4UPS-UPU, spherical clearance at S2), 002 (nine-bar, revolute clearances at A
and B), 003 (3-UPRU+UP, prismatic clearance), 004 (4-UPS/UPR screw-theory inverse dynamics).
Each paper's module has ``run(out, quick=False, workers=None, scheduler=None)``; the many runs
of a study go through pinclear.sweep / pinclear.analysis.bifurcation on one executor.
"""
from __future__ import annotations

from pathlib import Path

from ..errors import InputError
from . import paper000, paper002, paper003, paper004
from .report import write_report
from .verdicts import summary

PAPERS = {"000": paper000, "002": paper002, "003": paper003, "004": paper004}


def reproduce(paper, out, quick=False, workers=None, scheduler=None, bands=False, budget=None) -> dict:
    """Run ``paper``'s study, write its report into ``out``; return the report (a dict).

    workers: local processes for the study's simulations (default: one per CPU); scheduler: a Dask
    scheduler address (``tcp://HOST:8786``) instead. bands: also measure each row's band over the
    reconstructed inputs (pinclear.reproduce.bands), within ``budget`` CPU seconds if given."""
    mod = PAPERS.get(str(paper))
    if mod is None:
        raise InputError(f"reproduce: no study for paper {paper!r}", choices=sorted(PAPERS))
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    extra = {"bands": True, "budget": budget} if bands else {}
    report = mod.run(out, quick=quick, workers=workers, scheduler=scheduler, **extra)
    write_report(report, out)
    return report


def build_parser():
    """The parser of `pinclear reproduce`."""
    from .._argtypes import OneLineParser, number

    ap = OneLineParser(prog="pinclear reproduce", description=__doc__.splitlines()[0])
    ap.add_argument("paper", choices=sorted(PAPERS), help="the source paper's study to run")
    ap.add_argument("--quick", action="store_true", help="a reduced study (smoke run)")
    ap.add_argument("--bands", action="store_true",
                    help="measure each row's band over the reconstructed inputs (one-at-a-time plus a small "
                         "space-filling sample; costs runs: see --budget)")
    ap.add_argument("--budget", type=number("positive", "CPU s"), default=None, metavar="CPU_S",
                    help="CPU seconds the bands may use (default: the whole design)")
    ap.add_argument("--out", default=None, help="report folder (default: reproduce_PAPER)")
    ap.add_argument("--workers", type=int, default=None, help="local worker processes (default: one per CPU)")
    ap.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="run the simulations on the Dask cluster at ADDRESS (tcp://HOST:8786) "
                         "(default: local processes)")
    return ap


def cli_main(argv=None) -> int:
    ap = build_parser()
    args = ap.parse_args(argv)
    out = Path(args.out or f"reproduce_{args.paper}")
    if args.workers is not None and args.workers < 1:
        ap.error(f"--workers must be a positive number of processes, got {args.workers}")
    if args.budget is not None and not args.bands:
        ap.error("--budget is the CPU budget of --bands: give --bands too")
    rep = reproduce(args.paper, out, quick=args.quick, workers=args.workers, scheduler=args.scheduler,
                    bands=args.bands, budget=args.budget)
    print(f"{rep['title']}: {summary(rep['results'])}; report: {out / 'report.md'}")
    return 0
