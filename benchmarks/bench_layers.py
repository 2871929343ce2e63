"""The move into layered subpackages costs nothing at run time: ``pinclear bench rhs`` (one
evaluation of every formulation) and ``pinclear bench runs`` (whole runs, every scene) on the tree
before and the tree after, alternating in one session, ratio of the medians after/before.

    python3 benchmarks/bench_layers.py --base /tmp/base [--rounds 3]

``--base`` is a checkout of the tree before (its compiled extension copied in: the comparison
uses each tree's own pinclear through PYTHONPATH). Results: benchmarks/bench_layers.md.
"""
from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
RHS = [("four_bar", []), ("four_ups_upu", ["--clearance", "S2"]), ("rrr3", ["--clearance", "P2"]),
       ("slider_crank_clearance", ["--clearance", "P"]), ("three_upru_up", ["--clearance", "P_UP"])]
RUN = "import sys; from pinclear.cli import main; sys.exit(main(sys.argv[1:]))"


def bench(tree: Path, args: list[str], out: Path) -> dict:
    env = {**os.environ, "PYTHONPATH": str(tree), "PINCLEAR_QUIET_COMPILE": "1"}
    subprocess.run([sys.executable, "-c", RUN, *args, "--out", str(out)], env=env, check=True,
                   capture_output=True, text=True)
    return json.loads(next(out.glob("*.json")).read_text())


def one_round(tree: Path, tmp: Path) -> dict:
    got = {}
    for scene, extra in RHS:
        d = bench(tree, ["bench", "rhs", scene, *extra], tmp / f"rhs_{scene}")
        for method, r in d["methods"].items() if "methods" in d else d.items():
            if isinstance(r, dict) and "time_s" in r:
                got[f"rhs {scene} {method}"] = r["time_s"]
    d = bench(tree, ["bench", "runs", "--t-end", "0.5"], tmp / "runs")
    for s in d["scenes"]:
        if s.get("status") == "success":
            got[f"run {s['scene']}"] = s["cpu_per_sim_s"]
    return got


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--base", required=True, type=Path, help="the tree before (a checkout with its extension)")
    ap.add_argument("--rounds", type=int, default=3)
    a = ap.parse_args(argv)
    trees = {"before": a.base.resolve(), "after": REPO}
    samples = {k: {} for k in trees}
    for r in range(a.rounds):
        order = ["before", "after"] if r % 2 == 0 else ["after", "before"]
        for name in order:
            with tempfile.TemporaryDirectory() as tmp:
                for key, t in one_round(trees[name], Path(tmp)).items():
                    samples[name].setdefault(key, []).append(t)
        print(f"round {r + 1} of {a.rounds} done", file=sys.stderr)
    rows = []
    for key in sorted(set(samples["before"]) & set(samples["after"])):
        b, f = statistics.median(samples["before"][key]), statistics.median(samples["after"][key])
        rows.append((key, b, f, f / b))
    print("| quantity | before (median) | after (median) | after/before |\n|---|---|---|---|")
    for key, b, f, q in rows:
        print(f"| {key} | {b:.4g} s | {f:.4g} s | {q:.3f} |")
    ratios = [q for *_, q in rows]
    print(f"\nmedian ratio {statistics.median(ratios):.3f}, range {min(ratios):.3f}-{max(ratios):.3f} "
          f"over {len(rows)} quantities, {a.rounds} rounds")
    return 0


if __name__ == "__main__":
    sys.exit(main())
