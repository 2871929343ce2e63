"""`pinclear export FILE --mjcf OUT.xml`: the command line of the MJCF export.
"""
from __future__ import annotations

from pinclear.core import safeio
from pinclear.io.export_mjcf import export_mjcf


def build_parser():
    """The parser of `pinclear export`."""
    from pinclear.cli.args import OneLineParser, number

    p = OneLineParser(prog="pinclear export", description="a pinclear mechanism as MuJoCo MJCF "
                      "(docs/import_export.md)")
    p.add_argument("file", help="mechanism sidecar or a bundled mechanism's name")
    p.add_argument("--mjcf", required=True, metavar="OUT.xml", help="the MJCF file to write")
    p.add_argument("--h", type=number(unit="s"), default=1e-3,
                   help="MuJoCo time step [s] (solref's time constant is 2 h; default 1e-3)")
    p.add_argument("--trust", action="store_true", help="the mechanism file may run code (docs/security.md)")
    return p


def cli_main(argv=None) -> int:
    from pathlib import Path

    from pinclear.io.sidecar import load

    args = build_parser().parse_args(argv)
    mech = load(args.file, trust=args.trust or None)
    xml, notes = export_mjcf(mech, args.h)
    safeio.write_text(Path(args.mjcf), xml + "\n")
    print(f"wrote {args.mjcf}: {mech.nv} joints, {len(mech.closures)} closures")
    for n in notes:
        print(f"note: {n}")
    return 0
