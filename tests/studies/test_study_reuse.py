"""Issue 40's study-level savings change no result: the signals of one run share their frame
kinematics (the same numbers as resolving each alone), a study reuses a run only when it loads
the same model with the same inputs (then the runs are equal bit for bit), and the parsed-YAML
cache hands out independent copies and sees an edited file."""
from __future__ import annotations

import numpy as np
import pytest

from pinclear import analysis as an
from pinclear.analysis import signals
from pinclear.core.models import model_path
from pinclear.dynamics.simulate import simulate
from pinclear.io.sidecar import load, read_yaml
from pinclear.studies.reproduce import paper000 as P


@pytest.fixture(scope="module")
def s2_run():
    mech = load(model_path("four_ups_upu"), clearances=["S2"], overrides={"S2.mu": 0.01})
    return mech, simulate(mech, 0.2, dt_out=2e-3)


def test_signals_of_one_run_share_one_pass_per_frame_with_the_same_numbers(s2_run, monkeypatch):
    mech, tr = s2_run
    alone = {sig: signals.series(tr, sig, mech) for sig in P.SIGNALS}
    calls = []
    real = signals.frame_motion
    monkeypatch.setattr(signals, "frame_motion", lambda *a, **k: (calls.append(a[1]), real(*a, **k))[1])
    memo = {}
    shared = {sig: signals.series(tr, sig, mech, memo) for sig in P.SIGNALS}
    # platform x, y, z: one pass over one frame; the three eccentricity rates: one over the pair
    assert sorted(len(f) for f in calls) == [1, 2]
    for sig in P.SIGNALS:
        for f in ("x", "xdot", "xddot"):
            a, b = getattr(alone[sig], f), getattr(shared[sig], f)
            assert (a is None and b is None) or np.array_equal(a, b), (sig, f)
        sec = an.poincare(tr, 0.05, sig, mech=mech, resolved=shared[sig])
        ref = an.poincare(tr, 0.05, sig, mech=mech)
        assert np.array_equal(sec.points, ref.points) and np.array_equal(sec.scale, ref.scale)


def test_study_points_name_the_same_model_only():
    s = P._settings(False, None)
    base = list(P.SENS_VARIANTS)[0]
    # the sidecar's S2 is 0.5 mm at mu 0.1: the clearance study's 0.5 mm run is the mu study's 0.1
    assert P.study_point("clearance", 5e-4, s) == P.study_point("mu", 0.1, s)
    assert P.study_point("sens", base, s) == P.study_point("mu", P.SENS_MU, s)
    assert P.study_point("clearance", 6e-4, s) != P.study_point("mu", 0.1, s)
    assert all(P.study_point("sens", v, s) != P.study_point("mu", P.SENS_MU, s) for v in list(P.SENS_VARIANTS)[1:])
    # a study-wide override the sensitivity runs do not take makes them different models
    s2 = dict(s, overrides={"S2.v_impact_min": 1e-3})
    assert P.study_point("sens", base, s2) != P.study_point("mu", P.SENS_MU, s2)
    assert P.study_point("clearance", 5e-4, s2) == P.study_point("mu", 0.1, s2)


def _short(model, parameter, values, load_options):
    return an.bifurcation(model, parameter, values, period=P.T, signal=P.SIGNALS, cycles=1, transient=0,
                          per_period=25, executor="serial", load_options=load_options)


def test_runs_with_equal_study_points_are_equal_bit_for_bit():
    """What makes the reuse safe: the sensitivity baseline and the mu study's 0.01 run, and the
    clearance study's 0.5 mm run and the mu study's 0.1 run, computed separately, agree exactly."""
    path, lo = str(model_path("four_ups_upu")), {"clearances": ["S2"], "overrides": {}}
    pairs = [(_short(path, "S2.mu", [0.01], lo), _short(P.sensitivity_mechanism, "variant", [list(P.SENS_VARIANTS)[0]],
                                                         None)),
             (_short(path, "S2.mu", [0.1], lo), _short(path, "S2.clearance", [5e-4], lo))]
    for a, b in pairs:
        ra, rb = a.runs[0], b.runs[0]
        assert ra.ok and rb.ok
        for sig in P.SIGNALS:
            assert np.array_equal(ra.sections[sig].points, rb.sections[sig].points), sig


def test_reusing_runs_only_the_missing_values_and_keeps_their_order():
    s = P._settings(False, None)
    mu = _short(str(model_path("four_ups_upu")), "S2.mu", [0.1], {"clearances": ["S2"], "overrides": {}})
    known = {P.study_point("mu", r.value, s): r for r in mu.runs}
    asked = []

    def run(vals):
        asked.append(list(vals))
        return _short(str(model_path("four_ups_upu")), "S2.clearance", vals, {"clearances": ["S2"], "overrides": {}})
    res = P.reusing(known, "clearance", [3e-4, 5e-4], s, run)
    assert asked == [[3e-4]]
    assert [r.index for r in res.runs] == [0, 1] and list(res.values) == [3e-4, 5e-4]
    assert res.runs[1].sections is mu.runs[0].sections and res.parameter == "S2.clearance"
    assert P.study_point("clearance", 3e-4, s) in known          # the new run is known to later studies


def test_parsed_yaml_cache_gives_copies_and_sees_edits(tmp_path):
    f = tmp_path / "m.yaml"
    f.write_text("urdf: a.urdf\nforces: [{name: k, k: 1.0}]\n")
    doc = read_yaml(f)
    doc["forces"][0]["k"] = 99.0
    assert read_yaml(f)["forces"][0]["k"] == 1.0
    f.write_text("urdf: a.urdf\nforces: [{name: k, k: 2.0}]\n")
    assert read_yaml(f)["forces"][0]["k"] == 2.0
