"""The source papers' studies, run end to end, with our results beside the paper's own numbers:
``pinclear reproduce PAPER [--quick] [--out DIR]`` writes the figures, report.md, report.html
(figures inline) and report.json.

Available: 004 (the 4-UPS/UPR screw-theory inverse dynamics). The studies of 000, 002 and 003
(long clearance runs and their bifurcation diagrams) are open work.
"""
from __future__ import annotations

from pathlib import Path

from ..errors import InputError
from . import paper004
from .report import write_report

PAPERS = {"004": paper004}


def reproduce(paper, out, quick=False) -> dict:
    """Run ``paper``'s study, write its report into ``out``; return the report (a dict)."""
    mod = PAPERS.get(str(paper))
    if mod is None:
        raise InputError(f"reproduce: no study for paper {paper!r}", choices=sorted(PAPERS))
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    report = mod.run(out, quick=quick)
    write_report(report, out)
    return report


def cli_main(argv=None) -> int:
    import argparse

    ap = argparse.ArgumentParser(prog="pinclear reproduce", description=__doc__.splitlines()[0])
    ap.add_argument("paper", choices=sorted(PAPERS))
    ap.add_argument("--quick", action="store_true", help="a reduced study (smoke run)")
    ap.add_argument("--out", default=None, help="report folder (default: reproduce_PAPER)")
    args = ap.parse_args(argv)
    out = Path(args.out or f"reproduce_{args.paper}")
    rep = reproduce(args.paper, out, quick=args.quick)
    print(f"{rep['title']}: {sum(r['verdict'] == 'agrees' for r in rep['results'])} of {len(rep['results'])} "
          f"results agree within their stated tolerance; report: {out / 'report.md'}")
    return 0
