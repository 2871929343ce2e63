"""`pinclear export-run RUN --csv OUT.csv --mat OUT.mat`: a saved run's samples for other programs
(MATLAB, ADAMS, spreadsheets; pinclear.dynamics.export_run)."""
from __future__ import annotations

import sys
from pathlib import Path


def build_parser():
    """The parser of `pinclear export-run`."""
    from pinclear.cli.args import OneLineParser

    p = OneLineParser(prog="pinclear export-run",
                      description="a saved run's samples as CSV and/or MATLAB .mat (t, q, v, a, multipliers, "
                                  "outputs, energies; SI units; docs/outputs.md)")
    p.add_argument("run", help="a trajectory .npz, or the folder `pinclear simulate --out` wrote it to")
    p.add_argument("--csv", default=None, metavar="OUT.csv", help="write the samples as CSV (one column per channel)")
    p.add_argument("--mat", default=None, metavar="OUT.mat", help="write the samples as a MATLAB .mat file")
    return p


def cli_main(argv=None) -> int:
    from pinclear.core.bounded import check_regular
    from pinclear.core.errors import InputError
    from pinclear.dynamics.trajectory import Trajectory

    try:
        args = build_parser().parse_args(argv)
    except SystemExit as exc:          # --help (0) or a one-line usage error (2): a return code
        return int(exc.code or 0)
    if not (args.csv or args.mat):
        raise InputError("export-run: nothing to write: give --csv OUT.csv and/or --mat OUT.mat")
    run = Path(args.run)
    if run.is_dir():
        run = run / "trajectory.npz"
    if not run.exists():
        raise InputError(f"{args.run}: no such trajectory (a .npz, or a folder holding trajectory.npz)")
    check_regular(run, "path", "trajectory")          # a FIFO or a device would block or never end
    tr = Trajectory.load(run)
    for path, write, what in ((args.csv, tr.to_csv, "CSV"), (args.mat, tr.to_mat, "MATLAB .mat")):
        if path:
            write(path)
            print(f"wrote {path} ({what}: {len(tr.t)} samples)")
    return 0


if __name__ == "__main__":
    sys.exit(cli_main(sys.argv[1:]))
