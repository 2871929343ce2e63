"""The energy audit (pinclear.dynamics.energy) and the energy properties of the clearance contacts.

Property tests (Hypothesis): the spherical (clr_ball, clr_pendulum), planar revolute
(clr_planar_pendulum) and spatial revolute (clr_hinge) clearances, for every normal law and every
friction law, from random states inside the gap with random velocities and gravity off:

* every normal law with ce = 1 (its hysteresis factor chi is then 0: elastic) and no friction
  conserves T + V_el to the bound the audit derives from rtol and the steps;
* damped laws (ce < 1) with every friction law: the balance closes, the dissipated energy never
  decreases and T + V_el never grows (to the same bound).

Mutation checks: a law whose stiffness switches with the sense of the normal motion, and an
element that pushes without reporting its power, must fail the audit; a joint force that reports
its power, and the drives of nine_bar, must not.

Hypothesis profiles: the default runs 5 examples per parametrized case (554 generated cases in
all, about a minute on one core); ``HYPOTHESIS_PROFILE=ci`` runs 15 (1670).
"""
from __future__ import annotations

import os
import warnings

import numpy as np
import pytest

import pinclear
from pinclear.contact.laws import FRICTION_LAWS, HYSTERESIS, NormalLaw, make_normal_law
from pinclear.contact.spherical import SphericalClearance
from pinclear.model.forces import ForceElement, JointForce
from pinclear.model.timelaws import build_law

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

settings.register_profile("energy-default", max_examples=5, deadline=None, derandomize=True,
                          suppress_health_check=list(HealthCheck))
settings.register_profile("energy-ci", max_examples=15, deadline=None, derandomize=True,
                          suppress_health_check=list(HealthCheck))
PROFILE = settings.get_profile("energy-ci" if os.environ.get("HYPOTHESIS_PROFILE") == "ci" else "energy-default")

#: scene, clearance, its type
SCENES = [("clr_ball", "S", "spherical"), ("clr_pendulum", "S", "spherical"),
          ("clr_planar_pendulum", "A", "planar_revolute"), ("clr_hinge", "R", "revolute")]
#: normal laws of each joint type: the damped power laws, and the line law for journals (the plane
#: law needs a prismatic face)
POWER_LAWS = tuple(HYSTERESIS)
LAWS = {"spherical": POWER_LAWS, "planar_revolute": POWER_LAWS + ("line",), "revolute": POWER_LAWS + ("line",)}
CASES = [(s, c, law) for s, c, kind in SCENES for law in LAWS[kind]]
IDS = [f"{s}-{law}" for s, _, law in CASES]
RTOL = 1e-7
T_END = 4e-3          # 4 ms: several impacts at 0.05-0.3 m/s across a 0.1 mm gap


def test_the_registries_are_covered():
    """Every normal law but the prismatic-only plane law, and every friction law, is exercised."""
    from pinclear.contact.laws import NORMAL_LAWS

    assert set(NORMAL_LAWS) - {"plane"} == {law for *_, law in CASES}
    assert set(FRICTION_LAWS) == {"none", "coulomb", "modified_coulomb", "stick_slip", "lugre"}


def _scene(name, c, law, ce, friction="none", mu=0.0):
    ov = {f"{c}.normal_law": law, f"{c}.ce": ce, f"{c}.friction_law": "none"}
    if friction != "none":
        ov[f"{c}.friction_law"] = {"type": friction, "mu_s": 1.5 * mu} if friction in ("stick_slip", "lugre") \
            else {"type": friction}
        ov[f"{c}.mu"] = mu
    mech = pinclear.load(name, clearances=[c], overrides=ov)
    model = mech.copy_model()
    model.gravity.linear[:] = 0.0
    return mech.replace(model=model)


def _state(mech, name, u):
    """(q, v) from the unit-interval draws u: the ball or journal centre inside the gap (at most
    0.6 c from the centre), the hinge's journal tilted by at most 0.3 of the angle that closes the
    gap, velocities 0.05-0.3 m/s and up to 3 rad/s."""
    c = mech.forces[0].c
    q, v = mech.q0.copy(), np.zeros(mech.nv)
    lin = 3 if mech.nq == 6 else 2
    d = np.array(u[:lin]) - 0.5
    d *= 0.6 * c * u[3] / max(np.linalg.norm(d), 1e-12)
    q[:lin] = d
    w = np.array(u[4:4 + lin]) - 0.5
    v[:lin] = (0.05 + 0.25 * u[7]) * w / max(np.linalg.norm(w), 1e-12)
    v[lin:] = 6.0 * (np.array(u[8:8 + mech.nv - lin]) - 0.5)
    if name == "clr_hinge":
        el = mech.forces[0]
        tilt = 0.3 * 2.0 * c / el.L
        q[4:6] = tilt * (2.0 * np.array(u[11:13]) - 1.0)
        v[4:6] *= 0.1                      # a tumbling journal would meet the rims at once
    return q, v


def _run(mech, q, v, t_end=T_END, rtol=RTOL):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tr = pinclear.simulate(mech, t_end, rtol=rtol, q0=q, v0=v, assemble=False, dt_out=t_end / 200)
    assert tr.status == "success", tr.message
    return tr, tr.energy_balance()


UNIT = st.lists(st.floats(0.0, 1.0), min_size=13, max_size=13)


@pytest.mark.slow
@pytest.mark.parametrize("name, c, law", CASES, ids=IDS)
@settings(PROFILE)
@given(u=UNIT)
def test_elastic_laws_conserve_energy(name, c, law, u):
    """ce = 1, no friction: no dissipation at all, and T + V_el (gravity off, nothing else)
    constant to the bound derived from rtol and the steps (pinclear.dynamics.energy)."""
    mech = _scene(name, c, law, 1.0)
    q, v = _state(mech, name, u)
    tr, b = _run(mech, q, v)
    E = tr.energies
    total = E["kinetic"] + E["spring"]
    assert np.all(E["dissipated"] == 0.0)          # chi = 0: (F - F_el) dd vanishes identically
    assert b["bound"] < 0.1                         # the bound says something at this rtol
    assert np.max(np.abs(total - total[0])) <= b["bound"] * b["scale"]
    assert b["ok"], b
    assert len(tr.stats["events"]) >= 1             # the case met the contact


@pytest.mark.slow
@pytest.mark.parametrize("name, c, law", CASES, ids=IDS)
@pytest.mark.parametrize("friction", [f for f in FRICTION_LAWS if f != "lugre"])
@settings(PROFILE)
@given(u=UNIT, ce=st.floats(0.5, 0.95), mu=st.floats(0.05, 0.4))
def test_damped_laws_and_friction_never_create_energy(name, c, law, friction, u, ce, mu):
    _check_dissipative(name, c, law, friction, u, ce, mu)


@pytest.mark.parametrize("name, c, _kind", SCENES, ids=[s[0] for s in SCENES])
@settings(PROFILE, max_examples=max(1, PROFILE.max_examples // 3))
@given(u=UNIT, ce=st.floats(0.5, 0.95), mu=st.floats(0.05, 0.4), law=st.sampled_from(POWER_LAWS + ("line",)))
def test_lugre_friction_never_creates_energy(name, c, _kind, u, ce, mu, law):
    """LuGre runs on the Python path (several times slower): fewer examples, the law drawn."""
    if _kind == "spherical" and law == "line":
        law = "hertz"
    _check_dissipative(name, c, law, "lugre", u, ce, mu)


def _check_dissipative(name, c, law, friction, u, ce, mu):
    """The balance closes, E_diss never decreases and T + V_el never grows, each to the bound."""
    mech = _scene(name, c, law, ce, friction, mu)
    q, v = _state(mech, name, u)
    tr, b = _run(mech, q, v)
    assert len(tr.stats["events"]) >= 1
    assert b["bound"] < 0.1
    assert b["ok"], b
    tol = b["bound"] * b["scale"]
    E = tr.energies
    assert np.min(np.diff(E["dissipated"])) >= -tol
    total = E["kinetic"] + E["spring"]
    assert np.max(total - np.minimum.accumulate(total)) <= tol     # never above an earlier value
    assert total[-1] <= total[0] + tol


# ---------------------------------------------------------------------------- mutation checks
class _SwitchedLaw(NormalLaw):
    """Hertz with a stiffness that doubles while the bodies separate (dd < 0), reported as all
    elastic (so the joint integrates no dissipation) with the loading branch's potential: a
    force that depends on the mode of motion is not the gradient of any potential, and each
    impact hands back up to twice the energy it took. (Reporting the switched part as the
    non-elastic one instead shows up as negative dissipation and the balance closes: that case
    is caught by the dissipated energy decreasing.)"""

    name = "switched"

    def __init__(self, K, n=1.5):
        self.K, self.n = float(K), float(n)
        self._freeze()

    def elastic(self, d):
        return self.K * np.maximum(np.asarray(d, float), 0.0) ** self.n

    def energy(self, d):
        return self.K * np.maximum(np.asarray(d, float), 0.0) ** (self.n + 1.0) / (self.n + 1.0)

    def force_and_elastic(self, d, dd, dd0):
        fe = self.elastic(d)
        F = np.where(np.asarray(dd) < 0.0, 2.0 * fe, fe)
        return F, F

    def force(self, d, dd, dd0):
        return self.force_and_elastic(d, dd, dd0)[0]


def _ball(law=None):
    """clr_ball (gravity off already) with the law replaced, and a state heading for the wall."""
    mech = pinclear.load("clr_ball", clearances=["S"], overrides={"S.friction_law": "none"})
    el = mech.forces[0]
    if law is not None:
        el = SphericalClearance(el.name, mech.model, el.f1, el.f2, el.c, el.R2, law(el.law.K), el.friction,
                                v_impact_min=el.v_impact_min, max_initial_penetration=el.max_initial_penetration)
        mech = mech.replace(forces=[el])
    v = np.zeros(6)
    v[:3] = [0.2, 0.1, -0.05]
    return mech, np.zeros(6), v


def test_a_mode_switched_law_fails_the_audit():
    mech, q, v = _ball(_SwitchedLaw)
    tr, b = _run(mech, q, v, t_end=3e-3)
    assert len(tr.stats["events"]) >= 2
    assert not b["ok"], b
    # ...and the same scene with the elastic law passes: the audit is not merely noisy
    mech, q, v = _ball(lambda K: make_normal_law({"type": "hertz", "K": K}))
    tr2, b2 = _run(mech, q, v, t_end=3e-3)
    assert b2["ok"] and b2["error"] < 1e-2 * b["error"], (b, b2)


class _Pusher(ForceElement):
    """A constant generalized force on one coordinate that reports no power: injected energy."""

    conservative = True          # the lie under test

    def __init__(self, k, f):
        self.name, self.k, self.f = "pusher", int(k), float(f)
        self._freeze()

    def add_force(self, mech, ws, d, t, q, v, z, tau, zdot):
        tau[self.k] += self.f


def test_unreported_power_fails_the_audit_and_reported_power_passes():
    """The same constant push along x, once unreported and once as a joint force (which
    reports its power): the two runs are the same motion, so the unreported one's balance is off
    by exactly the work the other one accounts for."""
    mech, q, v = _ball()
    f = 50.0                                  # N on the 2 kg ball: pressed on the socket's +x side
    bad = mech.replace(forces=list(mech.forces) + [_Pusher(0, f)])
    tr_bad, b = _run(bad, q, v, t_end=3e-3)
    assert not b["ok"], b
    good = mech.replace(forces=list(mech.forces) + [JointForce("push", 0, build_law({"type": "constant", "value": f}))])
    tr, b2 = _run(good, q, v, t_end=3e-3)
    assert b2["ok"], b2
    np.testing.assert_allclose(tr.q, tr_bad.q, rtol=0, atol=1e-12)
    Wa = f * (tr.q[:, 0] - tr.q[0, 0])         # work of a constant force: f times the displacement
    assert abs(b["error"] * b["scale"] - np.max(np.abs(Wa))) <= b2["bound"] * b2["scale"] + 1e-3 * np.max(np.abs(Wa))


# ---------------------------------------------------------------------------- drives
@pytest.mark.parametrize("clr", [None, ["A"]], ids=["ideal", "clearance-A"])
def test_drive_work_closes_the_balance(clr):
    """nine_bar's two drives do work (their multipliers jump at every impact of clearance A);
    the work meter accounts for it: the balance closes to its bound, and the drive work is a
    sizeable part of the energy scale (so dropping it would fail the audit)."""
    mech = pinclear.load("nine_bar", clearances=clr)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tr = pinclear.simulate(mech, 0.1, rtol=1e-8)
    b = tr.energy_balance()
    assert tr.status == "success"
    assert b["ok"], b
    # without the meter the balance would be off by max |W_drives| - error > bound
    assert np.max(np.abs(tr.energies["work_drives"])) > 2.0 * b["bound"] * b["scale"]
    if clr is None:
        # a second, independent method where the power is smooth: the trapezoid of lam_d v_j
        # over fine samples; its error h^2/12 |P''| T is < 1e-6 of the work at 4000 samples
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fine = pinclear.simulate(mech, 0.1, rtol=1e-8, dt_out=0.1 / 4000)
        P = sum(fine.lam[d.name] * fine.v[:, d.idx_v] for d in mech.drives)
        W = float(np.sum(0.5 * (P[1:] + P[:-1]) * np.diff(fine.t)))
        assert abs(W - fine.energies["work_drives"][-1]) <= 1e-5 * abs(W)


def test_summary_carries_the_balance_and_the_cli_warns(tmp_path, monkeypatch, capsys):
    from pinclear.cli import commands as cli
    from pinclear.dynamics.trajectory import Trajectory

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tr = pinclear.simulate(pinclear.load("four_bar"), 0.2, rtol=1e-8)
    s = tr.summary()
    assert set(s["energy_balance"]) >= {"error", "t", "ok", "bound", "scale"} and s["energy_balance"]["ok"]
    assert "energy_drift_rel" in s                 # the older key stays
    # a run whose balance is off says so in one line, whatever its status
    real = Trajectory.energy_balance

    def off(self):
        return dict(real(self), ok=False, error=0.5)
    monkeypatch.setattr(Trajectory, "energy_balance", off)
    rc = cli.main(["simulate", "four_bar", "--t-end", "0.05", "--out", str(tmp_path / "o"), "--progress", "off"])
    err = capsys.readouterr().err
    assert rc == 0
    assert sum("energy balance off" in line for line in err.splitlines()) == 1
    import json

    summ = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert summ["energy_balance"]["ok"] is False


def test_the_work_meter_with_dropped_rows_is_the_same_in_both_loops():
    """four_bar_revolute's closure has 3 redundant rows, which lagrange drops: the compiled loop
    then solves for the multipliers of the kept rows only (the meter reads them by position).
    A crank drive added: both loops give the same meter, it matches the trapezoid of
    lam_d v_j over fine samples (a smooth power: h^2/12 |P''| T is ~1e-7 of the work), and the
    balance closes."""
    from pinclear.model.drives import Drive

    mech = pinclear.load("four_bar_revolute")
    j = mech.model.getJointId("crank_joint")
    iq, iv = mech.model.joints[j].idx_q, mech.model.joints[j].idx_v
    law = build_law({"type": "sines", "offset": float(mech.q0[iq]),
                     "terms": [{"amp": 1.0, "omega": 6.283, "kind": "sin"}]})
    mech = mech.replace(drives=[Drive("crank_drive", "crank_joint", iq, iv, law)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        fast = pinclear.simulate(mech, 0.5, rtol=1e-8, dt_out=0.5 / 4000)
        slow = pinclear.simulate(mech, 0.5, rtol=1e-8, dt_out=0.5 / 4000, loop="python")
    assert fast.stats["loop"] == "compiled" and len(fast.stats["redundant_rows_with_drives"]) == 3
    W = fast.energies["work_drives"]
    scale = np.max(np.abs(W))
    assert scale > 1e-3                                   # the drive does work
    np.testing.assert_allclose(W, slow.energies["work_drives"], rtol=0, atol=1e-12 * scale)
    P = fast.lam["crank_drive"] * fast.v[:, iv]
    Wt = np.concatenate([[0.0], np.cumsum(0.5 * (P[1:] + P[:-1]) * np.diff(fast.t))])
    np.testing.assert_allclose(W, Wt, rtol=0, atol=1e-5 * scale)
    assert fast.energy_balance()["ok"]
