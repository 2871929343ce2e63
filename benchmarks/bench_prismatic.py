"""Cost of one evaluation of the prismatic clearance's compiled kernel: the energy-consistent
model (``model: energy``, contact._kernels.prismatic_energy_force) against paper 003's per-mode
laws (``model: paper003``, contact._kernels.prismatic_force), same process, same states.

    python benchmarks/bench_prismatic.py [--states 400] [--reps 50] [--scale 1]

The states are random slider poses and velocities around the centred pose of urdf/clr_slider.yaml
(spread about one clearance at the corners, so nearly every state touches: corners, edges, faces
and their mixes). Each kernel runs in a compiled loop over the states with the joint placements
and Jacobians precomputed, so the timing is the kernel alone. Reported: best-of-7 mean time per
evaluation and the ratio energy / paper003.
"""
from __future__ import annotations

import argparse
import time

import numpy as np

import pinclear
from pinclear.model import kinematics
from pinclear.core.jit import njit
from pinclear.contact import prismatic
from pinclear.model.forces import Bodies, Frames


@njit(cache=False)
def _loop_energy(reps, geo, fr, bodies, modes, found, fric, ch, Hj, J, V, Z, tau, zdot):
    s = 0
    for _ in range(reps):
        for i in range(V.shape[0]):
            s += prismatic.prismatic_energy_force(geo, Frames(Hj[i], fr.jidx, fr.jMf, fr.slot, fr.M),
                                          Bodies(J[i], bodies.idx1, bodies.idx2), modes, found, fric, ch, V[i], Z[i],
                                          tau, zdot)
    return s


@njit(cache=False)
def _loop_paper003(reps, geo, fr, bodies, modes, rows, laws, fric, ch, Hj, J, V, Z, tau, zdot):
    s = 0
    for _ in range(reps):
        for i in range(V.shape[0]):
            s += prismatic.prismatic_force(geo, Frames(Hj[i], fr.jidx, fr.jMf, fr.slot, fr.M),
                                   Bodies(J[i], bodies.idx1, bodies.idx2), modes, rows, laws, fric, ch, V[i], Z[i], tau,
                                   zdot)
    return s


def states(count, scale=1.0, seed=3):
    rng = np.random.default_rng(seed)
    spread = scale * np.r_[1.5e-4, 1.5e-4, 1e-3, 3e-3, 3e-3, 3e-3]
    return [(rng.normal(size=6) * spread, rng.normal(size=6), np.r_[10 ** rng.uniform(-4, 0, 16), 0.0])
            for _ in range(count)]


def kernel_cost(model, st, reps):
    """(seconds per evaluation, fraction of states in contact) of one model's kernel."""
    mech = pinclear.load("clr_slider", clearances=["P"], overrides={"P.model": model})
    el = mech.forces[-1]
    ws = mech.workspace()
    d = ws.force_data[-1]
    Hj, J, touching = [], [], 0
    for q, v, z in st:
        kinematics.update(mech, ws, q, v)
        Hj.append(ws.fk.Hj.copy())
        J.append(ws.J6.copy())
        touching += el.event_values(mech, ws, d, 0.0, q, v, z).max() > 0
    Hj, J = np.array(Hj), np.array(J)
    V, Z = np.array([s[1] for s in st]), np.array([s[2] for s in st])
    tau, zdot = np.zeros(mech.nv), np.zeros(el.nz)
    # the kernel's own arguments (ForceElement.force_kernel) less the state and outputs, with the
    # placements and Jacobian of each state in place of the workspace's
    i = len(mech.forces) - 1
    _, args = el.force_kernel(mech, ws, d, ws.z_views[i], ws.zdot_views[i])
    a = list(args[:-4]) + [Hj, J, V, Z, tau, zdot]
    loop = _loop_energy if model == "energy" else _loop_paper003
    loop(1, *a)                                       # compile
    best = np.inf
    for _ in range(7):
        t0 = time.perf_counter()
        loop(reps, *a)
        best = min(best, time.perf_counter() - t0)
    return best / (reps * len(st)), touching / len(st)


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--states", type=int, default=400)
    p.add_argument("--reps", type=int, default=50)
    p.add_argument("--scale", type=float, default=1.0,
                   help="spread of the poses (1: deep contacts; 0.5: mostly free or grazing)")
    a = p.parse_args(argv)
    st = states(a.states, a.scale)
    cost = {}
    for model in ("energy", "paper003"):
        cost[model], frac = kernel_cost(model, st, a.reps)
        print(f"{model:9s} {cost[model] * 1e6:7.3f} us per evaluation ({100 * frac:.1f} % of states in contact)")
    print(f"ratio energy / paper003: {cost['energy'] / cost['paper003']:.2f}")


if __name__ == "__main__":
    main()
