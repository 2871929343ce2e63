"""Hostile round 4 (issue 42): a run resumed from a checkpoint taken inside a contact continues
exactly (bit for bit) for every clearance type. A checkpoint used to be taken after a chunk that
ended on a located event, before the event was handled: it held the state at the end of the
step past the impact, which the run itself discards, so the resumed run lost the impact (the
onset speed of the damping) and drifted (clr_pendulum: 2.4e-4 rad at rtol 1e-8, status success).
Now the event is handled first, and the checkpoint holds the restart at the impact."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

import pinclear

#: one bundled scene per clearance type (mechanism, clearance joint)
SCENES = [("clr_pendulum", "S"), ("clr_hinge", None), ("clr_planar_pendulum", None), ("clr_slider", "P")]
KW = dict(integrator="RK45", rtol=1e-8, dt_out=1e-3)
T_END = 0.1


def _mech(name, cl):
    import yaml

    from pinclear.core.models import model_path

    cl = cl or yaml.safe_load(model_path(name).read_text())["clearances"][0]["name"]
    return pinclear.load(name, clearances=[cl])


@pytest.mark.parametrize("name, cl", SCENES)
def test_resume_inside_a_contact_is_exact(name, cl):
    mech = _mech(name, cl)
    saved = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole = pinclear.simulate(mech, T_END, checkpoint=saved.append, checkpoint_every=0.0, **KW)
    assert whole.status == "success"
    events = [e["t"] for e in whole.stats["events"]]
    assert len(events) >= 10                                   # a run full of impacts
    # stop points at an impact (inside the contact it starts) and between impacts
    at_impact = [ck for ck in saved if any(ck.t == te for te in events)]
    between = [ck for ck in saved if ck not in at_impact and 0 < ck.t < T_END]
    assert len(at_impact) >= 3
    picks = at_impact[:: max(1, len(at_impact) // 3)][:3] + between[:: max(1, len(between) // 2)][:2]
    for ck in picks:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            rest = pinclear.simulate(mech, T_END, resume=ck, **KW)
        assert rest.status == "success"
        np.testing.assert_array_equal(rest.q, whole.q, err_msg=f"{name}: resumed at t = {ck.t}")
        np.testing.assert_array_equal(rest.v, whole.v)
        np.testing.assert_array_equal(rest.z, whole.z)
        assert [e["t"] for e in rest.stats["events"]] == events
        assert rest.stats["steps"] == whole.stats["steps"]


@pytest.mark.parametrize("name, cl", [("clr_hinge", None), ("clr_slider", "P")])
def test_an_implicit_resume_reuses_the_saved_jacobian(tmp_path, name, cl):
    """ROS34PW2 keeps its Jacobian across steps (a W-method): the checkpoint carries it (through
    a file here), and the resumed run is bit-identical; recomputing it at the resume point had
    moved clr_hinge by 2.4e-3 rad by t = 0.1 s."""
    from pinclear.dynamics.trajectory import Checkpoint

    mech = _mech(name, cl)
    kw = dict(integrator="ROS34PW2", rtol=1e-6, dt_out=1e-3)
    saved = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        whole = pinclear.simulate(mech, 0.05, checkpoint=saved.append, checkpoint_every=0.0, **kw)
        for ck in saved[len(saved) // 3:: max(1, len(saved) // 3)][:3]:
            assert ck.method_state["jacobian"].ndim == 2
            back = Checkpoint.load(ck.save(tmp_path / "ck.npz"))
            rest = pinclear.simulate(mech, 0.05, resume=back, **kw)
            np.testing.assert_array_equal(rest.q, whole.q, err_msg=f"resumed at t = {ck.t}")
            assert rest.stats["steps"] == whole.stats["steps"]
    ck = saved[len(saved) // 2]
    for bad, words in (({**ck.method_state, "jacobian": ck.method_state["jacobian"][:-1]}, "does not belong"),
                       ({**ck.method_state, "time_column": ck.method_state["time_column"] * np.nan}, "nan"),
                       ({**ck.method_state, "flags": np.array([7.0, 0.0])}, "not one this method writes")):
        ck.method_state = bad
        with pytest.raises(pinclear.InputError, match=words):
            pinclear.simulate(mech, 0.05, resume=Checkpoint.load(ck.save(tmp_path / "bad.npz")), strict=True, **kw)


def _resumed_midway(integrator, method_state=None):
    """clr_slider + P resumed from its middle checkpoint (``method_state`` replaces the saved one)."""
    mech = _mech("clr_slider", "P")
    saved = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pinclear.simulate(mech, 0.01, integrator=integrator, rtol=1e-5, checkpoint=saved.append, checkpoint_every=0.0)
        ck = saved[len(saved) // 2]
        if method_state is not None:
            ck.method_state = method_state
        return pinclear.simulate(mech, 0.01, integrator=integrator, rtol=1e-5, resume=ck)


def test_a_scipy_integrator_resume_says_it_starts_afresh():
    assert "starts afresh" in _resumed_midway("Radau").stats["resume_note"]


def test_an_older_implicit_checkpoint_without_its_jacobian_still_resumes():
    rest = _resumed_midway("ROS34PW2", method_state={})
    assert rest.status == "success" and "recomputed" in rest.stats["resume_note"]
