"""The stepping engine (pinclear.dynamics.stepping): one compiled step logic over stages.

The compiled stages and the plug-ins' Python methods (``loop="python"``) compute the same
numbers with the same kernels, and both are stepped by the same compiled step logic, so a run
takes the same steps, meets the same events at the same times and reaches the same states on
both. Output samples come from the same dense output; the outputs evaluated afterwards (a, lam)
go through one more evaluation of each path, which agree as the right-hand sides do."""
import importlib
import os
import subprocess
import sys
import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import pinclear
from pinclear.dynamics import formulations, stepping
from pinclear.dynamics.stepping.build import Evaluation
from pinclear.dynamics.stepping.run import CHUNK
from pinclear.dynamics.trajectory import FAILURE_KINDS, Trajectory
from pinclear.model import native

# scene, clearances, simulated time: ideal closures, seed drives with analytic inverse
# kinematics, dropped redundant rows, and the three clearance types with their events
CASES = [("four_bar", None, 1.0), ("nine_bar", None, 0.5), ("four_ups_upu", None, 0.5),
         ("three_upru_up", None, 0.5), ("four_bar_revolute", None, 1.0), ("a04_bricard", None, 1.0),
         ("slider_crank_clearance", ["P"], 0.15), ("four_ups_upu", ["S2"], 0.3), ("clr_slider", ["P"], 0.1),
         ("clr_planar_pendulum", ["A"], 0.2), ("clr_hinge", ["R"], 0.1)]


def _quiet(fn, *a, **kw):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return fn(*a, **kw)


def _pair(name, clr, t_end, **kw):
    mech = pinclear.load(name, clearances=clr)
    fast = _quiet(pinclear.simulate, mech, t_end, rtol=1e-6, dt_out=t_end / 50, **kw)
    slow = _quiet(pinclear.simulate, mech, t_end, rtol=1e-6, dt_out=t_end / 50, loop="python", **kw)
    return fast, slow


def _same_run(fast, slow):
    assert fast.stats["steps"] == slow.stats["steps"]
    assert fast.stats["rhs_evals"] == slow.stats["rhs_evals"]
    ev_f, ev_s = fast.stats["events"], slow.stats["events"]
    assert [e["event"] for e in ev_f] == [e["event"] for e in ev_s]
    assert [e["t"] for e in ev_f] == [e["t"] for e in ev_s]        # located on identical steps
    np.testing.assert_allclose(fast.q, slow.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fast.v, slow.v, rtol=0, atol=1e-12 * max(1.0, np.abs(slow.v).max()))


@pytest.mark.slow
@pytest.mark.parametrize("name, clr, t_end", CASES, ids=[c[0] + ("+" + c[1][0] if c[1] else "") for c in CASES])
def test_compiled_stages_take_the_python_paths_steps(name, clr, t_end):
    fast, slow = _pair(name, clr, t_end)
    assert fast.stats["loop"] == "compiled", fast.stats["loop"]
    assert slow.stats["loop"].startswith("python: asked")
    assert fast.status == slow.status == "success"
    _same_run(fast, slow)
    if clr:
        assert len(fast.stats["events"]) > 0                          # the case meets its contacts
    # outputs are evaluated from the samples by each path's own evaluation: the same kernels on
    # the same states; 1e-9 of the scale admits an amplification of round-off up to 1e7
    np.testing.assert_allclose(fast.a, slow.a, rtol=0, atol=1e-9 * max(1.0, np.abs(slow.a).max()))
    for k in slow.lam:
        np.testing.assert_allclose(fast.lam[k], slow.lam[k], rtol=0, atol=1e-9 * max(1.0, np.abs(slow.lam[k]).max()))


@pytest.mark.slow
@pytest.mark.parametrize("integrator, kw", [("DOP853", {}), ("RK4", {"h": 1e-5}), ("Radau", {}), ("LSODA", {})])
def test_every_integrator_takes_the_same_steps_on_both_paths(integrator, kw):
    """The integrators share the step logic and evaluate through the same stages: on a clearance
    scene with events the compiled stages and the Python path take the same steps."""
    rtol = {} if kw else {"rtol": 1e-6}
    mech = pinclear.load("clr_planar_pendulum", clearances=["A"])
    fast = _quiet(pinclear.simulate, mech, 0.05, integrator=integrator, **rtol, **kw)
    slow = _quiet(pinclear.simulate, mech, 0.05, integrator=integrator, loop="python", **rtol, **kw)
    assert fast.status == slow.status == "success" and fast.stats["events"]
    assert fast.stats["loop"].startswith("compiled")
    assert ("SciPy's" in fast.stats["loop"]) == (integrator in ("Radau", "LSODA"))
    _same_run(fast, slow)


@pytest.mark.parametrize("name, t_end", [("parallelogram", 0.5), ("a02_nfourbar_10", 0.5), ("a02_nfourbar_2", 3.0)])
def test_both_paths_stop_at_the_same_singular_passage(name, t_end):
    """Lagrange cannot pass a flat position: the step logic searches the step whose pivots
    dipped (Brent's minimiser on the pivot ratio along the dense output, every evaluation a
    right-hand side) and reports the rank loss the Python path raises there, with samples kept
    up to it. Both paths search with the same points (same dense output, same codes)."""
    fast, slow = _pair(name, None, t_end)
    assert fast.status == slow.status == "failed"
    assert fast.failure[0] == slow.failure[0] == "rank loss"
    rf, rs = fast.stats["rank_loss"], slow.stats["rank_loss"]
    assert (rf["rank"], rf["rows"]) == (rs["rank"], rs["rows"]) and rf["rank"] < rf["rows"]
    assert rf["t"] == rs["t"] == fast.failure[1]
    assert fast.stats["steps"] == slow.stats["steps"]
    assert fast.stats["rhs_evals"] == slow.stats["rhs_evals"]
    assert len(fast.t) == len(slow.t) and fast.t[-1] < rf["t"]      # samples up to the singular time kept
    np.testing.assert_allclose(fast.q, slow.q, rtol=0, atol=1e-12)


@pytest.mark.parametrize("method", ["RK45", "DOP853"])
def test_the_step_logic_takes_scipys_steps(method):
    """RK45 and DOP853 are SciPy's methods (coefficients, error norms, step control, initial step):
    solve_ivp on the same right-hand side (a run's Evaluation) takes the same number of steps
    and evaluations and ends at the same state. The stage sums differ in summation order only
    (SciPy's np.dot), which moves the state by round-off: 1e-9 bounds it over these steps."""
    mech = pinclear.load("four_bar")
    form = formulations.get("lagrange")(mech)
    q, v, z = importlib.import_module("pinclear.simulate").initial_state(mech, form)
    form.use_rows(list(range(mech.m)))
    f = Evaluation(form)
    x0, rtol, t_end = f.pack(q, v, z), 1e-8, 1.0
    ref = solve_ivp(f, (0.0, t_end), x0, method=method, rtol=rtol, atol=rtol * 1e-2)
    tr = pinclear.simulate(mech, t_end, integrator=method, rtol=rtol, t_eval=[0.0, t_end])
    assert tr.stats["rhs_evals"] == ref.nfev
    assert tr.stats["steps"] == len(ref.t) - 1
    np.testing.assert_allclose(tr.q[-1], ref.y[:mech.nq, -1], rtol=0, atol=1e-9)


@pytest.mark.parametrize("integrator", sorted(set(stepping.INTEGRATORS) - {"RK4"}))
def test_every_integrator_runs_compiled_stages_and_conserves_energy(integrator):
    """Every integrator evaluates through the compiled stages and conserves the four-bar's energy
    within the bound its tolerance implies (pinclear.dynamics.energy); RK4 at a step whose error is far
    below the bound."""
    mech = pinclear.load("four_bar")
    tr = _quiet(pinclear.simulate, mech, 1.0, integrator=integrator, rtol=1e-8)
    assert tr.status == "success", tr.message
    assert tr.stats["loop"].startswith("compiled"), tr.stats["loop"]
    assert tr.summary()["energy_balance"]["ok"]


def test_rk4_takes_fixed_steps_of_fourth_order():
    """RK4 takes t_end / h steps of four evaluations each (plus f at the start) and converges with
    order 4: halving h divides the error at t_end by 2^4 = 16 (12-20: order 4 +- 0.3). The
    reference, DOP853 at rtol 1e-12, is ~1e-11 off, below the smaller RK4 error (8e-10)."""
    mech = pinclear.load("four_bar")
    ref = pinclear.simulate(mech, 0.5, integrator="DOP853", rtol=1e-12, t_eval=[0.0, 0.5])
    errs = []
    for h in (1e-3, 5e-4):
        tr = pinclear.simulate(mech, 0.5, integrator="RK4", h=h, t_eval=[0.0, 0.5])
        assert tr.status == "success" and tr.stats["steps"] == round(0.5 / h)
        assert tr.stats["rhs_evals"] == 4 * tr.stats["steps"] + 1
        errs.append(np.abs(tr.q[-1] - ref.q[-1]).max())
    assert 12 < errs[0] / errs[1] < 20


def test_progress_reports_every_accepted_step_in_order():
    """Accepted steps are reported after each compiled chunk, each one, in order."""
    mech = pinclear.load("four_bar")
    ts = []
    tr = pinclear.simulate(mech, 2.0, rtol=1e-9, progress=lambda t: ts.append(t) and False)
    assert tr.stats["loop"] == "compiled" and tr.stats["steps"] > 2 * CHUNK
    assert len(ts) == tr.stats["steps"] and np.all(np.diff(ts) > 0) and ts[-1] == 2.0


@pytest.mark.parametrize("name, clearances, t_end, rtol", [("four_bar", [], 5.0, 1e-10),
                                                     ("slider_crank_clearance", ["P"], 0.2, 1e-6)])
def test_longer_chunks_take_the_same_steps(monkeypatch, name, clearances, t_end, rtol):
    """Without a progress callback the compiled chunks grow (run.next_chunk); with one they stay
    at CHUNK steps. The steps, evaluations, events and every sample must be the same bits: the
    step state lives in the compiled Steps, which a chunk boundary does not touch."""
    from pinclear.dynamics.stepping import run as R
    calls = []
    advance = R.C.advance
    monkeypatch.setattr(R.C, "advance", lambda *a: calls.append(a[-1]) or advance(*a))
    mech = pinclear.load(name, clearances=clearances)
    grown = pinclear.simulate(mech, t_end, rtol=rtol)
    n_grown, sizes = len(calls), set(calls)
    calls.clear()
    fixed = pinclear.simulate(mech, t_end, rtol=rtol, progress=lambda t: False)
    assert set(calls) == {CHUNK} and max(sizes) > CHUNK and n_grown < len(calls)
    assert grown.stats["steps"] == fixed.stats["steps"] > 2 * CHUNK
    assert grown.stats["rhs_evals"] == fixed.stats["rhs_evals"] and grown.stats["events"] == fixed.stats["events"]
    for a, b in ((grown.t, fixed.t), (grown.q, fixed.q), (grown.v, fixed.v)):
        assert np.array_equal(a, b)


def test_a_progress_stop_request_interrupts_the_run():
    mech = pinclear.load("four_bar")
    tr = _quiet(pinclear.simulate, mech, 50.0, rtol=1e-9, progress=lambda t: t > 1.0)
    assert tr.status == "interrupted" and tr.failure[0] == "interrupted"
    assert 1.0 <= tr.t[-1] < 3.0      # samples every 0.1 s


@pytest.mark.parametrize("kw, why", [({"method": "pinocchio"}, "method 'pinocchio'"), ({"loop": "python"}, "asked")])
def test_runs_evaluated_in_python_say_why(kw, why):
    tr = pinclear.simulate(pinclear.load("clr_pendulum"), 0.05, **kw)      # spherical closures: Pinocchio's kind
    assert tr.stats["loop"].startswith("python: ") and why in tr.stats["loop"]


def _with_python_law(mech, fn):
    """mech with its first drive's law replaced by the Python function fn (no compiled form)."""
    from pinclear.model import timelaws

    d = mech.drives[0]
    return mech.replace(drives=[type(d)(d.name, d.joint, d.idx_q, d.idx_v, timelaws.Callable(fn))])


def test_a_python_drive_law_is_a_python_stage_of_a_compiled_run():
    """A drive law given as a Python function (no compiled form) runs as one Python stage; the
    rest stays compiled; the run takes the Python path's steps."""
    mech = pinclear.load("slider_crank_clearance", clearances=["P"])
    law = mech.drives[0].law
    mech = _with_python_law(mech, lambda t: law.eval(t))
    fast = pinclear.simulate(mech, 0.02, rtol=1e-6)
    slow = pinclear.simulate(mech, 0.02, rtol=1e-6, loop="python")
    assert fast.stats["loop"].startswith("compiled; python stages: python drive laws"), fast.stats["loop"]
    _same_run(fast, slow)


def test_loop_option_is_checked():
    with pytest.raises(pinclear.InputError, match="loop"):
        pinclear.simulate(pinclear.load("four_bar"), 0.05, loop="numba")


@pytest.mark.slow
@pytest.mark.skipif(not native.available(), reason=f"compiled passes unavailable: {native.reason}")
def test_without_the_extension_the_passes_run_in_python_with_the_same_steps():
    code = ("import pinclear; tr = pinclear.simulate(pinclear.load('nine_bar', clearances=['A']), 0.05, rtol=1e-6); "
            "print(tr.status, tr.stats['steps'], tr.stats['rhs_evals'], len(tr.stats['events']), repr(tr.q[-1].tolist())); "
            "print(tr.stats['loop'])")
    outs = []
    for env in ({}, {"PINCLEAR_NATIVE": "0"}):
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=900,
                             env={**os.environ, "PINCLEAR_QUIET_COMPILE": "1", **env})
        assert out.returncode == 0, out.stderr
        outs.append(out.stdout.splitlines())
    (run_c, loop_c), (run_p, loop_p) = outs
    assert run_c == run_p and run_c.startswith("success")
    assert loop_c == "compiled" and "Pinocchio's passes (Python bindings)" in loop_p


def _failed(mech, t_end, **kw):
    return _quiet(pinclear.simulate, mech, t_end, **kw)


def test_failures_are_data(tmp_path):
    """Trajectory.failure = (kind, t, detail) for each way a run ends early, saved and loaded
    with the run; the atlas reads the kind instead of parsing the message."""
    four = pinclear.load("four_bar")
    rank = _failed(pinclear.load("parallelogram"), 0.5)
    # 500 s at rtol 1e-11 needs about 4.5 CPU s on the 2-core machine (50 s took 0.45 s): the
    # 0.05 s budget ends it on a machine 90x faster too (the budget bounds the test's cost)
    budget = _failed(four, 500.0, rtol=1e-11, max_cpu=0.05)
    stall = _failed(four, 10.0, rtol=1e-11, min_mean_step=1.0)
    ok = pinclear.simulate(four, 0.05)
    assert ok.failure is None and ok.summary()["failure"] is None
    for tr, kind in ((rank, "rank loss"), (budget, "budget"), (stall, "step-size collapse")):
        assert tr.status == "failed" and tr.failure[0] == kind, (tr.failure, tr.message)
        assert tr.failure[0] in FAILURE_KINDS and tr.failure[2] in tr.message
        assert tr.t[-1] <= tr.failure[1] + 1e-12
        tr.save(tmp_path / "run.npz")
        back = Trajectory.load(tmp_path / "run.npz")
        assert back.failure == tr.failure


def test_a_saved_failure_record_is_checked_as_data(tmp_path):
    import json

    tr = _failed(pinclear.load("parallelogram"), 0.5)
    tr.save(tmp_path / "run.npz")
    data = dict(np.load(tmp_path / "run.npz", allow_pickle=False))
    meta = json.loads(str(data["meta"]))
    meta["failure"]["kind"] = "cosmic ray"
    data["meta"] = np.array(json.dumps(meta))
    np.savez(tmp_path / "bad.npz", **data)
    with pytest.raises(pinclear.InputError, match="failure.kind.*cosmic ray"):
        Trajectory.load(tmp_path / "bad.npz")


def test_a_function_that_raises_ends_the_run_as_an_exception_failure():
    """A trusted Python stage (a drive law) raising inside a compiled chunk: the run fails with
    kind 'exception' naming the error, samples kept up to the last completed chunk."""
    mech = pinclear.load("slider_crank_clearance")
    law = mech.drives[0].law

    def failing(t):
        if t > 0.005:
            raise ValueError("the encoder lost its zero")
        return law.eval(t)
    tr = _failed(_with_python_law(mech, failing), 0.01, rtol=1e-6)
    assert tr.status == "failed" and tr.failure[0] == "exception"
    assert "encoder lost its zero" in tr.message and 0.0 < tr.t[-1] <= 0.005 + 1e-12
