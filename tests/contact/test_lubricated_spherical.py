"""Lubricated spherical joint (pinclear.contact.lubricated_spherical): the film's pressure solves
Reynolds' equation on the sphere, a loaded ball sinks through its film as the closed-form squeeze
law says (coupled dynamics), the film only dissipates, the audit closes through the blend into dry
contact, and bad keys stop the load with one line."""
import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import solve_ivp

import pinclear
from pinclear.contact.lubricated_spherical import film_loads, film_pressure
from pinclear.core.errors import ContactSetupError

BALL = Path(__file__).parents[1] / "data" / "lub_ball.yaml"
MU, R, C, M = 0.01, 0.02, 1e-4, 2.0            # the sidecar's oil, ball and socket, ball mass (kg)


def _frame(th, ph):
    """The unit normal and its theta, phi unit vectors in world spherical coordinates about z."""
    n = np.array([math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th)])
    et = np.array([math.cos(th) * math.cos(ph), math.cos(th) * math.sin(ph), -math.sin(th)])
    return n, et, np.array([-math.sin(ph), math.cos(ph), 0.0])


def reynolds_residual(e, edot, w, th, ph, d):
    """div_s(h^3 grad_s p) / (12 mu) - dh/dt - div_s(h U_mean) at (th, ph), central differences of
    step d in world spherical coordinates: h = c - e . n, dh/dt = -edot . n, U_mean = (1/2) w x R n
    (the ball's surface speed, the socket at rest), written out here without the module's
    squeeze-equivalent velocity. Returns (residual, size of the left side)."""
    def p(t, f):
        return float(film_pressure(MU, R, C, e, edot, w, _frame(t, f)[0][None, :])[0])

    def H(t, f):
        return (C - e @ _frame(t, f)[0]) ** 3 / (12 * MU)

    def flux_t(t, f):          # sin theta H dp/dtheta at a half point
        return math.sin(t) * H(t, f) * (p(t + d / 2, f) - p(t - d / 2, f)) / d

    def flux_f(t, f):
        return H(t, f) * (p(t, f + d / 2) - p(t, f - d / 2)) / d

    s = math.sin(th)
    lt = (flux_t(th + d / 2, ph) - flux_t(th - d / 2, ph)) / (d * R * R * s)
    lf = (flux_f(th, ph + d / 2) - flux_f(th, ph - d / 2)) / (d * R * R * s * s)

    def hU(t, f):
        n, et, ef = _frame(t, f)
        U = 0.5 * np.cross(w, R * n)
        return (C - e @ n) * (U @ et), (C - e @ n) * (U @ ef)

    div = ((math.sin(th + d / 2) * hU(th + d / 2, ph)[0] - math.sin(th - d / 2) * hU(th - d / 2, ph)[0]) / d
           + (hU(th, ph + d / 2)[1] - hU(th, ph - d / 2)[1]) / d) / (R * s)
    return lt + lf - (-(edot @ _frame(th, ph)[0]) + div), abs(lt) + abs(lf)


def test_the_film_pressure_solves_reynolds_equation_on_the_sphere():
    # the residual of the closed forms falls as d^2 (central differences): 1/4 per halving, not a floor
    rng = np.random.default_rng(3)
    for _ in range(12):
        e = rng.normal(size=3)
        e *= rng.uniform(0.05, 0.8) * C / np.linalg.norm(e)
        edot, w = rng.normal(size=3) * 1e-3, rng.normal(size=3) * 50
        th, ph = rng.uniform(0.3, math.pi - 0.3), rng.uniform(0, 2 * math.pi)
        r1, size = reynolds_residual(e, edot, w, th, ph, 2e-3)
        r2, _ = reynolds_residual(e, edot, w, th, ph, 1e-3)
        assert abs(r2) < 1e-4 * size
        assert abs(r2) < 0.3 * abs(r1) + 1e-9 * size


def g_squeeze(eps):
    """W c^2 / (6 pi mu R^4 eps_dot) of the uncavitated squeeze film: (2 eps / (1 - eps^2) -
    ln((1 + eps) / (1 - eps))) / eps^3 (docs/wear_lubrication.md sec. 4), its series below 0.2."""
    if eps < 0.2:
        k = np.arange(1, 30)
        return float(np.sum(4 * k / (2 * k + 1) * eps ** (2 * k - 2)))
    return (2 * eps / (1 - eps * eps) - math.log((1 + eps) / (1 - eps))) / eps ** 3


def test_a_loaded_ball_sinks_through_its_film_as_the_closed_form_squeeze_law_says():
    """A 2 kg ball under 200 N along -z, no spin, from eps 0.05 at rest: the simulated eps(t) against
    m c eps'' = W - 6 pi mu R^4 g(eps) eps' / c^2 integrated by DOP853 at rtol 1e-12 (a second method
    on the closed form, not the module). The error follows the tolerance (measured 0.3, 0.2, 0.24
    rtol at rtol 1e-7, 1e-8, 1e-9): bound 3 rtol."""
    G, T = 100.0, 0.03

    def rhs(t, y):
        eps, rate = y
        return [rate, G / C - 6 * math.pi * MU * R ** 4 * g_squeeze(eps) * max(rate, 0.0) / (M * C ** 3)]

    ref = solve_ivp(rhs, (0, T), [0.05, 0.0], method="DOP853", rtol=1e-12, atol=1e-14, dense_output=True)
    mech = pinclear.load(BALL, clearances=["S"])
    mech.model.gravity = pin.Motion(np.array([0.0, 0.0, -G]), np.zeros(3))
    q0 = np.zeros(6)
    q0[2] = -0.05 * C
    for rtol in (1e-8, 1e-9):
        tr = pinclear.simulate(mech, T, integrator="Radau", rtol=rtol, q0=q0, v0=np.zeros(6), assemble=False,
                               dt_out=T / 30)
        assert tr.status == "success"
        eps = -tr.q[:, 2] / C
        # through the film, not the asperities or dry contact
        assert eps[-1] > 0.88 and np.all(tr.outputs["S.asperity_force"] == 0.0) and np.all(tr.outputs["S.fn"] == 0.0)
        assert np.max(np.abs(eps - ref.sol(tr.t)[0])) < 3 * rtol
        assert np.max(np.abs(tr.q[:, [0, 1, 3, 4, 5]])) < 1e-12 * C               # straight down, no spin


def test_film_power_is_never_positive_at_random_states():
    # P = F . V - Couette = -(1/12 mu) int_{p>0} h^3 |grad p|^2 - Couette <= 0 (docs, sec. 4)
    rng = np.random.default_rng(7)
    worst = -np.inf
    for i in range(400):
        e = rng.normal(size=3)
        e *= rng.uniform(0, 0.98) * C / np.linalg.norm(e)
        # squeeze, whirl and spin over several decades of their ratios
        edot = rng.normal(size=3) * 10.0 ** rng.uniform(-6, -1)
        w = rng.normal(size=3) * 10.0 ** rng.uniform(-1, 3) * (i % 4 != 0)
        F, T, power, _ = film_loads(MU, R, C, e, edot, w)
        assert power <= 0.0
        worst = max(worst, power / (np.linalg.norm(F) * np.linalg.norm(edot - 0.5 * np.cross(w, e)) + 1e-300))
    assert worst < 0.0


@pytest.mark.slow
def test_a_ball_thrown_through_its_film_into_the_wall_closes_its_audit():
    """Thrown across its (thin) film with spin into the dry wall and back: the film's dissipation
    never decreases, and total + dissipated stays within the run's integration bound (pinclear.dynamics.energy)."""
    mech = pinclear.load(BALL, clearances=["S"], overrides={"S.viscosity": 1e-4, "S.roughness": 2e-6})
    tr = pinclear.simulate(mech, 0.004, integrator="Radau", rtol=1e-9, q0=np.zeros(6),
                           v0=np.array([0.3, -0.2, 0.4, 0.0, 200.0, 100.0]), assemble=False, dt_out=1e-5)
    assert tr.status == "success"
    assert np.max(tr.outputs["S.asperity_force"]) > 0                  # reached the asperities
    E, D = tr.energy()["total"], tr.outputs["S.dissipated"]
    film = tr.outputs["S.film_dissipated"]
    assert film[-1] > 0.1 * (E[0] - E[-1])
    assert np.all(np.diff(film) >= 0.0)
    b = tr.energy_balance()
    assert b["ok"] and b["error"] <= b["bound"]
    assert np.max(np.abs(E + D - E[0])) <= b["bound"] * b["scale"]


@pytest.mark.parametrize("key, value, pattern", [
    ("viscosity", -0.01, r"lub_ball.yaml: clearances.S.viscosity: must be > 0, got -0.01"),
    ("asperity", 2e-4, r"lub_ball.yaml: clearances.S.asperity: removed: .*'roughness' \(sigma, m; default 3e-07\)"),
    ("band", 0.0, r"lub_ball.yaml: clearances.S.band: removed: .*'roughness'"),
    ("theory", "short", r"lub_ball.yaml: clearances.S.theory: unknown key \(valid: .*boundary_mu.*roughness.*viscosity"),
    ("socket_radius", 0.0201, r"clearances.S.socket_radius: unknown key \(valid: .*radius"),
])
def test_bad_keys_stop_the_load_with_one_line(key, value, pattern):
    with pytest.raises(ContactSetupError, match=pattern) as exc:
        pinclear.load(BALL, clearances=["S"], overrides={f"S.{key}": value})
    assert len(str(exc.value).splitlines()) == 1


def test_a_missing_viscosity_stops_the_load(tmp_path):
    text = BALL.read_text().replace(", viscosity: 0.01", "")
    (tmp_path / "lub_ball.urdf").write_text((BALL.parent / "lub_ball.urdf").read_text())
    (tmp_path / "lub_ball.yaml").write_text(text)
    with pytest.raises(ContactSetupError, match=r"clearances.S.viscosity: required"):
        pinclear.load(tmp_path / "lub_ball.yaml", clearances=["S"])


def test_oil_in_s2_of_the_4ups_upu_delays_and_softens_the_landing():
    """pinclear.studies.wear_paper000's case runner on 0.1 s of paper 000's mechanism from its centred start:
    the squeeze film only slows the ball's approach (it carries no load at rest), so with oil the
    first dry contact comes later (or not within the window) and its peak force is lower than the
    dry joint's; the film's dissipation is part of the audited total and the audit closes. Later by
    more than 2x: at 0.1 Pa s under S2's ~140 N the squeeze law alone takes 6 pi mu R^4 / (c^2 W)
    int_0^0.98 g = 32 ms to cross 98 % of the film (quasi-static), and the rest grows without bound
    as the gap closes (g ~ 1 / (1 - eps)), against the dry joint's 12.6 ms fall."""
    from pinclear.studies import wear_paper000 as study

    s = {**study._settings(True), "periods": 0.05, "window": 0.025}
    cases = dict(study.cases())
    dry, oil = cases["dry (new joint)"], cases["oil 0.1 Pa s"]
    a, b = study.run_case(dry, s), study.run_case(oil, s)
    assert a["status"] == b["status"] == "success"
    # nan (no dry contact in the window) counts as later and softer
    assert not b["first_contact_s"] <= 2 * a["first_contact_s"]
    assert not b["peak_dry_N"] >= a["peak_dry_N"]
    assert 0 < b["film_J_run"] < b["dissipated_J_run"]
    assert b["audit_ok"] and a["audit_ok"]


def test_no_force_jump_at_the_asperity_onset_and_at_contact():
    """The joint's generalized force (film + asperities + dry law) for a ball approaching with spin,
    across h_min = 4 sigma (the asperities' onset) and h_min = 0 (the dry law's): the difference
    across each shrinks with the step (no jump)."""
    from pinclear.model import kinematics

    mech = pinclear.load(BALL, clearances=["S"])
    el = mech.forces[-1]
    ws = mech.workspace()
    d = ws.force_data[-1]
    v = np.array([0.0, 0.0, -1e-3, 0.0, 5.0, 0.0])
    z = np.zeros(el.nz)
    z[0] = 1e-3

    def tau_at(h_min):
        q = np.zeros(6)
        q[2] = -(C - h_min)
        kinematics.update(mech, ws, q, v)
        tau, zdot = np.zeros(6), np.zeros(el.nz)
        el.add_force(mech, ws, d, 0.0, q, v, z, tau, zdot)
        return tau

    sigma = el.sigma
    walk = np.array([tau_at(h) for h in np.linspace(-0.5 * sigma, 5 * sigma, 41)])
    scale = np.abs(walk).max()
    assert scale > 0 and np.abs(walk[-1]).max() > 0        # the film's own force is in the walk
    for h in (4 * sigma, 0.0):
        # across a jump the difference stays as the step shrinks; a continuous force's shrinks with it
        eta = 1e-6 * sigma
        wide = np.abs(tau_at(h + 10 * eta) - tau_at(h - 10 * eta)).max()
        near = np.abs(tau_at(h + eta) - tau_at(h - eta)).max()
        local = np.abs(tau_at(h)).max()
        assert near <= 0.2 * wide + 1e-12 * scale
        assert near < 1e-4 * local
