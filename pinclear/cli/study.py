"""`pinclear study NAME`: the command line of the wear studies.
"""
from __future__ import annotations

import json
from pathlib import Path

from pinclear.studies.wear import STUDIES


def build_parser():
    from pinclear.cli.args import OneLineParser

    p = OneLineParser(prog="pinclear study", description="wear and lubrication studies the seed papers "
                                "name as their next step (docs/wear_lubrication.md); each writes OUT/README.md with "
                                "its findings")
    p.add_argument("name", choices=sorted(STUDIES), help="the study")
    p.add_argument("--out", default=None, help="output folder (default docs/study/NAME)")
    p.add_argument("--quick", action="store_true", help="a shorter service life and chaos series (minutes)")
    p.add_argument("--smoke", action="store_true", help="the whole path in about a minute, to check that it runs "
                   "(not a result)")
    return p


def cli_main(argv=None) -> int:
    from pinclear.cli.commands import check_out_dir
    from pinclear.core import safeio

    args = build_parser().parse_args(argv)
    run = STUDIES[args.name]
    out = Path(args.out or Path("docs") / "study" / args.name)
    # as simulate does: an unwritable OUT fails before minutes of computing, and a second study into
    # the same folder is refused while the first runs
    check_out_dir(out)
    with safeio.folder_lock(out):
        rows = run(out, quick=args.quick or args.smoke, smoke=args.smoke)
    print(json.dumps(rows, indent=1, default=str))
    return 0
