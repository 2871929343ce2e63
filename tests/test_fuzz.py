"""Property-based fuzzing (issue 11): mutated mechanism files and random command lines end
either in a result or in a PinclearError with a one-line message; never in another
exception, never in a hang. Each case runs under a wall-clock alarm."""
from __future__ import annotations

import contextlib
import copy
import io
import math
import signal
from pathlib import Path

import numpy as np
import pytest
import yaml

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import pinclear  # noqa: E402
from pinclear import cli  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
BASE = yaml.safe_load((ROOT / "urdf" / "four_bar.yaml").read_text())
#: seconds a single case may take before it counts as a hang
CASE_LIMIT = 60


@contextlib.contextmanager
def alarm(seconds):
    def boom(signum, frame):
        raise TimeoutError(f"case exceeded {seconds} s")
    old = signal.signal(signal.SIGALRM, boom)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def _paths(obj, prefix=()):
    """Every path to a value inside a nested dict/list."""
    yield prefix
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _paths(v, prefix + (i,))


PATHS = [p for p in _paths(BASE) if p]

junk = st.recursive(
    st.none() | st.booleans() | st.integers(-10**6, 10**6)
    | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=12)
    | st.sampled_from(["pydoc:pipepager", "os:system", "pinclear.nope:f", "../x.urdf", "$limbs", "1e400",
                       "crank", "rocker", "spherical", "world"]),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=6), children, max_size=3),
    max_leaves=8)


def _set(doc, path, value):
    node = doc
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value


def _one_line(exc):
    text = str(exc)
    return text and "\n" not in text.strip() and "Traceback" not in text


@settings(max_examples=300, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)
@given(data=st.data())
def test_mutated_sidecar_loads_or_fails_cleanly(tmp_path_factory, data):
    doc = copy.deepcopy(BASE)
    for _ in range(data.draw(st.integers(1, 3))):
        path = data.draw(st.sampled_from(PATHS))
        action = data.draw(st.sampled_from(["replace", "delete", "add"]))
        try:
            if action == "replace":
                _set(doc, path, data.draw(junk))
            elif action == "delete":
                node = doc
                for k in path[:-1]:
                    node = node[k]
                del node[path[-1]]
            else:
                node = doc
                for k in path[:-1]:
                    node = node[k]
                if isinstance(node, dict):
                    node[data.draw(st.text(min_size=1, max_size=8))] = data.draw(junk)
        except (KeyError, IndexError, TypeError):
            pass                                  # the path vanished under an earlier mutation
    folder = tmp_path_factory.mktemp("fz")
    (folder / "four_bar.urdf").write_text((ROOT / "urdf" / "four_bar.urdf").read_text())
    path = folder / "m.yaml"
    try:
        path.write_text(yaml.safe_dump(doc, allow_unicode=True))
    except (yaml.YAMLError, ValueError):
        return
    with alarm(CASE_LIMIT):
        try:
            mech = pinclear.load(path)
            traj = pinclear.simulate(mech, 0.05, rtol=1e-6, max_cpu=2.0)
            assert traj.status in ("success", "failed")
            if traj.status == "failed":
                assert traj.message
        except pinclear.PinclearError as exc:
            assert _one_line(exc), repr(exc)
    assert not (folder / "pwned").exists()


flags = st.sampled_from(["--t-end", "--rtol", "--atol", "--h", "--max-step", "--dt-out", "--method", "--integrator",
                         "--alpha", "--beta", "--set", "--option", "--clearance", "--max-cpu", "--checkpoint-every",
                         "--out", "--resume", "--bogus"])
values = st.one_of(st.sampled_from(["0", "-1", "1e-300", "1e300", "nan", "inf", "-inf", "0.05", "1e-6", "RK45",
                                    "RK4", "Radau", "proximal", "pinocchio", "lagrange", "x", "", "S2", "S2.mu=nan",
                                    "limbs=2", "A.clearance=1e-3", "=", "a=b=c"]),
                   st.floats(allow_nan=True, allow_infinity=True).map(repr), st.text(max_size=6))


@settings(max_examples=250, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)
@given(cmd=st.sampled_from(["simulate", "simulate", "info"]),
       file=st.sampled_from(["four_bar", "nine_bar", "four_ups_upu", "missing.yaml", "urdf/four_bar.urdf"]),
       args=st.lists(st.tuples(flags, values), max_size=4))
def test_random_command_lines_give_a_status(tmp_path_factory, cmd, file, args):
    out = tmp_path_factory.mktemp("cli")
    argv = [cmd] + (["rhs"] if cmd == "bench" else []) + [file]
    for flag, val in args:
        argv += [flag, val]
    if cmd == "simulate":
        argv += ["--out", str(out / "o"), "--max-cpu", "1", "--progress", "off"]
        if "--t-end" not in argv:
            argv += ["--t-end", "0.02"]
    if cmd == "bench":
        argv += ["--methods", "lagrange"]
    err = io.StringIO()
    with alarm(CASE_LIMIT), contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = cli.main(argv)
        except SystemExit as exc:            # --help and friends
            code = exc.code
    text = err.getvalue().strip()
    assert code in (0, 1, 2, 130), (argv, code, text)
    assert "Traceback" not in text, (argv, text)
    if code == 2:
        lines = [ln for ln in text.splitlines() if ln.startswith("pinclear: error:")]
        assert len(lines) == 1, (argv, text)


def test_fuzz_cases_are_bounded():
    """The alarm really fires: a case that hangs is reported, not waited for."""
    with pytest.raises(TimeoutError):
        with alarm(1):
            while True:
                math.sqrt(2.0)
