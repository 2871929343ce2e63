"""A pin under a load whose line swings over an arc, worn over a life whose depth passes 10x the
contact law's penetration (issue 56 item 2a): quasi-static, the journal at rest on the worn profile
under each load (the package's least-distance kernel), the wear deposited by the package's
depth_increment (the elastic-foundation patch, pinclear.contact.wear.patch_shares), at two mesh sizes.

Criteria, from Archard's law over the ideal load history (the load F0 at the angle
alpha(t) = centre + swing sin(2 pi t / T)):
- the worn volume is k / H int F v dt;
- the pocket spans the swing plus the patch's half-width, beta_H + sqrt(2 d / c) (the Hertz
  half-width and the arc over which a journal conforming to a pocket of depth d touches it,
  w = (c + d) cos x - c > 0);
- the mean depth over that arc is the ideal history's (all its wear inside the arc) within 5 %;
- no node deeper than 1.5x the mean of its neighbours (no spike from the deposition);
- halving the cell changes the largest depth and the mean by <= 5 %.
Two caveats (measured, benchmarks/worn_contact.md): the pocket ends 8-11 deg inside the expected
arc, sqrt(2 d / c) taken at the largest depth over-stating the conforming arc at the swing's ends,
where the pocket is shallower, so the arc is checked as an envelope (the worn nodes inside it,
spanning the swing); and with every worn node inside it the mean over the arc equals the ideal
history's V / (R L arc) whatever the shape inside (Archard's volume is exact), so the 5 % criterion
adds nothing to the volume's; the spike and mesh criteria test the shape.
"""
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicSpline
from scipy.optimize import minimize

import pinclear
from pinclear.contact import channels, wear

JOURNAL = Path(__file__).parents[1] / "data" / "wear_journal.yaml"
CLEAR, LOAD, SPIN = 5e-4, 500.0, 20.0                # clearance m, load N, journal spin rad/s
SWING, CENTRE = math.radians(24.0), -0.5 * math.pi   # the load line's half-swing and mean direction
# samples per swing period, updates, service s per update: an update wears ~1.2e-7 m, below the
# patch's approach (the new bearing's Hertz approach b^2 / (2 R*) = 1.45e-7 m): a larger increment
# overshoots (a high spot worn below its neighbours) and the explicit update zigzags node to node
# (30 updates of 35 s: node / neighbours up to 1.9, benchmarks/worn_contact.md)
SAMPLES, UPDATES, FACTOR = 32, 400, 5.0


def _kernel(joint, e):
    """(delta, n, contact point) of the compiled worn geometry, journal centre at e (bearing frame)."""
    M1, M2 = np.eye(4), np.eye(4)
    M2[:2, 3] = e
    sc, de, n, p1, p2 = np.zeros((4, 3)), np.zeros(1), np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 3))
    channels.channel_geometry(joint.geometry_code, joint._geo.gpar, M1, M2, sc, de, n, p1, p2)
    return de[0], n[0, :2].copy(), p1[0, :2].copy()


def _rest(joint, P, x, spline, d0):
    """Journal centre (in units of c) at rest under the load P on the worn profile: the surface point
    whose outward normal is along P (Newton on theta - atan(w' / r) = alpha), the centre d0 (the
    law's penetration under |P|) inside it along P; accepted when the kernel's nearest point and
    normal agree, else the minimum of the potential U(delta) - P . e."""
    c, F0 = joint.c, np.linalg.norm(P)
    alpha = th = math.atan2(P[1], P[0])
    for _ in range(30):
        w, w1, w2 = (float(spline(th % (2 * math.pi), k)) for k in range(3))
        r = joint.R1 + w
        step = -(th - math.atan2(w1, r) - alpha) / (1.0 - (w2 * r - w1 * w1) / (r * r + w1 * w1))
        th += step
        if abs(step) < 1e-15:
            break
    pt = (joint.R1 + float(spline(th % (2 * math.pi)))) * np.array([math.cos(th), math.sin(th)])
    e = pt - (joint.R2 - d0) * P / F0
    d, n, _ = _kernel(joint, e)
    if abs(d - d0) < 1e-6 * d0 and np.linalg.norm(n - P / F0) < 1e-6:
        return e / c

    def potential(y):
        d, _, _ = _kernel(joint, y * c)
        return ((float(joint.law.energy(np.array([d]))[0]) if d > 0 else 0.0) - P @ (y * c)) / (F0 * c)
    y = e / c
    simplex = np.array([y, y + [d0 / c, 0], y + [0, d0 / c]])
    return minimize(potential, y, method="Nelder-Mead",
                    options={"xatol": 1e-7, "fatol": 1e-14, "initial_simplex": simplex, "maxfev": 2000}).x


def _life(nodes):
    mech = pinclear.load(JOURNAL, clearances=["A"], overrides={
        "A.material": {"E": 2.0e11, "nu": 0.3}, "A.clearance": CLEAR,
        "A.wear": {"model": "archard", "k": 1e-4, "hardness": 2e9, "nodes": nodes}})
    joint = mech.forces[-1]
    wm = joint.wear
    v = SPIN * wm.R2
    d0 = (LOAD / joint.law.K) ** (1 / joint.law.n)
    depth = np.zeros(wm.nodes)
    y = np.array([0.0, -1.0 - d0 / joint.c])
    dt = np.full(SAMPLES, 1.0 / SAMPLES)
    work = 0.0
    for u in range(UPDATES):
        # the samples' phase moved by the golden fraction each update: the life's samples fill the
        # swing's period evenly (the load history integrated, not 32 fixed angles)
        alpha = CENTRE + SWING * np.sin(2 * math.pi * (np.arange(SAMPLES) + (u * 0.6180339887) % 1.0) / SAMPLES)
        j = joint.with_depth(depth)
        spline = CubicSpline(np.append(wm.angles(), 2 * math.pi), np.append(depth, depth[0]), bc_type="periodic")
        th, F = np.empty(SAMPLES), np.empty(SAMPLES)
        for k, a in enumerate(alpha):
            P = LOAD * np.array([math.cos(a), math.sin(a)])
            y = _rest(j, P, y, spline, d0)
            d, _, p1 = _kernel(j, y * j.c)
            th[k] = math.atan2(p1[1], p1[0])
            F[k] = float(j.law.elastic(np.array([d]))[0]) if d > 0 else 0.0
        depth = depth + FACTOR * wear.depth_increment(wm, th, F, np.full(SAMPLES, v), dt, depth)
        work += FACTOR * np.sum(F * v * dt)
    return wm, joint, depth, work, d0


def _measures(wm, joint, depth, d0):
    beta = float(wear.half_width(wm, LOAD)) / wm.R1
    dmax = depth.max()
    half = SWING + beta + math.sqrt(2 * dmax / joint.c)
    lo, hi = 1.5 * math.pi - half, 1.5 * math.pi + half           # CENTRE in [0, 2 pi)
    sp = CubicSpline(np.append(wm.angles(), 2 * math.pi), np.append(depth, depth[0]), bc_type="periodic")
    mean = sp.integrate(lo, hi) / (hi - lo)
    ideal = wm.volume(depth) / (wm.R1 * wm.L * (hi - lo))
    nb = 0.5 * (np.roll(depth, 1) + np.roll(depth, -1))
    worn = depth > 1e-3 * dmax
    ang = wm.angles()
    return dict(half=half, beta=beta, lo=lo, hi=hi, mean=mean, ideal=ideal, dmax=dmax, d0=d0,
                spike=float(np.max(depth[depth > 0.1 * dmax] / nb[depth > 0.1 * dmax])),
                first=float(ang[worn].min()), last=float(ang[worn].max()))


def test_the_journal_rests_on_the_new_bearing_at_the_laws_penetration_along_the_load():
    # the new bearing: the rest position is the closed form e = (c + d0) P / |P|, K d0^n = |P|,
    # and a few updates wear Archard's volume k / H int F v dt with F = |P| (the fast tier's check
    # of the slow life's machinery)
    mech = pinclear.load(JOURNAL, clearances=["A"], overrides={
        "A.material": {"E": 2.0e11, "nu": 0.3}, "A.clearance": CLEAR,
        "A.wear": {"model": "archard", "k": 1e-4, "hardness": 2e9, "nodes": 360}})
    joint = mech.forces[-1]
    d0 = (LOAD / joint.law.K) ** (1 / joint.law.n)
    flat = CubicSpline(np.linspace(0, 2 * math.pi, 5), np.zeros(5), bc_type="periodic")
    for a in (CENTRE - SWING, CENTRE, 0.3):
        u = np.array([math.cos(a), math.sin(a)])
        y = _rest(joint, LOAD * u, np.zeros(2), flat, d0)
        assert np.linalg.norm(y * joint.c - (joint.c + d0) * u) < 1e-9 * joint.c
    wm = joint.wear
    th = CENTRE + SWING * np.sin(2 * math.pi * np.arange(SAMPLES) / SAMPLES)
    inc = wear.depth_increment(wm, th, np.full(SAMPLES, LOAD), np.full(SAMPLES, SPIN * wm.R2),
                               np.full(SAMPLES, 1.0 / SAMPLES))
    assert wm.volume(inc) == pytest.approx(wm.k * LOAD * SPIN * wm.R2 / wm.hardness, rel=1e-12)


@pytest.mark.slow
def test_a_swinging_load_wears_archards_pocket_over_the_swing_at_two_mesh_sizes():
    out = {}
    for nodes in (360, 720):
        wm, joint, depth, work, d0 = _life(nodes)
        m = out[nodes] = _measures(wm, joint, depth, d0)
        assert m["dmax"] > 10 * d0                                   # the life passes 10x the penetration
        assert wm.volume(depth) == pytest.approx(wm.k * work / wm.hardness, rel=1e-9)
        assert m["mean"] == pytest.approx(m["ideal"], rel=0.05)
        assert lo_ok(m, wm)
        assert m["spike"] <= 1.5
    a, b = out[360], out[720]
    assert b["dmax"] == pytest.approx(a["dmax"], rel=0.05) and b["mean"] == pytest.approx(a["mean"], rel=0.05)


def lo_ok(m, wm):
    """The worn nodes lie inside the expected arc (one cell's slack), and span the swing."""
    return (m["lo"] - wm.spacing <= m["first"] and m["last"] <= m["hi"] + wm.spacing
            and m["first"] <= 1.5 * math.pi - SWING and m["last"] >= 1.5 * math.pi + SWING)


if __name__ == "__main__":
    import time
    import sys
    for nodes in [int(a) for a in sys.argv[1:]] or (360, 720):
        t0 = time.process_time()
        wm, joint, depth, work, d0 = _life(nodes)
        m = _measures(wm, joint, depth, d0)
        print(nodes, "cpu", round(time.process_time() - t0, 1), "vol", wm.volume(depth), wm.k * work / wm.hardness,
              {k: (round(math.degrees(v), 2) if k in ("half", "beta", "lo", "hi", "first", "last") else v)
               for k, v in m.items()}, "ratio", m["mean"] / m["ideal"], "arc ok", lo_ok(m, wm))
        np.save(f"/tmp/w56c_scratch/depth_{nodes}.npy", depth)
