"""The compiled geometry switch against a table-driven dispatch, in one process (issue 40).

    python benchmarks/bench_geometry_dispatch.py

contact._kernels.channel_geometry picks a clearance type's geometry with `if code == ...`
(inlined into the clearance force kernel). The table-driven alternative binds each type's
geometry kernel as a stage and calls it through its address, as the engine calls every stage
(pinclear.core.call.call_stage). Printed: ns per geometry call each way on the spherical and
revolute geometries, their ratio, and one whole evaluation of a one-clearance scene for scale
(docs/design.md, "Registries")."""
import time, warnings, numpy as np
import pinclear
from pinclear.core.jit import njit
from pinclear.contact import channels
from pinclear.core.call import call_stage
from pinclear.core.stage import bind
from pinclear.dynamics.stepping.build import Evaluation
from pinclear.dynamics.stepping.system import evaluate
from pinclear.dynamics import formulations
warnings.simplefilter("ignore")

@njit(cache=False)
def by_switch(k, code, gpar, M1, M2, scratch, delta, n, p1, p2):
    s = 0.0
    for i in range(k):
        M2[0, 3] = 1e-4 * (i % 7)
        channels.channel_geometry(code, gpar, M1, M2, scratch, delta, n, p1, p2)
        s += delta[0]
    return s

@njit(cache=False)
def spherical_geometry(gpar, M1, M2, scratch, delta, n, p1, p2):
    channels.channel_geometry(channels.G_SPHERICAL, gpar, M1, M2, scratch, delta, n, p1, p2)
    return np.inf

@njit(cache=False)
def revolute_geometry(gpar, M1, M2, scratch, delta, n, p1, p2):
    channels.channel_geometry(channels.G_REVOLUTE, gpar, M1, M2, scratch, delta, n, p1, p2)
    return np.inf

@njit(cache=False)
def by_table(k, table, code, M2, delta):
    s = 0.0
    for i in range(k):
        M2[0, 3] = 1e-4 * (i % 7)
        call_stage(table[code, 0], table[code, 1], 0.0)
        s += delta[0]
    return s

gpar = np.array([1e-4, 0.01, 0.0099, 1e-4, 0.02])
M1, M2 = np.eye(4), np.eye(4)
scratch, delta, n, p1, p2 = np.zeros((4, 3)), np.zeros(4), np.zeros((4, 3)), np.zeros((4, 3)), np.zeros((4, 3))
args = (gpar, M1, M2, scratch, delta, n, p1, p2)
stages = [bind(spherical_geometry, args, code=True, name="spherical"), bind(revolute_geometry, args, code=True, name="revolute")]
table = np.array([[s.fn, s.ctx] for s in stages], dtype=np.int64)
k = 200000
by_switch(10, 0, *args); by_table(10, table, 0, M2, delta)
res = {}
for rep in range(5):               # best of 5
    for name, code, row in (("spherical", channels.G_SPHERICAL, 0), ("revolute", channels.G_REVOLUTE, 1)):
        c0 = time.perf_counter(); a = by_switch(k, code, *args); t1 = time.perf_counter() - c0
        c0 = time.perf_counter(); b = by_table(k, table, row, M2, delta); t2 = time.perf_counter() - c0
        assert a == b
        res.setdefault(name, []).append((t1 / k, t2 / k))
for name, v in res.items():
    v = np.array(v).min(axis=0)
    print(f"{name}: switch {v[0]*1e9:.1f} ns, table (stage call) {v[1]*1e9:.1f} ns, ratio {v[1]/v[0]:.2f}")
# one evaluation of a clearance scene for scale
for scene, clr in (("clr_ball", "S"), ("clr_hinge", "R")):
    mech = pinclear.load(scene, clearances=[clr])
    tr = pinclear.simulate(mech, 0.02, rtol=1e-6, dt_out=0.001)
    form = formulations.get("lagrange")(mech)
    ev = Evaluation(form)
    X = [ev.pack(q, v, z) for q, v, z in zip(tr.q, tr.v, tr.z)]
    dx = np.zeros(len(X[0]))
    best = np.inf
    for rep in range(5):
        c0 = time.perf_counter()
        for t, x in zip(tr.t, X):
            evaluate(ev.system, t, x, dx)
        best = min(best, (time.perf_counter() - c0) / len(X))
    print(f"{scene}: one evaluation {best*1e9:.0f} ns ({len(mech.clearances)} clearance(s))")
