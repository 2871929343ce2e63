"""Archard wear of a planar revolute clearance (pinclear.contact.wear, pinclear.analysis.wear_life) against
the law integrated by hand, energy conservation of the worn geometry, the iterative scheme and the
sidecar's errors."""
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad

import pinclear
from pinclear.analysis.wear_life import WearSettings, block_length, converged, wear_run
from pinclear.contact import wear
from pinclear.core.errors import ContactSetupError, InputError
from tests.helpers import assert_audit_closes

JOURNAL = Path(__file__).parents[1] / "data" / "wear_journal.yaml"
OMEGA = 20.0                                   # journal spin, rad/s


def _model(**kw):
    base = dict(k=1e-4, hardness=1e8, nodes=360, distribution="hertz", R1=0.0101, R2=0.01, L=0.02,
                estar=1.1e9, rstar=1.01)
    return wear.WearModel(**{**base, **kw})


def test_block_sliding_wears_k_F_s_over_H_A():
    # a flat block of contact area A = 2 b L (uniform pressure over whole cells) sliding a distance
    # s = v T at constant load F: Archard's h = k F s / (H A), exactly
    wm = _model(distribution="uniform")
    v, T, n = 0.3, 2.0, 400
    beta = 5 * wm.spacing                                  # the contact covers 10 cells exactly:
    b = beta * wm.R1
    F = b * b * math.pi * wm.L * wm.estar / (4 * wm.rstar)   # the load whose Hertz half-width is b
    assert wear.half_width(wm, F) == pytest.approx(b, rel=1e-14)
    theta = np.full(n, 0.5 * wm.spacing + 20 * wm.spacing)   # a cell boundary: 5 cells either side
    t = np.linspace(0.0, T, n)
    w = wear.trapezoid_weights(t)
    h = wear.depth_increment(wm, theta, np.full(n, F), np.full(n, v), w)
    ref = wm.k * F * v * T / (wm.hardness * 2 * b * wm.L)
    covered = h > 0
    assert covered.sum() == 10 and np.flatnonzero(covered).tolist() == list(range(16, 26))
    assert h[covered] == pytest.approx(ref, rel=1e-12)
    assert np.all(h[~covered] == 0.0)


def _static_start(mech):
    law = mech.forces[-1].law
    delta = (9.81 / law.K) ** (1.0 / law.n)               # K delta^n = m g (1 kg)
    c = mech.forces[-1].c
    return np.array([0.0, -(c + delta), 0.0]), np.array([0.0, 0.0, OMEGA])


def _conforming_depth(wm, c, volume):
    """Floor depth h of a pocket of the worn volume that conforms to the journal (the rigid limit of
    the patch deposition, valid once h >> the Hertz approach b^2 / (2 R*)): the journal's circle
    sunk h below the bearing's, w(theta) = (c + h) cos theta - c ~ h - c theta^2 / 2 over the arc
    theta0 = sqrt(2 h / c), so V = R_b L int w dtheta = (4 / 3) R_b L sqrt(2 / c) h^(3/2)."""
    return (3.0 * volume * math.sqrt(c) / (4.0 * math.sqrt(2.0) * wm.R1 * wm.L)) ** (2.0 / 3.0)


def _hertz_approach(wm, F):
    """The new bearing's Hertz approach b^2 / (2 R*) (Johnson eq. 4.43): the most the elastic patch
    can leave the worn floor off the journal's circle."""
    b = math.sqrt(4 * F * wm.rstar / (math.pi * wm.L * wm.estar))
    return b * b / (2 * wm.rstar)


def test_journal_under_constant_load_and_spin_wears_the_hand_integrated_crescent():
    mech = pinclear.load(JOURNAL, clearances=["A"])
    joint = mech.forces[-1]
    wm = joint.wear
    q0, v0 = _static_start(mech)
    T = 0.05
    tr = pinclear.simulate(mech, T, integrator="DOP853", rtol=1e-10, q0=q0, v0=v0, assemble=False, dt_out=1e-4)
    assert tr.status == "success"
    h = wear.block_increment(wm, "A", tr)
    # by hand: load m g at the bottom (theta = -90 deg), slip omega R_j, Hertz half-width
    F, vs = 9.81, OMEGA * wm.R2
    b = math.sqrt(4 * F * wm.rstar / (math.pi * wm.L * wm.estar))
    p0 = 2 * F / (math.pi * b * wm.L)
    centre = -0.5 * math.pi
    ref = np.zeros(wm.nodes)
    for i, th in enumerate(wm.angles()):
        rel = (th - centre + math.pi) % (2 * math.pi) - math.pi
        lo, hi = wm.R1 * (rel - 0.5 * wm.spacing), wm.R1 * (rel + 0.5 * wm.spacing)
        lo, hi = max(lo, -b), min(hi, b)
        if hi > lo:
            cell = quad(lambda s: p0 * math.sqrt(max(0.0, 1 - (s / b) ** 2)), lo, hi, epsabs=0, epsrel=1e-12)[0]
            ref[i] = wm.k * vs * T * cell / (wm.hardness * wm.R1 * wm.spacing)
    # the steady state holds F and the slip to the integration tolerance (rtol 1e-10)
    assert np.max(np.abs(h - ref)) <= 1e-6 * ref.max()
    # depth at the centre: k p0 v T / H up to the cell average of the ellipse, 1 - (d/b)^2 / 24
    hmax = wm.k * p0 * vs * T / wm.hardness
    d = wm.R1 * wm.spacing
    assert h.max() == pytest.approx(hmax, rel=(d / b) ** 2 / 12)
    # width: worn nodes within the Hertz half-width (plus the cell), all those inside it worn
    rel = np.abs((wm.angles() - centre + math.pi) % (2 * math.pi) - math.pi) * wm.R1
    assert np.all(h[rel > b + d / 2] == 0.0)
    assert np.all(h[rel < b - d / 2] > 0.0)
    # the worn volume is Archard's k F s / H
    vol = h.sum() * wm.R1 * wm.spacing * wm.L
    assert vol == pytest.approx(wm.k * F * vs * T / wm.hardness, rel=1e-6)


def test_worn_bearing_run_closes_the_energy_balance_and_creates_none():
    mech = pinclear.load(JOURNAL, clearances=["A"], overrides={"A.friction_law": {"type": "modified_coulomb",
                                                                                     "mu": 0.2}})
    joint = mech.forces[-1]
    th = joint.wear.angles()
    # a pocket of 80 % of the clearance, 0.2 rad wide, at the bottom: steep flanks (w'/r ~ 1)
    pocket = 0.8 * joint.c * np.exp(-0.5 * (((th + 0.5 * math.pi + math.pi) % (2 * math.pi) - math.pi) / 0.1) ** 2)
    worn = mech.replace(forces=list(mech.forces[:-1]) + [joint.with_depth(pocket)])
    tr = pinclear.simulate(worn, 0.05, integrator="DOP853", rtol=1e-10, q0=np.array([2e-5, 0.0, 0.0]),
                           v0=np.array([0.05, -0.1, 30.0]), assemble=False, dt_out=1e-5)
    assert tr.status == "success"
    assert tr.outputs["A.fn"].max() > 5.0 and len(tr.stats["events"]) >= 2
    assert_audit_closes(tr, "A")


def test_worn_profile_passes_through_the_nodes_and_is_continuous():
    mech = pinclear.load(JOURNAL, clearances=["A"])
    joint = mech.forces[-1]
    depth = np.zeros(joint.wear.nodes)
    depth[90] = 1e-5
    w = joint.with_depth(depth)
    # the spline passes through the nodes, and is C1 across a cell boundary
    ang = w.wear.angles()
    assert w.profile(ang[88:93])[0] == pytest.approx(depth[88:93], abs=1e-18)
    eps = 1e-9
    a, b = w.profile([ang[91] - eps, ang[91] + eps])
    assert abs(a[1] - a[0]) < 1e-6 * 1e-5 and abs(b[1] - b[0]) < 1e-3 * abs(b).max()


def _journal_life(tmp_path):
    """The journal's 2000-cycle life under its static load through the converged scheme:
    (mechanism, settings, start state, result)."""
    mech = pinclear.load(JOURNAL, clearances=["A"])
    start = _static_start(mech)
    s = WearSettings(cycles=2000.0, period=0.01, updates=2, block_periods=1, transient_periods=0, rtol=1e-8,
                     dt_out=1e-4)
    return mech, s, start, converged(mech, "A", s, out=tmp_path, start=start)


def test_scheme_update_factor_converges_and_resumes(tmp_path):
    mech, s, start, res = _journal_life(tmp_path)
    assert res["converged"]
    r1, r2 = res["rounds"][-2:]
    u2, f1, f2, d1, d2 = r2["updates"], r1["factor"], r2["factor"], r1["max_depth"]["A"], r2["max_depth"]["A"]
    assert f2 == pytest.approx(f1 / 2) and abs(d2 - d1) <= 0.05 * d2
    # constant load: Archard's volume k F v t / H, exactly; the patch deposition makes the pocket
    # conform to the journal (depth ~3.6x the Hertz approach at the end of this life), so the floor's
    # depth is the conforming pocket's of that volume, h ~ V^(2/3), no longer the linear k p0 v t / H
    # of the Hertz pressure (1.65e-6 m here; the conforming pocket's 1.02e-6 m)
    wm, c = mech.forces[-1].wear, mech.forces[-1].c
    V = wm.k * 9.81 * OMEGA * wm.R2 * s.cycles * s.period / wm.hardness
    assert wm.volume(res["depth"]["A"]) == pytest.approx(V, rel=1e-6)
    h = _conforming_depth(wm, c, V)
    assert h <= d2 <= h + _hertz_approach(wm, 9.81)
    for name in ("checkpoint.npz", "history.csv", "profile.csv"):
        assert (tmp_path / f"updates_{u2}" / name).exists()
    # an interrupted run resumes where its checkpoint stands, to the same profile
    s4 = WearSettings(**{**s.__dict__, "updates": 4})
    whole = wear_run(mech, "A", s4, start=start)

    def stop(done, total, depth):
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        wear_run(mech, "A", s4, out=tmp_path / "r", progress=stop, start=start)
    again = wear_run(mech, "A", s4, out=tmp_path / "r", start=start)
    assert np.array_equal(again["depth"]["A"], whole["depth"]["A"])
    assert again["history"]["cycles"] == whole["history"]["cycles"]


def test_depth_scheme_wears_the_hand_integrated_crescent_in_the_predicted_updates(tmp_path):
    # constant load and spin: every block wears the same crescent, so the depth-limited update makes
    # ceil(depth / (step c)) updates, whatever the step
    mech = pinclear.load(JOURNAL, clearances=["A"])
    start = _static_start(mech)
    wm, c = mech.forces[-1].wear, mech.forces[-1].c
    s = WearSettings(cycles=2000.0, period=0.01, transient_periods=0, rtol=1e-8, dt_out=1e-4, scheme="depth",
                     step=0.004)
    res = converged(mech, "A", s, out=tmp_path, start=start)
    # the rate falls as the pocket conforms (test_scheme_update_factor_converges_and_resumes): the
    # life's depth is the conforming pocket's of Archard's volume, and a depth-limited update wears
    # at most step x c at the deepest node (the pocket widens as it deepens: the largest nodal
    # increment is step x c, the deepest node's less), so there are at least ceil(depth / (step c))
    # updates, the first (on the new bearing) wearing step x c at the node it deepens most
    V = wm.k * 9.81 * OMEGA * wm.R2 * s.cycles * s.period / wm.hardness
    h = _conforming_depth(wm, c, V)
    assert res["converged"] and len(res["rounds"]) == 2
    for r in res["rounds"]:
        assert r["complete"]
        assert h <= r["max_depth"]["A"] <= h + _hertz_approach(wm, 9.81)
        assert r["updates"] >= math.ceil(r["max_depth"]["A"] / (r["step"] * c) - 1e-9)
    h = np.diff([0.0] + res["history"]["A.max_depth"])
    assert h[0] == pytest.approx(res["settings"].step * c, rel=1e-9)
    assert np.all(h > 0) and np.all(h <= res["settings"].step * c * (1 + 1e-9))
    assert (tmp_path / "step_0.002" / "checkpoint.npz").exists()


def test_depth_scheme_resumes_an_interrupted_run_to_the_same_profile(tmp_path):
    mech = pinclear.load(JOURNAL, clearances=["A"])
    start = _static_start(mech)
    s = WearSettings(cycles=2000.0, period=0.01, transient_periods=0, rtol=1e-8, dt_out=1e-4, scheme="depth",
                     step=0.004)
    whole = wear_run(mech, "A", s, start=start)

    def stop(done, total, depth):
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        wear_run(mech, "A", s, out=tmp_path, progress=stop, start=start)
    again = wear_run(mech, "A", s, out=tmp_path, start=start)
    assert np.array_equal(again["depth"]["A"], whole["depth"]["A"]) and again["complete"]
    assert again["history"]["cycles"] == whole["history"]["cycles"]
    assert again["history"]["factor"] == whole["history"]["factor"]
    # a checkpoint of other settings is refused, naming the folder
    with pytest.raises(InputError, match=r"checkpoint of another run: settings.step: 0.004 \(checkpoint\) vs 0.002"):
        wear_run(mech, "A", WearSettings(**{**s.__dict__, "step": 0.002}), out=tmp_path, start=start)


def test_block_length_of_a_steady_journal_is_one_period():
    # constant load and spin: every period wears the same crescent, so one period's mean is the
    # converged rate (k p0 v T / H at the centre node, to the integration tolerance)
    mech = pinclear.load(JOURNAL, clearances=["A"])
    s = WearSettings(cycles=2000.0, period=0.01, transient_periods=0, rtol=1e-8, dt_out=1e-4)
    n, ok, table = block_length(mech, "A", s, start=_static_start(mech))
    assert (n, ok, [row[0] for row in table]) == (1, True, [1, 2])
    assert table[1][1]["A"] == pytest.approx(table[0][1]["A"], rel=1e-6)
    # its blocks continue a state in contact: the start-pose check (here tighter than the static
    # penetration) is for a sidecar's pose, so it must not stop them (the nine-bar's B at 0.1 mm
    # ends its start-up in an impact 1.45x that limit)
    tight = pinclear.load(JOURNAL, clearances=["A"], overrides={"A.max_initial_penetration": 1e-9})
    with pytest.raises(ContactSetupError, match="initial pose penetrates"):
        pinclear.simulate(tight, 1e-3, q0=_static_start(mech)[0], v0=_static_start(mech)[1], assemble=False,
                          start="state")
    assert block_length(tight, "A", s, start=_static_start(tight))[:2] == (1, True)


SPRING = Path(__file__).parents[1] / "data" / "wear_spring.yaml"


def _spring_feedback(mech):
    """The spring-loaded journal's load F(h) by hand: K delta^n = k_s (Y0 - c - h - delta) (the spring
    holds the journal against the pocket's floor, h deeper)."""
    from scipy.optimize import brentq

    joint, spring = (next(f for f in mech.forces if f.name == n) for n in ("A", "press"))
    law = joint.law
    ks, Y0 = spring.k, -spring.reference

    def load(h):
        return brentq(lambda F: ks * (Y0 - joint.c - h - (F / law.K) ** (1 / law.n)) - F, 0.0, ks * Y0, xtol=1e-15,
                      rtol=1e-15)
    return load


def _spring_run(step, tol, max_rounds):
    from scipy.integrate import solve_ivp

    mech = pinclear.load(SPRING, clearances=["A"])
    joint = next(f for f in mech.forces if f.name == "A")
    load = _spring_feedback(mech)
    delta0 = (load(0.0) / joint.law.K) ** (1 / joint.law.n)
    start = np.array([0.0, -(joint.c + delta0), 0.0]), np.array([0.0, 0.0, OMEGA])
    s = WearSettings(cycles=3600.0, period=0.01, transient_periods=0, rtol=1e-8, dt_out=1e-4, scheme="depth",
                     step=step)
    res = converged(mech, "A", s, tol=tol, max_rounds=max_rounds, start=start)
    # the reference: Archard's volume rate k F(h) v / H into a pocket conforming to the journal (the
    # patch deposition's limit once the depth passes the Hertz approach), h(V) the conforming depth
    wm = joint.wear
    V = solve_ivp(lambda t, V: [wm.k * load(_conforming_depth(wm, joint.c, max(V[0], 0.0))) * OMEGA * wm.R2
                                / wm.hardness], (0.0, s.cycles * s.period), [0.0], rtol=1e-10, atol=1e-20).y[0, -1]
    exact = _conforming_depth(wm, joint.c, V)
    return res, exact, load, _hertz_approach(wm, load(0.0))


def joint_c(res):
    return next(f for f in res["mech"].forces if f.name == "A").c


def test_depth_scheme_follows_a_known_geometric_feedback():
    # the spring presses the journal less as it sinks into its wear: the load falls ~20 % over the
    # life and the wear rate with it. The scheme is explicit Euler in the cycles with a depth step:
    # it overestimates (the rate falls within each update) and its error is first order in the step,
    # so the finer trial's error is about the two trials' difference (an a-posteriori bound, x2)
    # (the rate also falls as the pocket conforms: the reference is the conforming pocket's, whose
    # model error, up to one Hertz approach, exceeds the step's, so the a-posteriori bound of the
    # finer trial's step error cannot be checked against it; the bracket is checked instead)
    res, exact, load, approach = _spring_run(0.004, 0.05, 3)
    # the feedback is there: the load falls ~12 % over the life (the conforming pocket is shallower
    # than the Hertz pressure's crescent would be, ~20 %)
    assert load(exact) < 0.9 * load(0.0)
    assert res["converged"]
    depths = [r["max_depth"]["A"] for r in res["rounds"]]
    steps = [r["step"] for r in res["rounds"]]
    assert all(b == pytest.approx(a / 2) for a, b in zip(steps, steps[1:]))
    (coarse, fine) = depths[-2:]
    # explicit Euler on a falling rate overestimates, so the depth falls as the step halves, once
    # the step is stable: an update wearing more than the patch's approach (the new bearing's Hertz
    # approach, 2.9e-7 m here, against step x c = 4e-7 m for the first trial) overshoots into a
    # narrow crescent and the coarsest trial comes out shallower (1.37e-6 against 1.49e-6 m)
    stable = [d for d, st in zip(depths, steps) if st * joint_c(res) < approach]
    assert len(stable) >= 2 and all(a > b for a, b in zip(stable, stable[1:]))
    assert coarse - fine <= 0.05 * fine
    assert exact <= fine <= exact + approach
    assert res["depth"]["A"].argmax() == 270                    # the pocket at the bottom (-90 deg)


def test_depth_scheme_reports_a_trial_sequence_that_did_not_converge():
    # the same feedback with a tolerance tighter than the coarse steps' error: the test must fail,
    # say so, and keep every trial's numbers (the finest trial's result returned)
    res, exact, _, _ = _spring_run(0.01, 1e-3, 2)
    assert not res["converged"]
    (c1, c2) = res["rounds"]
    assert c2["step"] == c1["step"] / 2 and c2["updates"] > c1["updates"]
    d1, d2 = c1["max_depth"]["A"], c2["max_depth"]["A"]
    assert d1 > d2 > exact and abs(d1 - d2) > 1e-3 * d2
    assert res["depth"]["A"].max() == d2 and res["settings"].step == c2["step"]


def test_depth_scheme_stops_at_max_updates_and_says_so(tmp_path):
    mech = pinclear.load(JOURNAL, clearances=["A"])
    s = WearSettings(cycles=2000.0, period=0.01, transient_periods=0, rtol=1e-8, dt_out=1e-4, scheme="depth",
                     step=1e-4, max_updates=3)
    res = converged(mech, "A", s, out=tmp_path, start=_static_start(mech))
    assert not res["converged"] and not res["complete"]
    (r,) = res["rounds"]
    assert r["updates"] == 3 and not r["complete"] and res["history"]["cycles"][-1] < s.cycles


@pytest.mark.parametrize("wear_spec, key, text", [
    ({"model": "archard", "hardness": 1e8}, "clearances.A.wear.k", "required"),
    ({"model": "rabinowicz", "k": 1e-4, "hardness": 1e8}, "clearances.A.wear.model", "archard"),
    ({"k": 1e-4, "hardness": 1e8, "nodes": 3}, "clearances.A.wear.nodes", "in [16, 100000]"),
    ({"k": 1e-4, "hardness": 1e8, "shape": 1}, "clearances.A.wear.shape", "distribution"),
])
def test_wear_key_errors_name_file_key_and_choices(wear_spec, key, text):
    with pytest.raises(ContactSetupError) as exc:
        pinclear.load(JOURNAL, clearances=["A"], overrides={"A.wear": wear_spec})
    msg = str(exc.value)
    assert "wear_journal.yaml" in msg and key in msg and text in msg


def test_wear_command_refuses_a_joint_without_wear():
    mech = pinclear.load(JOURNAL, clearances=["A"], overrides={"A.wear": None})
    with pytest.raises(ContactSetupError, match="wear_journal.yaml.*clearances.A.wear"):
        wear_run(mech, "A", WearSettings(cycles=10.0, period=0.01))


def test_convergence_covers_the_mesh_a_fine_mesh_passes_a_coarse_one_fails(tmp_path):
    # the mesh half of the convergence test: the converged trial rerun with the cells halved. The
    # pocket conforms to the journal over +-sqrt(2 h / c) ~ 8 deg (h ~ 1e-6 m, c = 1e-4 m,
    # test_scheme_update_factor_converges_and_resumes): 1 deg cells resolve it (the halving changes
    # the depth by the cell's share of the parabola, (d / theta0)^2 / 12 ~ 0.1 %), 22.5 deg cells
    # (16 nodes) do not: the whole pocket falls in one or two cells, and halving them moves the
    # largest depth by tens of per cent
    from pinclear.analysis.wear_life import profile_norm

    mech, s, start, res = _journal_life(tmp_path)
    m = res["mesh"]
    assert res["converged"] and m["ok"] and m["nodes"] == (360, 720)
    assert m["d_max"] <= 0.05 and m["d_l2"] <= 0.05 and (tmp_path / "mesh_halved").is_dir()
    # the L2 norm is the RMS over the angle: a mesh-independent measure of the same profile
    wm = mech.forces[-1].wear
    assert m["l2"][0] == pytest.approx(profile_norm(wm, res["depth"]["A"]), rel=1e-12)
    assert m["l2"][0] == pytest.approx(math.sqrt(np.sum(res["depth"]["A"] ** 2) * wm.spacing / (2 * math.pi)),
                                       rel=1e-12)
    coarse = pinclear.load(JOURNAL, clearances=["A"], overrides={"A.wear": {"model": "archard", "k": 1e-4,
                                                                            "hardness": 1e8, "nodes": 16}})
    bad = converged(coarse, "A", s, start=start)
    assert not bad["converged"] and not bad["mesh"]["ok"] and bad["mesh"]["nodes"] == (16, 32)
    assert bad["mesh"]["d_max"] > 0.05


def test_a_life_at_a_scaled_k_over_h_is_the_nominal_history_at_scaled_cycles(tmp_path):
    # Archard's rate is k/H times a function of the profile: halving k makes every depth-limited
    # update stand for twice the cycles with the same profiles, so the life of N cycles at k/2 is the
    # nominal run's history read at N/2 (pinclear.analysis.wear_life.at_wear_ratio, which the wear
    # studies' k/H tables use); the last, partial update is linear in its cycles, as the reading is
    from pinclear.analysis.wear_life import at_wear_ratio

    s = WearSettings(cycles=2000.0, period=0.01, transient_periods=0, rtol=1e-8, dt_out=1e-4, scheme="depth",
                     step=0.004)
    mech = pinclear.load(JOURNAL, clearances=["A"])
    start = _static_start(mech)
    nominal = wear_run(mech, "A", s, start=start)
    half = pinclear.load(JOURNAL, clearances=["A"], overrides={
        "A.wear": {"model": "archard", "k": 0.5e-4, "hardness": 1.0e8, "nodes": 360}})
    got = wear_run(half, "A", s, start=start)
    wm = half.forces[-1].wear
    d, v = at_wear_ratio(nominal["history"], "A", s.cycles, 0.5)
    assert len(got["history"]["cycles"]) < len(nominal["history"]["cycles"])
    assert float(got["depth"]["A"].max()) == pytest.approx(d, rel=1e-6)
    assert wm.volume(got["depth"]["A"]) == pytest.approx(v, rel=1e-6)
    # beyond the run's life there is nothing to read
    assert at_wear_ratio(nominal["history"], "A", s.cycles, 2.0) is None
