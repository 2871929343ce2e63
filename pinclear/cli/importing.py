"""`pinclear import FILE --out DIR`: the command line of the importers.
"""
from __future__ import annotations

import json
import sys

from pinclear.io.importers import import_file


def build_parser():
    """The parser of `pinclear import`."""
    from pinclear.cli.args import OneLineParser

    p = OneLineParser(prog="pinclear import", description="a mechanism from an SDF, MJCF or closing-frame URDF "
                      "file as a URDF tree + sidecar that pinclear.load accepts (docs/import_export.md)")
    p.add_argument("file", help="the mechanism file (.sdf; .xml or .mjcf: MJCF; .urdf with closing_<name>_1/_2 "
                   "frames)")
    p.add_argument("--out", required=True, help="output folder (NAME.urdf, NAME.yaml, NAME.import.json)")
    p.add_argument("--cut", action="append", default=[], metavar="JOINT",
                   help="cut this joint (repeatable), e.g. the joints that will get clearances (default: the "
                        "fewest closure rows)")
    p.add_argument("--fix", default=None, metavar="LINK", help="weld this link to the world (replacing the joints "
                   "between it and the world)")
    p.add_argument("--name", default=None, help="mechanism name (default: the model's)")
    return p


def cli_main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    report = import_file(args.file, args.out, args.cut, args.fix, args.name)
    print(json.dumps(report, indent=2))
    # what the import replaced or left out that changes the mechanism: one line each on stderr
    for line in report.get("warnings", ()):
        print(f"pinclear: warning: {' '.join(str(line).split())}", file=sys.stderr)
    return 0
