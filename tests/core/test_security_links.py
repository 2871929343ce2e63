"""Hostile round 4 (issue 42), links and sweep points: every file pinclear creates, truncates or
replaces in a results folder is written without following a link and stays inside the folder
(pinclear.core.safeio); sweep points carry their sweep's identity; sweep folders are locked; a point
that cannot be written leaves a named copy. Each test plants the hostile file and checks the
victim's bytes afterwards."""
from __future__ import annotations

import errno
import fcntl
import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import pinclear
from pinclear.analysis import sweeps
from pinclear.core import safeio
from pinclear.core.errors import InputError
from pinclear.dynamics.trajectory import Trajectory
from tests.helpers import run_cli

VICTIM = b"the user's data\n"
MODEL, LOAD = "clr_pendulum", {"clearances": ["S"], "overrides": {"S.friction_law": "coulomb", "S.mu": 0.1}}
SIM = {"rtol": 1e-6, "dt_out": 1e-3}
T_END = 0.01


def _victim(tmp_path, name="victim"):
    v = tmp_path / name
    v.write_bytes(VICTIM)
    return v


# ------------------------------------------------------------------ the module itself
def test_a_write_replaces_a_link_never_its_target(tmp_path):
    v = _victim(tmp_path)
    out = tmp_path / "R"
    out.mkdir()
    (out / "summary.json").symlink_to(v)
    safeio.write_text(out / "summary.json", "{}")
    assert v.read_bytes() == VICTIM
    assert not (out / "summary.json").is_symlink() and (out / "summary.json").read_text() == "{}"
    # no temporary left behind
    assert sorted(p.name for p in out.iterdir()) == ["summary.json"]


def _linked_points(tmp_path, name):
    """(elsewhere, tmp_path/name) where name/points is a link to the folder elsewhere."""
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    out = tmp_path / name
    out.mkdir()
    (out / "points").symlink_to(elsewhere)
    return elsewhere, out


def test_a_link_below_the_folder_is_refused_and_nothing_leaves_it(tmp_path):
    elsewhere, out = _linked_points(tmp_path, "R")
    with pytest.raises(safeio.LinkRefused, match="link.*points"):
        safeio.write_bytes(out / "points" / "00000.npz", b"x", root=out)
    with pytest.raises(safeio.LinkRefused):
        safeio.make_dirs(out / "points" / "sub", out)
    assert list(elsewhere.iterdir()) == []
    with pytest.raises(safeio.LinkRefused, match="not inside"):
        safeio.write_bytes(tmp_path / "x", b"x", root=out)


def test_the_lock_file_is_never_a_link_or_a_hard_link(tmp_path):
    v = _victim(tmp_path)
    out = tmp_path / "R"
    out.mkdir()
    (out / ".lock").symlink_to(v)
    with pytest.raises(InputError, match=r"\.lock.*link"):
        with safeio.folder_lock(out):
            pass
    (out / ".lock").unlink()
    os.link(v, out / ".lock")                        # a hard link would be truncated in place
    with pytest.raises(InputError, match=r"\.lock.*hard link"):
        with safeio.folder_lock(out):
            pass
    assert v.read_bytes() == VICTIM
    fifo = tmp_path / "F"
    fifo.mkdir()
    os.mkfifo(fifo / ".lock")                          # refused without blocking
    with pytest.raises(InputError, match="FIFO"):
        with safeio.folder_lock(fifo):
            pass


def test_a_failed_write_names_both_paths(tmp_path, monkeypatch):
    monkeypatch.setenv("PINCLEAR_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "R"
    (out / "summary.json").mkdir(parents=True)          # a folder where the file goes
    written, problem = safeio.write_or_fallback(lambda p, root: safeio.write_text(p, "{}", root),
                                                out / "summary.json")
    assert written is not None and written.read_text() == "{}" and written.parent == out
    assert str(out / "summary.json") in problem and str(written) in problem


# ------------------------------------------------------------------ simulate and --resume
def test_simulate_into_a_folder_with_a_linked_lock_keeps_the_victim(tmp_path, capsys):
    """The audit's case: ``ln -s ../victim R/.lock; pinclear simulate four_bar --out R`` emptied
    victim. Now refused with one line naming the lock file; victim unchanged."""
    v = _victim(tmp_path)
    out = tmp_path / "R"
    out.mkdir()
    (out / ".lock").symlink_to("../victim")
    code, _, err = run_cli(["simulate", "four_bar", "--t-end", "0.05", "--out", str(out), "--progress", "off"], capsys)
    assert code == 2 and ".lock" in err and "link" in err and len(err.strip().splitlines()) == 1
    assert v.read_bytes() == VICTIM


@pytest.mark.parametrize("name", ["trajectory.npz", "summary.json", "checkpoint.npz", "run.json"])
def test_simulate_refuses_a_linked_result_file(tmp_path, capsys, name):
    v = _victim(tmp_path)
    out = tmp_path / "R"
    out.mkdir()
    (out / name).symlink_to(v)
    code, _, err = run_cli(["simulate", "four_bar", "--t-end", "0.05", "--out", str(out), "--progress", "off"], capsys)
    assert code == 2 and name in err and "link" in err
    assert v.read_bytes() == VICTIM


def test_resume_on_a_received_folder_with_links(tmp_path, capsys):
    """A finished run's folder, received with links planted: the lock and the checkpoint. --resume
    refuses both before reading or writing anything, the victim keeps its bytes."""
    out = tmp_path / "R"
    argv = ["simulate", "four_bar", "--t-end", "0.05", "--out", str(out), "--progress", "off", "--rtol", "1e-6"]
    code, _, _ = run_cli(argv, capsys)
    assert code == 0
    shutil.copy(out / "trajectory.npz", out / "checkpoint.npz")
    v = _victim(tmp_path)
    (out / ".lock").unlink(missing_ok=True)
    (out / ".lock").symlink_to(v)
    code, _, err = run_cli(argv[:4] + ["--resume", str(out), "--progress", "off", "--rtol", "1e-6"], capsys)
    assert code == 2 and ".lock" in err and v.read_bytes() == VICTIM
    (out / ".lock").unlink()
    ck = out / "checkpoint.npz"
    shutil.move(ck, tmp_path / "ck.npz")
    ck.symlink_to(tmp_path / "ck.npz")
    code, _, err = run_cli(argv[:4] + ["--resume", str(out), "--progress", "off", "--rtol", "1e-6"], capsys)
    assert code == 2 and "checkpoint.npz" in err and "link" in err


# ------------------------------------------------------------------ sweep folders
def _sweep(out, vary=None, **kw):
    return pinclear.sweep(MODEL, vary or {"S.mu": [0.0, 0.3]}, T_END, out, sim_options=SIM, load_options=LOAD,
                          executor="serial", progress=None, **kw)


def test_a_sweep_folder_with_links_writes_nothing_outside(tmp_path):
    elsewhere, out = _linked_points(tmp_path, "S")
    with pytest.raises(InputError, match="points.*link"):
        _sweep(out)
    assert list(elsewhere.iterdir()) == []
    (out / "points").unlink()
    v = _victim(tmp_path)
    (out / ".lock").symlink_to(v)
    with pytest.raises(InputError, match=r"\.lock"):
        _sweep(out)
    (out / ".lock").unlink()
    (out / "sweep.json").symlink_to(v)
    with pytest.raises(InputError, match="sweep.json.*link"):     # never read, never replaced
        _sweep(out)
    assert v.read_bytes() == VICTIM


def test_foreign_points_are_moved_aside_and_computed_again(tmp_path, capsys):
    """The audit's planted points: another sweep's point, a four-bar run, a JSON saying success
    with no trajectory, a link to a valid point. Each is moved aside by name and recomputed."""
    a = _sweep(tmp_path / "A")
    assert a.computed == 2 and all(p.ok for p in a.points)
    other = _sweep(tmp_path / "B", vary={"S.mu": [0.5, 0.6]})
    capsys.readouterr()
    pts = tmp_path / "A" / "points"
    q0 = Trajectory.load(pts / "00000.npz").q
    shutil.copy(other.points[0].file, pts / "00000.npz")                   # another sweep's point
    four = pinclear.simulate(pinclear.load("four_bar"), 0.02, dt_out=0.01)
    four.save(pts / "00001.npz")                                             # not a sweep point at all
    again = _sweep(tmp_path / "A")
    err = capsys.readouterr().err
    assert again.computed == 2
    assert "00000.npz" in err and "00000.npz.foreign" in err and "00001.npz.foreign" in err
    assert (pts / "00000.npz.foreign").is_file() and (pts / "00001.npz.foreign").is_file()
    np.testing.assert_array_equal(Trajectory.load(again.points[0].file).q, q0)     # recomputed, bit-identical
    mu = [Trajectory.load(p.file).meta["sweep_point"]["overrides"]["S.mu"] for p in again.points]
    assert mu == [0.0, 0.3]
    # a point's own file, copied to another index, is foreign there (its index and values differ)
    (pts / "00001.npz").unlink()
    shutil.copy(pts / "00000.npz", pts / "00001.npz")
    (pts / "00000.npz").unlink()
    (pts / "00000.json").write_text(json.dumps({"status": "success", "message": "", "sweep_point": None}))
    again = _sweep(tmp_path / "A")
    err = capsys.readouterr().err
    assert again.computed == 2 and "00001.npz.foreign" in err and "00000.json.foreign" in err
    assert all(p.ok and p.file.suffix == ".npz" for p in again.points)


def test_an_edited_mechanism_file_makes_old_points_foreign(tmp_path, capsys):
    from pinclear.core.models import model_path

    side = tmp_path / "pend.yaml"
    src = model_path(MODEL)
    for f in src.parent.glob(src.stem + ".*"):
        shutil.copy(f, tmp_path / f.name.replace(src.stem, "pend"))
    text = side.read_text().replace(src.stem + ".urdf", "pend.urdf")
    side.write_text(text)
    kw = dict(sim_options=SIM, load_options=LOAD, executor="serial", progress=None)
    assert pinclear.sweep(str(side), {"S.mu": [0.0]}, T_END, tmp_path / "S", **kw).computed == 1
    side.write_text(text + "\n# edited\n")
    capsys.readouterr()
    assert pinclear.sweep(str(side), {"S.mu": [0.0]}, T_END, tmp_path / "S", **kw).computed == 1
    assert "foreign" in capsys.readouterr().err


def test_two_sweeps_into_one_folder_do_not_both_compute(tmp_path):
    out = tmp_path / "S"
    out.mkdir()
    with safeio.folder_lock(out):                        # another sweep holds the folder
        with pytest.raises(InputError, match="in use by another pinclear run"):
            _sweep(out)
    assert not (out / "points").exists()
    assert _sweep(out).computed == 2                      # released: it runs


def test_workers_are_bounded_by_points_and_cpus():
    cpus = os.cpu_count() or 1
    assert sweeps.worker_count(40, 2) == min(2, cpus)
    assert sweeps.worker_count(None, 1000) == cpus
    assert sweeps.worker_count(1, 1000) == 1
    assert sweeps.worker_count(100000) == cpus


@pytest.mark.parametrize("workers,jobs", [(100000, None), (100000, 3), (None, None), (1, None)])
def test_the_one_executor_maker_never_starts_more_processes_than_cpus(monkeypatch, workers, jobs):
    """Every command's --workers (sweep, reproduce, study, analyse bifurcation) reaches the pool
    through make_executor, which caps it: `reproduce 000 --quick --workers 100000` forked more
    than 1150 processes on 2 cores."""
    asked = []

    class Spy:
        def __init__(self, max_workers, **kw):
            asked.append(max_workers)

        def shutdown(self, wait=True, cancel_futures=False):
            pass

    monkeypatch.setattr(sweeps, "ProcessPoolExecutor", Spy)
    ex, close = sweeps.make_executor(workers, jobs=jobs)
    close()
    cpus = os.cpu_count() or 1
    assert asked == [min(workers or cpus, cpus, jobs or cpus)]


def _workers_options():
    """(command, parser) of every pinclear parser that has a --workers option (introspected)."""
    import argparse

    from pinclear.cli import analyse, commands, reproduce

    found = []

    def walk(name, parser):
        for a in parser._actions:
            if "--workers" in a.option_strings:
                found.append(name)
            if isinstance(a, argparse._SubParsersAction):
                for sub, sp in a.choices.items():
                    walk(f"{name} {sub}", sp)
    walk("pinclear", commands.build_parser())
    walk("pinclear analyse", analyse.build_parser())
    walk("pinclear reproduce", reproduce.build_parser())
    return found


def test_every_workers_option_ends_in_the_one_executor_maker():
    """The class, not the case: every parser's --workers is one of the commands whose code makes
    its pool with make_executor, and no module of pinclear builds a process pool of its own."""
    import ast

    import pinclear

    assert set(_workers_options()) == {"pinclear sweep", "pinclear analyse bifurcation", "pinclear reproduce"}
    own = []
    for p in Path(pinclear.__file__).parent.rglob("*.py"):
        for n in ast.walk(ast.parse(p.read_text())):
            if isinstance(n, ast.Call) and getattr(n.func, "id", getattr(n.func, "attr", None)) == "ProcessPoolExecutor":
                own.append(p.name)
    assert own == ["sweeps.py"]


def test_a_sweep_into_a_full_disk_keeps_the_point(tmp_path, capsys, monkeypatch):
    """The point's file cannot be written (ENOSPC): a copy is written to the user cache, both
    paths are named, the index still says what happened, and a rerun computes the point again."""
    monkeypatch.setenv("PINCLEAR_CACHE_DIR", str(tmp_path / "cache"))
    out = tmp_path / "S"
    real = safeio.write_bytes

    def full(path, data, root=None):
        if Path(path).parent == out / "points" or Path(path).parent == out:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))
        return real(path, data, root)

    monkeypatch.setattr(safeio, "write_bytes", full)
    res = _sweep(out, vary={"S.mu": [0.0]})
    err = capsys.readouterr().err
    copies = list((tmp_path / "cache").glob("unsaved-runs/*/00000.npz"))
    assert len(copies) == 1 and str(copies[0]) in err and str(out / "points" / "00000.npz") in err
    assert "No space left on device" in err
    assert Trajectory.load(copies[0]).status == res.points[0].status == "success"
    monkeypatch.setattr(safeio, "write_bytes", real)
    again = _sweep(out, vary={"S.mu": [0.0]})
    assert again.computed == 1
    np.testing.assert_array_equal(Trajectory.load(again.points[0].file).q, Trajectory.load(copies[0]).q)


def test_the_lock_is_released_after_a_refused_sweep(tmp_path):
    out = tmp_path / "S"
    _sweep(out)
    with pytest.raises(InputError, match="different sweep"):
        _sweep(out, vary={"S.mu": [0.9]})
    with open(out / ".lock") as fh:                       # nobody holds it
        fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
