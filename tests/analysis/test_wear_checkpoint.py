"""Wear checkpoints carry their run's identity and are read as data (pinclear.analysis.wear_life):
another run's checkpoint, a tampered one, an older layout are refused naming the field; a depth
beyond max_depth_fraction of the radius ends the trial as failed; profiles and node counts are
bounded."""
from pathlib import Path

import numpy as np
import pytest

import pinclear
from pinclear.analysis.wear_life import WearSettings, converged, read_profile, wear_run, with_profile
from pinclear.core.errors import ContactSetupError, InputError, ModelFileError

JOURNAL = Path(__file__).parents[1] / "data" / "wear_journal.yaml"
C, R1 = 1e-4, 0.0101                            # the sidecar's clearance and bearing radius
S = WearSettings(cycles=2000.0, period=0.01, updates=2, transient_periods=0, rtol=1e-8, dt_out=1e-4)


def _start(mech):
    law = mech.forces[-1].law
    delta = (9.81 / law.K) ** (1.0 / law.n)               # K delta^n = m g (1 kg): resting on the wall
    return np.array([0.0, -(C + delta), 0.0]), np.array([0.0, 0.0, 20.0])


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """A finished two-update run's folder, its mechanism, start and result."""
    out = tmp_path_factory.mktemp("wear")
    mech = pinclear.load(JOURNAL, clearances=["A"])
    start = _start(mech)
    res = wear_run(mech, "A", S, out=out, start=start)
    assert res["complete"] and res["failed"] is None and res["depth"]["A"].max() > 0
    return out, mech, start, res


def _copy(finished, tmp_path, **change):
    """The finished run's checkpoint in a new folder, fields replaced by ``change`` (a callable of the
    old array, or an array; None deletes it)."""
    out = finished[0]
    with np.load(out / "checkpoint.npz", allow_pickle=False) as z:
        arrays = {k: np.array(z[k]) for k in z.files}
    for k, new in change.items():
        if new is None:
            arrays.pop(k)
        else:
            arrays[k] = new(arrays[k]) if callable(new) else new
    folder = tmp_path / "ck"
    folder.mkdir()
    np.savez(folder / "checkpoint.npz", **arrays)
    return folder


def test_rerun_into_the_finished_folder_resumes_its_result(finished):
    out, mech, start, res = finished
    again = wear_run(mech, "A", S, out=out, start=start)
    assert np.array_equal(again["depth"]["A"], res["depth"]["A"])


@pytest.mark.parametrize("overrides, named", [({"A.wear": {"k": 1e-3, "hardness": 1e8, "nodes": 360}}, "wear"),
                                              ({"A.radius": 0.011, "A.clearance": 1e-4}, "mechanism")])
def test_a_run_of_another_wear_coefficient_or_mechanism_is_refused_naming_what_differs(finished, overrides, named):
    # the audit: 10x the wear coefficient, or another mechanism, reported the first run's depths
    out, _, start, _ = finished
    other = pinclear.load(JOURNAL, clearances=["A"], overrides=overrides)
    with pytest.raises(InputError, match=rf"checkpoint of another run: .*{named}"):
        wear_run(other, "A", S, out=out, start=start)


def test_other_settings_or_start_are_refused(finished):
    out, mech, start, _ = finished
    with pytest.raises(InputError, match="settings"):
        wear_run(mech, "A", WearSettings(**{**S.__dict__, "cycles": 4000.0}), out=out, start=start)
    with pytest.raises(InputError, match="start"):
        wear_run(mech, "A", S, out=out, start=(start[0], 2 * start[1]))


@pytest.mark.parametrize("field, change, text", [
    ("depth.A", lambda d: d - 1e-3, r"depth.A lies outside \[0, 0.000505\] m"),        # -1 mm
    ("depth.A", lambda d: d + 1.0, r"depth.A lies outside"),                              # 1 m
    ("done", lambda d: np.array(1), r"array 'cycles' has 2 rows, expected 1"),           # a rewound counter
    ("done", lambda d: np.array(-3), r"done = -3 lies outside \[1, 2\]"),
    ("q", lambda q: np.array([0.0, -6 * C, 0.0]), r"clearance 'A' 0.000(49|50)\d* m inside its bearing \(more than its clearance 0.0001"),
    ("q", lambda q: np.array([0.0, np.nan, 0.0]), r"array 'q' holds nan"),
    ("q", lambda q: np.zeros(4), r"array 'q' has 4 rows, expected 3"),
    ("A.max_depth", lambda h: h * 0.5, r"depth.A differs from its history's last max_depth"),
    ("cycles", lambda c: c[::-1].copy(), r"cycles do not increase"),
    ("t", lambda t: np.array(-1.0), r"t = -1.0 is negative"),
    ("format", None, r"another layout \(format None"),
    ("identity", lambda i: np.array("[1, 2]"), r"metadata is a list, not a mapping"),
])
def test_a_tampered_checkpoint_is_refused_naming_the_field(finished, tmp_path, field, change, text):
    _, mech, start, _ = finished
    folder = _copy(finished, tmp_path, **{field: change})
    with pytest.raises(InputError, match=text):
        wear_run(mech, "A", S, out=folder, start=start)


def test_a_checkpoint_of_an_older_contact_model_is_refused(finished, tmp_path, monkeypatch):
    import json

    _, mech, start, _ = finished
    folder = _copy(finished, tmp_path, identity=lambda i: np.array(json.dumps({**json.loads(str(i)),
                                                                                "contact_model": 1})))
    from pinclear.contact import MODEL_VERSION

    with pytest.raises(InputError, match=rf"contact_model: 1 \(checkpoint\) vs {MODEL_VERSION} \(this run\)"):
        wear_run(mech, "A", S, out=folder, start=start)


def test_a_depth_beyond_the_radius_fraction_ends_the_trial_as_failed(finished):
    # the audit: a trial reported a max depth of 2.4e10 m for a 0.1 mm clearance. A fraction well
    # below the first update's depth (~ rate x life / 2) fails at update 1, naming the joint
    _, mech, start, res = finished
    frac = 0.1 * res["history"]["A.max_depth"][0] / R1
    s = WearSettings(**{**S.__dict__, "max_depth_fraction": frac})
    bad = wear_run(mech, "A", s, start=start)
    assert not bad["complete"] and bad["failed"].startswith("A: update 1 wears")
    assert bad["history"]["cycles"] == [] and bad["depth"]["A"].max() == 0.0
    conv = converged(mech, "A", s, start=start)
    assert conv["converged"] is False and conv["rounds"][0]["failed"] == bad["failed"]
    with pytest.raises(InputError, match="max_depth_fraction"):
        WearSettings(**{**S.__dict__, "max_depth_fraction": 0.0}).check()


@pytest.mark.parametrize("shift, text", [(-1e-3, r"depths -0.001 to .* in \[0, 0.000505\] m"),
                                         (5.0, r"depths 5 to 5.* in \[0, 0.000505\] m")])
def test_a_profile_of_impossible_depths_is_refused(finished, tmp_path, shift, text):
    # the audit: profiles with depth -1 mm or 5 m were drawn
    out, mech, _, _ = finished
    prof = read_profile(out / "profile.csv")
    assert np.allclose(prof["A"], finished[3]["depth"]["A"], rtol=1e-8, atol=0)
    with pytest.raises(ModelFileError, match=text):
        with_profile(mech, {"A": prof["A"] + shift})


def test_node_counts_and_profile_files_are_bounded(tmp_path):
    with pytest.raises(ContactSetupError, match=r"wear.nodes: an integer in \[16, 100000\]"):
        pinclear.load(JOURNAL, clearances=["A"], overrides={"A.wear": {"k": 1e-4, "hardness": 1e8, "nodes": 10 ** 7}})
    big = tmp_path / "profile.csv"
    big.write_text("# angle [deg], A depth [m]\n" + "0.0, 0.0\n" * 100_001)
    with pytest.raises(ModelFileError, match="at most 100000 wear nodes"):
        read_profile(big)
