"""Cost of an oiled run against the dry run of the same mechanism (target: oiled <= 3x dry CPU).

    PYTHONPATH=$PWD python benchmarks/bench_lubrication.py [--window-s2 0.5] [--window-sc 0.024]

Two scenes: paper 000's 4UPS-UPU with its spherical clearance S2 (urdf/four_ups_upu.yaml) dry
against lubricated_spherical, and the slider-crank with its pin P (urdf/slider_crank_clearance.yaml)
dry against lubricated_revolute, both at viscosity 0.1 Pa s and the default roughness. Each run
once first to compile and load its kernels (outside the measurement), then measured in this one
process: CPU seconds of the run (``cpu_s``, compile excluded), right-hand-side evaluations, and
the oiled / dry ratios per run and per evaluation side by side, for three integrator pairings
(PAIRS). Both scenes start from their sidecars' start (the journal or ball centred).
"""
from __future__ import annotations

import argparse

import pinclear

SCENES = {
    "4UPS-UPU + S2": ("four_ups_upu", "S2", {"S2.type": "lubricated_spherical", "S2.viscosity": 0.1}),
    "slider-crank + P": ("slider_crank_clearance", "P", {"P.type": "lubricated_revolute", "P.viscosity": 0.1}),
}


#: (dry integrator, oiled integrator): the same explicit one; each its own (the film's squeeze
#: damping near contact makes the oiled run stiff: an implicit integrator, SciPy's BDF: pinclear's ROS34PW2 took 68.7e6 evaluations on the oiled
#: 4UPS-UPU over 0.5 s); the same implicit one
PAIRS = (("RK45", "RK45"), ("RK45", "BDF"), ("BDF", "BDF"))


def run(name, clearance, overrides, t_end, integrator):
    mech = pinclear.load(name, clearances=[clearance], overrides=overrides)
    pinclear.simulate(mech, min(t_end, 1e-3), integrator=integrator)     # compiled and loaded outside the measurement
    tr = pinclear.simulate(mech, t_end, integrator=integrator)
    assert tr.status == "success", tr.message
    return float(tr.stats["cpu_s"]), int(tr.stats["rhs_evals"])


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--window-s2", type=float, default=0.5, help="simulated seconds of the 4UPS-UPU runs")
    p.add_argument("--window-sc", type=float, default=0.024, help="simulated seconds of the slider-crank runs "
                   "(two crank revolutions at 5000 rpm)")
    a = p.parse_args(argv)
    windows = {"4UPS-UPU + S2": a.window_s2, "slider-crank + P": a.window_sc}
    print("| scene | window [s] | dry: integrator, cpu [s], evals | oiled: integrator, cpu [s], evals | "
          "oiled/dry per run | oiled/dry per evaluation |")
    print("|---|---|---|---|---|---|")
    for label, (name, clr, over) in SCENES.items():
        done = {}
        for dry, oiled in PAIRS:
            for integ, o in ((dry, {}), (oiled, over)):
                if (integ, bool(o)) not in done:
                    done[integ, bool(o)] = run(name, clr, o, windows[label], integ)
            (c0, n0), (c1, n1) = done[dry, False], done[oiled, True]
            print(f"| {label} | {windows[label]:g} | {dry}, {c0:.3f}, {n0} | {oiled}, {c1:.3f}, {n1} | {c1 / c0:.2f} | "
                  f"{(c1 / n1) / (c0 / n0):.2f} |", flush=True)


if __name__ == "__main__":
    main()
