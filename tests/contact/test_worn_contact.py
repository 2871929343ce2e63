"""Contact on the worn surface (pinclear.contact.worn_geometry): the least-distance penetration
against an independent dense distance, today's forces at zero wear, energy conservation on a worn
profile, and a pin under a swinging load worn through the same kernel and wear law as the runs
(pinclear.contact.wear) against Archard's law over the ideal load history."""
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.interpolate import CubicSpline
from scipy.optimize import minimize

import pinclear
from pinclear.contact import channels, wear
from tests.helpers import wear_override

DATA = Path(__file__).parents[1] / "data"
JOURNAL, BALL = DATA / "wear_journal.yaml", DATA / "wear_ball.yaml"


def _kernel(joint, e):
    """(delta, n, p1) of the joint's compiled geometry (the runs' kernel), frame1 = world at the
    origin, frame2 at e."""
    M1, M2 = np.eye(4), np.eye(4)
    M2[:len(e), 3] = e
    out = np.zeros(1), np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 3))
    channels.channel_geometry(joint.geometry_code, joint._geo.gpar, M1, M2, np.zeros((4, 3)), *out)
    return out[0][0], out[1][0].copy(), out[2][0].copy()


def _plain(code, gpar, e):
    M1, M2 = np.eye(4), np.eye(4)
    M2[:3, 3] = e
    out = np.zeros(1), np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 3))
    channels.channel_geometry(code, gpar, M1, M2, np.zeros((4, 3)), *out)
    return out


def _periodic(wm, depth):
    return CubicSpline(np.append(wm.angles(), 2 * math.pi), np.append(depth, depth[0]), bc_type="periodic")


def _pocket(joint, amp, width):
    th = joint.wear.angles()
    rel = (th + 0.5 * math.pi + math.pi) % (2 * math.pi) - math.pi
    return amp * joint.c * np.exp(-0.5 * (rel / width) ** 2)


# ------------------------------------------------------------------ zero wear: today's contact
def test_zero_wear_gives_the_unworn_revolute_and_spherical_contact_to_1e_12():
    rng = np.random.default_rng(3)
    for path, code in ((JOURNAL, channels.G_PLANAR_REVOLUTE), (BALL, channels.G_SPHERICAL)):
        joint = pinclear.load(path, clearances=["A" if path == JOURNAL else "S"]).forces[-1]
        assert not np.any(joint.depth)
        plain = np.array([joint.c, joint.R1, joint.R2, 0.0, 0.0]) if code == channels.G_SPHERICAL else \
            joint._geo.gpar[:5]
        for _ in range(200):
            u = rng.normal(size=3)
            if code == channels.G_PLANAR_REVOLUTE:
                u[2] = 0.0
            e = joint.c * rng.uniform(0.6, 1.2) * u / np.linalg.norm(u)
            worn = _plain(joint.geometry_code, joint._geo.gpar, e)
            ref = _plain(code, plain, e)
            # penetration, normal and both contact points: the force F(delta) n at p1, p2
            assert abs(worn[0][0] - ref[0][0]) <= 1e-12 * abs(ref[0][0])
            for a, b, scale in ((worn[1], ref[1], 1.0), (worn[2], ref[2], joint.R1), (worn[3], ref[3], joint.R1)):
                assert np.max(np.abs(a - b)) <= 1e-12 * scale


# ------------------------------------------------------------------ (b) against a dense distance
def _dense_planar(joint, spline, e):
    """R2 - the least distance from the journal centre e to 10^4 points of the worn bearing, plain
    NumPy (the surface R1 + w(theta), w the periodic cubic spline through the node depths)."""
    th = np.linspace(0.0, 2 * math.pi, 10_000, endpoint=False)
    pts = (joint.R1 + spline(th))[:, None] * np.c_[np.cos(th), np.sin(th)]
    return joint.R2 - np.min(np.linalg.norm(pts - e[:2], axis=1))


def _dense_sphere(joint, e):
    """R2 - the least distance from the ball centre e to 10^4 points of the worn socket near the
    ball's direction (a cap of 60 deg: a Fibonacci lattice), w from the socket's interpolant."""
    wm = joint.wear
    n = 10_000
    k = np.arange(n) + 0.5
    cosa = 1.0 - (1.0 - math.cos(math.radians(60))) * k / n
    az = math.pi * (1 + 5 ** 0.5) * k
    u = e / np.linalg.norm(e)
    a = np.cross(u, [1.0, 0.0, 0.0] if abs(u[0]) < 0.9 else [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(u, a)
    sina = np.sqrt(1 - cosa ** 2)
    dirs = cosa[:, None] * u + sina[:, None] * (np.cos(az)[:, None] * a + np.sin(az)[:, None] * b)
    loc = wm.local(dirs)
    th, ph = np.arccos(np.clip(loc[:, 2], -1, 1)), np.arctan2(loc[:, 1], loc[:, 0])
    w = joint.profile(th, ph)[0]
    return joint.R2 - np.min(np.linalg.norm((joint.R1 + w)[:, None] * dirs - e, axis=1))


def _elastic_worn_run(path, name, depth, q0, v0, T, rtol=1e-10, dt_out=2e-5, overrides=None):
    mech = pinclear.load(path, clearances=[name], overrides={f"{name}.normal_law": "hertz", **(overrides or {})})
    joint = mech.forces[-1]
    worn = mech.replace(forces=list(mech.forces[:-1]) + [joint.with_depth(depth(joint))])
    tr = pinclear.simulate(worn, T, integrator="DOP853", rtol=rtol, q0=q0, v0=v0, assemble=False, dt_out=dt_out)
    assert tr.status == "success"
    return worn.forces[-1], tr


def _drift(tr, name):
    """Largest |E - E0| over the energy the contact moved (its elastic energy's range)."""
    E = tr.energy()["total"]
    return np.max(np.abs(E - E[0])) / np.ptp(tr.energy()["spring"])


def _assert_energy_is_the_integrators(run):
    # elastic (hertz law, no damping, no friction): E is constant but for the integration error,
    # which falls with the tolerance (DOP853: about in proportion); a force that is not the
    # gradient of the energy (a jump of delta, a wrong normal) leaves a drift the tolerance does
    # not reduce (measured: 3.3e-5 at rtol 1e-8, 1e-10 and 1e-12 alike where the contact point
    # jumped between two minima 0.4 deg apart). Measured here: ~2e-7 at 1e-10, ~3e-9 at 1e-12.
    coarse, fine = _drift(run(1e-10), run.name), _drift(run(1e-12), run.name)
    assert coarse <= 1e-5 and fine <= 0.1 * coarse


def test_worn_bearing_penetration_matches_a_dense_distance_and_an_elastic_run_conserves_energy():
    def rippled(j):
        # 80 % of the clearance, 0.2 rad wide, and a 5 % one-node ripple over it: steep flanks
        # (w'/r ~ 1) and minima of the distance closer than a cell
        d = _pocket(j, 0.8, 0.1)
        return d * (1 + 0.05 * (np.arange(len(d)) % 2))

    q0, v0 = np.array([2e-5, 0.0, 0.0]), np.array([0.05, -0.1, 30.0])
    joint, tr = _elastic_worn_run(JOURNAL, "A", rippled, q0, v0, 0.05)
    spline = _periodic(joint.wear, joint.depth)
    e, delta = tr.outputs["A.eccentricity"], tr.outputs["A.penetration"]
    near = np.flatnonzero(delta > -0.5 * joint.c)
    assert tr.outputs["A.fn"].max() > 5.0 and len(near) > 100
    # 10^4 points: the dense distance's own error is (R dtheta)^2 / (8 R2) ~ 5e-12 m
    err = max(abs(delta[i] - _dense_planar(joint, spline, e[i])) for i in near)
    assert err <= 1e-3 * joint.c

    def run(rtol):
        return _elastic_worn_run(JOURNAL, "A", lambda j: _pocket(j, 0.8, 0.1), q0, v0, 0.05, rtol=rtol)[1]

    run.name = "A"
    _assert_energy_is_the_integrators(run)


def test_worn_socket_penetration_matches_a_dense_distance_and_an_elastic_run_conserves_energy():
    # the least-distance contact (wear.contact: least_distance; the foundation's own tests are in
    # test_worn_foundation.py)
    least = wear_override(BALL, "S", contact="least_distance")

    def pocket(j):
        wm = j.wear
        th, ph = wm.angles()
        x = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], 1)
        ang = np.arccos(np.clip(x @ np.array([0.0, -1.0, 0.0]), -1, 1))
        return 0.8 * j.c * np.exp(-0.5 * (ang / 0.15) ** 2) * (ang < 0.6)

    q0, v0 = np.array([2e-5, 0.0, 0.0, 0, 0, 0]), np.array([0.05, 0.03, -0.1, 30.0, 5.0, 0.0])
    joint, tr = _elastic_worn_run(BALL, "S", pocket, q0, v0, 0.03, overrides=least)
    e, delta = tr.outputs["S.eccentricity"], tr.outputs["S.penetration"]
    near = np.flatnonzero(delta > -0.5 * joint.c)
    assert tr.outputs["S.fn"].max() > 5.0 and len(near) > 100
    # 10^4 points on a 60 deg cap: spacing ~0.9 mm, the dense distance's error ~ s^2 / (8 R2) ~ 5e-6 c
    err = max(abs(delta[i] - _dense_sphere(joint, e[i])) for i in near)
    assert err <= 1e-3 * joint.c

    def run(rtol):
        return _elastic_worn_run(BALL, "S", pocket, q0, v0, 0.03, rtol=rtol, overrides=least)[1]

    run.name = "S"
    _assert_energy_is_the_integrators(run)


def test_patch_of_a_vanishing_load_on_a_worn_bearing_is_finite_and_whole():
    # a sample at the edge of contact (zero or 1e-300 rad half-width) on a worn profile whose spline
    # dips below its lowest node: each sample's shares are finite and sum to 1 (before, the patch
    # window was 0 / 0 and a study stopped with "cannot convert float NaN to integer"); a load
    # of ordinary size keeps its Hertz-calibrated patch, which the floor does not touch
    wm = pinclear.load(JOURNAL, clearances=["A"]).forces[-1].wear
    th = wm.angles()
    depth = 2e-6 * np.exp(-((th - 1.5 * math.pi) / 0.05) ** 2)     # a narrow pocket: the spline rings
    depth[0] = 0.0
    theta = np.array([1.5 * math.pi, 1.5 * math.pi + 0.3, 0.7, 1.5 * math.pi])
    beta = np.array([0.0, 1e-300, 1e-12, 0.02])
    nodes, share = wear.patch_shares(wm, theta, beta, depth)
    assert np.all(np.isfinite(share)) and np.allclose(share.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    n1, s1 = wear.patch_shares(wm, theta[-1:], beta[-1:], depth)
    assert np.array_equal(n1[0][s1[0] > 0], nodes[-1][share[-1] > 0]) and np.allclose(s1[0][s1[0] > 0], share[-1][share[-1] > 0])
    with pytest.raises(ValueError, match="not finite"):
        wear.patch_shares(wm, np.array([math.nan]), np.array([0.01]), depth)
