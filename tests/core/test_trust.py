"""Trust and nothing lost, round 2 (issue 23): one test per root cause. The trust gate holds
against attribute chains; a results folder is data, never authority; one lock per output
folder; no window where a finished run is lost; an honest status. Code execution is detected
with marker files that must not appear."""
from __future__ import annotations

import io
import json
import os
import signal
import subprocess
import sys
import time
import warnings
import zipfile
from pathlib import Path

import numpy as np
import pytest
import yaml

import pinclear
from pinclear.cli import commands as cli
from pinclear.core.errors import InputError, ModelFileError
from pinclear.core.trust import OFFERED, resolve_function
from pinclear.dynamics.screw.section import read_section
from pinclear.dynamics.trajectory import Checkpoint
from tests.helpers import run_cli, write_sidecar

ROOT = Path(__file__).resolve().parents[2]
FOUR = yaml.safe_load((ROOT / "urdf" / "four_bar.yaml").read_text())


@pytest.fixture(autouse=True)
def _untrusted(monkeypatch):
    monkeypatch.delenv("PINCLEAR_TRUST", raising=False)




def _run(args, **kw):
    return subprocess.run([sys.executable, "-m", "pinclear.cli"] + args, capture_output=True, text=True,
                          timeout=600, **kw)


# ------------------------------------------------------------------ A. a trust gate that holds
def _shell(marker):
    return ["sh", "-c", f"echo pwned > {marker}"]


def _chain_docs(marker):
    """The routes of the audit: os.spawn* reached through attributes of pinclear modules, which
    the library calls as f(t, **args) (they fork and exec before checking ``mode``)."""
    # t arrives as spawn*'s ``mode``; the keyword arguments are exactly theirs (on f080d40 the
    # first of these ran the shell command on ``pinclear info``)
    spawnv = {"file": "/bin/sh", "args": _shell(marker)}
    return {
        "drive law": dict(FOUR, drives=[{"name": "d", "joint": "crank_joint", "law": {
            "type": "python", "function": "pinclear.model.timelaws:os.spawnv", "args": spawnv}}]),
        "joint_force law": dict(FOUR, forces=[{"name": "f", "type": "joint_force", "joint": "crank_joint", "law": {
            "type": "python", "function": "pinclear.cli.commands:os.spawnvp", "args": dict(spawnv, file="sh")}}]),
        "platform motion": dict(FOUR, platform={"frame": "coupler", "motion": {
            "function": "pinclear.core.stage:os.spawnve", "args": dict(spawnv, env={})}}),
        "hook": dict(FOUR, hook="pinclear.io.sidecar:re.enum.bltns.exec"),
        "cli main as a law": dict(FOUR, drives=[{"name": "d", "joint": "crank_joint", "law": {
            "type": "python", "function": "pinclear.cli:main", "args": {"argv": ["info", "x"]}}}]),
        "screw ik": dict(FOUR, screw={"ik": "pinclear.dynamics.trajectory:os.system"}),
    }


@pytest.mark.parametrize("route", list(_chain_docs("M")))
def test_attribute_chains_through_pinclear_modules_run_nothing(tmp_path, capsys, route):
    marker = tmp_path / "MARKER"
    path = write_sidecar(tmp_path, _chain_docs(marker)[route])
    for argv in (["info", str(path)], ["simulate", str(path), "--t-end", "0.05", "--out", str(tmp_path / "o"),
                                       "--progress", "off"]):
        code, _, err = run_cli(argv, capsys)
        if route == "screw ik":          # the screw section is read by inverse dynamics only
            assert code in (0, 1)
            with pytest.raises(ModelFileError, match="refusing.*--trust"):
                read_section(pinclear.load(path))
        else:
            assert code == 2 and "refusing" in err and "--trust" in err, err
        assert not marker.exists()


def test_the_allow_list_is_exactly_what_the_bundled_files_name():
    """Every module:function of the bundled sidecars (and of their generators) is offered, each
    offered name is a function defined in its module, and the bundled mechanisms load untrusted."""
    import re

    named = set()
    for f in list((ROOT / "urdf").glob("*.yaml")) + list((ROOT / "pinclear" / "mechanisms").glob("*.py")):
        named |= set(re.findall(r"pinclear(?:\.\w+)+:\w+", f.read_text()))
    named = {n.replace("{fn}", "") for n in named}
    assert named and named <= set(OFFERED), named - set(OFFERED)
    for spec in OFFERED:
        mod, attr = spec.split(":")
        f = resolve_function(spec, "f.yaml", "k")
        assert f.__module__ == mod and f.__qualname__ == attr and callable(f)
    for name in ("four_ups_upu", "three_upru_up", "four_ups_upr"):
        assert pinclear.load(name).platform_motion is not None
    # an offered name's module is imported only after the string check: other names never are
    before = set(sys.modules)
    with pytest.raises(ModelFileError, match="refusing"):
        resolve_function("pinclear.nonexistent_module_xyz:f", "f.yaml", "k")
    assert "pinclear.nonexistent_module_xyz" not in sys.modules and set(sys.modules) == before


def test_trust_still_opens_user_code(tmp_path, monkeypatch):
    spec = f"{__name__}:constant_torque"      # this module, by the name it was imported under
    with pytest.raises(ModelFileError, match="refusing"):
        resolve_function(spec, "f.yaml", "k")
    assert resolve_function(spec, "f.yaml", "k", trust=True) is constant_torque
    monkeypatch.setenv("PINCLEAR_TRUST", "1")
    assert resolve_function(spec, "f.yaml", "k") is constant_torque


def constant_torque(t):
    return 0.25, 0.0, 0.0


def motion_with_marker(t, marker):
    Path(marker).write_text("ran")
    import pinocchio as pin

    return pin.SE3.Identity()


def test_viewing_or_plotting_a_run_calls_no_sidecar_code(tmp_path, capsys, monkeypatch):
    """A run made (trusted) with a sidecar whose platform motion is user code: view, plot and
    load_mechanism never call it without --trust (view once reloaded the sidecar and called it)."""
    monkeypatch.syspath_prepend(str(Path(__file__).parent))
    marker = tmp_path / "MARKER"
    doc = dict(FOUR, platform={"frame": "coupler", "motion": {"function": "test_trust:motion_with_marker",
                                                               "args": {"marker": str(marker)}}})
    path = write_sidecar(tmp_path, doc)
    mech = pinclear.load(path, trust=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tr = pinclear.simulate(mech, 0.05)
    tr.save(tmp_path / "run.npz")
    marker.unlink()                                  # the save computed the tracking error (trusted)
    run = str(tmp_path / "run.npz")
    code, _, err = run_cli(["view", run, "--mech", str(path), "--html", str(tmp_path / "x.html")], capsys)
    assert code == 2 and "refusing" in err and not marker.exists()
    code, _, err = run_cli(["plot", run, "--mech", str(path), "--out", str(tmp_path / "figs")], capsys)
    assert code == 2 and "refusing" in err and not marker.exists()
    with pytest.raises(ModelFileError, match="refusing"):
        pinclear.Trajectory.load(tmp_path / "run.npz").load_mechanism(path)
    # without --mech the recorded path is not opened at all (issue 42)
    code, _, err = run_cli(["view", run, "--html", str(tmp_path / "x.html")], capsys)
    assert code == 2 and "not a bundled mechanism" in err and not marker.exists()
    assert not marker.exists() and not (tmp_path / "x.html").exists()
    # the attribute-chain spelling of the same motion, recorded in a run: refused as well
    meta_doc = dict(FOUR, platform={"frame": "coupler", "motion": {"function": "pinclear.cli.view:sys.exit",
                                                                    "args": {}}})
    m = write_sidecar(tmp_path, meta_doc, name="m.yaml")
    code, _, err = run_cli(["view", run, "--mech", str(m), "--html", str(tmp_path / "x.html")], capsys)
    assert code == 2 and "refusing" in err


# ------------------------------------------------------------------ B. a results folder is data
@pytest.fixture(scope="module")
def interrupted_run(tmp_path_factory):
    """A four-bar run stopped by its CPU budget, with run.json and checkpoint.npz in its folder."""
    out = tmp_path_factory.mktemp("run") / "o"
    r = _run(["simulate", "four_bar", "--t-end", "100", "--rtol", "1e-10", "--max-cpu", "0.3", "--progress", "off",
              "--out", str(out)])
    assert r.returncode == 1 and (out / "checkpoint.npz").exists(), r.stderr
    return out


def _copy_run(src, dst):
    dst.mkdir(parents=True, exist_ok=True)
    for name in ("run.json", "checkpoint.npz", "trajectory.npz"):
        (dst / name).write_bytes((src / name).read_bytes())
    return dst


@pytest.mark.slow
def test_resume_takes_no_trust_and_no_file_from_run_json(tmp_path, interrupted_run, capsys, monkeypatch):
    """A run.json saying trust: true and naming another sidecar switches nothing on: the
    mechanism and trust come from the command line."""
    monkeypatch.syspath_prepend(str(Path(__file__).parent))
    marker = tmp_path / "MARKER"
    evil = write_sidecar(tmp_path, dict(FOUR, platform={"frame": "coupler", "motion": {
        "function": "test_trust:motion_with_marker", "args": {"marker": str(marker)}}}), name="evil.yaml")
    out = _copy_run(interrupted_run, tmp_path / "o")
    run = json.loads((out / "run.json").read_text())
    (out / "run.json").write_text(json.dumps(dict(run, trust=True, file=str(evil))))
    # the bare --resume takes nothing from the folder: it asks for the command line
    code, _, err = run_cli(["simulate", "--resume", str(out)], capsys)
    assert code == 2 and "mechanism file and --t-end" in err and not marker.exists()
    # the evil sidecar named on the command line, without --trust: the gate refuses it
    code, _, err = run_cli(["simulate", str(evil), "--t-end", "100", "--rtol", "1e-10", "--resume", str(out)], capsys)
    assert code == 2 and "refusing" in err and not marker.exists()
    # the original mechanism on the command line contradicts the doctored run.json: refused, named
    code, _, err = run_cli(["simulate", "four_bar", "--t-end", "100", "--rtol", "1e-10", "--resume", str(out)], capsys)
    assert code == 2 and "mechanism" in err and not marker.exists()


@pytest.mark.parametrize("extra, named", [
    (["--t-end", "50", "--rtol", "1e-10"], ["--t-end", "50"]),
    (["--t-end", "100", "--rtol", "1e-6"], ["--rtol"]),
    (["--t-end", "100", "--rtol", "1e-10", "--method", "projection"], ["--method"]),
    (["--t-end", "100", "--rtol", "1e-10", "--out", "elsewhere"], ["--out"]),
])
def test_resume_refuses_a_contradicting_command_line(tmp_path, interrupted_run, capsys, extra, named):
    out = _copy_run(interrupted_run, tmp_path / "o")
    before = (out / "checkpoint.npz").read_bytes()
    code, _, err = run_cli(["simulate", "four_bar"] + extra + ["--resume", str(out), "--progress", "off"], capsys)
    assert code == 2 and err.count("\n") == 1, err
    for word in named:
        assert word in err
    assert (out / "checkpoint.npz").read_bytes() == before


def test_resume_with_the_same_command_line_continues(tmp_path, interrupted_run, capsys):
    out = _copy_run(interrupted_run, tmp_path / "o")
    part = pinclear.Trajectory.load(out / "trajectory.npz")
    code, _, err = run_cli(["simulate", "four_bar", "--t-end", "100", "--rtol", "1e-10", "--max-cpu", "600",
                         "--progress", "off", "--resume", str(out)], capsys)
    assert code == 0, err
    done = pinclear.Trajectory.load(out / "trajectory.npz")
    assert done.status == "success" and done.t[-1] == 100.0
    np.testing.assert_array_equal(done.q[:len(part.t) - 1], part.q[:len(part.t) - 1])


def _tampered(src, dst, **changes):
    """A copy of a checkpoint NPZ with arrays or metadata fields replaced."""
    with np.load(src, allow_pickle=False) as d:
        arrays = {k: d[k] for k in d.files}
    meta = json.loads(str(arrays["meta"]))
    for k, v in changes.items():
        if k in meta:
            meta[k] = v
        else:
            arrays[k] = v
    arrays["meta"] = np.array(json.dumps(meta))
    np.savez(dst, **arrays)
    return dst


def _ck(interrupted_run):
    return interrupted_run / "checkpoint.npz"


@pytest.mark.slow
def test_wrong_length_checkpoint_state_never_reaches_the_compiled_loop(tmp_path, interrupted_run):
    """v_now one entry short once made the compiled loop write out of bounds (glibc abort, exit
    134); now a clear error naming the array, before any compiled code runs."""
    out = _copy_run(interrupted_run, tmp_path / "o")
    with np.load(out / "checkpoint.npz") as d:
        v_now, q_now, qs = d["v_now"], d["q_now"], d["qs"]
    for key, bad in (("v_now", v_now[:-1]), ("q_now", np.r_[q_now, 0.0]), ("qs", qs[:, :-1])):
        _tampered(_ck(interrupted_run), out / "checkpoint.npz", **{key: bad})
        r = _run(["simulate", "four_bar", "--t-end", "100", "--rtol", "1e-10", "--progress", "off",
                  "--resume", str(out)])
        assert r.returncode == 2, (key, r.returncode, r.stderr)
        assert key in r.stderr and "checkpoint.npz" in r.stderr and r.stderr.count("\n") == 1
    # the Python API refuses the same before its loop too
    ck = Checkpoint.load(_ck(interrupted_run))
    ck.v_now = ck.v_now[:-1]
    with pytest.raises(InputError, match="v_now"):
        pinclear.simulate(pinclear.load("four_bar"), 100.0, rtol=1e-10, resume=ck)


@pytest.mark.parametrize("what", ["nan sample", "reversed times", "off manifold", "stale run", "bad h_next",
                                  "stats junk", "no identity"])
def test_tampered_checkpoints_are_refused(tmp_path, interrupted_run, what):
    src = _ck(interrupted_run)
    with np.load(src) as d:
        qs, ts, q_now = d["qs"].copy(), d["ts"].copy(), d["q_now"].copy()
    mech = pinclear.load("four_bar")
    rtol = 1e-10
    if what == "nan sample":
        qs[len(qs) // 2, 0] = np.nan
        p, word = _tampered(src, tmp_path / "c.npz", qs=qs), "nan"
    elif what == "reversed times":
        p, word = _tampered(src, tmp_path / "c.npz", ts=ts[::-1].copy()), "increasing"
    elif what == "off manifold":
        q_now[0] += 0.1                               # 0.1 rad on the crank alone opens the loop
        p, word = _tampered(src, tmp_path / "c.npz", q_now=q_now), "off the constraint manifold"
    elif what == "stale run":                         # another run's checkpoint: another rtol
        p, word, rtol = src, "rtol", 1e-9
    elif what == "bad h_next":
        p, word = _tampered(src, tmp_path / "c.npz", h_next=-1.0), "h_next"
    elif what == "no identity":
        p, word = _tampered(src, tmp_path / "c.npz", identity=None), "identity"
    else:
        p, word = _tampered(src, tmp_path / "c.npz", stats={"steps": "many"}), "stats.steps"
    with pytest.raises(InputError, match=word):
        pinclear.simulate(mech, 100.0, rtol=rtol, resume=Checkpoint.load(p))


def test_a_stale_checkpoint_names_the_differences(interrupted_run):
    ck = Checkpoint.load(_ck(interrupted_run))
    with pytest.raises(InputError) as info:
        pinclear.simulate(pinclear.load("four_bar", overrides={"gravity": [0.0, 0.0, -1.62]}), 60.0, rtol=1e-9,
                          resume=ck)
    text = str(info.value)
    assert "another run" in text and "mechanism" in text and "rtol" in text and "t_end" in text


def _npz_declaring(path, shape, extra=None):
    """An NPZ whose one array's header declares ``shape`` while holding a few bytes."""
    import numpy.lib.format as fmt

    buf = io.BytesIO()
    fmt.write_array_header_1_0(buf, {"descr": "<f8", "fortran_order": False, "shape": shape})
    buf.write(b"\0" * 64)
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("t.npy", buf.getvalue())
        for k, v in (extra or {}).items():
            b = io.BytesIO()
            np.save(b, v)
            zf.writestr(f"{k}.npy", b.getvalue())
    return path


def test_npz_sizes_are_checked_before_loading(tmp_path):
    p = _npz_declaring(tmp_path / "huge.npz", (4_000_000_000,), {"meta": np.array("{}")})
    t0 = time.process_time()
    for load in (pinclear.Trajectory.load, Checkpoint.load):
        with pytest.raises(InputError, match="refused before loading") as info:
            load(p)
        assert str(p) in str(info.value) and "'t'" in str(info.value)
    assert time.process_time() - t0 < 2
    # object arrays (pickles) are refused from the header too
    with zipfile.ZipFile(tmp_path / "obj.npz", "w") as zf:
        b = io.BytesIO()
        np.save(b, np.array([{"a": 1}], dtype=object), allow_pickle=True)
        zf.writestr("meta.npy", b.getvalue())
    with pytest.raises(InputError, match="dtype object"):
        pinclear.Trajectory.load(tmp_path / "obj.npz")


def test_truncated_and_foreign_files_name_the_file(tmp_path, interrupted_run):
    good = (interrupted_run / "trajectory.npz").read_bytes()
    cases = {"truncated.npz": good[: len(good) // 2], "text.npz": b"hello", "empty.npz": b""}
    for name, data in cases.items():
        (tmp_path / name).write_bytes(data)
        for load in (pinclear.Trajectory.load, Checkpoint.load):
            with pytest.raises(InputError) as info:
                load(tmp_path / name)
            assert str(tmp_path / name) in str(info.value) and "\n" not in str(info.value)
    (tmp_path / "dir.npz").mkdir()
    with pytest.raises(InputError, match="not a regular file"):
        pinclear.Trajectory.load(tmp_path / "dir.npz")


def test_tampered_saved_runs_are_refused(tmp_path, interrupted_run):
    src = interrupted_run / "trajectory.npz"
    mech = pinclear.load("four_bar")
    with np.load(src) as d:
        arrays = {k: d[k] for k in d.files}
    meta = json.loads(str(arrays["meta"]))

    def write(**kw):
        a = dict(arrays)
        m = json.loads(json.dumps(meta))
        for k, v in kw.items():
            if k.startswith("meta."):
                m[k[5:]] = v
            else:
                a[k] = v
        a["meta"] = np.array(json.dumps(m))
        np.savez(tmp_path / "r.npz", **a)
        return tmp_path / "r.npz"

    gravity = dict(meta["mechanism"], gravity=[0.0, 0.0, -1.62])
    cases = [(dict(**{"meta.mechanism": gravity}), "gravity"),
             (dict(t=arrays["t"][::-1].copy()), "increasing"),
             (dict(q=np.where(np.arange(arrays["q"].size).reshape(arrays["q"].shape) == 3, np.nan, arrays["q"])),
              "nan"),
             (dict(v=arrays["v"][:, :-1]), "'v'"),
             (dict(**{"meta.status": ["success"]}), "status"),
             (dict(**{"meta.stats": 3}), "stats"),
             (dict(**{"meta.lam_names": "B"}), "lam_names")]
    for kw, word in cases:
        with pytest.raises(InputError, match=word):
            pinclear.Trajectory.load(write(**kw), mech=mech)


# ------------------------------------------------------------------ C. one lock per output folder
def test_a_second_run_into_a_locked_folder_is_refused(tmp_path, capsys):
    import fcntl

    out = tmp_path / "o"
    out.mkdir()
    with open(out / ".lock", "a+") as fh:
        fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        fh.write("pid 4242, started earlier\n")
        fh.flush()
        code, _, err = run_cli(["simulate", "four_bar", "--t-end", "0.1", "--out", str(out), "--progress", "off"], capsys)
    assert code == 2 and str(out) in err and "pid 4242" in err
    assert not (out / "run.json").exists()
    code, _, err = run_cli(["simulate", "four_bar", "--t-end", "0.1", "--out", str(out), "--progress", "off"], capsys)
    assert code == 0, err


# ------------------------------------------------------------------ D. no finished run lost
@pytest.mark.slow
def test_sigterm_while_saving_keeps_the_run(tmp_path):
    """The signal arrives while trajectory.npz is being written (it is sent from inside the
    save): the save completes, the summary is written, the command exits with 130."""
    out = tmp_path / "o"
    script = (
        "import os, signal, sys\n"
        "import pinclear.dynamics.trajectory as T\n"
        "from pinclear import cli\n"
        "orig = T.Trajectory.save\n"
        "def save(self, path):\n"
        "    os.kill(os.getpid(), signal.SIGTERM)\n"
        "    os.kill(os.getpid(), signal.SIGTERM)\n"
        "    return orig(self, path)\n"
        "T.Trajectory.save = save\n"
        f"sys.exit(cli.main(['simulate', 'four_bar', '--t-end', '0.5', '--progress', 'off', '--out', {str(out)!r}]))\n")
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert r.returncode == 130, r.stderr
    tr = pinclear.Trajectory.load(out / "trajectory.npz")
    assert tr.status == "success" and tr.t[-1] == 0.5
    assert json.loads((out / "summary.json").read_text())["samples"] == len(tr.t)
    assert "Traceback" not in r.stderr and not list(out.glob(".*.npz"))


def test_two_quick_signals_still_keep_the_run(tmp_path):
    """SIGTERM twice, 20 ms apart, mid-integration: the first stops the run in order, the second
    may not cut the checkpoint or the save short; the samples are on disk, exit 130."""
    out = tmp_path / "o"
    proc = subprocess.Popen([sys.executable, "-m", "pinclear.cli", "simulate", "four_bar", "--t-end", "300",
                             "--rtol", "1e-11", "--progress", "off", "--checkpoint-every", "0.2", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    while not (out / "checkpoint.npz").exists() and time.time() < deadline:
        time.sleep(0.02)
    assert proc.poll() is None, "the run ended before it could be interrupted"
    proc.send_signal(signal.SIGTERM)
    time.sleep(0.02)
    proc.send_signal(signal.SIGTERM)
    _, err = proc.communicate(timeout=300)
    assert proc.returncode == 130, err
    tr = pinclear.Trajectory.load(out / "trajectory.npz")
    assert tr.status == "interrupted" and len(tr.t) > 5 and 0.0 < tr.t[-1] < 300.0
    ck = Checkpoint.load(out / "checkpoint.npz")
    assert ck.t >= tr.t[-1] and "Traceback" not in err


def raising_motion(t):
    raise RuntimeError("platform motion broken after the run")


def test_summary_failure_does_not_lose_the_run(tmp_path, capsys, monkeypatch):
    monkeypatch.syspath_prepend(str(Path(__file__).parent))
    path = write_sidecar(tmp_path, dict(FOUR, platform={"frame": "coupler", "motion": {
        "function": "test_trust:raising_motion", "args": {}}}))
    out = tmp_path / "o"
    code, _, err = run_cli(["simulate", str(path), "--t-end", "0.2", "--trust", "--out", str(out), "--progress", "off"],
                        capsys)
    assert code == 1 and "RuntimeError" in err and "saved" in err
    tr = pinclear.Trajectory.load(out / "trajectory.npz")
    assert tr.status == "success" and tr.t[-1] == 0.2
    assert "summary_error" in json.loads((out / "summary.json").read_text())


def test_a_failed_write_leaves_a_fallback_copy(tmp_path, capsys, monkeypatch):
    """Disk full while writing OUT/trajectory.npz: the error names the path and the reason, and
    the run is written to the user cache folder instead (the probe file had passed)."""
    import errno

    from pinclear.dynamics import trajectory

    out = tmp_path / "o"
    cache = tmp_path / "cache"
    monkeypatch.setenv("PINCLEAR_CACHE_DIR", str(cache))
    real = trajectory.atomic_savez

    def full(path, arrays):
        if Path(path).parent == out:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        return real(path, arrays)

    monkeypatch.setattr(trajectory, "atomic_savez", full)
    code, _, err = run_cli(["simulate", "four_bar", "--t-end", "0.2", "--out", str(out), "--progress", "off"], capsys)
    assert code == 1
    assert str(out / "trajectory.npz") in err and "No space left on device" in err
    copies = list(cache.glob("unsaved-runs/*/trajectory.npz"))
    assert len(copies) == 1 and str(copies[0]) in err
    assert pinclear.Trajectory.load(copies[0]).t[-1] == 0.2


def test_an_output_path_that_is_a_folder_is_refused_before_the_run(tmp_path, capsys):
    out = tmp_path / "o"
    (out / "trajectory.npz").mkdir(parents=True)
    t0 = time.process_time()
    code, _, err = run_cli(["simulate", "four_bar", "--t-end", "50", "--out", str(out)], capsys)
    assert code == 2 and "trajectory.npz" in err and "not a regular file" in err
    assert time.process_time() - t0 < 10


class LawFailure(pinclear.PinclearError):
    pass


def law_raising_a_pinclear_error(t):
    if t > 0.05:
        raise LawFailure("the user's law gave up")
    return 0.0, 0.0, 0.0


def test_a_pinclear_error_from_a_trusted_law_keeps_the_samples(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(Path(__file__).parent))
    doc = dict(FOUR, forces=[{"name": "motor", "type": "joint_force", "joint": "crank_joint",
                              "law": {"type": "python", "function": "test_trust:law_raising_a_pinclear_error"}}])
    mech = pinclear.load(write_sidecar(tmp_path, doc), trust=True)
    with pytest.warns(RuntimeWarning, match="LawFailure"):
        tr = pinclear.simulate(mech, 0.2, dt_out=0.01)
    assert tr.status == "failed" and "LawFailure" in tr.message and "gave up" in tr.message
    assert 0.03 <= tr.t[-1] <= 0.05 + 1e-9 and np.all(np.isfinite(tr.q))


def test_sigint_while_the_cli_starts_is_one_line():
    """SIGINT while the command imports pinclear (once a raw KeyboardInterrupt traceback): the
    signal is sent as soon as Pinocchio's library is mapped into the process, i.e. mid-import."""
    proc = subprocess.Popen([sys.executable, "-m", "pinclear.cli", "info", "four_bar"], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.time() + 60
    while time.time() < deadline and proc.poll() is None:
        try:
            if "pinocchio" in Path(f"/proc/{proc.pid}/maps").read_text():
                break
        except OSError:
            break
        time.sleep(0.002)
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert "Traceback" not in err, err
    assert proc.returncode == 130 and err.strip() == "pinclear: interrupted", err


# ------------------------------------------------------------------ E. an honest status
def test_a_broken_closure_is_not_success(tmp_path, capsys):
    """The parallelogram started exactly flat (a singular configuration) ends with its closure
    open by 0.4 m; it once reported success."""
    doc = yaml.safe_load((ROOT / "urdf" / "parallelogram.yaml").read_text())
    doc["initial"] = {"q": {"crank_joint": 0.0, "coupler_joint": 0.0, "rocker_joint": 0.0}}
    path = write_sidecar(tmp_path, doc, urdf="parallelogram.urdf")
    code, _, err = run_cli(["simulate", str(path), "--t-end", "2", "--out", str(tmp_path / "o"), "--progress", "off"],
                        capsys)
    assert code == 1 and "constraint violated" in err
    tr = pinclear.Trajectory.load(tmp_path / "o" / "trajectory.npz")
    cv = tr.stats["constraint_violation"]
    assert tr.status == "failed" and tr.t[-1] == 2.0 and cv["max_residual"] > 0.1 > cv["bound"]
    # the same scene from its ordinary start is a success, its residual far inside the bound
    ok = pinclear.simulate(pinclear.load("parallelogram"), 0.25)
    assert ok.status == "success" and "constraint_violation" not in ok.stats


@pytest.mark.parametrize("key, value", [("atol", []), ("atol", [None, []]), ("atol", [1e-9, None]), ("atol", -1.0),
                                        ("rtol", 0.0), ("rtol", [1e-8]), ("stats.steps", "abc"),
                                        ("stats.steps", 1.5), ("stats.rhs_evals", -3)])
def test_a_saved_run_with_tampered_tolerances_or_counts_is_refused_on_load(tmp_path, key, value):
    # the energy audit and the residual bound read these back: a saved run must not reach them
    # with a list, a negative or a non-integer where a number belongs (found by the fuzz under
    # another Hypothesis version: atol [None, []] reached np.max in summary())
    run = tmp_path / "run.npz"
    pinclear.simulate(pinclear.load("four_bar"), 0.02).save(run)
    arrays = dict(np.load(run))
    meta = json.loads(str(arrays["meta"]))
    if key.startswith("stats."):
        meta["stats"][key[6:]] = value
    else:
        meta[key] = value
    arrays["meta"] = np.array(json.dumps(meta))
    bad = tmp_path / "bad.npz"
    np.savez(bad, **arrays)
    with pytest.raises(InputError, match=key.split(".")[-1]):
        pinclear.Trajectory.load(bad)
