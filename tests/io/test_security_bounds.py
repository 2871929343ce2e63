"""Hostile round 4 (issue 42): network waits that end, outputs bounded before allocating, saved
results read back as data, and a URDF construct pinclear cannot model refused. One test per
class of the audit; each would hang, crash or give a traceback on the code before the fix."""
from __future__ import annotations

import socket
import threading

import numpy as np
import pytest

import pinclear
import pinclear.analysis as an
from pinclear.core.errors import InputError, ModelFileError
from tests.helpers import run_cli


def _listener(answer: bytes | None):
    """A TCP server on 127.0.0.1 that accepts and then says nothing (None) or sends ``answer``."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    conns = []

    def serve():
        while True:
            try:
                c, _ = srv.accept()
            except OSError:
                return
            conns.append(c)
            if answer:
                c.sendall(answer)
    threading.Thread(target=serve, daemon=True).start()
    return srv, conns


@pytest.mark.slow
@pytest.mark.parametrize("answer", [None, b"\xff" * 64], ids=["silent", "garbage"])
def test_a_dask_scheduler_that_never_answers_or_answers_garbage_is_one_line(answer, monkeypatch):
    pytest.importorskip("distributed")
    from pinclear.analysis import sweeps

    monkeypatch.setattr(sweeps, "SCHEDULER_TIMEOUT_S", 1.0)
    srv, _ = _listener(answer)
    try:
        with pytest.raises(InputError, match="cannot reach a Dask scheduler") as e:
            sweeps.make_executor(scheduler=f"tcp://127.0.0.1:{srv.getsockname()[1]}")
    finally:
        srv.close()
    assert "\n" not in str(e.value)


def test_a_viewer_url_nobody_answers_on_ends_with_one_line(capsys, monkeypatch):
    """`pinclear view four_bar --zmq-url tcp://127.0.0.1:PORT --no-block` blocked forever."""
    pytest.importorskip("meshcat")
    import pinclear.viz as viz

    monkeypatch.setattr(viz, "ZMQ_TIMEOUT_S", 1.0)
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    port = srv.getsockname()[1]
    srv.close()                                            # a free port: nobody listens
    code, _, err = run_cli(["view", "four_bar", "--zmq-url", f"tcp://127.0.0.1:{port}", "--no-block"], capsys)
    assert code == 2 and "no meshcat server answered" in err and len(err.strip().splitlines()) == 1


@pytest.fixture(scope="module")
def run():
    return pinclear.simulate(pinclear.load("four_bar"), 0.2, dt_out=0.01)


def test_a_tiny_poincare_period_is_refused_before_allocating(run, tmp_path, capsys):
    """21 samples over 0.2 s: a 1e-9 s period asked for 2e8 section points (23 GB on the audit's
    longer run). The bound: 4 per sample + 1000."""
    with pytest.raises(InputError, match=r"section points.*21 samples.*at most 1084"):
        an.poincare(run, 1e-9, "crank_joint")
    with pytest.raises(InputError, match="section points"):
        an.poincare(run, 5e-324, "crank_joint")               # the count overflows to inf
    sec = an.poincare(run, 0.2 / 1084, "crank_joint")          # at the bound: computed
    assert len(sec) <= 1085
    with pytest.raises(InputError, match="refused before allocating"):
        an.section_times(0.1, 10 ** 12)
    npz = run.save(tmp_path / "run.npz")
    code, _, err = run_cli(["analyse", "poincare", str(npz), "--period", "1e-9", "--signal", "crank_joint",
                            "--out", str(tmp_path / "a")], capsys)
    assert code == 2 and "section points" in err


def _bifurcation_file(tmp_path):
    from pinclear.analysis.poincare import PoincareSection

    k = np.arange(3)
    sec = PoincareSection(k, k * 0.1, np.sin(k), np.cos(k), 0.1, 0.0, "slide", np.zeros(3, bool), True,
                          np.ones(3))
    runs = [an.BifurcationRun(0, 1.0, "success", "", {"slide": sec})]
    res = an.BifurcationResult("k", np.array([1.0]), runs, ["slide"], np.array([0.1]))
    return res.save(tmp_path / "bif.npz")


def test_bifurcation_result_load_reads_as_data(tmp_path):
    path = _bifurcation_file(tmp_path)
    back = an.BifurcationResult.load(path)
    np.testing.assert_array_equal(back.runs[0].sections["slide"].x, np.sin(np.arange(3)))
    data = path.read_bytes()
    (tmp_path / "cut.npz").write_bytes(data[: len(data) // 2])
    with pytest.raises(InputError, match="cut.npz"):
        an.BifurcationResult.load(tmp_path / "cut.npz")
    # a member declaring 32 GB: refused from its header, before allocation
    import io
    import zipfile

    head = io.BytesIO()
    np.lib.format.write_array_header_1_0(head, {"descr": "<f8", "fortran_order": False, "shape": (1 << 32,)})
    with zipfile.ZipFile(tmp_path / "big.npz", "w") as z:
        z.writestr("meta.npy", head.getvalue())
    with pytest.raises(InputError, match="big.npz.*refused before loading"):
        an.BifurcationResult.load(tmp_path / "big.npz")
    # a foreign NPZ whose metadata is not a bifurcation result
    run = pinclear.simulate(pinclear.load("four_bar"), 0.02).save(tmp_path / "traj.npz")
    with pytest.raises(InputError, match="traj.npz: not a readable bifurcation result"):
        an.BifurcationResult.load(run)


def test_a_urdf_mimic_joint_is_refused(tmp_path):
    link = ('<link name="{}"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" '
            'ixz="0" iyz="0"/></inertial></link>')
    joint = ('<joint name="{}" type="revolute"><parent link="{}"/><child link="{}"/><axis xyz="0 0 1"/>'
             '<limit lower="-3" upper="3" effort="1" velocity="1"/>{}</joint>')
    body = (link.format("base") + link.format("a") + link.format("b") + joint.format("j1", "base", "a", "")
            + joint.format("j2", "base", "b", '<mimic joint="j1" multiplier="2"/>'))
    (tmp_path / "m.urdf").write_text(f'<?xml version="1.0"?><robot name="m">{body}</robot>')
    (tmp_path / "m.yaml").write_text("name: m\nurdf: m.urdf\n")
    with pytest.raises(ModelFileError, match=r"m\.urdf: joint 'j2'\.mimic: couples the joint to 'j1'"):
        pinclear.load(tmp_path / "m.yaml")


# ------------------------------------------------------------------ silent wrong results
def test_a_fixed_step_run_with_a_huge_step_fails_with_its_samples(tmp_path, capsys):
    """`simulate four_bar --integrator RK4 --h 10` ended success with a 0.999 m closure residual.
    Each criterion of the check on its own case: the residual (four-bar, h = 10), the energy
    balance (parallelogram, no closure residual to see: h = 10 gives 0.57 of its energy scale),
    the step-doubling estimate (four-bar, h = 0.1: the run at 2h is unstable). At h = 1e-3 the
    estimate is ~2e-8, far below the tolerance, and the run succeeds."""
    code, out, err = run_cli(["simulate", "four_bar", "--integrator", "RK4", "--h", "10", "--t-end", "1",
                              "--out", str(tmp_path / "o"), "--progress", "off"], capsys)
    assert code == 1 and '"status": "failed"' in out
    tr = pinclear.Trajectory.load(tmp_path / "o" / "trajectory.npz")
    assert tr.failure[0] == "fixed step too large" and "closure residual" in tr.message and len(tr.t) == 501
    with pytest.warns(RuntimeWarning, match="energy balance"):
        par = pinclear.simulate(pinclear.load("parallelogram"), 1.0, integrator="RK4", h=10.0)
    assert par.status == "failed" and par.stats["fixed_step_check"]["energy"] > 0.1
    with pytest.warns(RuntimeWarning, match="step-doubling"):
        fb = pinclear.simulate(pinclear.load("four_bar"), 1.0, integrator="RK4", h=0.1)
    assert fb.status == "failed"
    ok = pinclear.simulate(pinclear.load("four_bar"), 1.0, integrator="RK4", h=1e-3)
    check = ok.stats["fixed_step_check"]
    assert ok.status == "success" and check["step_doubling"] < 1e-6 and check["residual"] < 1e-6
    off = pinclear.simulate(pinclear.load("four_bar"), 1.0, integrator="RK4", h=10.0, fixed_step_tol=None)
    assert off.status == "success" and "fixed_step_check" not in off.stats


@pytest.mark.parametrize("argv, words", [
    (["--set", "S1.mu=0.1", "--set", "S1.mu=0.2"], ["--set S1.mu=0.1", "S1.mu=0.2", "contradict"]),
    (["--option", "limbs=true", "--set", "limbs=false"], ["--option limbs=True", "--set limbs=False"]),
])
def test_contradicting_options_are_refused_naming_both(tmp_path, capsys, argv, words):
    code, _, err = run_cli(["simulate", "four_bar", "--t-end", "0.01", "--out", str(tmp_path / "o")] + argv, capsys)
    assert code == 2, err
    for w in words:
        assert w in err


def test_a_key_both_varied_and_fixed_in_a_sweep_is_refused(tmp_path, capsys):
    code, _, err = run_cli(["sweep", "clr_pendulum", "--clearance", "S", "--set", "S.mu=0.1", "--vary",
                            "S.mu=0,0.2", "--t-end", "0.01", "--out", str(tmp_path / "s")], capsys)
    assert code == 2 and "--set S.mu=0.1" in err and "--vary" in err
    code, _, err = run_cli(["sweep", "clr_pendulum", "--clearance", "S", "--vary", "S.mu=0,0.2", "--vary",
                            "S.mu=0.5", "--t-end", "0.01", "--out", str(tmp_path / "s")], capsys)
    assert code == 2 and "varied twice" in err


def test_the_fixed_step_tolerance_on_the_command_line(tmp_path, capsys):
    """--fixed-step-tol 0 turns the check off; a tolerance below the run's estimates fails it
    (four-bar, h = 1e-2: estimate 1.2e-4, residual 1.8e-5 m, both above 1e-6)."""
    base = ["simulate", "four_bar", "--integrator", "RK4", "--t-end", "1", "--progress", "off"]
    code, out, _ = run_cli(base + ["--h", "10", "--fixed-step-tol", "0", "--out", str(tmp_path / "a")], capsys)
    assert code == 0 and '"status": "success"' in out
    code, _, err = run_cli(base + ["--h", "0.01", "--fixed-step-tol", "1e-6", "--out", str(tmp_path / "b")], capsys)
    assert code == 1 and "step-doubling error estimate" in err and "fixed_step_tol = 1e-06" in err
