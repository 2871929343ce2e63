"""The compiled integration loop (pinclear.fastloop) against the Python loop it replaces.

Both take SciPy's RK45 steps with the same stage arithmetic on the same kernels, so a run must
take the same steps, meet the same events and reach the same step states; only output samples
are interpolated with another summation order (SciPy's dense output through a BLAS product here,
a compiled loop there), a rounding difference of a few eps * (|y| + h |f|) that never feeds
back into the run. 1e-12 on states of order one bounds it with a wide margin."""
import os
import subprocess
import sys
import warnings

import numpy as np
import pytest

import pinclear
from pinclear import fastloop, native

pytestmark = pytest.mark.skipif(not native.available(), reason=f"compiled passes unavailable: {native.reason}")

# scene, clearances, simulated time: ideal closures, seed drives with analytic inverse
# kinematics, dropped redundant rows, and the three clearance types with their events
CASES = [("four_bar", None, 1.0), ("nine_bar", None, 0.5), ("four_ups_upu", None, 0.5),
         ("three_upru_up", None, 0.5), ("four_bar_revolute", None, 1.0),
         ("slider_crank_clearance", ["P"], 0.15), ("four_ups_upu", ["S2"], 0.3), ("clr_slider", ["P"], 0.1),
         ("clr_planar_pendulum", ["A"], 0.2)]


def _pair(name, clr, t_end, **kw):
    mech = pinclear.load(name, clearances=clr)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fast = pinclear.simulate(mech, t_end, rtol=1e-6, dt_out=t_end / 50, **kw)
        slow = pinclear.simulate(mech, t_end, rtol=1e-6, dt_out=t_end / 50, loop="python", **kw)
    return fast, slow


@pytest.mark.parametrize("name, clr, t_end", CASES, ids=[c[0] + ("+" + c[1][0] if c[1] else "") for c in CASES])
def test_compiled_loop_takes_the_python_loops_steps(name, clr, t_end):
    fast, slow = _pair(name, clr, t_end)
    assert fast.stats["loop"] == "compiled", fast.stats["loop"]
    assert slow.stats["loop"].startswith("python")
    assert fast.status == slow.status == "success"
    assert fast.stats["steps"] == slow.stats["steps"]
    assert fast.stats["rhs_evals"] == slow.stats["rhs_evals"]
    ev_f, ev_s = fast.stats["events"], slow.stats["events"]
    assert [e["event"] for e in ev_f] == [e["event"] for e in ev_s]
    assert [e["t"] for e in ev_f] == [e["t"] for e in ev_s]        # located on identical steps
    if clr:
        assert len(ev_f) > 0                                         # the case meets its contacts
    np.testing.assert_allclose(fast.q, slow.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(fast.v, slow.v, rtol=0, atol=1e-12 * max(1.0, np.abs(slow.v).max()))
    # outputs are evaluated from the samples: their ~1e-16 difference carried through one
    # evaluation (the KKT solve); 1e-9 of the scale admits an amplification up to 1e7
    np.testing.assert_allclose(fast.a, slow.a, rtol=0, atol=1e-9 * max(1.0, np.abs(slow.a).max()))
    for k in slow.lam:
        np.testing.assert_allclose(fast.lam[k], slow.lam[k], rtol=0, atol=1e-9 * max(1.0, np.abs(slow.lam[k]).max()))


@pytest.mark.parametrize("name, t_end", [("parallelogram", 0.5), ("a02_nfourbar_10", 0.5), ("a02_nfourbar_2", 3.0)])
def test_both_loops_stop_at_the_same_singular_passage(name, t_end):
    """Lagrange cannot pass a flat position: both loops search the step that dips for the rank
    loss with the same Brent search (compiled there, Python here) and report it at the same
    time, with the same rank and the same evaluations counted (the search's included). The
    search points differ only through the dense output's rounding (1e-16) and its tolerance is
    1e-13 s, so 1e-9 s bounds the difference of the reported times."""
    fast, slow = _pair(name, None, t_end)
    assert fast.stats["loop"] == "compiled"
    assert fast.status == slow.status == "failed"
    rf, rs = fast.stats["rank_loss"], slow.stats["rank_loss"]
    assert (rf["rank"], rf["rows"]) == (rs["rank"], rs["rows"]) and rf["rank"] < rf["rows"]
    assert abs(rf["t"] - rs["t"]) < 1e-9
    assert fast.stats["steps"] == slow.stats["steps"]
    assert fast.stats["rhs_evals"] == slow.stats["rhs_evals"]
    assert len(fast.t) == len(slow.t) and fast.t[-1] < rf["t"]      # samples up to the singular time kept
    np.testing.assert_allclose(fast.q, slow.q, rtol=0, atol=1e-12)


def test_the_search_for_a_singular_passage_counts_its_evaluations(monkeypatch):
    """The search's evaluations are right-hand sides like the steps' (uncounted, a failing
    run's search cost looked like a cost per step evaluation in the bench). On the Python loop
    the count grows by exactly the formulation's evaluations inside the search; the compiled
    loop's search counts as many."""
    import importlib

    sim = importlib.import_module("pinclear.simulate")
    real = sim._locate_singular_passage
    seen = []

    def counted(form, sysf, dense, t_old, t_new, fast=None, solver=None):
        calls = [0]
        inner = form.accelerations

        def acc(*a):
            calls[0] += 1
            return inner(*a)
        form.accelerations = acc
        before = sysf.nfev + (fast.evals if fast is not None else 0)
        try:
            real(form, sysf, dense, t_old, t_new, fast, solver)
        finally:
            del form.accelerations
            seen.append((sysf.nfev + (fast.evals if fast is not None else 0) - before, calls[0], fast is not None))
    monkeypatch.setattr(sim, "_locate_singular_passage", counted)
    _pair("parallelogram", None, 0.5)
    (n_fast, py_calls_fast, f1), (n_slow, py_calls_slow, f2) = seen
    assert f1 and not f2
    assert n_slow == py_calls_slow >= 2          # Brent evaluates at least two points
    assert n_fast == n_slow
    assert py_calls_fast == 1                    # Python only re-takes the rank loss to report it


def test_progress_reports_every_accepted_step_in_order():
    """On the compiled loop the steps of a chunk are reported after it, each one, in order."""
    mech = pinclear.load("four_bar")
    ts = []
    tr = pinclear.simulate(mech, 2.0, rtol=1e-9, progress=lambda t: ts.append(t) and False)
    assert tr.stats["loop"] == "compiled" and tr.stats["steps"] > 2 * fastloop.CHUNK
    assert len(ts) == tr.stats["steps"] and np.all(np.diff(ts) > 0) and ts[-1] == 2.0


def test_a_progress_stop_request_interrupts_the_compiled_loop():
    mech = pinclear.load("four_bar")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tr = pinclear.simulate(mech, 50.0, rtol=1e-9, progress=lambda t: t > 1.0)
    assert tr.status == "interrupted" and 1.0 <= tr.t[-1] < 3.0      # samples every 0.1 s


@pytest.mark.parametrize("kw, why", [({"integrator": "DOP853"}, "integrator"), ({"method": "proximal"}, "method"),
                                     ({"loop": "python"}, "asked")])
def test_runs_the_compiled_loop_cannot_take_say_why(kw, why):
    tr = pinclear.simulate(pinclear.load("four_bar"), 0.05, **kw)
    assert tr.stats["loop"].startswith("python: ") and why in tr.stats["loop"]


def test_loop_option_is_checked():
    with pytest.raises(pinclear.InputError, match="loop"):
        pinclear.simulate(pinclear.load("four_bar"), 0.05, loop="numba")


def test_without_the_extension_runs_take_the_python_loop():
    code = ("import pinclear; tr = pinclear.simulate(pinclear.load('four_bar'), 0.05); "
            "print(tr.status, tr.stats['loop'])")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=900,
                         env={**os.environ, "PINCLEAR_NATIVE": "0"})
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("success python: ") and "PINCLEAR_NATIVE" in out.stdout
