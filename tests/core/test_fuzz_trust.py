"""Property-based fuzzing of the trust gate and of what a results folder holds (issue 23).

* ``module:function`` names built from attribute chains of every pinclear module (walked through
  dir() a few levels, through modules and classes): an untrusted file resolves only the offered
  functions; every other name is refused before anything is called (process-spawning functions
  are replaced by tripwires while a case runs).
* Tampered checkpoints (arrays, metadata, bytes) resumed with simulate(), tampered saved runs
  loaded with Trajectory.load(), junk run.json files resumed on the command line: a result or a
  PinclearError with a one-line message, never another exception, never a crash (a compiled loop
  writing out of bounds would abort the test process).

550 generated cases in all (300 + 150 + 60 + 40), derandomized, each under a wall-clock alarm.
"""
from __future__ import annotations

import contextlib
import importlib
import io
import json
import os
import pkgutil
import shutil
import subprocess
import types
import warnings
from pathlib import Path

import numpy as np
import pytest
import yaml

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, event, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import pinclear  # noqa: E402
from pinclear.cli import commands as cli  # noqa: E402
from pinclear.core.trust import OFFERED, resolve_function  # noqa: E402
from pinclear.dynamics.trajectory import Checkpoint  # noqa: E402
from tests.io.test_fuzz import CASE_LIMIT, alarm  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
FOUR = yaml.safe_load((ROOT / "urdf" / "four_bar.yaml").read_text())
SETTINGS = dict(deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)


# ------------------------------------------------------------------ attribute chains
def _pinclear_modules():
    mods = {"pinclear": pinclear}
    for info in pkgutil.walk_packages(pinclear.__path__, "pinclear."):
        try:
            mods[info.name] = importlib.import_module(info.name)
        except Exception:             # an optional dependency missing: its names cannot resolve either
            continue
    return mods


def _chains(root, depth):
    """Attribute paths from a module: every name, and through modules and classes up to
    ``depth`` names long (breadth first, so each module or class is expanded at its shortest
    path: pinclear.cli.commands:os.spawnvp, not only pinclear.cli.commands:argparse._os.spawnvp)."""
    import builtins

    seen, queue = {id(root)}, [(root, ())]
    while queue:
        obj, prefix = queue.pop(0)
        for name in dir(obj):
            if name.startswith("__") and name not in ("__builtins__", "__loader__", "__class__"):
                continue
            path = prefix + (name,)
            yield ".".join(path)
            if len(path) >= depth:
                continue
            try:
                child = getattr(obj, name)
            except Exception:
                continue
            if isinstance(child, dict) and name == "__builtins__":
                child = builtins
            if isinstance(child, (types.ModuleType, type)) and id(child) not in seen:
                seen.add(id(child))
                queue.append((child, path))


MODULES = _pinclear_modules()
CHAINS = sorted({f"{m}:{c}" for m, mod in MODULES.items() for c in _chains(mod, 3)})
#: the audit's routes, whatever the walk finds
KNOWN = ["pinclear.model.timelaws:os.spawnv", "pinclear.cli.commands:os.spawnvp", "pinclear.core.stage:os.spawnve",
         "pinclear.io.sidecar:re.enum.bltns.exec", "pinclear.cli:main", "pinclear.io.sidecar:yaml.load",
         "pinclear.dynamics.trajectory:os.system", "pinclear.analysis.sweeps:subprocess.run", "pinclear.cli.commands:sys.exit",
         "pinclear.model.timelaws:np.load", "pinclear.io.sidecar:copy.copyreg.__builtins__.eval"]


def test_the_walk_reaches_the_dangerous_names():
    assert len(MODULES) > 40 and len(CHAINS) > 10_000
    for spec in ("pinclear.core.trust:os.spawnv", "pinclear.cli.commands:os.spawnvp", "pinclear.cli:main",
                 "pinclear.cli.commands:os.system", "pinclear.io.sidecar:re.enum"):
        assert spec in CHAINS, spec


@contextlib.contextmanager
def tripwires():
    """Replace the functions that start programs or delete trees by ones that record a call."""
    calls = []

    def trip(name):
        def f(*a, **k):
            calls.append(name)
            raise AssertionError(f"{name} was called")
        return f
    targets = [(os, n) for n in dir(os) if n.startswith(("spawn", "exec", "posix_spawn", "fork", "system",
                                                         "popen", "kill"))]
    targets += [(subprocess, "Popen"), (subprocess, "run"), (subprocess, "call"), (shutil, "rmtree")]
    saved = [(m, n, getattr(m, n)) for m, n in targets if hasattr(m, n)]
    for m, n, _ in saved:
        setattr(m, n, trip(n))
    try:
        yield calls
    finally:
        for m, n, f in saved:
            setattr(m, n, f)


ROUTES = {
    "drive law": lambda spec: dict(FOUR, drives=[{"name": "d", "joint": "crank_joint", "law": {
        "type": "python", "function": spec, "args": {"file": "/bin/sh", "args": ["sh", "-c", "true"]}}}]),
    "joint_force": lambda spec: dict(FOUR, forces=[{"name": "f", "type": "joint_force", "joint": "crank_joint",
                                                    "law": {"type": "python", "function": spec}}]),
    "platform motion": lambda spec: dict(FOUR, platform={"frame": "coupler", "motion": {"function": spec}}),
    "hook": lambda spec: dict(FOUR, hook=spec),
}

spec_strategy = (st.sampled_from(CHAINS) | st.sampled_from(KNOWN) | st.sampled_from(sorted(OFFERED))
                 | st.builds(lambda m, a: f"{m}:{a}", st.sampled_from(sorted(MODULES)),
                             st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,8}(\.[A-Za-z_][A-Za-z0-9_]{0,8}){0,3}",
                                           fullmatch=True)))


@pytest.mark.slow
@settings(max_examples=300, **SETTINGS)
@given(spec=spec_strategy, route=st.sampled_from(sorted(ROUTES)))
def test_untrusted_names_resolve_only_to_offered_functions(tmp_path_factory, spec, route):
    folder = tmp_path_factory.mktemp("gate")
    (folder / "four_bar.urdf").write_text((ROOT / "urdf" / "four_bar.urdf").read_text())
    path = folder / "m.yaml"
    path.write_text(yaml.safe_dump(ROUTES[route](spec)))
    with alarm(CASE_LIMIT), tripwires() as calls:
        try:
            obj = resolve_function(spec, str(path), "k", trust=False)
            assert spec in OFFERED and isinstance(obj, types.FunctionType), spec
        except pinclear.ModelFileError as exc:
            assert spec not in OFFERED and "\n" not in str(exc), spec
        try:
            mech = pinclear.load(path, trust=False)
            # loaded: the name was offered (or is never resolved on this route)
            assert spec in OFFERED, spec
            del mech
        except pinclear.PinclearError as exc:
            assert "\n" not in str(exc)
    assert calls == [], (spec, calls)


# ------------------------------------------------------------------ tampered checkpoints
T_END, RTOL = 5.0, 1e-8


@pytest.fixture(scope="module")
def mech():
    return pinclear.load("four_bar")


@pytest.fixture(scope="module")
def checkpoint_file(mech, tmp_path_factory):
    saved = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tr = pinclear.simulate(mech, T_END, rtol=RTOL, checkpoint=saved.append, checkpoint_every=0.0)
    assert tr.status == "success" and tr.stats["loop"] == "compiled" and len(saved) > 1
    p = tmp_path_factory.mktemp("ck") / "checkpoint.npz"
    saved[len(saved) // 2].save(p)
    # the untampered checkpoint resumes (so the fuzz below starts from a working file)
    assert pinclear.simulate(mech, T_END, rtol=RTOL, resume=Checkpoint.load(p)).status == "success"
    return p


junk = st.recursive(st.none() | st.booleans() | st.integers(-10**12, 10**12)
                    | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=8),
                    lambda c: st.lists(c, max_size=3) | st.dictionaries(st.text(max_size=5), c, max_size=3),
                    max_leaves=6)


def _array_mutation(draw, a):
    kind = draw(st.sampled_from(["shorter", "longer", "nan", "inf", "scale", "reverse", "reshape", "text",
                                 "empty", "huge"]))
    a = np.array(a, float)
    if kind == "shorter":
        return a[..., :-1] if a.size else a
    if kind == "longer":
        return np.concatenate([a, a[..., :1]], axis=-1) if a.size else np.zeros(3)
    if kind in ("nan", "inf", "huge") and a.size:
        flat = a.ravel().copy()
        flat[draw(st.integers(0, flat.size - 1))] = {"nan": np.nan, "inf": -np.inf, "huge": 1e300}[kind]
        return flat.reshape(a.shape)
    if kind == "scale":
        return a * draw(st.sampled_from([0.0, -1.0, 1.0 + 1e-9, 1.001, 1e6]))
    if kind == "reverse":
        return a[::-1].copy()
    if kind == "reshape":
        return a.reshape(-1, 1) if a.ndim == 1 else a.ravel()
    if kind == "text":
        return np.array(["x"] * max(a.size, 1))
    return np.zeros((0,) + a.shape[1:])


def _tamper(draw, src, dst):
    with np.load(src, allow_pickle=False) as d:
        arrays = {k: d[k] for k in d.files}
    meta = json.loads(str(arrays["meta"]))
    where = draw(st.sampled_from(["array", "array", "meta", "identity", "stats", "bytes"]))
    if where == "array":
        k = draw(st.sampled_from([k for k in arrays if k != "meta"]))
        arrays[k] = _array_mutation(draw, arrays[k])
    elif where == "meta":
        meta[draw(st.sampled_from(["t0", "t", "h_next", "stats", "identity"]))] = draw(junk)
    elif where == "identity":
        meta["identity"][draw(st.sampled_from(sorted(meta["identity"])))] = draw(junk)
    elif where == "stats":
        meta["stats"][draw(st.sampled_from(sorted(meta["stats"]) + ["events"]))] = draw(junk)
    arrays["meta"] = np.array(json.dumps(meta, allow_nan=True))
    np.savez(dst, **arrays)
    if where == "bytes":
        raw = bytearray(Path(src).read_bytes())
        if draw(st.booleans()):
            raw = raw[:draw(st.integers(0, len(raw) - 1))]
        else:
            i = draw(st.integers(0, len(raw) - 1))
            raw[i] ^= draw(st.integers(1, 255))
        Path(dst).write_bytes(bytes(raw))
    return dst


@pytest.mark.slow
@settings(max_examples=150, **SETTINGS)
@given(data=st.data())
def test_tampered_checkpoints_resume_or_fail_cleanly(tmp_path_factory, mech, checkpoint_file, data):
    p = _tamper(data.draw, checkpoint_file, tmp_path_factory.mktemp("t") / "checkpoint.npz")
    with alarm(CASE_LIMIT), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            tr = pinclear.simulate(mech, T_END, rtol=RTOL, max_cpu=5.0, resume=Checkpoint.load(p))
            assert tr.status in ("success", "failed") and np.all(np.isfinite(tr.t))
            event(f"resumed ({tr.stats['loop'].split(':')[0]} loop): {tr.status}")
        except pinclear.PinclearError as exc:
            assert "\n" not in str(exc) and str(exc)
            event("refused")


# ------------------------------------------------------------------ tampered saved runs
@pytest.fixture(scope="module")
def run_file(mech, tmp_path_factory):
    p = tmp_path_factory.mktemp("run") / "trajectory.npz"
    pinclear.simulate(mech, 0.2, rtol=RTOL).save(p)
    return p


@settings(max_examples=60, **SETTINGS)
@given(data=st.data())
def test_tampered_runs_load_or_fail_cleanly(tmp_path_factory, mech, run_file, data):
    with np.load(run_file, allow_pickle=False) as d:
        arrays = {k: d[k] for k in d.files}
    meta = json.loads(str(arrays["meta"]))
    if data.draw(st.booleans()):
        k = data.draw(st.sampled_from([k for k in arrays if k != "meta"]))
        arrays[k] = _array_mutation(data.draw, arrays[k])
    else:
        key = data.draw(st.sampled_from(sorted(meta)))
        meta[key] = data.draw(junk)
    arrays["meta"] = np.array(json.dumps(meta, allow_nan=True))
    p = tmp_path_factory.mktemp("r") / "trajectory.npz"
    np.savez(p, **arrays)
    with alarm(CASE_LIMIT):
        try:
            tr = pinclear.Trajectory.load(p, mech=mech)
            tr.summary()
            tr.energy()
        except pinclear.PinclearError as exc:
            assert "\n" not in str(exc)


# ------------------------------------------------------------------ junk run.json on --resume
@pytest.fixture(scope="module")
def run_folder(tmp_path_factory):
    out = tmp_path_factory.mktemp("rf") / "o"
    code = cli.main(["simulate", "four_bar", "--t-end", "100", "--rtol", "1e-10", "--max-cpu", "0.2",
                     "--progress", "off", "--out", str(out)])
    assert code == 1 and (out / "checkpoint.npz").exists()
    return out


@settings(max_examples=40, **SETTINGS)
@given(doc=junk | st.dictionaries(st.sampled_from(list(cli.RUN_KEYS)), junk, max_size=6)
       | st.fixed_dictionaries({"file": st.just("four_bar"), "t_end": junk, "trust": junk}))
def test_junk_run_json_is_a_clear_error(tmp_path_factory, run_folder, doc):
    out = tmp_path_factory.mktemp("j") / "o"
    shutil.copytree(run_folder, out)
    (out / "run.json").write_text(json.dumps(doc, allow_nan=True))
    err = io.StringIO()
    with alarm(CASE_LIMIT), contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = cli.main(["simulate", "four_bar", "--t-end", "100", "--rtol", "1e-10", "--progress", "off",
                         "--resume", str(out)])
    text = err.getvalue()
    assert code in (0, 1, 2), text
    assert "Traceback" not in text and "unexpected" not in text
    if code == 2:
        assert text.count("\n") == 1, text
