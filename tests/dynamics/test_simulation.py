"""The Simulation object: a run's options checked once, before anything is computed, with one
InputError naming the argument; the one atol rule; the schema version of a saved run."""
from __future__ import annotations

import json
import math
import time

import numpy as np
import pytest

import pinclear
from pinclear.dynamics import simulation
from pinclear.dynamics.simulate import Restarts
from tests.helpers import run_cli


@pytest.fixture(scope="module")
def four_bar():
    return pinclear.load("four_bar")


#: (options, the argument the error must name): each was accepted, ignored or ended in a foreign
#: exception (TypeError, ValueError from NumPy, AttributeError) before the options were checked once
BAD = [({"max_cpu": float("nan")}, "max_cpu"),
       ({"max_cpu": -1.0}, "max_cpu"),
       ({"checkpoint_every": -1}, "checkpoint_every"),
       ({"checkpoint_every": float("inf")}, "checkpoint_every"),
       ({"integrator": "RK4", "h": 1e-3, "fixed_step_tol": -1}, "fixed_step_tol"),
       ({"fixed_step_tol": float("nan")}, "fixed_step_tol"),
       ({"atol": "small"}, "atol"),
       ({"atol": [1e-8, 1e-8]}, "atol"),
       ({"atol": [[1e-8]]}, "atol"),
       ({"progress": 3}, "progress"),
       ({"checkpoint": "file.npz"}, "checkpoint"),
       ({"rtol": "1e-8"}, "rtol"),
       ({"rtol": float("nan")}, "rtol"),
       ({"h": "1e-3", "integrator": "RK4"}, "h"),
       ({"max_step": float("nan")}, "max_step"),
       ({"first_step": True}, "first_step"),
       ({"dt_out": "0.01"}, "dt_out"),
       ({"t0": "0"}, "t0"),
       ({"t_eval": ["a", "b"]}, "t_eval"),
       ({"min_mean_step": float("nan")}, "min_mean_step"),
       ({"method": ["lagrange"]}, None)]


@pytest.mark.parametrize("options, key", BAD, ids=[f"{k or 'method'}-{i}" for i, (_, k) in enumerate(BAD)])
def test_bad_option_is_one_input_error_naming_it(four_bar, options, key):
    t = time.process_time()
    with pytest.raises(pinclear.InputError) as err:
        pinclear.simulate(four_bar, 0.05, **options)
    text = str(err.value)
    assert "\n" not in text
    if key is not None:
        assert err.value.key == key and text.startswith(f"{key}: ")
    else:
        assert "unknown method" in text and "lagrange" in text
    # refused before anything ran (a nan budget used to be ignored and the run went on)
    assert time.process_time() - t < 2.0


@pytest.mark.parametrize("t_end", ["1", np.array([0.05, 0.1]), None, float("nan"), -1.0, True])
def test_bad_t_end_is_one_input_error(four_bar, t_end):
    with pytest.raises(pinclear.InputError) as err:
        pinclear.simulate(four_bar, t_end)
    assert err.value.key == "t_end" and repr(t_end)[:10] in str(err.value)


def test_simulate_none_names_the_mechanism():
    with pytest.raises(pinclear.InputError) as err:
        pinclear.simulate(None, 1.0)
    assert err.value.key == "mech" and "NoneType" in str(err.value)


def test_atol_of_the_state_length_is_accepted_and_scalar_0d_t_end(four_bar):
    """A per-component atol of the state's length runs; so does a 0-d array t_end (a number)."""
    sim = simulation.Simulation(four_bar, np.array(0.05))
    n = len(sim.form.ws.x)
    tr = pinclear.simulate(four_bar, np.array(0.05), atol=np.full(n, 1e-10))
    assert tr.status == "success" and tr.t[-1] == 0.05
    assert tr.meta["atol"] == [1e-10] * n


def test_zero_means_every_chunk_or_no_check(four_bar):
    """checkpoint_every=0: a checkpoint after every chunk; fixed_step_tol=0: no check (as the
    command line's --fixed-step-tol 0); min_mean_step=0: no stall test."""
    sim = simulation.Simulation(four_bar, 0.05, checkpoint=[].append, checkpoint_every=0.0, min_mean_step=0.0,
                                integrator="RK4", h=1e-3, fixed_step_tol=0)
    assert sim.checkpoint_every == 0.0 and sim.fixed_step_tol is None and sim.h_stall(0.0, 0.05) == 0.0


def test_the_one_atol_rule():
    assert simulation.default_atol(1e-6) == pytest.approx(1e-8, rel=1e-15)
    assert simulation.default_atol(1e-6, 3e-7) == 3e-7
    assert simulation.default_atol(None) is None


def test_saved_run_and_summary_carry_the_schema(four_bar, tmp_path, capsys):
    tr = pinclear.simulate(four_bar, 0.02)
    assert tr.meta["schema_version"] == simulation.SUMMARY_SCHEMA and isinstance(simulation.SUMMARY_SCHEMA, int)
    tr.save(tmp_path / "run.npz")
    back = pinclear.Trajectory.load(tmp_path / "run.npz")
    assert back.meta["schema_version"] == simulation.SUMMARY_SCHEMA
    code, _, _ = run_cli(["simulate", "four_bar", "--t-end", "0.02", "--out", str(tmp_path / "out")], capsys)
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert code == 0 and summary["schema_version"] == simulation.SUMMARY_SCHEMA
    # the default atol recorded is the rule's, from the default rtol
    assert math.isclose(tr.meta["atol"], simulation.default_atol(simulation.RTOL_DEFAULT), rel_tol=0, abs_tol=0)


def test_restarts_checks_its_options_once(four_bar):
    with pytest.raises(pinclear.InputError) as err:
        Restarts(four_bar, max_cpu=float("nan"))
    assert err.value.key == "max_cpu"
    with pytest.raises(pinclear.InputError) as err:
        Restarts(four_bar, method="projection", rtol=2.0)
    assert err.value.key == "rtol"
    r = Restarts(four_bar)
    with pytest.raises(pinclear.InputError) as err:
        r.run(0.0, four_bar.q0, four_bar.v0, np.zeros(four_bar.nz), "0.1")
    assert err.value.key == "t_end"
