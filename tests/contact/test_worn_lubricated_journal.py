"""The oiled and worn journal (issue 56: lubricated wear for paper 002's bearings): a
lubricated_revolute entry with ``wear:``. At zero wear it is the lubricated journal; in a worn
pocket the dry law and the asperities act on the least-distance gap, the film on the line of
centres at the worn gap there, and wear follows the load the surfaces carry (dry + asperity)."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import pinclear
from pinclear.contact.lubricated import LubricatedRevoluteClearance, WornLubricatedRevoluteClearance
from pinclear.contact.mixed import asperity_py
from tests.helpers import assert_same_element_force
from tests.helpers import element_force as _tau

JOURNAL = Path(__file__).parents[1] / "data" / "lub_journal.yaml"
WEAR = {"model": "archard", "k": 1e-4, "hardness": 1e8, "nodes": 180}


def _load(wear=WEAR, **over):
    return pinclear.load(JOURNAL, clearances=["A"], overrides={"A.wear": wear, **over})


def _pocket(joint, depth, towards=-math.pi / 2):
    """The pocket a journal wears under a steady load towards ``towards`` (rad, bearing x to y),
    ``depth`` deep: w = (c + depth) cos(theta - towards) - c where positive (the journal's own
    circle displaced by c + depth, to within (c + depth)^2 sin^2 / (2 R2): it conforms)."""
    th = 2.0 * math.pi * np.arange(joint.wear.nodes) / joint.wear.nodes
    return np.maximum((joint.c + depth) * np.cos(th - towards) - joint.c, 0.0)


@pytest.mark.parametrize("theory", ["short", "long"])
def test_the_oiled_and_worn_journal_at_zero_wear_is_the_oiled_journal_to_1e_12(theory):
    worn = _load(**{"A.theory": theory})
    oiled = pinclear.load(JOURNAL, clearances=["A"], overrides={"A.theory": theory})
    assert isinstance(worn.forces[-1], WornLubricatedRevoluteClearance) and not np.any(worn.forces[-1].depth)
    assert type(oiled.forces[-1]) is LubricatedRevoluteClearance
    assert_same_element_force(worn, oiled, _states(np.random.default_rng(7), 100, oiled.forces[-1].c))


def _states(rng, n, c):
    for _ in range(n):
        a = rng.uniform(0, 2 * math.pi)
        r = c * rng.uniform(0.05, 1.02)                    # inside c / 2 too: the worn film joint searches there
        q = np.array([r * math.cos(a), r * math.sin(a), rng.uniform(-3, 3)])
        yield q, np.array([*(rng.normal(size=2) * 10.0 ** rng.uniform(-5, -2)), rng.normal() * 100.0])


def test_in_a_worn_pocket_the_asperities_see_the_least_gap_and_the_film_the_worn_gap_on_the_line_of_centres():
    mech = _load(**{"A.roughness": 0.5e-6})
    j0 = mech.forces[-1]
    depth = 0.3 * j0.c
    joint = j0.with_depth(_pocket(j0, depth))
    worn = mech.replace(forces=list(mech.forces[:-1]) + [joint])
    oiled = pinclear.load(JOURNAL, clearances=["A"], overrides={"A.roughness": 0.5e-6})
    sigma, c = joint.sigma, joint.c
    w_floor = float(joint.profile(-math.pi / 2)[0][0])
    assert w_floor == pytest.approx(depth, rel=1e-3)
    v = np.array([0.0, -1e-4, 100.0])
    regimes = set()
    for lam in (0.5, 2.0, 12.0):
        # the journal lowered into the pocket's floor (-y) until the ray's gap c + w - r is lam sigma
        r = c + w_floor - lam * sigma
        q = np.array([0.0, -r, 0.0])
        _, _, out = _tau(worn, q, v)
        h = -float(out["penetration"])
        assert 0.0 < h <= lam * sigma * (1 + 1e-9)              # the pocket's gap, not the round bearing's (-30 um)
        assert out["film_parameter"] == pytest.approx(h / sigma, rel=1e-9)
        assert out["asperity_force"] == pytest.approx(asperity_py(joint.mixed, h)[0], rel=1e-12, abs=0.0)
        # the film is the round bearing's at the equivalent eccentricity r - w: its force equals the
        # oiled joint's with the journal there (same squeeze speed, same spin)
        _, _, ref = _tau(oiled, np.array([0.0, -(r - w_floor), 0.0]), v)
        np.testing.assert_allclose(out["film_force"], ref["film_force"], rtol=1e-9, atol=1e-12)
        if h >= 4.0 * sigma:
            regimes.add("film")
            assert out["asperity_force"] == 0.0 and out["wear_load"] == 0.0 and out["slip"] == 0.0
        else:
            regimes.add("mixed")
            assert out["asperity_force"] > 0.0 and out["slip"] > 0.0
            assert out["wear_load"] == pytest.approx(out["asperity_force"] + out["fn"], rel=1e-12)
    assert regimes == {"film", "mixed"}


def test_an_oiled_journal_landing_in_a_worn_pocket_never_creates_energy_and_wears_by_the_asperities():
    """Thrown from the centre at 5 cm/s through a thin film (0.01 mPa s, which lets it through)
    into a 30 um pocket under gravity and the drive's spin (Radau: the squeeze film is stiff): the
    film's dissipation never decreases, the audit closes, the journal goes beyond c (into the
    pocket) and reaches the asperities, and Archard's volume is k / H int (W_dry + W_a) v_slip dt."""
    mech = _load(**{"A.roughness": 0.5e-6, "A.viscosity": 1e-5})
    j0 = mech.forces[-1]
    worn = mech.replace(forces=list(mech.forces[:-1]) + [j0.with_depth(_pocket(j0, 0.3 * j0.c))])
    tr = pinclear.simulate(worn, 0.02, integrator="Radau", rtol=1e-9, q0=np.zeros(3), v0=np.array([0.0, -0.05, 100.0]),
                           assemble=False, dt_out=2.5e-4)
    assert tr.status == "success", tr.message
    out = tr.outputs
    assert np.all(np.diff(out["A.film_dissipated"]) >= 0.0)
    b = tr.energy_balance()
    assert b["ok"], b
    assert np.max(np.linalg.norm(out["A.eccentricity"], axis=1)) > 1.1 * j0.c
    assert out["A.asperity_force"].max() > 0.05
    np.testing.assert_allclose(out["A.wear_load"], out["A.asperity_force"] + out["A.fn"], rtol=1e-12, atol=0.0)
    from pinclear.contact import wear
    from pinclear.contact.wear import trapezoid_weights

    wm = worn.forces[-1].wear
    h = wear.block_increment(wm, "A", tr, worn.forces[-1].depth)
    work = np.sum(out["A.wear_load"] * out["A.slip"] * trapezoid_weights(tr.t))
    assert work > 0.0 and np.all(h >= 0.0)
    assert wm.volume(h) == pytest.approx(wm.k * work / wm.hardness, rel=1e-9)
