"""Normal-force and friction laws of pinclear.contact.laws against physics references:
analytic Hertz impact, literature restitution curves, closed-form steady states."""
import math

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp

from pinclear.contact import laws
from pinclear.contact.laws import make_friction_law, make_normal_law, restitution_1dof
from pinclear.core.errors import ContactSetupError

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


# ---------------------------------------------------------------- each law written once, checked
# against the formulas written out here (random penetrations, rates, onset speeds, slip velocities)
CHI = {"hertz": lambda ce: 0.0, "lankarani_nikravesh": lambda ce: 0.75 * (1 - ce ** 2),
       "flores": lambda ce: 1.6 * (1 - ce) / ce, "hunt_crossley": lambda ce: 1.5 * (1 - ce),
       "gonthier": lambda ce: (1 - ce ** 2) / ce}


def random_contacts(rng, k=2000):
    """Penetrations across the whole range (separated, grazing, deep, beyond the 0.1 m cap),
    approach and separation rates, onset speeds from the floor up."""
    d = np.concatenate([-rng.uniform(0, 1e-3, k // 4), 10 ** rng.uniform(-12, -3, k // 2),
                        rng.uniform(0.05, 0.3, k - k // 4 - k // 2)])
    dd = rng.uniform(-3, 3, k) * 10 ** rng.uniform(-4, 0, k)
    dd0 = 10 ** rng.uniform(-4, 0.5, k)
    return d, dd, dd0


def random_slips(rng, k=2000):
    vt = rng.normal(size=(k, 3)) * 10 ** rng.uniform(-7, 0.5, (k, 1))
    vt[: k // 20] = 0.0                                  # sticking contacts
    return vt


def damped_reference(fe, dd, dd0, chi):
    return np.maximum(fe * (1 + chi * np.clip(dd / dd0, -1e6, 1e6)), 0.0)


@pytest.mark.parametrize("name", ["hertz", "lankarani_nikravesh", "flores", "hunt_crossley", "gonthier", "plane"])
def test_power_laws_equal_their_formula_on_random_inputs(name):
    rng = np.random.default_rng(7)
    d, dd, dd0 = random_contacts(rng)
    for ce, K, n in ((0.35, 3.2e9, 1.5), (0.8, 7.0e10, 1.23), (0.97, 1.0e6, 1.0)):
        if name == "plane":
            E, A, thick = 2.0e11, 5e-3, 0.05
            law = make_normal_law({"type": "plane", "ce": ce}, plane=(E, A, thick))
            K, n, chi = E * A / thick, 1.0, CHI["lankarani_nikravesh"](ce)
        else:
            law = make_normal_law({"type": name, "ce": ce, "K": K, "n": n})
            chi = CHI[name](ce)
        assert law.chi == pytest.approx(chi, rel=1e-15, abs=0)
        fe = np.where(d > 0, K * np.minimum(np.maximum(d, 0), 0.1) ** n, 0.0)
        F, Fel = law.force_and_elastic(d, dd, dd0)
        np.testing.assert_allclose(Fel, fe, rtol=1e-12, atol=0)
        np.testing.assert_allclose(law.elastic(d), fe, rtol=1e-12, atol=0)
        np.testing.assert_allclose(F, damped_reference(fe, dd, dd0, chi), rtol=1e-12, atol=0)
        np.testing.assert_allclose(law.force(d, dd, dd0), F, rtol=1e-12, atol=0)
        assert np.all(F[d <= 0] == 0.0) and np.all(F >= 0.0)
        # the potential of fe: beyond the 0.1 m cap the force is constant, so the energy grows linearly
        dc = np.minimum(np.maximum(d, 0), 0.1)
        U = K * dc ** (n + 1) / (n + 1) + K * 0.1 ** n * np.maximum(d - 0.1, 0)
        np.testing.assert_allclose(law.energy(d), U, rtol=1e-12, atol=0)
        # the compiled channel loop of the joints takes exactly these parameters
        assert law.kernel_params() == (0, K, n, pytest.approx(chi, rel=1e-15))


def test_line_law_equals_eq6_root_and_hysteresis_on_random_inputs():
    from scipy.optimize import brentq

    Es, l, R = laws.effective_modulus(200e9, 0.3, 200e9, 0.3), 0.04, 3e-3
    rng = np.random.default_rng(11)
    d, dd, dd0 = random_contacts(rng, 300)
    d = np.where(d > 1e-4, d * 1e-3, d)                  # eq. 6 holds below pi E* l^3 / R
    for ce in (0.4, 0.9):
        law = make_normal_law({"type": "line", "ce": ce}, line=(Es, l, R))
        c, a = 1 / (np.pi * Es * l), R / (np.pi * Es * l ** 3)
        P = np.array([brentq(lambda x: c * np.exp(x) * (1 - np.log(a * np.exp(x))) - di, -60.0, np.log(1 / a) - 1e-9,
                             xtol=1e-15, rtol=1e-15) if di > 0 else -np.inf for di in d])
        P = np.where(d > 0, np.exp(P), 0.0)
        F, Fel = law.force_and_elastic(d, dd, dd0)
        np.testing.assert_allclose(Fel, P, rtol=1e-12, atol=0)
        np.testing.assert_allclose(F, damped_reference(P, dd, dd0, CHI["lankarani_nikravesh"](ce)), rtol=1e-12, atol=0)
        # the compiled channel loop takes the line law by its (c, a) and chi
        assert law.kernel_params() == (1, pytest.approx(c, rel=1e-15), pytest.approx(a, rel=1e-15),
                                       pytest.approx(CHI["lankarani_nikravesh"](ce), rel=1e-15))


def friction_reference(spec, s):
    t = spec["type"]
    if t == "none":
        return np.zeros_like(s)
    if t == "coulomb":
        return spec["mu"] * s / np.sqrt(s ** 2 + spec["v_eps"] ** 2)
    if t == "modified_coulomb":
        return spec["mu"] * np.clip((s - spec["v0"]) / (spec["v1"] - spec["v0"]), 0, 1)
    mu_s, mu_d, Vs, Vd = spec["mu_s"], spec["mu_d"], spec["Vs"], spec["Vd"]
    mid = (mu_s + mu_d) / 2 + (mu_s - mu_d) / 2 * np.cos(np.pi * (s - Vs) / (Vd - Vs))
    return np.where(s < Vs, mu_s * np.sin(np.pi * s / (2 * Vs)), np.where(s > Vd, mu_d, mid))


@pytest.mark.parametrize("spec", [
    {"type": "none"},
    {"type": "coulomb", "mu": 0.3, "v_eps": 2e-4},
    {"type": "modified_coulomb", "mu": 0.15, "v0": 1e-4, "v1": 5e-3},
    {"type": "stick_slip", "mu_s": 0.8, "mu_d": 0.16, "Vs": 1e-3, "Vd": 5e-3},
])
def test_memoryless_friction_equals_its_formula_on_random_inputs(spec):
    rng = np.random.default_rng(3)
    vt = random_slips(rng)
    Fn = rng.uniform(0, 5e3, len(vt))
    law = make_friction_law(spec)
    s = np.sqrt((vt ** 2).sum(axis=1))
    mu = friction_reference(spec, s)
    np.testing.assert_allclose(law.coefficient(s), mu, rtol=1e-12, atol=0)
    ref = np.zeros_like(vt)
    m = s > 0
    ref[m] = -(mu[m] * Fn[m] / s[m])[:, None] * vt[m]
    np.testing.assert_allclose(law.force(Fn, vt), ref, rtol=1e-12, atol=0)
    assert law.nstate == 0 and law.kernel_params() is not None


def test_lugre_equals_its_formula_on_random_inputs():
    spec = {"type": "lugre", "mu_s": 0.5, "mu_c": 0.3, "vs": 2e-3, "s0": 1e5, "s1": 300.0, "s2": 0.02}
    law = make_friction_law(spec)
    rng = np.random.default_rng(5)
    vt = random_slips(rng, 500)
    Fn = rng.uniform(0, 5e3, len(vt))
    z = rng.normal(size=vt.shape) * 1e-6
    dz = np.empty_like(z)
    Ft = law.force(Fn, vt, z, dz)
    s = np.sqrt((vt ** 2).sum(axis=1))
    g = 0.3 + 0.2 * np.exp(-(s / 2e-3) ** 2)
    dz_ref = vt - (1e5 * s / g)[:, None] * z
    np.testing.assert_allclose(dz, dz_ref, rtol=1e-12, atol=1e-300)
    np.testing.assert_allclose(Ft, -Fn[:, None] * (1e5 * z + 300.0 * dz_ref + 0.02 * vt), rtol=1e-12, atol=1e-300)
    # LuGre declares its compiled form (the joints' channel loop evaluates it, contact._kernels.F_LUGRE)
    assert law.nstate == 3 and law.kernel_params() is not None


def test_laws_are_immutable_abstract_classes():
    law = make_normal_law({"type": "flores", "ce": 0.5, "K": 1e9})
    fr = make_friction_law({"type": "coulomb", "mu": 0.2})
    with pytest.raises(AttributeError, match="immutable"):
        law.K = 2e9
    with pytest.raises(AttributeError, match="immutable"):
        fr.mu = 0.5
    assert isinstance(law, laws.NormalLaw) and isinstance(fr, laws.FrictionLaw)
    with pytest.raises(TypeError):
        laws.NormalLaw()                                 # the contract has abstract methods
    with pytest.raises(TypeError):
        laws.FrictionLaw()
