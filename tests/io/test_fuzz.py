"""Property-based fuzzing (issue 11): mutated mechanism files and random command lines end
either in a result or in a PinclearError with a one-line message; never in another
exception, never in a hang. Each case runs under a wall-clock alarm."""
from __future__ import annotations

import contextlib
import copy
import io
import math
from pathlib import Path

import numpy as np
import pytest
import yaml

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import pinclear  # noqa: E402
from pinclear.cli import commands as cli  # noqa: E402
from tests.helpers import alarm  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
BASE = yaml.safe_load((ROOT / "urdf" / "four_bar.yaml").read_text())
#: seconds a single case may take before it counts as a hang
CASE_LIMIT = 60




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


@pytest.mark.slow
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


@pytest.mark.slow
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


# ------------------------------------------------------------------ issue 42: results folders and the cache
def _meta_paths(meta, prefix=(), depth=0):
    yield prefix
    if depth >= 3:
        return
    if isinstance(meta, dict):
        for k, v in meta.items():
            yield from _meta_paths(v, prefix + (k,), depth + 1)
    elif isinstance(meta, list):
        for i, v in enumerate(meta[:3]):
            yield from _meta_paths(v, prefix + (i,), depth + 1)


hostile = junk | st.sampled_from([
    {"forces": [{"name": "e", "type": "joint_force", "joint": "crank_joint",
                 "law": {"type": "python", "function": "os:system", "args": {"command": "touch pwned"}}}]},
    {"hook": "pinclear.cli:main"}, {"urdf": "/etc/passwd"}, "/etc/passwd", "/dev/zero", "four_bar", "four_bar.yaml",
    "/nonexistent/four_bar.yaml", {"path": "/etc/shadow"}, [None], 1e308, -1e308, 10 ** 30])


@pytest.fixture(scope="module")
def saved_run(tmp_path_factory):
    import json

    from pinclear.dynamics import validate

    d = tmp_path_factory.mktemp("fzrun")
    path = pinclear.simulate(pinclear.load("four_bar"), 0.2, dt_out=0.01).save(d / "run.npz")
    arrays = validate.read_npz(path)
    return arrays, json.loads(str(arrays["meta"]))


@pytest.mark.slow
@settings(max_examples=60, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)
@given(data=st.data())
def test_tampered_run_metadata_gives_a_status(tmp_path_factory, saved_run, data, monkeypatch):
    """A saved run whose JSON metadata is rewritten (junk, code names, paths of files the user
    did not name, huge numbers) on plot, view and analyse, with and without --trust: a result or
    one error line, never a traceback (exit 3), never code run, never a recorded path's text."""
    import json

    arrays, meta = saved_run
    meta = copy.deepcopy(meta)
    paths = [p for p in _meta_paths(meta) if p]
    for _ in range(data.draw(st.integers(1, 3))):
        path = data.draw(st.sampled_from(paths))
        try:
            if data.draw(st.booleans()):
                _set(meta, path, data.draw(hostile))
            else:
                node = meta
                for k in path[:-1]:
                    node = node[k]
                del node[path[-1]]
        except (KeyError, IndexError, TypeError):
            pass
    folder = tmp_path_factory.mktemp("fzmeta")
    monkeypatch.chdir(folder)
    run = folder / "run.npz"
    np.savez_compressed(run, **dict(arrays, meta=np.array(json.dumps(meta))))
    trust = data.draw(st.sampled_from([[], ["--trust"]]))
    cmd = data.draw(st.sampled_from([["plot", str(run), "--out", str(folder / "f")],
                                     ["view", str(run), "--html", str(folder / "x.html")],
                                     ["analyse", "poincare", str(run), "--period", "0.05", "--signal", "crank_joint",
                                      "--out", str(folder / "a")]]))
    if cmd[0] == "analyse":
        trust = []
    err = io.StringIO()
    with alarm(CASE_LIMIT), contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            code = cli.main(cmd + trust)
        except SystemExit as exc:
            code = exc.code
    text = err.getvalue().strip()
    assert code in (0, 1, 2), (cmd, meta, text)
    assert "Traceback" not in text and "root:" not in text, text          # nothing of /etc/passwd
    if code == 2:
        assert len([ln for ln in text.splitlines() if ln.startswith("pinclear: error:")]) == 1, text
    assert not (folder / "pwned").exists()


@pytest.fixture(scope="module")
def finished_sweep(tmp_path_factory):
    out = tmp_path_factory.mktemp("fzsweep") / "s"
    pinclear.sweep("clr_pendulum", {"S.mu": [0.0, 0.2]}, 0.005, out, sim_options={"rtol": 1e-6, "dt_out": 1e-3},
                   load_options={"clearances": ["S"], "overrides": {"S.friction_law": "coulomb"}},
                   executor="serial", progress=None)
    return out


def _sweep_mutation(folder, victim, kind, arg):
    import os
    import shutil

    pts = folder / "points"
    target = pts / f"{arg % 2:05d}.npz"
    # (the mutations themselves never write through a link planted by an earlier one)
    if kind == "truncate":
        if target.is_symlink():
            return
        data = target.read_bytes()
        target.write_bytes(data[: len(data) * (arg % 10) // 10])
    elif kind == "swap":
        (pts / "00001.npz").unlink(missing_ok=True)
        shutil.copy(pts / "00000.npz", pts / "00001.npz")
    elif kind == "link point":
        target.unlink()
        target.symlink_to(victim)
    elif kind == "link lock":
        (folder / ".lock").unlink(missing_ok=True)
        (folder / ".lock").symlink_to(victim)
    elif kind == "link index":
        (folder / "sweep.json").unlink()
        (folder / "sweep.json").symlink_to(victim)
    elif kind == "junk index":
        (folder / "sweep.json").unlink(missing_ok=True)
        (folder / "sweep.json").write_bytes(bytes(range(256))[: arg % 256])
    elif kind == "json success":
        target.unlink()
        (pts / f"{arg % 2:05d}.json").write_text('{"status": "success", "message": "planted"}')
    elif kind == "fifo":
        target.unlink()
        os.mkfifo(target)
    elif kind == "points is a file":
        shutil.rmtree(pts)
        pts.write_text("x")
    elif kind == "points is a link":
        shutil.rmtree(pts)
        pts.symlink_to(victim.parent)


@settings(max_examples=40, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)
@given(kinds=st.lists(st.sampled_from(["truncate", "swap", "link point", "link lock", "link index", "junk index",
                                       "json success", "fifo", "points is a file", "points is a link"]),
                      min_size=1, max_size=3, unique=True),
       arg=st.integers(0, 1000))
def test_tampered_sweep_folders_give_a_status(tmp_path_factory, finished_sweep, kinds, arg):
    """A finished sweep folder tampered one to three ways, swept again: the sweep completes with
    every point's file read back as its own (or it is refused in one line), the victim keeps its
    bytes, and no file appears outside the folder."""
    import shutil

    base = tmp_path_factory.mktemp("fzsw")
    folder = base / "s"
    shutil.copytree(finished_sweep, folder, symlinks=True)
    victim_dir = base / "outside"
    victim_dir.mkdir()
    victim = victim_dir / "victim"
    victim.write_bytes(b"keep")
    for kind in kinds:
        try:
            _sweep_mutation(folder, victim, kind, arg)
        except OSError:
            pass                                         # an earlier mutation removed the file
    with alarm(CASE_LIMIT):
        try:
            res = pinclear.sweep("clr_pendulum", {"S.mu": [0.0, 0.2]}, 0.005, folder,
                                 sim_options={"rtol": 1e-6, "dt_out": 1e-3},
                                 load_options={"clearances": ["S"], "overrides": {"S.friction_law": "coulomb"}},
                                 executor="serial", progress=None)
        except pinclear.PinclearError as exc:
            assert _one_line(exc), repr(exc)
        else:
            for p in res.points:
                assert p.ok, (kinds, p)
                tr = p.trajectory()
                assert tr.meta["sweep_point"]["overrides"]["S.mu"] == [0.0, 0.2][p.index]
    assert victim.read_bytes() == b"keep" and sorted(x.name for x in victim_dir.iterdir()) == ["victim"]


@settings(max_examples=80, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)
@given(mode=st.integers(0, 0o7777), parent_mode=st.integers(0, 0o7777), missing=st.booleans())
def test_cache_folder_modes(tmp_path_factory, mode, parent_mode, missing):
    """Any mode of the cache folder and of the folder above it: accepted exactly when neither
    group nor others may write the folder and others may not change the one above it (unless
    sticky); a missing folder is created 0700; a refusal is one line naming the folder."""
    import os
    import stat as st_

    from pinclear.core.jit import CacheFolderError, private_folder

    if not hasattr(os, "getuid"):
        pytest.skip("POSIX permissions")
    parent = tmp_path_factory.mktemp("fzcache") / "p"
    parent.mkdir()
    cache = parent / "cache"
    if not missing:
        cache.mkdir()
        os.chmod(cache, mode | 0o700)                    # the owner can always enter it here
    os.chmod(parent, parent_mode | 0o700)
    parent_ok = not (parent_mode & 0o002) or bool(parent_mode & st_.S_ISVTX)
    folder_ok = missing or not (mode & 0o022)
    try:
        private_folder(cache)
        accepted = True
    except CacheFolderError as exc:
        accepted = False
        assert _one_line(exc) and str(cache) in str(exc)
    finally:
        os.chmod(parent, 0o700)
    assert accepted == (parent_ok and folder_ok), (oct(mode), oct(parent_mode), missing)
    if accepted and missing:
        assert cache.stat().st_mode & 0o777 == 0o700     # (a setgid parent passes its bit on)
