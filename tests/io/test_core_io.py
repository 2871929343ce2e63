"""Trajectory files (NPZ + JSON metadata) and the `pinclear simulate` command's outputs."""
from __future__ import annotations

import json

import numpy as np
import pinocchio as pin
import pytest
import scipy

import pinclear
from pinclear.cli import commands as cli
from pinclear.dynamics.trajectory import Trajectory
from tests.helpers import URDF_DIR


@pytest.fixture(scope="module")
def short_run(four_bar, sim):
    return sim(four_bar, 0.5, method="lagrange", integrator="DOP853", rtol=1e-9, alpha=3.0, beta=4.0,
               dt_out=0.01)


def test_save_load_round_trip(short_run, tmp_path):
    tr = short_run
    path = tr.save(tmp_path / "sub" / "run.npz")
    assert path.exists()
    back = Trajectory.load(path)
    for k in ("t", "q", "v", "a", "residual"):
        np.testing.assert_array_equal(getattr(back, k), getattr(tr, k), err_msg=k)
    assert back.lam.keys() == tr.lam.keys() and set(tr.lam) == {"B.u", "B.v"}
    for k in tr.lam:
        np.testing.assert_array_equal(back.lam[k], tr.lam[k])
    for k in tr.energies:
        np.testing.assert_array_equal(back.energies[k], tr.energies[k])
    assert back.status == tr.status == "success"
    assert back.stats["rhs_evals"] == tr.stats["rhs_evals"] > 0
    meta = back.meta
    assert meta["versions"]["pinocchio"] == pin.__version__
    assert meta["versions"]["numpy"] == np.__version__
    assert meta["versions"]["scipy"] == scipy.__version__
    assert meta["versions"]["pinclear"] == pinclear.__version__
    assert meta["method"] == {"method": "lagrange", "alpha": 3.0, "beta": 4.0, "drop_redundant": True}
    assert meta["integrator"] == "DOP853" and meta["rtol"] == 1e-9
    assert meta["mechanism"]["name"] == "four_bar"
    assert meta["mechanism"]["closures"][0]["type"] == "planar_point"
    assert {p["name"] for p in meta["parameters"]} >= {"a", "b", "c", "d"}
    # the summary stored with the file is the run's summary
    assert meta["summary"]["max_closure_residual"] == pytest.approx(float(tr.residual.max()))


def test_energy_recomputed_from_loaded_states(short_run, tmp_path, four_bar):
    """What a user does with a loaded file: recompute energies from q, v."""
    back = Trajectory.load(short_run.save(tmp_path / "run.npz"))
    model, data = four_bar.model, four_bar.model.createData()
    T = [pin.computeKineticEnergy(model, data, q, v) for q, v in zip(back.q, back.v)]
    np.testing.assert_allclose(back.energies["kinetic"], T, rtol=1e-12)


def test_cli_simulate_writes_trajectory_and_summary(tmp_path, capsys, four_bar):
    out = tmp_path / "out"
    rc = cli.main(["simulate", str(URDF_DIR / "four_bar.yaml"), "--t-end", "1", "--out", str(out),
                   "--rtol", "1e-9", "--alpha", "2.5"])
    stdout, stderr = capsys.readouterr()
    assert rc == 0, stderr
    assert (out / "trajectory.npz").exists() and (out / "summary.json").exists()
    summary = json.loads((out / "summary.json").read_text())
    for key in ("mobility", "redundant_constraints", "max_closure_residual", "energy_drift_rel", "rhs_evals",
                "cpu_s", "status"):
        assert key in summary, key
    assert summary["status"] == "success"
    assert summary["mobility"] == 1 and summary["redundant_constraints"] == 0
    assert summary["max_closure_residual"] < 1e-8
    assert summary["energy_drift_rel"] < 1e-6
    assert summary["rhs_evals"] > 0 and summary["cpu_s"] > 0
    printed = json.loads(stdout.strip().splitlines()[-1])
    assert printed["status"] == "success" and printed["rhs_evals"] == summary["rhs_evals"]
    tr = Trajectory.load(out / "trajectory.npz")
    assert tr.t[0] == 0.0 and tr.t[-1] == pytest.approx(1.0)
    assert tr.meta["method"]["alpha"] == 2.5
    # the file's states are a valid run: closure satisfied at every sample
    from pinclear.model import kinematics

    ws = four_bar.workspace()
    res = [np.abs(kinematics.closure_residual(four_bar, ws, q)).max() for q in tr.q]
    assert max(res) < 1e-8
    np.testing.assert_allclose(res, tr.residual, atol=1e-15)


def test_cli_failed_run_writes_partial_results(tmp_path, capsys):
    """A run that fails (lagrange through the parallelogram's flat configuration) still writes
    what it computed, says why on one stderr line, and exits 1."""
    out = tmp_path / "out"
    rc = cli.main(["simulate", str(URDF_DIR / "parallelogram.yaml"), "--t-end", "3", "--out", str(out),
                   "--integrator", "DOP853", "--rtol", "1e-10"])
    stdout, stderr = capsys.readouterr()
    assert rc == 1
    assert len(stderr.strip().splitlines()) == 1 and "rank" in stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "failed" and "rank" in summary["message"]
    tr = Trajectory.load(out / "trajectory.npz")
    assert tr.status == "failed" and 0.25 < tr.t[-1] < 3.0
