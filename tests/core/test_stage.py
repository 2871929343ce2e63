"""Stages (pinclear.core.stage): a kernel bound to its buffers, called through a C address
from compiled code and from Python. A stage must run the kernel on the very memory it was given
(a wrong address, shape or memory order would give other numbers or garbage) and return its code."""
import sys
from pathlib import Path

import numpy as np
import pytest

import pinclear
from pinclear.core.call import ERROR, OK, run_stages
from pinclear.core.jit import cache_dir
from pinclear.core.stage import T, bind, python_stage
from tests.stage_kernels import Pair, mix


def _args(rng):
    p = Pair(rng.standard_normal(5), np.asfortranarray(rng.standard_normal((5, 3))), float(rng.uniform(1, 2)), 7)
    x = np.asfortranarray(rng.standard_normal((2, 3)))       # column-major, as Pinocchio's M and J
    return p, x


def test_a_stage_runs_its_kernel_on_its_buffers():
    rng = np.random.default_rng(4)
    p, x = _args(rng)
    out_direct, out_stage = np.zeros(5), np.zeros(5)
    stage = bind(mix, (p, x, T, out_stage, 0.25), code=True)
    for t in (0.0, 1.5, -2.0):
        r_direct = mix(p, x, t, out_direct, 0.25)
        out_stage[:] = np.nan
        assert stage(t) == r_direct
        assert np.array_equal(out_stage, out_direct)
        # the stage reads the buffers at call time: a changed input changes its result
        p.a[0] += 1.0
        x[0, 1] -= 0.5


def test_a_stage_without_a_code_returns_ok_and_stages_run_in_order():
    rng = np.random.default_rng(5)
    p, x = _args(rng)
    out1, out2 = np.zeros(5), np.zeros(5)
    s1 = bind(mix, (p, x, T, out1, 0.0))
    s2 = bind(mix, (p, x, T, out2, 1.0), code=True)
    assert s1(0.5) == OK
    table = np.array([[s1.fn, s1.ctx], [s2.fn, s2.ctx]], dtype=np.int64)
    code = run_stages(table, 0.5)
    assert code == out2.sum() and np.allclose(out2 - out1, 1.0)


def test_what_cannot_be_bound_is_refused_with_its_place():
    rng = np.random.default_rng(6)
    p, x = _args(rng)
    with pytest.raises(TypeError, match="argument 1.*contiguous"):
        bind(mix, (p, np.zeros((4, 6))[:, ::2], T, np.zeros(5), 0.0))
    with pytest.raises(TypeError, match="argument 4.*bool"):
        bind(mix, (p, x, T, np.zeros(5), True))
    with pytest.raises(TypeError, match=r"argument 0\.a"):
        bind(mix, (Pair(np.zeros(5, dtype=np.float32), p.M, 1.0, 1), x, T, np.zeros(5), 0.0))


def test_a_python_stage_passes_its_exception_to_the_run():
    errors = []
    s = python_stage(lambda t: 2.0 * t if t < 1 else 1 / 0, errors)
    assert s(0.25) == 0.5 and not errors
    assert s(2.0) == ERROR and isinstance(errors[0], ZeroDivisionError)
    table = np.array([[s.fn, s.ctx]], dtype=np.int64)
    assert run_stages(table, 3.0) == ERROR and len(errors) == 2


def test_generated_wrappers_live_in_the_user_cache_folder():
    rng = np.random.default_rng(7)
    p, x = _args(rng)
    bind(mix, (p, x, T, np.zeros(5), 0.0))
    files = [Path(m.__file__).resolve() for k, m in sys.modules.items() if k.startswith("pinclear_stage_")]
    assert files and all(cache_dir().resolve() in f.parents for f in files)
    assert not any(Path(pinclear.__file__).resolve().parent in f.parents for f in files)
