"""Paper 004's screw-theory inverse dynamics of the 4-UPS/UPR simulator: the printed influence
coefficients, the three drive-force cases of its sec. 4.2 and the hinge layouts of its Fig. 2,
beside the paper's numbers (the study of ``pinclear reproduce 004``).

    python examples/four_ups_upr_inverse_dynamics.py [--out DIR] [--quick]

Gravity off, as in the paper's example. Writes DIR/report.md, report.html, report.json and
drive_forces.png, and prints the report.
"""
from __future__ import annotations

import argparse

from pinclear.studies.reproduce import reproduce
from pinclear.studies.reproduce.report import markdown


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="reproduce_004")
    ap.add_argument("--quick", action="store_true", help="smoke run: 201 samples per period")
    args = ap.parse_args(argv)
    print(markdown(reproduce("004", args.out, quick=args.quick)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
