"""The Lyapunov loop of a paper-000 or -002 check, its chunks run as simulate() calls
(mechanism_lyapunov(keep_alive=False), the reference) and as pinclear.dynamics.simulate.Restarts runs
(the default), alternating in one process: CPU of each, CPU outside the compiled chunks, and
whether the exponents agree bit for bit (benchmarks/bench_reproduce.md, last section).

    python benchmarks/bench_lyapunov_keep.py 000|002 PERIODS REPEATS     # e.g. 000 4 5
"""
import os
import sys
import time
import warnings

warnings.simplefilter("ignore")
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import numpy as np
from bench_reproduce import _setup
from pinclear.io.sidecar import load
from pinclear.analysis.lyapunov import mechanism_lyapunov
import pinclear.dynamics.stepping.chunk as C
paper = sys.argv[1]; n = float(sys.argv[2]); rep = int(sys.argv[3])
path, par, value, T, common = _setup(paper)
ov = dict(common["load_options"]["overrides"])
for key in (par if isinstance(par, dict) else {par: 1.0}):
    ov[key] = value
mech = load(path, clearances=common["load_options"]["clearances"], overrides=ov)
sim = {"rtol": 1e-8} if paper == "000" else dict(rtol=1e-6, method="lagrange", integrator="RK45")
adv0 = C.advance
box = [0.0]
def adv(*a):
    c = time.process_time(); r = adv0(*a); box[0] += time.process_time() - c; return r
C.advance = adv
for ka in (False, True):
    mechanism_lyapunov(mech, 0.5 * T, renorm=T / 4, transient=0.25 * T, keep_alive=ka, **sim)
tot = {True: [], False: []}; out = {True: [], False: []}; res = {}
for r in range(rep):
    for ka in ((False, True) if r % 2 == 0 else (True, False)):
        box[0] = 0.0
        c = time.process_time()
        res[ka] = mechanism_lyapunov(mech, n * T, renorm=T / 4, transient=2 * T, keep_alive=ka, **sim)
        tot[ka].append(time.process_time() - c)
        out[ka].append(tot[ka][-1] - box[0])
a, b = res[False], res[True]
eq = a.exponent == b.exponent and np.array_equal(a.running, b.running) and np.array_equal(a.t, b.t)
med = {k: float(np.median(v)) for k, v in tot.items()}
mo = {k: float(np.median(v)) for k, v in out.items()}
adv_med = float(np.median(np.array(tot[False] + tot[True]) - np.array(out[False] + out[True])))
print(f"{paper}: {n:g} periods of {T:g} s, renorm {T/4:g} s, transient 2 periods, {sim}; exponent {b.exponent!r}, "
      f"bit for bit: {eq}")
print("  total CPU old", [round(x, 3) for x in tot[False]], "new", [round(x, 3) for x in tot[True]])
print("  outside the compiled chunks old", [round(x, 3) for x in out[False]], "new", [round(x, 3) for x in out[True]])
print(f"  medians: total old {med[False]:.3f} new {med[True]:.3f} ratio {med[True]/med[False]:.3f}; pairwise ratio median "
      f"{np.median(np.array(tot[True]) / np.array(tot[False])):.3f}")
print(f"  medians: compiled chunks {adv_med:.3f}, outside old {mo[False]:.3f} new {mo[True]:.3f}; "
      f"ratio (chunks + outside) {(adv_med + mo[True]) / (adv_med + mo[False]):.3f}")
