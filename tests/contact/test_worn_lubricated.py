"""The oiled and worn ball (issue 56: lubricated wear): a lubricated_spherical entry with ``wear:``.
At zero wear it is the lubricated joint; on a worn socket the dry law and the asperities act on the
least-distance gap and the film at that gap; wear follows the load the surfaces carry (dry +
asperity), so a film that keeps lambda >= 4 wears nothing."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import pinclear
from pinclear.contact.lubricated_spherical import WornLubricatedSphericalClearance
from pinclear.contact.mixed import asperity_py
from tests.helpers import assert_same_element_force
from tests.helpers import element_force as _tau

BALL = Path(__file__).parents[1] / "data" / "lub_ball.yaml"
WEAR = {"model": "archard", "k": 1e-4, "hardness": 1e8, "nodes": 36, "pole": "x"}


def _load(wear=WEAR, **over):
    return pinclear.load(BALL, clearances=["S"], overrides={"S.wear": wear, **over})


def _pocket(joint, depth):
    """The seat a ball wears at -z, ``depth`` deep: w = (c + depth) cos(angle from -z) - c where
    positive, the socket surface R2 + (c + depth) cos: the ball's own sphere displaced by c + depth to
    within (c + depth)^2 sin^2 / (2 R2) (a narrower pocket would hold the ball on its rim)."""
    wm = joint.wear
    th, ph = wm.angles()
    x = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], 1)
    loc = np.zeros_like(x)
    loc[:, [(wm.pole + 1) % 3, (wm.pole + 2) % 3, wm.pole]] = x         # mesh axes -> frame1 axes
    ang = np.arccos(np.clip(loc @ np.array([0.0, 0.0, -1.0]), -1, 1))
    return np.maximum((joint.c + depth) * np.cos(ang) - joint.c, 0.0)


def _states(rng, n, c):
    for _ in range(n):
        u = rng.normal(size=3)
        q = np.zeros(6)
        q[:3] = c * rng.uniform(0.3, 1.02) * u / np.linalg.norm(u)
        v = np.concatenate([rng.normal(size=3) * 10.0 ** rng.uniform(-5, -2), rng.normal(size=3) * 10.0])
        yield q, v


def test_the_oiled_and_worn_ball_at_zero_wear_is_the_oiled_ball_to_1e_12():
    worn, oiled = _load(), pinclear.load(BALL, clearances=["S"])
    assert isinstance(worn.forces[-1], WornLubricatedSphericalClearance) and not np.any(worn.forces[-1].depth)
    assert_same_element_force(worn, oiled, _states(np.random.default_rng(4), 100, oiled.forces[-1].c))


def test_on_a_worn_seat_the_asperities_see_the_least_distance_gap_and_the_film_carries_above_4_sigma():
    mech = _load(**{"S.roughness": 0.5e-6})
    j0 = mech.forces[-1]
    joint = j0.with_depth(_pocket(j0, 0.3 * j0.c))
    worn = mech.replace(forces=list(mech.forces[:-1]) + [joint])
    sigma, c, depth = joint.sigma, joint.c, 0.3 * j0.c
    v = np.array([0.0, 0.0, -1e-4, 3.0, 0.0, 0.0])
    loc = joint.wear.local(np.array([[0.0, 0.0, -1.0]]))[0]
    w_floor = float(joint.profile(math.acos(loc[2]), math.atan2(loc[1], loc[0]))[0][0])   # the interpolant's
    assert w_floor == pytest.approx(depth, rel=0.01)
    regimes = set()
    for lam in (0.5, 2.0, 12.0):
        # the ball lowered into the seat's floor (-z) until the ray's gap is lam sigma; the least gap
        # can only be smaller (the interpolant undershoots the seat's rim by ~0.7 um: a nearer point)
        q = np.zeros(6)
        q[2] = -(c + w_floor - lam * sigma)
        _, _, out = _tau(worn, q, v)
        h = -float(out["penetration"])
        assert 0.0 < h <= lam * sigma * (1 + 1e-9)              # the seat's gap, not the unworn sphere's (-30 um)
        assert out["film_parameter"] == pytest.approx(h / sigma, rel=1e-9)
        # Greenwood-Tripp's load at that least gap
        assert out["asperity_force"] == pytest.approx(asperity_py(joint.mixed, h)[0], rel=1e-12, abs=0.0)
        if h >= 4.0 * sigma:
            regimes.add("film")
            assert out["asperity_force"] == 0.0 and out["wear_load"] == 0.0 and out["slip"] == 0.0
        else:
            regimes.add("mixed")
            assert out["asperity_force"] > 0.0
            assert out["wear_load"] == pytest.approx(out["asperity_force"] + out["fn"], rel=1e-12)
            assert out["slip"] > 0.0                            # the spin slides the asperities: Archard's integrand
        assert np.linalg.norm(out["film_force"]) > 0.0          # the squeeze film pushes back at every gap
    assert regimes == {"film", "mixed"}
    # on the unworn sphere the same q would be inside the wall by depth - lam sigma
    assert depth > 10 * sigma


def test_an_oiled_ball_sinking_into_a_worn_seat_never_creates_energy():
    """From the centre through a thin film (1 mPa s) into a 30 um seat, spinning (BDF: the squeeze
    film is stiff): the film's dissipation never decreases, the audit closes, the ball goes where
    the unworn sphere's wall would stop it (beyond c) and reaches the asperities, which then carry
    the wear load. The film's force is continuous across r = c / 2 and across the seat's medial axis
    (the ray's gap, not the nearest point's)."""
    mech = _load(**{"S.roughness": 0.5e-6, "S.viscosity": 1e-3})
    j0 = mech.forces[-1]
    worn = mech.replace(forces=list(mech.forces[:-1]) + [j0.with_depth(_pocket(j0, 0.3 * j0.c))])
    tr = pinclear.simulate(worn, 0.05, integrator="BDF", rtol=1e-9, q0=np.zeros(6),
                           v0=np.array([0.0, 0.0, -0.02, 20.0, 0.0, 0.0]), assemble=False, dt_out=2.5e-4)
    assert tr.status == "success"
    out = tr.outputs
    assert np.all(np.diff(out["S.film_dissipated"]) >= 0.0)
    b = tr.energy_balance()
    assert b["ok"], b
    E, D = tr.energy()["total"], out["S.dissipated"]
    assert np.max(E + D - (E[0] + D[0])) <= b["bound"]
    assert np.max(np.linalg.norm(out["S.eccentricity"], axis=1)) > 1.2 * j0.c
    assert out["S.asperity_force"].max() > 1.0
    np.testing.assert_allclose(out["S.wear_load"], out["S.asperity_force"] + out["S.fn"], rtol=1e-12, atol=0.0)
    # Archard's law over the block wears by the asperities' load alone: V = k / H int W_a v_slip dt
    from pinclear.contact import wear_spherical
    from pinclear.contact.wear import trapezoid_weights

    wm = worn.forces[-1].wear
    h = wear_spherical.block_increment(wm, "S", tr)
    work = np.sum(out["S.wear_load"] * out["S.slip"] * trapezoid_weights(tr.t))
    assert work > 0.0 and np.all(h >= 0.0)
    assert wm.volume(h) == pytest.approx(wm.k * work / wm.hardness, rel=1e-12)
