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
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300,
                         env={**os.environ, "PINCLEAR_NATIVE": "0"})
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("success python: ") and "PINCLEAR_NATIVE" in out.stdout
