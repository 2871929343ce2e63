"""The stability atlas (issue 12): failures are recorded with the right reason and time, the
outputs carry the documented columns, successful cells are as accurate as their tolerance
says, and peers (other simulators) enter the same tables and charts.

References are independent of the cells: the parallelogram's flat time by quadrature of its
energy integral, A02's state from its closed-form 1-dof branch pendulum."""
from __future__ import annotations

import csv
import json
import math

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import quad, solve_ivp
from scipy.optimize import brentq

import pinclear
from pinclear.cli import commands as cli
from pinclear.mechanisms import bench_scenes
from pinclear.mechanisms import benchmarks as B
from pinclear.model import kinematics
from pinclear.studies.bench import atlas
from tests.helpers import URDF_DIR


def _flat_time_by_quadrature(mech):
    """First time the parallelogram, released at rest at crank angle th0 on its branch
    q = th (1, -1, 1), is flat (th = 0): t = int_0^th0 sqrt(I(th) / (2 (V(th0) - V(th)))) dth,
    energy conservation of the 1-dof branch (I = u^T M u; V Pinocchio's potential). The
    substitution th = th0 - s^2 removes the endpoint singularity (V(th0) - V(th) ~ s^2)."""
    model, data = mech.model, mech.model.createData()
    u = np.array([1.0, -1.0, 1.0])
    th0 = float(mech.q0[0])
    assert np.allclose(mech.q0, th0 * u) and np.allclose(mech.v0, 0.0)

    def inertia(th):
        M = pin.crba(model, data, th * u)
        return u @ (np.triu(M) + np.triu(M, 1).T) @ u

    def V(th):
        return pin.computePotentialEnergy(model, data, th * u)

    def integrand(s):
        if s == 0.0:            # the limit: V(th0) - V(th) -> V'(th0) s^2, V' = u^T g(q)
            dV = u @ pin.computeGeneralizedGravity(model, data, th0 * u)
            return 2.0 * math.sqrt(inertia(th0) / (2.0 * dV))
        th = th0 - s * s
        return 2.0 * s * math.sqrt(inertia(th) / (2.0 * (V(th0) - V(th))))

    t, err = quad(integrand, 0.0, math.sqrt(th0), epsabs=1e-13, epsrel=1e-12, limit=200)
    assert err < 1e-10
    return t


def test_flat_time_quadrature_agrees_with_the_branch_ode():
    """The two independent singular times: quadrature of the energy integral and the event of the
    1-dof branch ODE (pinclear.mechanisms.bench_scenes.parallelogram_flat_times) agree to 1e-9 s."""
    mech = pinclear.load(URDF_DIR / "parallelogram.yaml")
    tq = _flat_time_by_quadrature(mech)
    te = bench_scenes.parallelogram_flat_times(mech, 1.0)
    assert len(te) == 2 and 0.2 < tq < 0.4
    assert te[0] == pytest.approx(tq, abs=1e-9)


def test_lagrange_on_the_parallelogram_is_recorded_as_rank_loss_at_the_flat_time(tmp_path):
    """lagrange cannot solve its KKT system where the parallelogram is flat: each cell says
    'rank loss' at the flat time. The run stops where the pivot ratio of the kept rows falls
    under the rank threshold, located along the step's dense output (xatol 1e-13 s): the crank
    is then within an angle d of flat, with d the Jacobian's relative pivot threshold (~1e-8)
    divided by its sensitivity (O(1)), reached at crank rate w_flat ~ 7 rad/s, so |t_failed -
    t_flat| is ~1e-9 s plus the integration error of the arrival time (rtol-sized). Bound 1e-5 s:
    the crank moves 7e-5 rad in it, while a failure one output interval (5 ms) late or at a
    wrong passage (the next one is 0.24 s later) is caught."""
    mech = pinclear.load(URDF_DIR / "parallelogram.yaml")
    t_flat = _flat_time_by_quadrature(mech)
    res = atlas.run_atlas([str(URDF_DIR / "parallelogram.yaml")], out=tmp_path, methods=["lagrange", "proximal"],
                          integrators_=["DOP853", "RK45"], tols=[1e-8, 1e-10], t_end=1.0, budget=120.0)
    # budget: a hang guard only (each cell costs well under 0.1 CPU s; compile time is never in it)
    lag = [r for r in res["rows"] if r["method"] == "lagrange"]
    assert len(lag) == 4
    for r in lag:
        assert (r["status"], r["reason"]) == ("failed", "rank loss"), r
        assert r["t_failed"] == pytest.approx(t_flat, abs=1e-5)
        assert math.isnan(r["error"])
    # the method made for it passes both flat configurations on the branch (spread ~ closure)
    prox = [r for r in res["rows"] if r["method"] == "proximal"]
    assert prox and all(r["status"] == "success" and r["branch_spread"] < 1e-6 for r in prox)
    assert res["scenes"]["parallelogram"]["reference"].startswith("1-dof reduction")
    saved = json.loads((tmp_path / "atlas.json").read_text())
    assert [r["reason"] for r in saved["rows"] if r["method"] == "lagrange"] == ["rank loss"] * 4


def test_branch_spread_tells_the_two_branches_apart():
    """On the parallelogram branch the cranks stay parallel (spread 0). The anti-parallelogram
    closure of the same linkage (crank a = 0.2 m at th from the origin, rocker a at phi from the
    ground pivot (b, 0), b = 0.4 m: |rocker tip - crank tip| = b has the root phi = th and one
    other) closes the loop (residual checked) with the rocker O(1) away from the crank, far over
    the atlas's branch threshold."""
    mech = pinclear.load(URDF_DIR / "parallelogram.yaml")
    assert atlas.branch_spread(mech, mech.q0)[0] < 1e-14
    a, b, th = 0.2, 0.4, 1.2

    def e(x):
        return np.array([math.cos(x), math.sin(x)])

    def gap(phi):
        return np.sum((np.array([b, 0.0]) + a * e(phi) - a * e(th)) ** 2) - b * b

    phi = brentq(gap, th + 0.5, th + 2 * math.pi - 0.5)
    tip = np.array([b, 0.0]) + a * e(phi) - a * e(th)
    q = np.array([th, math.atan2(tip[1], tip[0]) - th, phi])
    assert np.abs(kinematics.closure_residual(mech, mech.workspace(), q)).max() < 1e-12
    assert np.abs(kinematics.closure_residual(mech, mech.workspace(), mech.q0)).max() < 1e-12
    assert atlas.branch_spread(mech, q)[0] > 50 * atlas.BRANCH_TOL
    # A02 (N = 2): every crank equal on the published branch state
    a02 = pinclear.load(B.a02_name(2))
    assert atlas.branch_spread(a02, a02.q0)[0] < 1e-14
    assert atlas.branch_joints(pinclear.load(URDF_DIR / "four_bar.yaml")) is None


class FakePeer:
    """A peer in the agreed interface: its answer at tol is the exact branch state of A02 (N = 1)
    with crank 0 moved by tol, so its error must read tol; its second rung reports a failure."""

    name = "fake"
    scenes = {"a02_nfourbar_1", "not_in_this_run"}
    tols = [1e-3, 1e-4]

    def __init__(self):
        self.calls = []

    def run(self, sidecar_path, t_end, tol):
        self.calls.append((sidecar_path, t_end, tol))
        if tol == 1e-4:
            return {"status": "failed", "reason": "step-size collapse", "message": "fake collapse",
                    "q_final": None, "cpu_s": 0.5, "steps": 7, "t_failed": 0.25}
        mech = pinclear.load(sidecar_path)
        sol = solve_ivp(B.a02_branch_rhs(1), (0.0, t_end), [B.A02_THETA0, B.a02_initial_rate()], method="Radau",
                        rtol=1e-12, atol=1e-13)
        qd, _ = B.a02_branch_state(1, sol.y[0, -1], sol.y[1, -1])
        q = np.zeros(mech.model.nq)
        for name, val in qd.items():
            q[mech.model.joints[mech.model.getJointId(name)].idx_q] = val
        q[mech.model.joints[mech.model.getJointId("crank0_joint")].idx_q] += tol
        return {"status": "success", "reason": "", "message": "ok", "q_final": q, "cpu_s": 0.1, "steps": 100,
                "energy_drift": 1e-6}


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    out = tmp_path_factory.mktemp("atlas_quick")
    peer = FakePeer()
    res = atlas.run_atlas(["four_bar", "a02_nfourbar_1"], out=out, quick=True, peers=[peer])
    return out, res, peer


@pytest.mark.slow
def test_quick_atlas_writes_the_documented_files(quick):
    out, res, _ = quick
    assert set(res["scenes"]) == {"four_bar", "a02_nfourbar_1"}
    with open(out / "atlas.csv", newline="") as fh:
        rd = csv.DictReader(fh)
        assert rd.fieldnames == atlas.COLUMNS
        rows = list(rd)
    saved = json.loads((out / "atlas.json").read_text())
    assert len(rows) == len(saved["rows"]) == len(res["rows"])
    for key in ("scene", "method", "integrator", "tol", "status", "reason", "message", "t_failed", "error",
                "energy_drift", "max_residual", "cpu_s", "rhs_evals"):
        assert key in atlas.COLUMNS
    for r in saved["rows"]:
        assert r["status"] in ("success", "failed")
        assert (r["reason"] == "") == (r["status"] == "success") and r["reason"] in atlas.REASONS + ("",)
    # every pinclear combo of the quick grid that the scene admits: lagrange, projection,
    # proximal (pinocchio refuses planar closures and says why) x DOP853, Radau, RK4 x 2 rungs
    for label in res["scenes"]:
        own = [r for r in saved["rows"] if r["scene"] == label and r["method"] != "fake"]
        assert len(own) == 3 * 3 * len(atlas.QUICK_TOLS)
        assert "pinocchio" in res["scenes"][label]["skipped"]
        for kind in ("heatmap", "work_precision"):
            png = out / f"{kind}_{label}.png"
            assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    assert res["scenes"]["a02_nfourbar_1"]["reference"].startswith("analytic")
    assert res["scenes"]["four_bar"]["reference"].startswith("projection + DOP853")
    assert res["scenes"]["four_bar"]["energy_kind"] == "drift"


def test_quick_atlas_successes_meet_their_tolerance(quick):
    """Global error at t_end of a success <= 10 tol. Adaptive cells: local error per step <= rtol
    |y| + atol with |q| ~ 1 rad, and for these short (<= 1 s), non-chaotic runs the global error
    stays within a small multiple of it (tolerance proportionality). RK4 cells: h = 1e-2 (tol /
    1e-4)^(1/4), so C h^4 = C 1e-4 tol and the bound holds for C <= 1e5. This grid measured error
    / tol <= 1.3 (RK4: C ~ 1.3e4) and energy drift / tol <= 2.3 over both scenes, all three
    formulations and integrators: the bound leaves 4x-8x. Conservative scenes: drift under the
    same 10 tol."""
    _, res, _ = quick
    ok = [r for r in res["rows"] if r["status"] == "success" and r["method"] != "fake"]
    assert len(ok) >= 20
    for r in ok:
        assert r["error"] < 10 * r["tol"], r
        assert r["energy_kind"] == "drift" and r["energy_drift"] < 10 * r["tol"], r
    # proximal passes A02's flat configuration on its branch at every cell of the grid
    prox = [r for r in res["rows"] if r["scene"] == "a02_nfourbar_1" and r["method"] == "proximal"]
    assert prox and all(r["status"] == "success" for r in prox)


def test_peer_rows_use_the_same_reference(quick):
    """The fake peer's answer is the exact state moved by tol on one crank: the atlas, comparing
    with its own analytic reference, must read error = tol (to the reference's 1e-10)."""
    out, res, peer = quick
    assert [c[2] for c in peer.calls] == [1e-3, 1e-4]            # only scenes of this run, every rung
    assert peer.calls[0][1] == res["scenes"]["a02_nfourbar_1"]["t_end"]
    fake = [r for r in res["rows"] if r["method"] == "fake"]
    assert [(r["integrator"], r["tol"], r["status"]) for r in fake] == [("fake", 1e-3, "success"),
                                                                        ("fake", 1e-4, "failed")]
    assert fake[0]["error"] == pytest.approx(1e-3, abs=1e-9)
    assert fake[0]["energy_drift"] == 1e-6
    assert (fake[1]["reason"], fake[1]["t_failed"], fake[1]["rhs_evals"]) == ("step-size collapse", 0.25, 7)
    assert math.isnan(fake[1]["error"])
    assert "a02_nfourbar_1" in res["scenes"] and res["scenes"]["a02_nfourbar_1"]["peers"] == ["fake"]


def test_budget_is_reported_as_budget(tmp_path):
    """A cell that exceeds its CPU budget stops early with reason 'budget' and the time reached."""
    res = atlas.run_atlas(["four_bar"], out=tmp_path, methods=["lagrange"], integrators_=["Radau"], tols=[1e-10],
                          t_end=2.0, budget=0.02)
    (r,) = res["rows"]
    assert (r["status"], r["reason"]) == ("failed", "budget")
    assert 0.0 <= r["t_failed"] < 2.0 and r["cpu_s"] < 1.0


def test_bad_input_is_a_clear_error(tmp_path, capsys):
    with pytest.raises(pinclear.InputError, match="budget"):
        atlas.run_atlas(["four_bar"], out=tmp_path, budget=-1.0)
    with pytest.raises(pinclear.InputError, match="valid: .*lagrange"):
        atlas.run_atlas(["four_bar"], out=tmp_path, methods=["euler"])
    with pytest.raises(pinclear.InputError, match="peers"):
        atlas.run_atlas(["four_bar"], out=tmp_path, peers=[object()])
    assert cli.main(["bench", "atlas", "four_bar", "--out", str(tmp_path), "--budget", "-2"]) == 2
    assert "budget" in capsys.readouterr().err
