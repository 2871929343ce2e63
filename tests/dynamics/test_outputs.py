"""A run's outputs (pinclear.dynamics.stepping.outputs) and its peaks from the integration
(pinclear.dynamics.stepping.peaks): docs/outputs.md.

The compiled pass over the samples and the per-sample Python path (``outputs="python"``, the path
of every run before it) are two implementations of the same outputs: accelerations and
multipliers from the formulation's evaluation, residuals from the constraint rows, energies
(Pinocchio's computeKineticEnergy / computePotentialEnergy against v^T M v / 2 and the centres
of mass from the compiled joint chain) and each force element's record. They agree to rounding.
The peaks are taken over the accepted steps, which do not depend on the output grid, so they do
not either; a contact peak located between steps is the maximum of the same dense output a fine
grid of samples resolves."""
import warnings

import numpy as np
import pytest

import pinclear

# scene, clearances, method, simulated time: closures (lagrange), the manifold method's moved
# state and projected samples, a spherical, a planar revolute and a prismatic clearance (the
# last through the Python path: no compiled record), a spring-damper scene
CASES = [("four_bar", None, "lagrange", 0.5), ("a02_nfourbar_2", None, "manifold", 0.5),
         ("four_ups_upu", ["S2"], "lagrange", 0.1), ("clr_planar_pendulum", ["A"], "lagrange", 0.2),
         ("nine_bar", None, "projection", 0.2), ("slider_crank_clearance", ["P"], "lagrange", 0.1),
         ("squeezer", None, "lagrange", 0.01)]


def _run(mech, t_end, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return pinclear.simulate(mech, t_end, rtol=1e-6, **kw)


def _close(a, b, what, scale=0.0):
    a, b = np.asarray(a, float), np.asarray(b, float)
    assert a.shape == b.shape, (what, a.shape, b.shape)
    if not b.size:
        return
    scale = max(float(np.nanmax(np.abs(b))), scale, 1e-300)
    # rounding: the energies are the same sums in another order (at most ~nv terms of size scale)
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-11 * scale, err_msg=what)


@pytest.mark.parametrize("name, clr, method, t_end", CASES, ids=[c[0] + "-" + c[2] for c in CASES])
def test_compiled_outputs_equal_the_python_path(name, clr, method, t_end):
    mech = pinclear.load(name, clearances=clr)
    fast = _run(mech, t_end, method=method, dt_out=t_end / 40)
    slow = _run(mech, t_end, method=method, dt_out=t_end / 40, outputs="python")
    assert fast.status == slow.status == "success"
    assert fast.stats["steps"] == slow.stats["steps"]
    for k in ("t", "q", "v", "z", "a", "residual", "drive_error"):
        _close(getattr(fast, k), getattr(slow, k), k)
    assert sorted(fast.lam) == sorted(slow.lam)
    for k in slow.lam:
        _close(fast.lam[k], slow.lam[k], f"lam {k}")
    assert sorted(fast.energies) == sorted(slow.energies)
    # energies against the run's energy scale (J), powers against it over the run's span (W):
    # the closure rows' power is zero up to rounding, its own size is no scale
    scale = slow.energy_balance()["scale"]
    for k in slow.energies:
        _close(fast.energies[k], slow.energies[k], f"energy {k}", scale / (t_end if "power" in k else 1.0))
    assert sorted(fast.outputs) == sorted(slow.outputs)
    for k in slow.outputs:
        _close(fast.outputs[k], slow.outputs[k], f"output {k}")
    assert fast.energy_balance()["error"] == pytest.approx(slow.energy_balance()["error"], rel=1e-6, abs=1e-12)


def test_peaks_do_not_depend_on_the_output_grid():
    mech = pinclear.load("four_ups_upu", clearances=["S2"])
    coarse = _run(mech, 0.2, dt_out=0.2 / 20)
    fine = _run(mech, 0.2, dt_out=0.2 / 4000)
    assert coarse.stats["steps"] == fine.stats["steps"] and coarse.stats["rhs_evals"] == fine.stats["rhs_evals"]
    a, b = coarse.peak_summary(), fine.peak_summary()
    assert a["peaks_from"] == b["peaks_from"] == "integration"
    assert a == b
    # located between steps: at least every value of a fine grid of the same dense output
    clr = {c["name"]: c for c in a["clearances"]}
    assert clr["S2"]["peak_normal_force"] >= np.max(fine.outputs["S2.fn"]) * (1 - 1e-9)
    assert a["drive_force_peaks"] == coarse.summary()["drive_force_peaks"]


def test_a_contact_peak_between_steps_is_the_dense_outputs_maximum():
    """The located peak against a fine grid of samples around it (the same steps, the same dense
    output): the grid's maximum lies below it by at most the grid's miss of a smooth maximum,
    |F''| (dt/2)^2 / 2, F'' from the grid's second differences."""
    mech = pinclear.load("clr_planar_pendulum", clearances=["A"])
    run = _run(mech, 0.2, dt_out=0.2 / 20)
    peak = run.peak_summary()["clearances"][0]
    fmax, tp = peak["peak_normal_force"], peak["t_peak"]
    assert fmax > 0 and 0 < tp < 0.2
    dt = 1e-7
    grid = tp + dt * np.arange(-2000, 2001)
    fine = _run(mech, 0.2, t_eval=grid[(grid > 0) & (grid < 0.2)])
    assert fine.stats["steps"] == run.stats["steps"]
    F = fine.outputs["A.fn"]
    k = int(np.argmax(F))
    assert abs(fine.t[k] - tp) < 2 * dt + 1e-7 * 0.2            # Brent's time tolerance
    curvature = abs(F[k + 1] - 2 * F[k] + F[k - 1]) / dt ** 2
    miss = 0.5 * curvature * (dt / 2) ** 2
    assert F[k] <= fmax * (1 + 1e-12) + 1e-9
    assert fmax - F[k] <= miss + 1e-9 * fmax


def test_drive_force_peaks_are_the_accepted_states_evaluations():
    """The drive-force and acceleration peaks against a second run sampled exactly at the first
    run's accepted steps (progress reports them; a sample at a step's end is its state, and the
    outputs evaluate there again): the largest sampled |lam| and |a| are the peaks, at their times,
    and no evaluation was added for them (the same steps, the same evaluations)."""
    mech = pinclear.load("four_ups_upu")
    steps = []
    run = _run(mech, 0.2, dt_out=0.2 / 10, progress=steps.append)
    at = _run(mech, 0.2, t_eval=np.array([0.0] + steps))
    assert at.stats["steps"] == run.stats["steps"] == len(steps)
    assert at.stats["rhs_evals"] == run.stats["rhs_evals"]
    pk = run.stats["peaks"]
    for d in mech.drives:
        lam = np.abs(at.lam[d.name])
        k = int(np.argmax(lam))
        assert pk["drive_forces"][d.name]["value"] == pytest.approx(lam[k], rel=1e-12)
        assert pk["drive_forces"][d.name]["t"] == at.t[k]
    acc = np.abs(at.a).max(axis=0)
    got = np.array([r["value"] for r in pk["accelerations"].values()])
    np.testing.assert_allclose(got, acc, rtol=1e-12)


def test_summary_json_and_summary_give_the_same_peaks(tmp_path, capsys):
    """summary.json and traj.summary() come from one function: the same drive-force peaks and
    clearances (with their located peaks), also for the run read back from its file."""
    import json

    from pinclear.cli.commands import main

    out = tmp_path / "o"
    assert main(["simulate", "four_ups_upu", "--clearance", "S2", "--t-end", "0.05", "--out", str(out),
                 "--progress", "off"]) == 0
    capsys.readouterr()
    saved = json.loads((out / "summary.json").read_text())
    back = pinclear.Trajectory.load(out / "trajectory.npz").summary()
    for key in ("drive_force_peaks", "drive_force_peak_times", "acceleration_peaks", "clearances", "peaks_from",
                "contact_force_peaks", "contact_force_peak_times"):
        assert saved[key] == back[key], key
    assert saved["peaks_from"] == "integration"
    (s2,) = saved["clearances"]
    assert s2["name"] == "S2" and s2["peak_normal_force"] > 0 and 0 <= s2["t_peak"] <= 0.05
    assert saved["contact_force_peaks"] == {"S2": s2["peak_normal_force"]}
    assert set(saved["drive_force_peaks"]) == {d.name for d in pinclear.load("four_ups_upu").drives}
