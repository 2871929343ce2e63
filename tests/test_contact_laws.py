"""Normal-force and friction laws of pinclear.contact.laws against physics references:
analytic Hertz impact, literature restitution curves, closed-form steady states."""
import math

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp

from pinclear.contact import laws
from pinclear.contact.laws import make_friction_law, make_normal_law, restitution_1dof
from pinclear.errors import ContactSetupError

CE = (0.3, 0.6, 0.9)


def test_undamped_hertz_impact_is_elastic_and_matches_analytic_penetration():
    law = make_normal_law({"type": "hertz", "K": 2.0e9})
    m, v0 = 3.0, 0.4
    assert restitution_1dof(law, v0=v0, m=m) == pytest.approx(1.0, abs=1e-9)
    # energy balance of the Hertz spring: K d^2.5 / 2.5 = m v0^2 / 2
    dmax = (5.0 * m * v0 ** 2 / (4.0 * law.K)) ** 0.4
    assert laws.max_penetration(law, 0.5 * m * v0 ** 2) == pytest.approx(dmax, rel=1e-10)


@pytest.mark.parametrize("name,expected", [
    # effective restitution of the 1-DOF impact as published for these laws (Flores et al.,
    # Nonlinear Dyn. 2011, comparison of dissipative contact laws; issue 4 orientation values)
    ("flores", (0.26, 0.58, 0.89)),
    ("lankarani_nikravesh", (0.68, 0.76, 0.91)),
])
def test_effective_restitution_matches_literature(name, expected):
    got = [restitution_1dof(make_normal_law({"type": name, "ce": ce, "K": 1e10})) for ce in CE]
    assert got == pytest.approx(expected, abs=0.006)


@pytest.mark.parametrize("name", ["lankarani_nikravesh", "flores", "hunt_crossley", "gonthier"])
def test_restitution_is_scale_free_and_tends_to_nominal_for_hard_impacts(name):
    # K d^n (1 + chi dd/dd0) is homogeneous: the speed ratio cannot depend on m, K or v0
    a = restitution_1dof(make_normal_law({"type": name, "ce": 0.8, "K": 1e8}), v0=0.05, m=0.2)
    b = restitution_1dof(make_normal_law({"type": name, "ce": 0.8, "K": 5e11}), v0=3.0, m=40.0)
    assert a == pytest.approx(b, rel=1e-7)
    # weak damping: the energy lost in one impact, to first order in chi, is
    # chi/dd0 * int K d^n dd^2 dt = 4/3 chi * (m v0^2 / 2) (Hertz impact integral), so
    # e = sqrt(1 - 4 chi / 3) + O(chi^2) whatever the law's chi(ce)
    law = make_normal_law({"type": name, "ce": 0.99, "K": 1e9})
    e = restitution_1dof(law)
    assert abs(e - math.sqrt(1 - 4 * law.chi / 3)) < law.chi ** 2
    if name in ("lankarani_nikravesh", "hunt_crossley"):
        # these two are the first-order-exact choices: e -> ce
        assert abs(e - 0.99) < 2e-4


def test_restitution_depends_on_the_hysteresis_factor_only():
    # m v dv/dW = -(1 + chi v/v0) with W the elastic work: the elastic curve drops out
    Es = laws.effective_modulus(200e9, 0.3, 200e9, 0.3)
    e = [restitution_1dof(make_normal_law({"type": "lankarani_nikravesh", "ce": 0.7, "K": 1e9, "n": n}))
         for n in (1.0, 1.5, 2.2)]
    e.append(restitution_1dof(make_normal_law({"type": "line", "ce": 0.7}, line=(Es, 0.05, 1e-3)), v0=0.3, m=5))
    e.append(restitution_1dof(make_normal_law({"type": "plane", "ce": 0.7}, plane=(200e9, 5e-3, 0.05))))
    assert np.ptp(e) < 1e-8


def test_negative_force_is_clipped():
    law = make_normal_law({"type": "flores", "ce": 0.3, "K": 1e9})
    # separating faster than 1/chi of the onset speed: the formula pulls, the law must not
    d = np.array([1e-6, 1e-6])
    F = law.force(d, np.array([-0.5, 0.5]), np.array([1.0, 1.0]))
    assert F[0] == 0.0
    assert F[1] == pytest.approx(1e9 * 1e-9 * (1 + law.chi * 0.5))
    assert np.all(law.force(np.array([-1e-6]), np.array([1.0]), np.array([1.0])) == 0.0)


def test_line_law_inverts_paper_003_eq6_and_energy_is_its_integral():
    Es = laws.effective_modulus(200e9, 0.3, 200e9, 0.3)
    law = make_normal_law({"type": "line", "ce": 0.9}, line=(Es, 0.05, 2e-3))
    d = np.array([1e-8, 3e-7, 4e-6])
    P = law.elastic(d)
    # eq. 6 written out independently
    back = P / (math.pi * Es * 0.05) * (1.0 - np.log(P * 2e-3 / (math.pi * Es * 0.05 ** 3)))
    assert back == pytest.approx(d, rel=1e-10)
    for di, Ei in zip(d, law.energy(d)):
        ref = quad(lambda x: law.elastic(np.array([x]))[0], 0.0, di, limit=200, epsabs=0, epsrel=1e-11)[0]
        assert Ei == pytest.approx(ref, rel=1e-8)


def test_plane_law_is_EA_over_l():
    law = make_normal_law({"type": "plane", "ce": 1.0}, plane=(200e9, 0.1 * 0.05, 0.05))
    assert law.elastic(np.array([2e-6]))[0] == pytest.approx(200e9 * 5e-3 * 2e-6 / 0.05)


def test_conformal_and_printed_stiffness():
    Es = laws.effective_modulus(207e9, 0.3, 207e9, 0.3)
    assert Es == pytest.approx(207e9 / (2 * (1 - 0.09)))
    R2, R1 = 0.01, 0.0105
    kc = laws.hertz_stiffness(Es, R2, R1, "conformal")
    kp = laws.hertz_stiffness(Es, R2, R1, "printed")
    assert kc / kp == pytest.approx(math.sqrt((R1 + R2) / (R1 - R2)))
    assert kp == pytest.approx(4 / 3 * Es * math.sqrt(R1 * R2 / (R1 + R2)))


def test_modified_coulomb_ramp_papers_000_002():
    law = make_friction_law({"type": "modified_coulomb", "mu": 0.2, "v0": 1e-3, "v1": 3e-3})
    s = np.array([5e-4, 1e-3, 2e-3, 3e-3, 1.0])
    assert law.coefficient(s) == pytest.approx([0.0, 0.0, 0.1, 0.2, 0.2])
    vt = np.array([[0.0, 2e-3, 0.0], [0.0, 0.0, -0.5]])
    Ft = law.force(np.array([10.0, 10.0]), vt)
    assert Ft == pytest.approx(np.array([[0, -1.0, 0], [0, 0, 2.0]]))


def test_stick_slip_law_paper_003_eq3():
    law = make_friction_law({"type": "stick_slip", "mu_s": 0.8, "mu_d": 0.16, "Vs": 1e-3, "Vd": 5e-3})
    s = np.array([0.0, 5e-4, 1e-3, 3e-3, 5e-3, 1.0])
    ref = [0.0, 0.8 * math.sin(math.pi / 4), 0.8, 0.48, 0.16, 0.16]
    assert law.coefficient(s) == pytest.approx(ref, abs=1e-12)
    # continuity at both transitions
    for v in (1e-3, 5e-3):
        lo, hi = law.coefficient(np.array([v * (1 - 1e-9), v * (1 + 1e-9)]))
        assert lo == pytest.approx(hi, abs=1e-7)


def test_regularised_coulomb_saturates():
    law = make_friction_law({"type": "coulomb", "mu": 0.3, "v_eps": 1e-4})
    assert law.coefficient(np.array([1.0]))[0] == pytest.approx(0.3, rel=1e-7)
    assert law.coefficient(np.array([1e-4]))[0] == pytest.approx(0.3 / math.sqrt(2))


def test_lugre_state_reaches_the_closed_form_steady_state():
    law = make_friction_law({"type": "lugre", "mu_s": 0.5, "mu_c": 0.3, "vs": 1e-2, "s0": 1e4, "s1": 50.0,
                             "s2": 0.1})
    v = 2e-2
    vt = np.array([[v, 0.0, 0.0]])
    Fn = np.array([20.0])

    def rhs(t, z):
        dz = np.zeros((1, 3))
        law.force(Fn, vt, z.reshape(1, 3), dz)
        return dz.ravel()

    sol = solve_ivp(rhs, (0, 0.05), np.zeros(3), method="Radau", rtol=1e-10, atol=1e-14)
    z = sol.y[:, -1].reshape(1, 3)
    F = law.force(Fn, vt, z, np.zeros((1, 3)))
    g = 0.3 + 0.2 * math.exp(-(v / 1e-2) ** 2)          # Stribeck curve at v
    assert F[0, 0] == pytest.approx(-20.0 * (g + 0.1 * v), rel=1e-7)
    assert abs(F[0, 1]) < 1e-12


def test_bad_law_parameters_name_key_and_choices():
    with pytest.raises(ContactSetupError, match=r"normal_law.ce.*outside \(0, 1\]"):
        make_normal_law({"type": "lankarani_nikravesh", "ce": 1.2, "K": 1e9})
    with pytest.raises(ContactSetupError, match=r"normal_law.ce"):
        make_normal_law({"type": "flores", "ce": 0.0, "K": 1e9})
    with pytest.raises(ContactSetupError, match=r"valid: .*gonthier.*lankarani_nikravesh"):
        make_normal_law({"type": "hertzian", "K": 1e9})
    with pytest.raises(ContactSetupError, match=r"friction_law.v1: must exceed v0"):
        make_friction_law({"type": "modified_coulomb", "mu": 0.1, "v0": 1e-2, "v1": 1e-3})
    with pytest.raises(ContactSetupError, match=r"friction_law.type.*valid: coulomb, lugre"):
        make_friction_law({"type": "viscous"})
    with pytest.raises(ContactSetupError, match=r"normal_law.Kx: unknown key"):
        make_normal_law({"type": "hertz", "Kx": 1e9})
