"""Time laws (exact derivatives, shared evaluation) and bad input: model files, simulate()
arguments, and the command line (exit status, one-line message, no traceback)."""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

import pinclear
from pinclear.cli import commands as cli
from pinclear.model import kinematics
from pinclear.model.timelaws import (
    Callable,
    Constant,
    Polynomial,
    Sines,
    Spline,
    build_law,
)
from tests.helpers import DATA, ROOT, URDF_DIR


# ---------------------------------------------------------------------------- 9. time laws
def _fd_check(law, ts, h=1e-5, rtol=1e-7):
    """First and second derivatives against central differences of the value and of the first
    derivative (O(h^2) truncation, roundoff ~1e-16/h)."""
    for t in ts:
        y, yd, ydd = law.eval(t)
        yp, ydp, _ = law.eval(t + h)
        ym, ydm, _ = law.eval(t - h)
        scale = max(1.0, abs(y), abs(yd), abs(ydd))
        assert yd == pytest.approx((yp - ym) / (2 * h), abs=rtol * scale), f"{law.describe()} at t={t}"
        assert ydd == pytest.approx((ydp - ydm) / (2 * h), abs=rtol * scale), f"{law.describe()} at t={t}"


TS = [0.0, 0.13, 0.77, 1.4, 2.9]


def test_constant_law():
    law = build_law({"type": "constant", "value": 0.25})
    assert isinstance(law, Constant)
    for t in TS:
        assert law.eval(t) == (0.25, 0.0, 0.0)
    assert build_law(0.25).eval(3.0) == (0.25, 0.0, 0.0)


def test_sines_law_values_and_derivatives():
    spec = {"type": "sines", "offset": 0.3,
            "terms": [{"amp": 1.2, "omega": 2.0, "phase": 0.4, "kind": "sin"},
                      {"amp": -0.5, "omega": 7.0, "phase": -1.0, "kind": "cos"}]}
    law = build_law(spec, "f.yaml", "drives[0].law")
    assert isinstance(law, Sines)
    for t in TS:
        ref = 0.3 + 1.2 * math.sin(2.0 * t + 0.4) - 0.5 * math.cos(7.0 * t - 1.0)
        assert law.eval(t)[0] == pytest.approx(ref, abs=1e-14)
    _fd_check(law, TS)


def test_polynomial_law():
    c = [0.5, -1.0, 0.25, 0.125]
    law = build_law({"type": "polynomial", "coeffs": c})
    assert isinstance(law, Polynomial)
    for t in TS:
        y, yd, ydd = law.eval(t)
        assert y == pytest.approx(c[0] + c[1] * t + c[2] * t**2 + c[3] * t**3, abs=1e-14)
        assert yd == pytest.approx(c[1] + 2 * c[2] * t + 3 * c[3] * t**2, abs=1e-14)
        assert ydd == pytest.approx(2 * c[2] + 6 * c[3] * t, abs=1e-13)


def test_spline_law_is_exact_on_a_cubic_and_smooth_elsewhere():
    """A not-a-knot cubic spline through samples of a cubic is that cubic: value and both
    derivatives exact; on other data its derivatives are those of the interpolant itself."""
    tk = np.linspace(0.0, 3.0, 7)
    cubic = lambda t: 1.0 - 0.5 * t + 0.3 * t**2 - 0.2 * t**3        # noqa: E731
    law = build_law({"type": "spline", "t": tk.tolist(), "y": cubic(tk).tolist()})
    assert isinstance(law, Spline)
    for t in [0.05, 0.7, 1.61, 2.99]:
        y, yd, ydd = law.eval(t)
        assert y == pytest.approx(cubic(t), abs=1e-12)
        assert yd == pytest.approx(-0.5 + 0.6 * t - 0.6 * t**2, abs=1e-11)
        assert ydd == pytest.approx(0.6 - 1.2 * t, abs=1e-10)
    law2 = build_law({"type": "spline", "t": tk.tolist(), "y": np.sin(3 * tk).tolist()})
    for tt, yy in zip(tk, np.sin(3 * tk)):
        assert law2.eval(tt)[0] == pytest.approx(yy, abs=1e-14)     # interpolates the table
    _fd_check(law2, [0.21, 0.9, 1.77, 2.6], rtol=1e-6)             # off the knots


def _osc(t, amp=1.0, w=3.0):
    return amp * math.sin(w * t), amp * w * math.cos(w * t), -amp * w * w * math.sin(w * t)


CALLS: list = []


def shared_ik(t, scale=1.0):
    """A vector law (e.g. all limb lengths from one inverse kinematics): counts its calls."""
    CALLS.append(t)
    y = scale * np.array([np.sin(t), t**2, np.exp(0.5 * t)])
    yd = scale * np.array([np.cos(t), 2 * t, 0.5 * np.exp(0.5 * t)])
    ydd = scale * np.array([-np.sin(t), 2.0, 0.25 * np.exp(0.5 * t)])
    return y, yd, ydd


def test_python_law_plain_callable():
    law = build_law(lambda t: _osc(t, 0.7, 2.0))
    assert isinstance(law, Callable)
    _fd_check(law, TS)
    law = Callable(_osc, {"amp": 0.2, "w": 5.0})
    assert law.eval(0.4)[0] == pytest.approx(0.2 * math.sin(2.0))


def test_python_law_with_index_evaluates_once_per_time():
    from pinclear.model.drives import Drive, DriveRows

    spec = {"type": "python", "function": "tests.io.test_core_input:shared_ik", "args": {"scale": 2.0}}
    laws = [build_law(dict(spec, index=k), "f.yaml", f"drives[{k}].law", trust=True) for k in range(3)]
    rows = DriveRows([Drive(f"d{k}", f"j{k}", k, k, law) for k, law in enumerate(laws)], 3)
    data = rows.create_data()        # the shared value lives in the workspace's drive data
    CALLS.clear()
    for t in (0.1, 0.35, 0.35, 1.2):
        f = rows.values(t, data)
        vals = [tuple(f[:, k]) for k in range(3)]
        y, yd, ydd = shared_ik(t, 2.0)
        CALLS.pop()                                             # the reference call above
        for k, val in enumerate(vals):
            assert val == pytest.approx((y[k], yd[k], ydd[k]), abs=1e-14)
    # once per evaluation for the three drives sharing it (no value kept by time: a run's
    # compiled stages write the same buffer, pinclear.model.drives)
    assert CALLS == [0.1, 0.35, 0.35, 1.2]
    for law in laws:
        _fd_check(law, [0.3, 1.1])


def test_python_law_through_drives_in_a_simulation(double_pendulum_urdf, sim):
    """Both joints of the double pendulum driven by components of ONE vector law: the law is
    evaluated once per evaluation (two separate laws would cost two calls each), and the motion
    follows it."""
    from pinclear.model.drives import Drive

    def law2(t):
        CALLS.append(t)
        return (np.array([0.3 * np.sin(2 * t), 0.2 * t]), np.array([0.6 * np.cos(2 * t), 0.2]),
                np.array([-1.2 * np.sin(2 * t), 0.0]))

    mech = pinclear.load(double_pendulum_urdf)
    model = mech.model
    drives = []
    for k, name in enumerate(model.names[1:]):
        jm = model.joints[model.getJointId(name)]
        drives.append(Drive(f"d{k}", name, jm.idx_q, jm.idx_v, Callable(law2, index=k)))
    mech = mech.replace(drives=drives)
    CALLS.clear()
    traj = sim(mech, 0.3, method="lagrange", integrator="RK45", rtol=1e-9, dt_out=0.05,
               q0=np.zeros(2), v0=np.array([0.6, 0.2]))
    assert traj.status == "success"
    np.testing.assert_allclose(traj.q[:, 0], 0.3 * np.sin(2 * traj.t), atol=1e-8)
    np.testing.assert_allclose(traj.q[:, 1], 0.2 * traj.t, atol=1e-8)
    # once per right-hand side, plus the samples' output evaluations (at most two per sample)
    n = traj.stats["rhs_evals"]
    assert n <= len(CALLS) <= n + 2 * len(traj.t) < 2 * n


def test_law_spec_errors_name_key_and_choices():
    with pytest.raises(pinclear.ModelFileError) as e:
        build_law({"type": "sine", "offset": 0}, "m.yaml", "drives[0].law")
    msg = str(e.value)
    assert "m.yaml" in msg and "drives[0].law.type" in msg and "sines" in msg and "polynomial" in msg
    with pytest.raises(pinclear.ModelFileError, match=r"drives\[0\]\.law\.terms\[0\]\.freq.*omega"):
        build_law({"type": "sines", "terms": [{"amp": 1, "freq": 2}]}, "m.yaml", "drives[0].law")
    with pytest.raises(pinclear.ModelFileError, match="cannot import"):
        build_law({"type": "python", "function": "no_such_module_xyz:f"}, "m.yaml", "law", trust=True)
    with pytest.raises(pinclear.ModelFileError, match=r"law\.coeffs"):
        build_law({"type": "polynomial"}, "m.yaml", "law")


# ---------------------------------------------------------------------------- 10. bad files
def test_malformed_urdf():
    for path in (DATA / "core_malformed_urdf.yaml", DATA / "core_malformed.urdf"):
        with pytest.raises(pinclear.ModelFileError) as e:
            pinclear.load(path)
        assert "core_malformed.urdf" in str(e.value)
        assert e.value.key == "urdf"


def test_unknown_frame_names_file_key_and_choices():
    with pytest.raises(pinclear.ModelFileError) as e:
        pinclear.load(DATA / "core_bad_frame.yaml")
    err = e.value
    assert "core_bad_frame.yaml" in str(err) and err.key == "closures[0].frame1"
    assert "coupler_tip" in str(err)
    assert {"coupler", "rocker", "crank"} <= set(err.choices)


def test_unknown_key_names_file_key_and_choices():
    with pytest.raises(pinclear.ModelFileError) as e:
        pinclear.load(DATA / "core_bad_key.yaml")
    err = e.value
    assert "core_bad_key.yaml" in str(err) and err.key == "closures[0].frame_2"
    assert "frame2" in str(err) and "valid:" in str(err)


def test_other_sidecar_errors(tmp_path):
    base = (URDF_DIR / "four_bar.yaml").read_text()
    cases = {
        "type: planar_point": ("type: hinge", "closures[0].type", "revolute"),
        "gravity: [0.0, -9.81, 0.0]": ("gravity: [0.0, -9.81]", "gravity", None),
        "name: four_bar\n": ("name: four_bar\ngravty: [0, 0, -9.81]\n", "gravty", "gravity"),
        "v: {crank_joint: 2.0}": ("v: {crank: 2.0}", "initial.v.crank", "crank_joint"),
    }
    for old, (new, key, choice) in cases.items():
        f = tmp_path / "case.yaml"
        f.write_text(base.replace("urdf: four_bar.urdf", f"urdf: {URDF_DIR / 'four_bar.urdf'}").replace(old, new, 1))
        with pytest.raises(pinclear.ModelFileError) as e:
            pinclear.load(f)
        assert str(f) in str(e.value) and e.value.key == key, str(e.value)
        if choice:
            assert choice in e.value.choices
    f = tmp_path / "broken.yaml"
    f.write_text("name: [unclosed\n")
    with pytest.raises(pinclear.ModelFileError, match="YAML"):
        pinclear.load(f)


def test_loop_that_cannot_assemble():
    mech = pinclear.load(DATA / "core_no_assembly.yaml")
    with pytest.raises(pinclear.AssemblyError) as e:
        kinematics.assemble(mech)
    # geometric lower bound: the coupler tip stays within 0.45 m of the crank pivot, the rocker
    # point at least 0.6 m from it, so |p1 - p2| >= 0.15 and its largest component >= 0.15/sqrt2
    assert e.value.residual >= 0.15 / math.sqrt(2) - 1e-9
    assert f"{e.value.residual:.3e}" in str(e.value) and "residual" in str(e.value)
    with pytest.raises(pinclear.AssemblyError):
        pinclear.simulate(mech, 0.1)


# ---------------------------------------------------------------------------- 10. bad arguments
@pytest.mark.parametrize("kw, words", [
    (dict(integrator="RK4", h=-1e-3), ["h", "positive"]),
    (dict(integrator="RK4"), ["RK4", "h"]),
    (dict(rtol=-1e-6), ["rtol", "positive"]),
    (dict(rtol=0.0), ["rtol"]),
    (dict(atol=-1.0), ["atol"]),
    (dict(t_end=0.0), ["t_end"]),
    (dict(t_end=-1.0), ["t_end"]),
    (dict(t_end=float("nan")), ["t_end"]),
    (dict(method="lagrangian"), ["lagrangian", "lagrange", "projection", "pinocchio", "proximal"]),
    (dict(integrator="rk45"), ["rk45", "RK45", "DOP853", "Radau", "BDF", "LSODA", "RK4"]),
    (dict(method="lagrange", alpah=3.0), ["alpah", "alpha", "beta"]),
    (dict(method="projection", integrator="LSODA"), ["LSODA", "projection"]),
    (dict(dt_out=-0.1), ["dt_out"]),
])
def test_bad_simulate_arguments(four_bar, kw, words):
    kw = dict(kw)
    t_end = kw.pop("t_end", 0.1)
    with pytest.raises(pinclear.InputError) as e:
        pinclear.simulate(four_bar, t_end, **kw)
    for w in words:
        assert w in str(e.value)


# ---------------------------------------------------------------------------- 10. CLI
def _one_line_error(capsys, argv, *words):
    rc = cli.main(argv)
    out, err = capsys.readouterr()
    assert rc == 2, (rc, out, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pinclear: error: "), err
    assert "Traceback" not in err
    for w in words:
        assert w in lines[0]


def test_cli_errors_in_process(capsys, tmp_path):
    out = str(tmp_path / "out")
    sim = ["simulate", "--t-end", "0.1", "--out", out]
    _one_line_error(capsys, sim + [str(DATA / "core_bad_key.yaml")], "core_bad_key.yaml", "frame_2", "frame2")
    _one_line_error(capsys, sim + [str(DATA / "core_bad_frame.yaml")], "coupler_tip", "closures[0].frame1")
    _one_line_error(capsys, sim + [str(DATA / "core_no_assembly.yaml")], "residual")
    four = str(URDF_DIR / "four_bar.yaml")
    _one_line_error(capsys, sim + [four, "--method", "nope"], "nope", "lagrange")
    _one_line_error(capsys, sim + [four, "--integrator", "Euler"], "Euler", "RK45")
    _one_line_error(capsys, sim + [four, "--rtol=-1e-6"], "rtol")
    _one_line_error(capsys, ["simulate", four, "--t-end", "-1", "--out", out], "--t-end", "positive")
    _one_line_error(capsys, sim + [four, "--integrator", "RK4", "--h=-0.01"], "h", "positive")
    _one_line_error(capsys, sim + [str(tmp_path / "missing.yaml")], "missing.yaml", "no such file")
    assert not (tmp_path / "out" / "trajectory.npz").exists()


def test_cli_subprocess_exit_status_and_single_line():
    """The installed entry point, as a user runs it: exit 2, one line, no traceback."""
    r = subprocess.run([sys.executable, "-m", "pinclear.cli", "simulate", str(DATA / "core_bad_key.yaml"),
                        "--t-end", "1", "--out", "/nonexistent/never_written"],
                       capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pinclear: error: ") and "frame_2" in lines[0], r.stderr
    assert "Traceback" not in r.stderr and r.stdout == ""


def test_cli_malformed_urdf_single_line():
    r = subprocess.run([sys.executable, "-m", "pinclear.cli", "simulate", str(DATA / "core_malformed_urdf.yaml"),
                        "--t-end", "1", "--out", "/nonexistent/never_written"],
                       capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.returncode == 2
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("pinclear: error: ") and "core_malformed.urdf" in lines[0], r.stderr
