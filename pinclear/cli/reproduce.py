"""`pinclear reproduce PAPER`: the command line of the papers' studies.
"""
from __future__ import annotations

from pathlib import Path

from pinclear.studies.reproduce import PAPERS, reproduce
from pinclear.studies.reproduce.verdicts import summary


def build_parser():
    """The parser of `pinclear reproduce`."""
    from pinclear.cli.args import OneLineParser, number

    ap = OneLineParser(prog="pinclear reproduce", description=__doc__.splitlines()[0])
    ap.add_argument("paper", choices=sorted(PAPERS) + ["claims"],
                    help="the source paper's study to run, or 'claims': write the claims page (docs/claims.md) "
                         "from the reports under --from")
    ap.add_argument("--from", dest="source", default="docs/reproduce", metavar="DIR",
                    help="with 'claims': the folder of the reports (NNN/report.json; default docs/reproduce)")
    ap.add_argument("--quick", action="store_true", help="a reduced study (smoke run)")
    ap.add_argument("--bands", action="store_true",
                    help="measure each row's band over the reconstructed inputs: a one-at-a-time screen, then "
                         "the inputs that matter for each row (their ends plus a small space-filling sample). "
                         "Every point is stored under OUT/bands/: the same command again resumes")
    ap.add_argument("--budget", type=number("positive", "CPU s"), default=None, metavar="CPU_S",
                    help="CPU seconds the bands may use in this run (default: the whole design); the rows it "
                         "does not reach are 'not measured' with the CPU they need, and a later run resumes")
    ap.add_argument("--out", default=None, help="report folder (default: reproduce_PAPER)")
    ap.add_argument("--workers", type=int, default=None, help="local worker processes (default: one per CPU)")
    ap.add_argument("--scheduler", default=None, metavar="ADDRESS",
                    help="run the simulations on the Dask cluster at ADDRESS (tcp://HOST:8786) "
                         "(default: local processes)")
    return ap


def cli_main(argv=None) -> int:
    ap = build_parser()
    args = ap.parse_args(argv)
    if args.paper == "claims":
        from pinclear.core import safeio
        from pinclear.studies.reproduce.report import claims_page

        if not any(Path(args.source).glob("*/report.json")):
            ap.error(f"--from {args.source}: no report there (NNN/report.json, as pinclear reproduce NNN --out "
                     f"{args.source}/NNN writes)")
        target = Path(args.out or "docs/claims.md")
        safeio.write_text(target, claims_page(args.source))
        print(f"claims of the reports under {args.source}: {target}")
        return 0
    out = Path(args.out or f"reproduce_{args.paper}")
    if args.workers is not None and args.workers < 1:
        ap.error(f"--workers must be a positive number of processes, got {args.workers}")
    if args.budget is not None and not args.bands:
        ap.error("--budget is the CPU budget of --bands: give --bands too")
    rep = reproduce(args.paper, out, quick=args.quick, workers=args.workers, scheduler=args.scheduler,
                    bands=args.bands, budget=args.budget)
    print(f"{rep['title']}: {summary(rep['results'])}; report: {out / 'report.md'}")
    return 0
