"""Helpers shared by the test modules (``from tests.helpers import ...``): paths, small mechanism
files, independent references and the audit check. Fixtures are in tests/conftest.py."""
from __future__ import annotations

import contextlib
import importlib.metadata
import signal
from pathlib import Path

import numpy as np
import pinocchio as pin

ROOT = Path(__file__).resolve().parents[1]
URDF_DIR = ROOT / "urdf"
DATA = Path(__file__).resolve().parent / "data"


def _double_pendulum_urdf() -> Path | None:
    """example-robot-data ships its URDFs as package data; find them through the installed
    distribution's file list rather than a hard-coded site-packages path."""
    try:
        files = importlib.metadata.files("example-robot-data") or []
    except importlib.metadata.PackageNotFoundError:
        return None
    for f in files:
        if str(f).endswith("double_pendulum_description/urdf/double_pendulum.urdf"):
            return Path(f.locate())
    return None


def kkt_singular_time(mech, a, b, law="high"):
    """Independent reference for a singular crossing of the 4-UPS/UPR: the time in [a, b] at which
    the closed chain's full constraint Jacobian (closures + drive rows, from pinclear.model.kinematics at
    the exact inverse-kinematics configuration of ``law``) has its smallest singular value."""
    from scipy.optimize import minimize_scalar

    from pinclear.mechanisms import four_ups_upr as m
    from pinclear.model import kinematics

    ws = mech.workspace()

    def smin(t):
        q = m.tree_configuration(mech.model, m.platform_pose(t, law))
        return np.linalg.svd(kinematics.jacobian(mech, ws, q, t, with_drives=True), compute_uv=False)[-1]

    return minimize_scalar(smin, bounds=(a, b), method="bounded", options={"xatol": 1e-12}).x


def clearance_states(mech, el, count, seed, spread):
    """Random (q, v, z) near the assembled pose (q moved by ``spread`` rad or m per coordinate on
    the manifold), with impact speeds z spread over 1e-4..1 m/s: many states touch the clearance."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        q = pin.integrate(mech.model, mech.q0, rng.normal(size=mech.nv) * spread)
        yield q, rng.normal(size=mech.nv), np.r_[10 ** rng.uniform(-4, 0, el.nc), 0.0]


# ------------------------------------------------------------------ shared references of the
# singular-passage tests (test_benchmark_mechanisms, test_singular_manifold, test_core_fourbar)
def energy_drift_samples(mech, traj):
    """|E - E0| / max T at every sample, energies from Pinocchio at the returned states."""
    model, data = mech.model, mech.model.createData()
    T = np.array([pin.computeKineticEnergy(model, data, q, v) for q, v in zip(traj.q, traj.v)])
    V = np.array([pin.computePotentialEnergy(model, data, q) for q in traj.q])
    E = T + V
    return np.abs(E - E[0]) / T.max()


def energy_drift(mech, traj):
    """max |E - E0| / max T over the samples (energy_drift_samples)."""
    return float(energy_drift_samples(mech, traj).max())


def a02_cranks(mech, n, traj):
    """Angles of A02's n + 1 cranks over the samples."""
    idx = [mech.model.joints[mech.model.getJointId(f"crank{k}_joint")].idx_q for k in range(n + 1)]
    return traj.q[:, idx]


def a02_branch(n, t):
    """A02's parallelogram branch as a 1-dof pendulum from the published start (closed form),
    SciPy DOP853 at rtol 1e-13 (the solve_ivp result)."""
    from scipy.integrate import solve_ivp

    from pinclear.mechanisms import benchmarks as B
    return solve_ivp(B.a02_branch_rhs(n), (0.0, t[-1]), [B.A02_THETA0, B.a02_initial_rate()], method="DOP853",
                     rtol=1e-13, atol=1e-14, t_eval=t)


def parallelogram_branch(mech, th0, t_eval, events=None):
    """The parallelogram scene's branch q = th u, u = (1, -1, 1), from rest at th0: linear in the
    joints, so Lagrange's equation of the 1-dof reduction is u^T (M(th u) u th'' + nle(th u,
    th' u)) = 0 with Pinocchio's mass matrix and bias forces, no difference quotient; SciPy
    DOP853 at rtol 1e-13 (rtol 1e-11 .. 1e-14 agree to 8e-10 over 3 s). Returns solve_ivp's
    result (y[0] = th; t_events when ``events`` is given)."""
    from scipy.integrate import solve_ivp

    model, data = mech.model, mech.model.createData()
    u = np.array([1.0, -1.0, 1.0])

    def f(_, y):
        M = pin.crba(model, data, y[0] * u)
        M = np.triu(M) + np.triu(M, 1).T
        return [y[1], -(u @ pin.nonLinearEffects(model, data, y[0] * u, y[1] * u)) / (u @ M @ u)]

    return solve_ivp(f, (0.0, t_eval[-1]), [th0, 0.0], method="DOP853", rtol=1e-13, atol=1e-15,
                     t_eval=t_eval, events=events)


def flat_passages(th):
    """Number of flat configurations (sin th changes sign) a crank angle history passes."""
    s = np.sin(th)
    return int(np.sum(np.sign(s[1:]) != np.sign(s[:-1])))


def write_sidecar(folder, doc, name="m.yaml", urdf="four_bar.urdf"):
    """A sidecar document written beside a copy of a bundled URDF (tests that edit a seed file)."""
    import yaml

    (folder / urdf).write_text((ROOT / "urdf" / urdf).read_text())
    p = folder / name
    p.write_text(yaml.safe_dump(doc))
    return p


def wear_override(path, name, **keys):
    """{"NAME.wear": mapping}: the sidecar's ``wear:`` mapping of clearance ``name`` with ``keys``
    changed, as pinclear.load's overrides (tests of one wear key of a test data file)."""
    import yaml

    doc = yaml.safe_load(Path(path).read_text())
    wear = next(c for c in doc["clearances"] if c["name"] == name)["wear"]
    return {f"{name}.wear": {**wear, **keys}}


def run_cli(argv, capsys):
    """pinclear's command line in this process: (exit code, stdout, stderr)."""
    from pinclear.cli import commands as cli

    code = cli.main(argv)
    out = capsys.readouterr()
    return code, out.out, out.err


def assert_audit_closes(tr, joint, rel=1e-6):
    """A dissipative contact run's energy audit: the joint's dissipated energy D is a real share
    (> 10 % of the energy moved), E + D stays at its start value to ``rel`` of the energy moved (the
    integration tolerance's order: the run's rtol is far below it), and D never decreases by more
    than the dense output's interpolation error."""
    E, D = tr.energy()["total"], tr.outputs[f"{joint}.dissipated"]
    scale = E[0] - E.min()
    assert D[-1] > 0.1 * scale
    assert np.max(np.abs(E + D - E[0])) < rel * scale
    # D is the integral of a power >= 0, so the exact D never decreases; the samples (dt_out) are
    # the integrator's dense output, a polynomial over each step, not the exact D. Its error on
    # a component is of the order of the local error the step-size control admits, and the
    # control bounds a norm over all n state components of err_i / (atol + rtol |y_i|) by 1 (RMS
    # for RK45; DOP853's err5^2 / sqrt(n (err5^2 + 0.01 err3^2)) <= err5 / sqrt(n)), so one
    # component alone may carry sqrt(n) (atol + rtol |D|). Two neighbouring samples can be off in
    # opposite directions: a fall of up to 2 sqrt(n) (atol + rtol max|D|) is interpolation, not
    # physics. It happens where the contact ends inside a step (the power's kink at separation:
    # the polynomial overshoots the plateau): measured, 2.7e-13 J in the worn bearing (D 0.052 J,
    # bound 3.5e-11 J) and 7.4e-11 J in the worn socket (D 0.49 J, bound 3.8e-10 J) at rtol 1e-10.
    # The bound stays tight against energy creation: 3.8e-10 J over one sample interval (1e-5 s)
    # is 4e-5 W, 4e-6 of those runs' mean dissipated power (~10 W); a friction or damping term
    # of the wrong sign falls by its whole power times dt_out at every sample.
    rtol = tr.meta["rtol"] or 0.0
    atol = float(np.max(tr.meta["atol"])) if tr.meta["atol"] is not None else 0.0
    n = tr.q.shape[1] + tr.v.shape[1] + tr.z.shape[1]
    interpolation = 2.0 * np.sqrt(n) * (atol + rtol * np.max(np.abs(D)))
    assert np.all(np.diff(D) >= -interpolation), (np.diff(D).min(), interpolation)


@contextlib.contextmanager
def alarm(seconds, what="case"):
    """Raise TimeoutError in the main thread after ``seconds``: a hang becomes a failure that
    names itself instead of a stalled suite (the fuzz tests' per-example bound)."""
    def boom(signum, frame):
        raise TimeoutError(f"{what} exceeded {seconds} s")
    old = signal.signal(signal.SIGALRM, boom)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def element_force(mech, q, v, z=None):
    """(tau, zdot, outputs) of the mechanism's last force element alone at (q, v, z): its
    generalized force and state rates from one add_force call (z defaults to zeros)."""
    from pinclear.model import kinematics

    el = mech.forces[-1]
    ws = mech.workspace()
    d = ws.force_data[-1]
    kinematics.update(mech, ws, q, v)
    z = np.zeros(el.nz) if z is None else z
    tau, zdot = np.zeros(mech.model.nv), np.zeros(el.nz)
    el.add_force(mech, ws, d, 0.0, q, v, z, tau, zdot)
    return tau, zdot, el.outputs(mech, ws, d, 0.0, q, v, z)


def assert_same_element_force(a, b, states, rel=1e-12):
    """The last force elements of mechanisms ``a`` and ``b`` give the same generalized force and
    state rates, to ``rel`` of b's largest, at every (q, v) of ``states``."""
    for q, v in states:
        ta, za, _ = element_force(a, q, v)
        tb, zb, _ = element_force(b, q, v)
        assert np.max(np.abs(ta - tb)) <= rel * max(np.abs(tb).max(), 1e-300), (q, v)
        assert np.max(np.abs(za - zb)) <= rel * max(np.abs(zb).max(), 1e-300), (q, v)
