"""Peaks after a transient (issue 52, item 6): ``Trajectory.summary(peaks_after=T)``, ``simulate
--peaks-after`` and one window function (pinclear.dynamics.stepping.peaks.window_peak) that the
reproductions' steady peaks use too.

References: a window from the start is the whole run (every peak from the integration, unchanged);
a run sampled at its own accepted steps has the accepted states as samples, so the largest sampled
|lambda| after T is the integration's window peak of a drive force (drive peaks are taken over the
accepted states: tests/dynamics/test_outputs.py), which window_peaks must return whether the whole
run's peak lies inside the window (then taken from the integration) or not (then from samples)."""
import json
import warnings

import numpy as np
import pytest

import pinclear
from pinclear.core.errors import InputError
from pinclear.dynamics.stepping.peaks import window_peak


def _run(mech, t_end, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return pinclear.simulate(mech, t_end, rtol=1e-6, **kw)


def test_window_peak_bounds_abs_and_nan():
    t = np.array([0.0, 0.1, 0.2, 0.3, 0.4])
    y = np.array([5.0, -3.0, np.nan, -4.0, 1.0])
    assert window_peak(t, y) == (5.0, 0.0)
    assert window_peak(t, y, t_from=0.1) == (4.0, 0.3)          # |y|, NaN skipped, bound inclusive
    assert window_peak(t, y, t_from=0.1, t_to=0.2) == (3.0, 0.1)
    v, tt = window_peak(t, y, t_from=0.5)
    assert np.isnan(v) and np.isnan(tt)
    v, _ = window_peak(t[2:3], y[2:3])
    assert np.isnan(v)


def test_the_reproductions_steady_peak_is_the_window_function():
    from pinclear.studies.reproduce import paper002

    t = np.linspace(0.0, 1.0, 11)
    y = np.where(t < paper002.STEADY, 100.0, 1.0) * np.cos(7 * t)
    assert paper002._steady_peak(t, y) == window_peak(t, y, t_from=paper002.STEADY)
    assert paper002._steady_peak(t, y)[0] == pytest.approx(np.max(np.abs(y[t >= paper002.STEADY])), rel=0)
    assert paper002._peak(t, y, 0.3) == window_peak(t, y, t_to=0.3 + 1e-12)


@pytest.fixture(scope="module")
def stepped():
    """four_ups_upu (ideal joints: no events, so every accepted step reports progress), sampled
    exactly at its accepted steps."""
    mech = pinclear.load("four_ups_upu")
    steps = []
    run = _run(mech, 0.02, dt_out=0.02 / 10, progress=steps.append)
    at = _run(mech, 0.02, t_eval=np.array([0.0] + steps))
    assert at.stats["steps"] == run.stats["steps"] == len(steps)
    return mech, at


def test_peaks_after_zero_is_the_whole_run(stepped):
    _, tr = stepped
    s = tr.summary(peaks_after=0.0)
    w = s["peaks_after"]
    assert w["t_from"] == 0.0
    assert w["drive_force_peaks"] == s["drive_force_peaks"]
    assert w["acceleration_peaks"] == s["acceleration_peaks"]
    assert set(w["peaks_from"].values()) == {"integration"}


def test_peaks_after_a_window_are_the_accepted_states_largest(stepped):
    mech, tr = stepped
    whole = tr.peak_summary()
    # a window that starts after some drive's whole-run peak (the start-up) and one that does not
    sources = set()
    for T in (0.2 * tr.t[-1], 0.5 * tr.t[-1], 0.9 * tr.t[-1]):
        w = tr.window_peaks(T)
        late = tr.t >= T
        for d in mech.drives:
            lam = np.abs(tr.lam[d.name])
            k = np.flatnonzero(late)[int(np.argmax(lam[late]))]
            assert w["drive_force_peaks"][d.name] == pytest.approx(lam[k], rel=1e-12), d.name
            assert w["drive_force_peak_times"][d.name] == tr.t[k]
            assert w["drive_force_peaks"][d.name] <= whole["drive_force_peaks"][d.name]
            src = w["peaks_from"][f"drive_force_peaks.{d.name}"]
            assert src == ("integration" if whole["drive_force_peak_times"][d.name] >= T else "samples")
            sources.add(src)
    assert sources == {"integration", "samples"}          # both branches were exercised


def test_peaks_after_is_recorded_and_read_back(stepped, tmp_path):
    _, tr = stepped
    tr.meta["peaks_after"] = 0.01
    try:
        path = tr.save(tmp_path / "run.npz")
    finally:
        del tr.meta["peaks_after"]
    back = pinclear.Trajectory.load(path)
    assert back.meta["summary"]["peaks_after"]["t_from"] == 0.01
    assert back.summary()["peaks_after"] == back.meta["summary"]["peaks_after"]
    assert "peaks_after" not in tr.summary()


def test_peaks_after_bad_values(stepped):
    _, tr = stepped
    with pytest.raises(InputError, match="after the run's end"):
        tr.window_peaks(1.0)
    with pytest.raises(InputError, match="peaks_after"):
        tr.window_peaks(float("nan"))


def test_simulate_peaks_after_cli(tmp_path, capsys):
    from pinclear.cli.commands import main

    out = tmp_path / "o"
    assert main(["simulate", "clr_planar_pendulum", "--clearance", "A", "--t-end", "0.1", "--peaks-after", "0.05",
                 "--out", str(out), "--progress", "off"]) == 0
    s = json.loads((out / "summary.json").read_text())
    w = s["peaks_after"]
    assert w["t_from"] == 0.05
    tr = pinclear.Trajectory.load(out / "trajectory.npz")
    fn = np.ravel(tr.outputs["A.fn"])
    # the start-up landing is the whole run's peak; after it, the window's is below it
    assert s["contact_force_peak_times"]["A"] < 0.05
    assert w["contact_force_peaks"]["A"] == np.max(fn[tr.t >= 0.05]) < s["contact_force_peaks"]["A"]
    capsys.readouterr()
    assert main(["simulate", "clr_planar_pendulum", "--t-end", "0.1", "--peaks-after", "0.1",
                 "--out", str(tmp_path / "p"), "--progress", "off"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--peaks-after" in err and "--t-end" in err
