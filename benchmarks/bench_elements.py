"""Cost of the force elements inside real runs: microseconds per right-hand-side evaluation and the
ratio over the Pinocchio floor, measured in the same process.

    python benchmarks/bench_elements.py [--t-end 0.2] [--repeat 5] [--scenes NAME ...] [--json out.json]

Scenes: the four-bar with a point-to-point spring-damper and a constant crank torque (a sidecar
written to a temporary folder beside a copy of urdf/four_bar.urdf), the bundled clearance scenes
with each joint type (spherical, planar and spatial revolute, prismatic with both contact
models), and LuGre variants (sidecar overrides). Each scene runs RK45 at rtol 1e-6; the cost of
an evaluation is the integration's CPU over its evaluations, (cpu_s - setup_cpu_s) / rhs_evals
(integrator, events and output sampling included), best of ``--repeat`` runs. The floor is
pinclear.studies.bench.rhs.pinocchio_floor at the run's own samples (computeAllTerms +
updateFramePlacements per state). ``loop`` shows whether any stage of the run went through
Python (the target, every scene <= 3x the floor, needs none).
"""
from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
import warnings
from pathlib import Path

import yaml

import pinclear
from pinclear.studies.bench.rhs import pinocchio_floor
from pinclear.core.models import model_path

LUGRE = {"type": "lugre", "mu_s": 0.3, "mu_c": 0.2, "vs": 1e-3, "s0": 1e4, "s1": 10.0}


def four_bar_spring_torque(folder: Path) -> Path:
    """The bundled four-bar with a spring-damper from a ground point to the coupler's middle and
    a constant torque on the crank, as a sidecar in ``folder``."""
    doc = yaml.safe_load(model_path("four_bar").read_text())
    doc["name"] = "four_bar_spring_torque"
    doc["forces"] = [
        {"name": "spring", "type": "spring_damper", "frame1": {"parent": "ground", "xyz": [0.15, 0.35, 0.0]},
         "frame2": {"parent": "coupler", "xyz": [0.175, 0.0, 0.0]}, "k": 40.0, "c": 0.5, "free_length": 0.1},
        {"name": "motor", "type": "joint_force", "joint": "crank_joint", "law": {"type": "constant", "value": 0.02}},
    ]
    shutil.copy(model_path("four_bar").with_suffix(".urdf"), folder / "four_bar.urdf")
    path = folder / "four_bar_spring_torque.yaml"
    path.write_text(yaml.safe_dump(doc))
    return path


def scenes(folder: Path):
    """(label, load arguments, simulate arguments) of every benchmarked scene."""
    return [
        # a smooth run takes few evaluations: longer, so that they outweigh the run's fixed costs
        ("four_bar+spring+torque", dict(path=four_bar_spring_torque(folder)), dict(t_end=2.0)),
        # the ball starts at rest without gravity: a push sends it bouncing round the socket
        ("clr_ball+S", dict(path="clr_ball", clearances=["S"]), dict(v0=[0.02, 0.01, 0.0, 0.0, 0.0, 3.0])),
        ("clr_pendulum+S", dict(path="clr_pendulum", clearances=["S"]), {}),
        ("clr_planar_pendulum+A", dict(path="clr_planar_pendulum", clearances=["A"]), {}),
        ("clr_hinge+R", dict(path="clr_hinge", clearances=["R"]), {}),
        ("clr_slider+P energy", dict(path="clr_slider", clearances=["P"]), {}),
        ("clr_slider+P paper003", dict(path="clr_slider", clearances=["P"], overrides={"P.model": "paper003"}), {}),
        ("slider_crank+P", dict(path="slider_crank_clearance", clearances=["P"]), {}),
        ("clr_pendulum+S lugre", dict(path="clr_pendulum", clearances=["S"], overrides={"S.friction_law": LUGRE}), {}),
        ("clr_hinge+R lugre", dict(path="clr_hinge", clearances=["R"], overrides={"R.friction_law": LUGRE}), {}),
        ("clr_slider+P lugre", dict(path="clr_slider", clearances=["P"], overrides={"P.friction_law": LUGRE}), {}),
    ]


def measure(mech, t_end, repeat, **kw):
    """(us per evaluation, floor us, the best run) over ``repeat`` runs after a warm-up."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pinclear.simulate(mech, min(t_end, 1e-3), rtol=1e-6, **kw)            # loads (or compiles) the kernels
        best = None
        for _ in range(repeat):
            tr = pinclear.simulate(mech, t_end, rtol=1e-6, dt_out=t_end / 100, **kw)
            per = (tr.stats["cpu_s"] - tr.stats["setup_cpu_s"]) / max(tr.stats["rhs_evals"], 1)
            if best is None or per < best[0]:
                best = (per, tr)
    per, tr = best
    floor = pinocchio_floor(mech, tr.q, tr.v, repeat=10)
    return 1e6 * per, 1e6 * floor, tr


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--t-end", type=float, default=0.2, help="simulated seconds per run (scenes may set theirs)")
    ap.add_argument("--repeat", type=int, default=5, help="runs per scene (the best counts)")
    ap.add_argument("--scenes", nargs="+", default=None, help="labels to run (default: all)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        todo = [s for s in scenes(Path(tmp)) if a.scenes is None or s[0] in a.scenes]
        print(f"{'scene':24s} {'status':8s} {'evals':>7s} {'events':>6s} {'us/eval':>8s} {'floor us':>8s} "
              f"{'ratio':>6s}  loop")
        for label, kw, run in todo:
            mech = pinclear.load(kw.pop("path"), **kw)
            run = dict(run)
            us, floor, tr = measure(mech, run.pop("t_end", a.t_end), a.repeat, **run)
            row = {"scene": label, "status": tr.status, "rhs_evals": tr.stats["rhs_evals"],
                   "events": len(tr.stats["events"]), "us_per_eval": us, "floor_us": floor, "ratio": us / floor,
                   "loop": tr.stats["loop"]}
            rows.append(row)
            print(f"{label:24s} {tr.status:8s} {row['rhs_evals']:7d} {row['events']:6d} {us:8.2f} {floor:8.2f} "
                  f"{row['ratio']:6.2f}  {row['loop']}", flush=True)
    if a.json:
        Path(a.json).write_text(json.dumps({"t_end": a.t_end, "repeat": a.repeat, "scenes": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
