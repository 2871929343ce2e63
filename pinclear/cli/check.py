"""`pinclear simulate ... --check`: is the run converged?

The run is made again with its integration tolerances divided by REFINE (rtol and atol; RK4's
fixed step h halved) and half its output step, into OUT/check/, and the two summaries are compared:
every peak (drive forces, contact forces, accelerations, and the window's with --peaks-after),
the number of events and the energy audit. A quantity has "moved" when it changes by more than
``tol`` (default 1 %) of its size; the audit must close in both runs. The table goes to stdout,
the exit status is 0 when nothing moved, 1 otherwise.

Why this test: a run at tolerance rtol carries a global error of order C rtol (the error per
step is controlled, the global error is not, and contact events amplify it); the difference
between the run and one at rtol/10 estimates that error (the refined run's own is about ten times
smaller), the same Richardson-style argument as a grid study. Half the output step checks what
the samples resolve (a peak from the integration does not depend on the grid: a change there
points at the integration; a window peak from the samples, --peaks-after, may move with it).
"""
from __future__ import annotations

import argparse
import math
from pathlib import Path

#: the factor the tolerances are divided by
REFINE = 10.0
#: the relative change above which a quantity has moved (--check-tol)
DEFAULT_TOL = 0.01


def refined_args(args, traj):
    """The simulate arguments of the refined run: rtol and atol / REFINE (atol stays derived from
    rtol when it was), RK4's h and the output step halved (the run's own output step when it used
    the default), into OUT/check, without --check or --resume."""
    import numpy as np

    ref = argparse.Namespace(**vars(args))
    rtol = args.rtol if args.rtol is not None else traj.meta.get("rtol")
    ref.rtol = None if rtol is None else float(rtol) / REFINE
    ref.atol = None if args.atol is None else args.atol / REFINE
    ref.h = None if args.h is None else args.h / 2.0
    dt = args.dt_out
    if dt is None and len(traj.t) > 1:
        dt = float(np.median(np.diff(traj.t)))
    ref.dt_out = None if dt is None else dt / 2.0
    ref.out = str(Path(args.out) / "check")
    ref.check, ref.resume, ref.checkpoint_every = False, None, None
    return ref


def _peaks(summary: dict, prefix="") -> dict:
    """{quantity: value} of a summary's peaks and event count."""
    out = {}
    for fam, unit in (("drive_force_peaks", "N or N m"), ("contact_force_peaks", "N")):
        for k, v in (summary.get(fam) or {}).items():
            out[f"{prefix}{fam}.{k}"] = (v, unit)
    for k, rec in (summary.get("acceleration_peaks") or {}).items():
        out[f"{prefix}acceleration_peaks.{k}"] = ((rec or {}).get("value"), "m/s^2 or rad/s^2")
    return out


def compare(run: dict, refined: dict, tol=DEFAULT_TOL) -> list[dict]:
    """Rows {quantity, unit, run, refined, change, moved} of two summaries (Trajectory.summary):
    change = |refined - run| / max(|run|, |refined|) for the peaks and the event count (moved: >
    tol; a window's peak below the run's resolution, rtol x the channel's whole-run peak, is
    judged against that), and the energy audit's relative error and verdict (moved: an audit that
    does not close)."""
    rows = []
    a, b = _peaks(run), _peaks(refined)
    wa, wb = run.get("peaks_after"), refined.get("peaks_after")
    if isinstance(wa, dict) and isinstance(wb, dict):
        a.update(_peaks(wa, "peaks_after."))
        b.update(_peaks(wb, "peaks_after."))
    a["events"], b["events"] = (run.get("events"), "1"), (refined.get("events"), "1")
    rtol = run.get("rtol") if isinstance(run.get("rtol"), (int, float)) else 0.0
    for key in a:
        x, unit = a[key]
        y = b.get(key, (None, unit))[0]
        if x is None or y is None or not (math.isfinite(x) and math.isfinite(y)):
            rows.append({"quantity": key, "unit": unit, "run": x, "refined": y, "change": None, "moved": x != y})
            continue
        size = max(abs(x), abs(y))
        change = abs(y - x) / size if size > 0 else 0.0
        # a window's peak that is zero to the run's resolution (rtol x the same channel's whole-run
        # peak: e.g. a coordinate at rest after the transient, 1e-14) cannot move by a fraction of itself
        whole = a.get(key.removeprefix("peaks_after."), (None,))[0]
        floor = rtol * abs(whole) if isinstance(whole, (int, float)) and math.isfinite(whole) else 0.0
        moved = abs(y - x) > tol * max(size, floor)
        rows.append({"quantity": key, "unit": unit, "run": x, "refined": y, "change": change, "moved": moved})
    ea, eb = run.get("energy_balance") or {}, refined.get("energy_balance") or {}
    for key in ("error_rel",):
        rows.append({"quantity": f"energy_balance.{key}", "unit": "1 (of scale_J)", "run": ea.get(key),
                     "refined": eb.get(key), "change": None, "moved": False})
    rows.append({"quantity": "energy_balance.ok", "unit": "", "run": ea.get("ok"), "refined": eb.get("ok"),
                 "change": None, "moved": ea.get("ok") is False or eb.get("ok") is False})
    rows.append({"quantity": "max_closure_residual", "unit": "m or rad", "run": run.get("max_closure_residual"),
                 "refined": refined.get("max_closure_residual"), "change": None, "moved": False})
    return rows


def _cell(v):
    if isinstance(v, float):
        return f"{v:.6g}"
    return "-" if v is None else str(v)


def table(rows, tol) -> str:
    """The rows as an aligned text table, with a verdict line."""
    head = ["quantity", "run", "refined", "change", "moved"]
    body = [[r["quantity"] + (f" [{r['unit']}]" if r["unit"] else ""), _cell(r["run"]), _cell(r["refined"]),
             "-" if r["change"] is None else f"{100 * r['change']:.3g} %", "MOVED" if r["moved"] else ""]
            for r in rows]
    width = [max(len(x[i]) for x in [head, *body]) for i in range(len(head))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(line, width)).rstrip() for line in [head, *body]]
    moved = [r["quantity"] for r in rows if r["moved"]]
    lines.append(f"converged to {100 * tol:g} %: nothing moved" if not moved else
                 f"not converged to {100 * tol:g} %: {len(moved)} moved ({', '.join(moved[:5])}"
                 + (", ..." if len(moved) > 5 else "") + "); tighten --rtol (or --h) and check again")
    return "\n".join(lines)


def check_run(args, simulate) -> int:
    """After a successful `simulate` into args.out: the refined run (``simulate(refined_args)``
    returns its exit status), the table on stdout; 0 when nothing moved, 1 otherwise."""
    import json

    from pinclear.core.bounded import read_text_bounded
    from pinclear.dynamics.trajectory import Trajectory

    out = Path(args.out)
    traj = Trajectory.load(out / "trajectory.npz")
    ref = refined_args(args, traj)
    print(f"pinclear: check: the run again at rtol {_cell(ref.rtol)}"
          + (f", h {_cell(ref.h)} s" if ref.h is not None else "")
          + (f", output step {_cell(ref.dt_out)} s" if ref.dt_out is not None else "") + f", into {ref.out}")
    rc = simulate(ref)
    if rc != 0:
        print(f"pinclear: check: the refined run did not complete (exit {rc}); nothing to compare")
        return 1

    def summary(folder):
        return json.loads(read_text_bounded(Path(folder) / "summary.json", 64 << 20, "summary.json", "summary"))
    tol = getattr(args, "check_tol", None) or DEFAULT_TOL
    rows = compare(summary(out), summary(ref.out), tol)
    print(table(rows, tol))
    return 1 if any(r["moved"] for r in rows) else 0
