"""Parameter sweeps (pinclear.sweep / pinclear sweep): the grid, executors that give identical
results, resume after a kill, failed and impossible points recorded with their reasons."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

import pinclear
from pinclear.analysis.sweeps import grid, parse_vary
from pinclear.core.errors import InputError
from pinclear.dynamics.trajectory import Trajectory

# a pendulum on a spherical joint with clearance and Coulomb friction: cheap, with impacts; friction and
# clearance both change its motion, so every point's trajectory differs from the others
MODEL, LOAD = "clr_pendulum", {"clearances": ["S"], "overrides": {"S.friction_law": "coulomb", "S.mu": 0.1}}
VARY = {"S.mu": [0.0, 0.3], "S.clearance": [1e-4, 2e-4]}
SIM = {"rtol": 1e-6, "dt_out": 1e-3}
T_END = 0.03


def _arrays(res):
    return [(p.overrides, p.status, Trajectory.load(p.file).q) for p in res.points]


def _same(a, b):
    assert len(a) == len(b)
    for (ova, sa, qa), (ovb, sb, qb) in zip(a, b):
        assert ova == ovb and sa == sb
        np.testing.assert_array_equal(qa, qb)          # bit-identical, wherever it ran


def test_grid_and_vary_syntax():
    assert parse_vary("S2.mu=0:0.2:3") == ("S2.mu", [0.0, 0.1, 0.2])
    assert parse_vary("S2.clearance=1e-5:1e-3:3:log")[1] == pytest.approx([1e-5, 1e-4, 1e-3], rel=1e-12)
    assert parse_vary("law=flores,gonthier") == ("law", ["flores", "gonthier"])
    g = grid({"a": [1, 2], "b": [10, 20, 30]})
    assert len(g) == 6 and g[0] == {"a": 1, "b": 10} and g[1] == {"a": 1, "b": 20} and g[-1] == {"a": 2, "b": 30}
    for bad in ("S2.mu", "S2.mu=0:1", "S2.mu=0:1:0", "S2.mu=0:1:3:cubic", "S2.mu=-1:1:3:log"):
        with pytest.raises(InputError, match="--vary"):
            parse_vary(bad)


@pytest.mark.slow
def test_process_pool_and_dask_cluster_give_identical_points(tmp_path):
    distributed = pytest.importorskip("distributed")
    serial = pinclear.sweep(MODEL, VARY, T_END, tmp_path / "serial", sim_options=SIM, load_options=LOAD,
                            executor="serial", progress=None)
    pool = pinclear.sweep(MODEL, VARY, T_END, tmp_path / "pool", sim_options=SIM, load_options=LOAD, workers=2,
                          progress=None)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  host="127.0.0.1") as cluster, distributed.Client(cluster) as client:
        dask = pinclear.sweep(MODEL, VARY, T_END, tmp_path / "dask", sim_options=SIM, load_options=LOAD,
                              executor=client.get_executor(), progress=None)
    assert all(p.ok for p in serial.points) and serial.computed == 4
    _same(_arrays(serial), _arrays(pool))
    _same(_arrays(serial), _arrays(dask))
    # the points differ from each other: friction and clearance both change the motion
    q = [t for _, _, t in _arrays(serial)]
    assert min(np.abs(q[i] - q[j]).max() for i in range(4) for j in range(i)) > 1e-9


class _Kill(Exception):
    pass


def test_a_killed_sweep_resumes_with_only_the_rest_and_identical_results(tmp_path):
    whole = pinclear.sweep(MODEL, VARY, T_END, tmp_path / "whole", sim_options=SIM, load_options=LOAD,
                           executor="serial", progress=None)

    def kill_after_two(done, total, point):
        if done == 2:
            raise _Kill                                  # the process dies after writing 2 points
    with pytest.raises(_Kill):
        pinclear.sweep(MODEL, VARY, T_END, tmp_path / "cut", sim_options=SIM, load_options=LOAD,
                       executor="serial", progress=kill_after_two)
    assert len(list((tmp_path / "cut" / "points").glob("*.npz"))) == 2
    seen = []
    rest = pinclear.sweep(MODEL, VARY, T_END, tmp_path / "cut", sim_options=SIM, load_options=LOAD,
                          executor="serial", progress=lambda d, n, p: seen.append(p.index))
    assert rest.computed == 2 and sorted(seen) == [2, 3]
    _same(_arrays(whole), _arrays(rest))
    # a different sweep is never mixed into that folder
    with pytest.raises(InputError, match="different sweep.*t_end"):
        pinclear.sweep(MODEL, VARY, 2 * T_END, tmp_path / "cut", sim_options=SIM, load_options=LOAD,
                       executor="serial", progress=None)


def test_failed_and_impossible_points_keep_their_reasons(tmp_path):
    """A clearance below zero cannot be built ('error', reason kept, not recomputed); a CPU budget
    of 1 ns stops the other run after its first step ('failed', its samples kept)."""
    vary = {"S.clearance": [1e-4, -1e-4]}
    res = pinclear.sweep(MODEL, vary, T_END, tmp_path / "s", sim_options={**SIM, "max_cpu": 1e-9},
                         load_options=LOAD, executor="serial", progress=None)
    bad = res.points[1]
    assert bad.status == "error" and "clearance" in bad.message and bad.file.suffix == ".json"
    with pytest.raises(InputError, match="has no trajectory"):
        bad.trajectory()
    first = res.points[0]
    assert first.status == "failed" and "max_cpu" in first.message
    tr = first.trajectory()
    assert tr.status == "failed" and len(tr.t) >= 1               # the samples computed are kept
    index = json.loads((tmp_path / "s" / "sweep.json").read_text())
    assert [s["status"] for s in index["status"]] == ["failed", "error"]
    again = pinclear.sweep(MODEL, vary, T_END, tmp_path / "s", sim_options={**SIM, "max_cpu": 1e-9},
                           load_options=LOAD, executor="serial", progress=None)
    assert again.computed == 0


@pytest.mark.slow
def test_cli_sweep_writes_the_folder_and_reports_failures(tmp_path):
    out = tmp_path / "cli"
    cmd = [sys.executable, "-m", "pinclear.cli", "sweep", MODEL, "--clearance", "S", "--set",
           "S.friction_law=coulomb", "--vary", "S.mu=0:0.2:2", "--vary", "S.clearance=1e-4,-1", "--t-end", "0.01",
           "--out", str(out), "--workers", "2"]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    report = json.loads(r.stdout.strip().splitlines()[-1])
    assert r.returncode == 1, r.stderr                      # failures are reported by the exit code
    assert report["points"] == 4 and report["status"] == {"success": 2, "error": 2}
    assert all(f["point"]["S.clearance"] == -1 for f in report["failures"])
    r2 = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert json.loads(r2.stdout.strip().splitlines()[-1])["computed_now"] == 0
    bad = subprocess.run(cmd[:-4] + ["--vary", "S.nonsense=1,2", "--t-end", "0.01", "--out", str(tmp_path / "x")],
                         capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2 and "nonsense" in bad.stderr and len(bad.stderr.strip().splitlines()) == 1
