"""Figures that show what the summary says and what a clearance changes (issue 52, items 4 and 5):
the contact and drive figures mark the peaks from the integration (the markers' values are
summary.json's peaks, not the sampled curve's maximum), the platform figure has a deviation panel
whose data are run - reference (checked against Pinocchio's kinematics of both runs, not against
the plotting code), an orientation panel for a turning platform, and the drive figure the ideal
run dashed."""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.viz import plots

URDF = Path(__file__).resolve().parents[2] / "urdf"


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """The journal-bearing pendulum of tests/viz/test_plots.py (0.1 mm clearance at A), its journal
    frame as platform, with and without clearance, on one output grid."""
    d = tmp_path_factory.mktemp("peaks")
    text = (URDF / "clr_planar_pendulum.yaml").read_text()
    text = text.replace("urdf: clr_planar_pendulum.urdf", f"urdf: {URDF / 'clr_planar_pendulum.urdf'}")
    side = d / "pendulum.yaml"
    side.write_text(text + "\nplatform: {frame: journal}\n")
    clr, ideal = pinclear.load(side, clearances=["A"]), pinclear.load(side)
    tr = pinclear.simulate(clr, 0.05, dt_out=2e-3, rtol=1e-6)
    ref = pinclear.simulate(ideal, 0.05, dt_out=2e-3, rtol=1e-8)
    assert tr.status == "success" and ref.status == "success"
    return clr, tr, ref, d


def _lines(fig):
    return {ln.get_gid(): ln for ax in fig.axes for ln in ax.get_lines() if ln.get_gid()}


def _placements(mech, q, fid):
    data = mech.model.createData()
    out = []
    for qk in q:
        pin.framesForwardKinematics(mech.model, data, qk)
        out.append(data.oMf[fid].copy())
    return out


def test_contact_marker_is_the_summarys_step_peak(runs, tmp_path):
    _, tr, _, _ = runs
    L = _lines(plots.fig_contact_force(tr))
    # summary.json as simulate writes it, read back from disk
    npz = tr.save(tmp_path / "run.npz")
    summary = pinclear.Trajectory.load(npz).meta["summary"]
    mark = L["A.peak"]
    assert mark.get_ydata()[0] == summary["contact_force_peaks"]["A"]
    assert mark.get_xdata()[0] == summary["contact_force_peak_times"]["A"]
    # the curve is the total normal force at the samples (the peak's quantity), and at a 2 ms output
    # step it misses the landing's top: the step peak lies above every sample (the samples lie on
    # the dense output whose local maxima the peak search located, to its tolerance)
    curve = L["A.normal"].get_ydata()
    np.testing.assert_array_equal(curve, np.ravel(tr.outputs["A.fn"]))
    assert summary["contact_force_peaks"]["A"] >= curve.max() * (1 - 1e-9)
    assert summary["contact_force_peaks"]["A"] > 1.05 * curve.max()
    fig = plots.fig_contact_force(tr)
    assert "samples" in fig._suptitle.get_text() and "steps" in fig._suptitle.get_text()


@pytest.mark.slow
def test_drive_markers_are_the_step_peaks_and_the_ideal_run_is_dashed():
    mech = pinclear.load(URDF / "nine_bar.yaml")
    tr = pinclear.simulate(mech, 0.05, dt_out=0.005)
    ref = pinclear.simulate(mech, 0.05, dt_out=0.005, rtol=1e-10)
    L = _lines(plots.fig_drives(tr, ref=ref))
    s = tr.summary()
    for d in mech.drives:
        m = L[f"drive.{d.name}.peak"]
        # the peak is of |lambda|; the marker sits on the side of the sampled curve's sign there
        assert abs(m.get_ydata()[0]) == s["drive_force_peaks"][d.name]
        assert m.get_xdata()[0] == s["drive_force_peak_times"][d.name]
        assert abs(m.get_ydata()[0]) >= np.max(np.abs(tr.lam[d.name])) * (1 - 1e-9)
        r = L[f"drive.{d.name}.ref"]
        assert r.get_linestyle() == "--"
        np.testing.assert_array_equal(r.get_ydata(), ref.lam[d.name])


def test_deviation_panel_is_run_minus_reference(runs):
    mech, tr, ref, _ = runs
    fid = mech.platform_frame
    L = _lines(plots.fig_platform(tr, mech.model, fid, ref=ref))
    Mr, Mi = _placements(mech, tr.q, fid), _placements(mech, ref.q, fid)
    np.testing.assert_array_equal(tr.t, ref.t)      # one grid: the reference's own samples
    dP = np.array([a.translation - b.translation for a, b in zip(Mr, Mi)])
    for c in "xy":
        line = L[f"deviation.position.{c}"]
        np.testing.assert_array_equal(line.get_xdata(), tr.t)
        np.testing.assert_allclose(line.get_ydata(), dP[:, "xyz".index(c)] * 1e3, rtol=0, atol=1e-12)
    # the clearance's effect is visible there: of the order of the 0.1 mm gap, not of the 0.5 m swing
    assert 1e-3 < np.max(np.abs(L["deviation.position.y"].get_ydata())) < 1.0
    # the journal turns with the rod about z: orientation = rz - rz(0), its deviation rz - rz_ref
    iq = mech.model.joints[mech.model.getJointId("rz")].idx_q
    np.testing.assert_allclose(L["orientation.z"].get_ydata(), tr.q[:, iq] - tr.q[0, iq], rtol=0, atol=1e-12)
    np.testing.assert_allclose(L["deviation.orientation.z"].get_ydata(), (tr.q[:, iq] - ref.q[:, iq]) * 1e3,
                               rtol=0, atol=1e-9)


def test_deviation_on_other_grids_is_against_the_interpolated_reference(runs):
    mech, tr, _, _ = runs
    fid = mech.platform_frame
    ref = pinclear.simulate(pinclear.load(mech.path), 0.05, dt_out=1.5e-3, rtol=1e-8)
    L = _lines(plots.fig_platform(tr, mech.model, fid, ref=ref))
    P = np.array([M.translation for M in _placements(mech, tr.q, fid)])
    Pi = np.array([M.translation for M in _placements(mech, ref.q, fid)])
    for c in "xy":
        i = "xyz".index(c)
        want = P[:, i] - np.interp(tr.t, ref.t, Pi[:, i], left=np.nan, right=np.nan)
        np.testing.assert_allclose(L[f"deviation.position.{c}"].get_ydata(), want * 1e3, rtol=0, atol=1e-12)


def test_plot_cli_figures_and_summary_json_agree(runs, tmp_path, capsys):
    """`pinclear simulate` then `pinclear plot`: the contact figure's marker (read back from the
    figure made of the saved run) is summary.json's peak."""
    from pinclear.cli.commands import main

    _, _, _, d = runs
    out = tmp_path / "run"
    assert main(["simulate", str(d / "pendulum.yaml"), "--clearance", "A", "--t-end", "0.02", "--dt-out", "2e-3",
                 "--rtol", "1e-6", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    tr = pinclear.Trajectory.load(out / "trajectory.npz")
    mark = _lines(plots.fig_contact_force(tr))["A.peak"]
    assert mark.get_ydata()[0] == summary["contact_force_peaks"]["A"]


def test_a_ball_in_its_socket_names_its_projection():
    """A spherical clearance's journal figure is a projection of a 3-D path: it says onto which
    plane and how much spread the hidden direction has (the drawn data are the two named
    components)."""
    mech = pinclear.load("four_ups_upu", clearances=["S2"])
    tr = pinclear.simulate(mech, 0.02, dt_out=1e-3, rtol=1e-6)
    fig = plots.fig_journal(tr)
    E = tr.outputs["S2.eccentricity"]
    text = next(t for t in fig.axes[0].texts if t.get_gid() == "S2.projection").get_text()
    xl = fig.axes[0].get_xlabel()
    i, j = "xyz".index(xl[2]), "xyz".index(fig.axes[0].get_ylabel()[2])
    (k,) = {0, 1, 2} - {i, j}
    assert f"e_{'xyz'[i]}-e_{'xyz'[j]} plane" in text and f"e_{'xyz'[k]} not shown" in text
    assert f"{(E[:, k].max() - E[:, k].min()) * 1e3:.3g} mm" in text
    L = _lines(fig)
    np.testing.assert_allclose(L["S2.path"].get_xdata(), E[:, i] * 1e3)
