"""Mixed lubrication of the lubricated journal (pinclear.contact.mixed, pinclear.contact.lubricated):
Greenwood-Tripp's asperity load against its integral over the exact gap, the asperity energy, the
film holding a steady load with an asperity share below 1 % at lambda >= 3 and sharing it below,
the full-film-arc friction, film power <= 0 down to and beyond contact, no force jump at the
asperity and dry onsets, and the removed keys' one-line errors."""
import math
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

import pinclear
from pinclear.contact.lubricated import film_loads
from pinclear.core.errors import ContactSetupError

JOURNAL = Path(__file__).parents[1] / "data" / "lub_journal.yaml"
MU, R, L, C, OMEGA = 0.01, 0.01, 0.02, 1e-4, 100.0       # the sidecar's oil, journal and drive
SIGMA = 0.3e-6                                            # the default combined roughness
ESTAR = 1.0 / (2 * (1 - 0.3 ** 2) / 207e9)                # steel on steel (E 207 GPa, nu 0.3)
# Greenwood-Tripp with eta beta sigma = 0.04, sigma / beta = 1e-3 (the defaults' published values)
K_GT = 16 * math.sqrt(2) / 15 * math.pi * 0.04 ** 2 * math.sqrt(1e-3)


def p_asperity(h):
    """Greenwood-Tripp's nominal pressure at the local gap h, F_5/2 as Hu et al.'s fit."""
    lam = h / SIGMA
    return K_GT * ESTAR * 4.4086e-5 * (4 - lam) ** 6.804 if lam < 4 else 0.0


def asperity_exact(h_min):
    """The asperity load integrated over the bearing with the exact gap c - r cos psi (r = c - h_min)."""
    r = C - h_min
    half = math.acos(min(1.0, (C - 4 * SIGMA) / r)) if C - 4 * SIGMA < r else 0.0
    val, _ = quad(lambda psi: p_asperity(C - r * math.cos(psi)) * math.cos(psi), -half, half, epsabs=0, epsrel=1e-10)
    return L * R * val


def short_film(mu, eps):
    """(radial, tangential) film force components of the steady short bearing (closed forms)."""
    k = mu * OMEGA * R * L ** 3 / C ** 2
    return k * eps ** 2 / (1 - eps ** 2) ** 2, k * math.pi * eps / (4 * (1 - eps ** 2) ** 1.5)


def _state(mech, h_min, angle=-math.pi / 2, v=None):
    """(workspace, data, element, q, v) with the journal at the gap h_min along ``angle``."""
    from pinclear.model import kinematics

    el = mech.forces[-1]
    ws = mech.workspace()
    q = np.array([(C - h_min) * math.cos(angle), (C - h_min) * math.sin(angle), 0.0])
    v = np.array([0.0, 0.0, OMEGA]) if v is None else v
    kinematics.update(mech, ws, q, v)
    return ws, ws.force_data[-1], el, q, v


def test_asperity_load_is_greenwood_tripp_over_the_exact_gap_and_the_gradient_of_its_energy():
    mech = pinclear.load(JOURNAL, clearances=["A"])
    for lam in (4.5, 3.9, 3.0, 2.0, 1.0, 0.3):
        ws, d, el, q, v = _state(mech, lam * SIGMA, v=np.zeros(3))
        out = el.outputs(mech, ws, d, 0.0, q, v, np.zeros(el.nz))
        ref = asperity_exact(lam * SIGMA)
        assert out["film_parameter"] == pytest.approx(lam, rel=1e-9)
        # the closed form takes the gap's parabola near its minimum: O(4 sigma / c) + O(psi^2) = 1.3 %
        assert out["asperity_force"] == pytest.approx(ref, rel=0.015, abs=1e-300)
        if lam < 4:
            # elastic: U_a(h) with dU/dh = -W_a (central difference, step 1e-4 sigma)
            dh = 1e-4 * SIGMA
            U = [el.potential(mech, *_state(mech, lam * SIGMA + s * dh)[:2], _state(mech, lam * SIGMA + s * dh)[3])
                 for s in (1, -1)]
            assert -(U[0] - U[1]) / (2 * dh) == pytest.approx(out["asperity_force"], rel=1e-6)


def _settle(mu, lam, t_end):
    """The journal loaded so that the steady short bearing with asperities rests at lambda: W = the
    vector sum of film (closed form) and asperity load there; returns (lambda reached, share W_a / W,
    outputs)."""
    eps = 1 - lam * SIGMA / C
    fr, ft = short_film(mu, eps)
    Wa = asperity_exact(lam * SIGMA)
    W = math.hypot(fr + Wa, ft)
    psi = math.atan2(ft, fr + Wa)             # from the load line (-y) to e, in the spin's sense
    G = 98.1
    mech = pinclear.load(JOURNAL, clearances=["A"], overrides={"A.viscosity": mu})
    jid = mech.model.getJointId("rz")
    mech.model.inertias[jid] = pin.Inertia(W / G, np.zeros(3), np.eye(3) * 1e-6)
    mech.model.gravity = pin.Motion(np.array([0.0, -G, 0.0]), np.zeros(3))
    r0 = C - 1.05 * lam * SIGMA                # started 5 % of the gap away, 2 degrees off
    q0 = np.array([r0 * math.sin(psi + 0.035), -r0 * math.cos(psi + 0.035), 0.0])
    tr = pinclear.simulate(mech, t_end, integrator="Radau", rtol=1e-8, q0=q0, v0=np.array([0, 0, OMEGA]),
                           assemble=False, dt_out=t_end / 20)
    assert tr.status == "success"
    out = {k[2:]: v[-1] for k, v in tr.outputs.items() if k.startswith("A.")}
    return out["film_parameter"], out["asperity_force"] / W, Wa / W, out


@pytest.mark.slow
def test_the_film_holds_its_load_with_an_asperity_share_below_one_percent_at_lambda_3_and_more():
    lam, share, share_ref, out = _settle(MU, 3.3, 0.05)
    assert lam == pytest.approx(3.3, rel=0.01)
    assert share < 0.01 and share == pytest.approx(share_ref, rel=0.05)
    assert out["fn"] == 0.0                               # no dry contact


@pytest.mark.slow
def test_film_and_asperities_share_the_load_below_lambda_3():
    # an oil 1e4 times thinner: the film alone would need lambda ~ 0.2; the asperities take part of it
    lam, share, share_ref, out = _settle(1e-6, 1.8, 0.05)
    assert lam == pytest.approx(1.8, rel=0.01)
    assert 0.1 < share < 0.9 and share == pytest.approx(share_ref, rel=0.05)
    assert out["fn"] == 0.0


def test_the_ruptured_film_carries_no_shear():
    # steady pure wedge (short bearing): P > 0 on phi in (0, pi) exactly, so the Couette torque is
    # int_0^pi mu R^3 L w / (c (1 + eps cos phi)) dphi = pi mu R^3 L w / (c sqrt(1 - eps^2)), half Petroff's
    axis = np.array([0.0, 0.0, 1.0])
    for eps in (0.1, 0.6, 0.95):
        e = np.array([eps * C, 0.0, 0.0])
        F, Tj, _, _ = film_loads("short", MU, R, L, C, e, np.zeros(3), axis, OMEGA)
        Ft = F @ np.cross(axis, e / np.linalg.norm(e))
        couette = Tj + 0.5 * eps * C * Ft
        assert couette == pytest.approx(-math.pi * MU * R ** 3 * L * OMEGA / (C * math.sqrt(1 - eps ** 2)), rel=1e-5)


@pytest.mark.parametrize("theory", ["short", "long"])
def test_film_power_is_never_positive_down_to_and_beyond_contact(theory):
    # near contact and below the gap floor (FLOOR sigma), beyond contact (eps > 1): the short
    # bearing's P+ > 0 only where the bracket is (q > 0), so P_film <= 0 exactly; the long one's
    # identity holds above the floor, and below it the floored pressure is checked here
    from pinclear.contact.mixed import FLOOR
    rng = np.random.default_rng(3)
    axis = np.array([0.0, 0.0, 1.0])
    qmin = FLOOR * SIGMA / C
    worst = -np.inf
    for _ in range(300):
        eps = rng.uniform(0.97, 1.005)
        a = rng.uniform(0, 2 * math.pi)
        e = eps * C * np.array([math.cos(a), math.sin(a), 0.0])
        edot = np.append(rng.normal(0, 1e-3, 2), 0.0)
        w = rng.normal(0, 200)
        F, Tj, power, _ = film_loads(theory, MU, R, L, C, e, edot, axis, w, qmin=qmin)
        scale = abs(F @ edot) + abs(Tj * w) + 1e-300
        worst = max(worst, power / scale)
    assert worst <= (0.0 if theory == "short" else 1e-3), worst


def test_no_force_jump_at_the_asperity_onset_and_at_contact():
    """The joint's generalized force (film + asperities + dry law) for a journal approaching with
    spin, across h = 4 sigma (asperity onset) and h = 0 (dry onset): the difference across each
    shrinks with the step (no jump)."""
    mech = pinclear.load(JOURNAL, clearances=["A"])
    v = np.array([0.0, -1e-4, OMEGA])

    def tau_at(h):
        ws, d, el, q, _ = _state(mech, h, v=v)
        z = np.zeros(el.nz)
        z[0] = 1e-4
        tau, zdot = np.zeros(3), np.zeros(el.nz)
        el.add_force(mech, ws, d, 0.0, q, v, z, tau, zdot)
        return tau

    walk = np.array([tau_at(h) for h in np.linspace(-0.5 * SIGMA, 5 * SIGMA, 45)])
    scale = np.abs(walk).max()
    assert scale > 0
    for h in (4 * SIGMA, 0.0):
        eta = 1e-6 * SIGMA
        wide = np.abs(tau_at(h + 10 * eta) - tau_at(h - 10 * eta)).max()
        near = np.abs(tau_at(h + eta) - tau_at(h - eta)).max()
        local = np.abs(tau_at(h)).max()
        assert near <= 0.2 * wide + 1e-12 * scale
        assert near < 1e-4 * local


@pytest.mark.parametrize("key, value, pattern", [
    ("asperity", 1e-6, r"lub_journal.yaml: clearances.A.asperity: removed: .* combined roughness 'roughness'"),
    ("band", 1e-6, r"lub_journal.yaml: clearances.A.band: removed: .* combined roughness 'roughness'"),
    ("roughness", 1e-10, r"clearances.A.roughness: must lie in \[1e-09, 5e-06\] m, got 1e-10"),
    ("roughness", 4e-5, r"clearances.A.roughness: must lie in \[1e-09, 5e-06\] m"),
    ("boundary_mu", 2.0, r"clearances.A.boundary_mu: must lie in \[0, 1\], got 2"),
    ("asperity_density", -1.0, r"clearances.A.asperity_density: must be > 0"),
])
def test_removed_and_bad_keys_stop_the_load_with_one_line(key, value, pattern):
    with pytest.raises(ContactSetupError, match=pattern) as exc:
        pinclear.load(JOURNAL, clearances=["A"], overrides={f"A.{key}": value})
    assert len(str(exc.value).splitlines()) == 1


def test_roughness_must_leave_the_asperity_layer_inside_the_clearance(tmp_path):
    text = JOURNAL.read_text().replace("clearance: 1.0e-4", "clearance: 4.0e-6")
    (tmp_path / "lub_journal.urdf").write_text((JOURNAL.parent / "lub_journal.urdf").read_text())
    (tmp_path / "lub_journal.yaml").write_text(text)
    with pytest.raises(ContactSetupError, match=r"4 x roughness = 8e-06 m must be below the clearance 4e-06"):
        pinclear.load(tmp_path / "lub_journal.yaml", clearances=["A"], overrides={"A.roughness": 2e-6})
