"""Issue-3 table: per source mechanism, tree size, closures and rows, mobility, redundant rows,
and CPU seconds per simulated second over one period of its motion law at rtol 1e-8 (lagrange,
RK45), with the closure residual and tracking error of that run.

    python benchmarks/mechanisms_table.py
"""
import json
import sys
import warnings
from pathlib import Path

import pinclear

ROOT = Path(__file__).resolve().parents[1]
RUNS = [("four_ups_upu", 2.0, {}), ("nine_bar", 1.0, {}), ("three_upru_up", 25.1327412, {}),
        ("four_ups_upr", 1.0, {"law": "high"}), ("four_ups_upr", 1.0, {"law": "high", "limbs": False}),
        ("four_ups_upr", 2.0 * 3.14159265, {"law": "low"})]


def main():
    rows = []
    for name, t_end, opts in RUNS:
        mech = pinclear.load(ROOT / "urdf" / f"{name}.yaml", options=opts or None)
        q = pinclear.model.kinematics.assemble(mech)
        mob = pinclear.model.kinematics.mobility(mech, q)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            tr = pinclear.simulate(mech, t_end, rtol=1e-8)
        s = tr.summary()
        rows.append({"mechanism": name, "options": opts, "nq": mech.nq, "nv": mech.nv,
                     "closures": {c.name: c.nrows for c in mech.closures}, "mobility": mob["mobility"],
                     "redundant_rows": mob["redundant_rows"], "t_end": t_end, "status": s["status"],
                     "message": s["message"] if s["status"] != "success" else "",
                     "cpu_per_sim_s": s.get("cpu_per_sim_s"), "max_closure_residual": s["max_closure_residual"],
                     "tracking_error": s.get("tracking_error")})
        print(json.dumps(rows[-1]), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
