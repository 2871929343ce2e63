"""Standard plots (issue 5): files are written, and every plotted array is the trajectory
array it claims to show (checked on the line data, not the pixels).

The platform curves are checked against physics rather than against the plotting code:
positions against Pinocchio's frame placement, velocities against the time derivative of the
plotted positions, accelerations against the derivative of the plotted velocities (this
catches plotting the spatial instead of the classical acceleration).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.cli.view import plot_main
from pinclear.viz import plots

URDF = Path(__file__).resolve().parents[2] / "urdf"


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """A pendulum hanging from a journal in a bearing with 0.1 mm clearance (urdf/clr_planar_
    pendulum), its rod tip declared as platform, with and without the clearance."""
    d = tmp_path_factory.mktemp("plots")
    text = (URDF / "clr_planar_pendulum.yaml").read_text()
    text = text.replace("urdf: clr_planar_pendulum.urdf", f"urdf: {URDF / 'clr_planar_pendulum.urdf'}")
    side = d / "pendulum.yaml"
    side.write_text(text + "\nplatform: {frame: journal}\n")
    clr = pinclear.load(side, clearances=["A"])
    ideal = pinclear.load(side)
    tr = pinclear.simulate(clr, 0.05, dt_out=5e-4, rtol=1e-6)
    ref = pinclear.simulate(ideal, 0.05, dt_out=5e-4, rtol=1e-8)
    assert tr.status == "success" and ref.status == "success"
    return clr, tr, ref, d


def _lines(fig):
    return {ln.get_gid(): ln for ax in fig.axes for ln in ax.get_lines() if ln.get_gid()}


def test_platform_curves_are_the_platform_kinematics(runs):
    mech, tr, ref, _ = runs
    fid = mech.platform_frame
    fig = plots.fig_platform(tr, mech.model, fid, ref=ref)
    L = _lines(fig)
    data = mech.model.createData()
    P = np.array([pin.framesForwardKinematics(mech.model, data, q) or data.oMf[fid].translation.copy()
                  for q in tr.q])
    # the pendulum swings in x-y: both components plotted, solid and dashed (ideal run)
    for c in "xy":
        i = "xyz".index(c)
        assert f"position.{c}" in L and f"position.{c}.ref" in L
        np.testing.assert_array_equal(L[f"position.{c}"].get_xdata(), tr.t)
        np.testing.assert_allclose(L[f"position.{c}"].get_ydata(), P[:, i], rtol=0, atol=1e-15)
        assert L[f"position.{c}.ref"].get_linestyle() == "--"
        np.testing.assert_array_equal(L[f"position.{c}.ref"].get_xdata(), ref.t)
        # v = dp/dt and a = dv/dt on the ideal (smooth) run, to the finite-difference error
        for what, deriv_of in (("velocity", "position"), ("acceleration", "velocity")):
            y = L[f"{deriv_of}.{c}.ref"].get_ydata()
            fd = np.gradient(y, ref.t)[2:-2]
            plotted = L[f"{what}.{c}.ref"].get_ydata()[2:-2]
            assert np.max(np.abs(fd - plotted)) < 1e-3 * max(np.max(np.abs(plotted)), 1e-9)
    assert "position.z" not in L          # z never moves in a planar run


def test_contact_journal_residual_energy_drive_curves_are_the_run_arrays(runs):
    mech, tr, ref, _ = runs
    L = _lines(plots.fig_contact_force(tr))
    np.testing.assert_array_equal(L["A.normal"].get_xdata(), tr.t)
    np.testing.assert_allclose(L["A.normal"].get_ydata(), np.linalg.norm(tr.outputs["A.normal_force"], axis=1))
    assert np.max(L["A.normal"].get_ydata()) > 0        # the journal did hit the bearing
    np.testing.assert_allclose(L["A.normal"].get_ydata(), tr.outputs["A.fn"], rtol=1e-9, atol=1e-9)

    L = _lines(plots.fig_journal(tr))
    E = tr.outputs["A.eccentricity"]
    np.testing.assert_allclose(L["A.path"].get_xdata(), E[:, 0] * 1e3)
    np.testing.assert_allclose(L["A.path"].get_ydata(), E[:, 1] * 1e3)
    circle = np.hypot(L["A.circle"].get_xdata(), L["A.circle"].get_ydata())
    np.testing.assert_allclose(circle, 0.1, rtol=1e-12)          # c = 0.1 mm from the sidecar
    # physics: the journal stays inside the circle up to the contact penetration
    assert np.max(np.hypot(E[:, 0], E[:, 1])) <= 1e-4 + np.max(tr.outputs["A.penetration"]) + 1e-12

    assert plots.fig_residual(tr) is None        # the clearance replaced the only closure
    L = _lines(plots.fig_residual(ref))
    r = L["residual"].get_ydata()
    assert np.all(ref.residual >= 0) and np.any(ref.residual > 0)
    np.testing.assert_array_equal(r[ref.residual > 0], ref.residual[ref.residual > 0])
    assert np.all(np.isnan(r[ref.residual == 0]))   # exact zeros cannot sit on a log axis

    L = _lines(plots.fig_energy(tr))
    # the kinetic curve is 1/2 v^T M(q) v from Pinocchio's mass matrix at the samples
    data = mech.model.createData()
    T = [0.5 * v @ pin.crba(mech.model, data, q) @ v for q, v in zip(tr.q, tr.v)]
    np.testing.assert_allclose(L["energy.kinetic"].get_ydata(), T, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(L["energy.dissipated"].get_ydata(), np.ravel(tr.outputs["A.dissipated"]))
    # the curves add up to the plotted balance error, which the audit's bound contains
    signs = {k: sgn for k, (_, sgn) in plots.ENERGY_CURVES.items()}
    total = sum(signs[k[7:]] * line.get_ydata() for k, line in L.items() if k[7:] in signs)
    bal = L["energy.balance"].get_ydata()
    eb = tr.energy_balance()
    # to round-off of the run's energy scale (the terms are sums of O(scale) numbers)
    np.testing.assert_allclose(total - total[0], bal, rtol=0, atol=1e-12 * eb["scale"])
    assert np.abs(bal).max() <= eb["bound"] * eb["scale"]
    assert eb["terms_t"] == tr.t[-1] and eb["terms"]["kinetic"] == pytest.approx(T[-1], rel=1e-10)
    k = int(np.argmin(np.abs(tr.t - eb["t"])))
    assert eb["terms_at_error"]["kinetic"] == pytest.approx(T[k], rel=1e-10)

    assert plots.fig_drives(tr) is None                  # the pendulum has no drive
    mech9 = pinclear.load(URDF / "nine_bar.yaml")
    tr9 = pinclear.simulate(mech9, 0.05, dt_out=0.005)
    L = _lines(plots.fig_drives(tr9))
    for d in mech9.drives:
        np.testing.assert_array_equal(L[f"drive.{d.name}"].get_ydata(), tr9.lam[d.name])


def test_plot_cli_writes_every_figure(runs, capsys):
    mech, tr, ref, d = runs
    npz = tr.save(d / "run.npz")
    refz = ref.save(d / "ideal.npz")
    out = d / "figs"
    # the run's own sidecar is named: a path recorded in a run is never opened (issue 42)
    assert plot_main([str(npz), "--mech", str(d / "pendulum.yaml"), "--out", str(out), "--ref", str(refz)]) == 0
    names = {"platform", "contact_force", "journal", "energy"}
    for n in names:
        f = out / f"{n}.png"
        assert f.exists() and f.stat().st_size > 5000, n
        assert f.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    text = capsys.readouterr().out
    assert "skipped drives: no drives" in text and "skipped residual: no closure rows" in text
    # a run reloaded from disk plots the same arrays as the live one
    tr2 = pinclear.Trajectory.load(npz)
    np.testing.assert_array_equal(_lines(plots.fig_contact_force(tr2))["A.normal"].get_ydata(),
                                  _lines(plots.fig_contact_force(tr))["A.normal"].get_ydata())
    assert plots.clearance_size(tr2, "A") == pytest.approx(1e-4)


def test_plot_cli_bad_input(tmp_path, capsys):
    assert plot_main([str(tmp_path / "missing.npz"), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("pinclear: error:") and "missing.npz" in err
    bad = tmp_path / "bad.npz"
    bad.write_text("not an archive")
    assert plot_main([str(bad), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "bad.npz" in err and "not a pinclear trajectory" in err


def test_slider_in_guide_is_plotted_across_the_guide_inside_its_gaps():
    import yaml

    spec = yaml.safe_load((URDF / "clr_slider.yaml").read_text())
    c1, c2 = [c for c in spec["clearances"] if c["name"] == "P"][0]["clearance"]
    mech = pinclear.load(URDF / "clr_slider.yaml", clearances=["P"])
    tr = pinclear.simulate(mech, 0.02, dt_out=5e-4, rtol=1e-6)
    L = _lines(plots.fig_journal(tr))
    E = tr.outputs["P.eccentricity"]
    # the guide frame's x and y (across the slide axis z), never the travel along it
    np.testing.assert_allclose(L["P.path"].get_xdata(), E[:, 0] * 1e3)
    np.testing.assert_allclose(L["P.path"].get_ydata(), E[:, 1] * 1e3)
    gx, gy = L["P.gap"].get_xdata(), L["P.gap"].get_ydata()
    np.testing.assert_allclose([gx.max(), -gx.min(), gy.max(), -gy.min()],
                               [c1 * 1e3, c1 * 1e3, c2 * 1e3, c2 * 1e3], rtol=1e-12)
