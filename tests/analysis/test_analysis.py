"""pinclear.analysis against closed-form physics.

Model (tests/data/analysis_oscillator.*): two uncoupled prismatic oscillators,
  slide: m x'' + c x' + k x = F0 sin(w t)  (m = 2, k = 50, c = 8, F0 = 3, w = 4)
  swing: m2 y'' + k2 y = 0                 (m2 = 0.5, k2 = 20, y(0) = 0.1, y'(0) = 0)
The driven one has the steady state x = X sin(w t - phi), X = F0 / |k - m w^2 + i c w|,
phi = arg(k - m w^2 + i c w); on the section t = k T it sits at (-X sin phi, X w cos phi).
The free one moves on the energy ellipse (y / A)^2 + (y' / (A W))^2 = 1, A = 0.1, W^2 = k2/m2.
"""
from pathlib import Path

import numpy as np
import pytest

import pinclear
from pinclear import analysis as an
from pinclear.cli.analyse import cli_main as analyse_main
from pinclear.core.errors import InputError, ModelFileError

DATA = Path(__file__).parents[1] / "data"
OSC = DATA / "analysis_oscillator.yaml"
M, K, C, F0, W = 2.0, 50.0, 8.0, 3.0, 4.0
T = 2 * np.pi / W
# the transient decays like exp(-c t / 2m) = exp(-2 t): after 6 periods (9.4 s) it is below 1e-9
TRANSIENT, CYCLES = 6, 4
SIM = dict(integrator="DOP853", rtol=1e-10)


def steady_point(k=K, w=W, f0=F0, c=C, m=M):
    """Section point (x, xdot) at t = n 2pi/w of the steady state, from the transfer function."""
    H = complex(k - m * w * w, c * w)
    X, phi = f0 / abs(H), np.angle(H)
    return -X * np.sin(phi), X * w * np.cos(phi)


@pytest.fixture(scope="module")
def mech():
    return pinclear.load(OSC)


@pytest.fixture(scope="module")
def traj(mech):
    te = an.section_times(T, TRANSIENT + CYCLES, per_period=16)
    return pinclear.simulate(mech, te[-1], t_eval=te, **SIM)


def test_section_times_hit_the_section_exactly():
    te = an.section_times(0.3, 5, phase=0.05, t0=1.0, per_period=7)
    assert len(te) == 36
    k = np.arange(6)
    assert np.array_equal(te[::7], 1.0 + 0.05 + k * 0.3)       # bit-identical to poincare()'s times
    assert np.allclose(np.diff(te), 0.3 / 7, rtol=0, atol=1e-15)


def test_poincare_converges_to_transfer_function_steady_state(traj):
    assert traj.status == "success"
    sec = an.poincare(traj, T, "slide", skip_transient=TRANSIENT)
    assert len(sec) == CYCLES + 1 and sec.k[0] == TRANSIENT
    assert not sec.interpolated.any()                        # aligned output: no interpolation
    x0, v0 = steady_point()
    assert np.max(np.abs(sec.x - x0)) < 1e-6 * abs(x0)
    assert np.max(np.abs(sec.xdot - v0)) < 1e-6 * abs(v0)
    # before the transient has died the points are far off: the section really samples the run
    early = an.poincare(traj, T, "slide")
    assert abs(early.x[0] - 0.0) < 1e-15 and abs(early.xdot[1] - v0) > 1e-3
    c = an.classify(sec)
    assert (c.kind, c.period, c.clusters) == ("period-1", 1, 1)


def test_frame_signal_equals_joint_signal(traj):
    """Second route to the same numbers: Pinocchio forward kinematics of the body frame."""
    xj, vj = an.phase_portrait(traj, "slide")
    xf, vf = an.phase_portrait(traj, "mass.x")
    assert np.max(np.abs(xf - xj)) < 1e-14 and np.max(np.abs(vf - vj)) < 1e-14
    yb, _ = an.phase_portrait(traj, "bob.z")
    assert np.allclose(yb, 2.0, atol=1e-14)                  # the swing joint sits 2 m up


def test_interpolated_section_is_close_and_flagged(mech):
    te = np.linspace(0.0, (TRANSIENT + CYCLES) * T, 374)      # 37.3 samples per period: none on the section
    tr = pinclear.simulate(mech, te[-1], t_eval=te, **SIM)
    sec = an.poincare(tr, T, "slide", skip_transient=TRANSIENT)
    assert sec.interpolated[:-1].all()                    # the last one is t_end itself
    x0, v0 = steady_point()
    # cubic Hermite with the exact rate (and acceleration for xdot): error ~ h^4 X w^4 / 384 ~ 1e-7
    assert np.max(np.abs(sec.x - x0)) < 1e-5 * abs(x0)
    assert np.max(np.abs(sec.xdot - v0)) < 1e-5 * abs(v0)


def test_conservative_phase_portrait_is_energy_ellipse(traj):
    y, yd = an.phase_portrait(traj, "swing")
    A, Wn = 0.1, np.sqrt(20.0 / 0.5)
    r = (y / A) ** 2 + (yd / (A * Wn)) ** 2
    assert np.max(np.abs(r - 1.0)) < 1e-8
    assert y.min() < -0.99 * A and yd.max() > 0.99 * A * Wn  # the whole ellipse is traversed


def test_period_detection():
    k = np.arange(60)
    assert an.detect_period(np.full(60, 0.7)) == (1, 1)
    p2 = np.column_stack([0.3 + 0.1 * (-1.0) ** k, 1.0 - 0.2 * (-1.0) ** k]) + 1e-9 * np.sin(k)[:, None]
    assert an.detect_period(p2) == (2, 2)
    p3 = np.array([0.1, 0.5, -0.4])[k % 3]
    assert an.detect_period(p3) == (3, 3)
    quasi = np.cos(2 * np.pi * k * (np.sqrt(5) - 1) / 2)      # golden-mean rotation: never repeats
    period, clusters = an.detect_period(quasi)
    assert period is None and clusters > 30


def test_period_doubled_signal_from_a_run(traj):
    """A callable signal with a component at half the driving frequency repeats every 2 T."""
    def doubled(tr):
        x, v = tr.q[:, 0], tr.v[:, 0]
        return x + 0.01 * np.sin(W * tr.t / 2 + 0.3), v + 0.005 * W * np.cos(W * tr.t / 2 + 0.3)

    sec = an.poincare(traj, T, doubled, skip_transient=TRANSIENT)
    c = an.classify(sec)
    assert (c.kind, c.period, c.clusters) == ("period-2", 2, 2)
    assert an.classify(an.poincare(traj, T, "slide", skip_transient=TRANSIENT)).period == 1


def _logistic(r, n, x=0.3, skip=500):
    out = np.empty(n)
    for i in range(skip + n):
        x = r * x * (1 - x)
        if i >= skip:
            out[i - skip] = x
    return out


def test_chaos_01_test():
    # fully developed chaos of the logistic map (Lyapunov exponent ln 2)
    assert an.chaos_01(_logistic(4.0, 2000)) > 0.95
    # regular sequences: period 2 and 4 of the logistic map, a quasi-periodic rotation, a fixed point
    k = np.arange(1000)
    for phi in (_logistic(3.2, 1000), _logistic(3.5, 1000), np.cos(2 * np.pi * k * (np.sqrt(5) - 1) / 2) + 1.3):
        assert abs(an.chaos_01(phi)) < 0.1
    assert an.chaos_01(np.full(500, 2.0)) == 0.0
    c = an.classify(_logistic(4.0, 1000))
    # the 0-1 test alone does not make chaos: 'irregular' until a Lyapunov exponent confirms it
    assert c.kind == "irregular" and c.period is None and c.K > an.CHAOS_THRESHOLD
    # the map's own exponent, mean ln|f'(x)| = ln|4 (1 - 2x)| along the orbit (exactly ln 2), at two lengths
    x = _logistic(4.0, 4000)
    ev = an.confirm_chaos(lambda _r, n: float(np.mean(np.log(np.abs(4.0 * (1.0 - 2.0 * x[:int(n)]))))),
                          rtols=[0.0], lengths=[2000, 4000], rel=0.1)
    assert ev.confirmed and abs(ev.exponent - np.log(2.0)) < 0.05
    assert an.classify(_logistic(4.0, 1000), lyapunov=ev).kind == "chaotic"
    q = an.classify(np.cos(2 * np.pi * k * (np.sqrt(5) - 1) / 2))
    assert q.kind == "quasi-periodic" and q.K < 0.1
    with pytest.raises(InputError):
        an.chaos_01(np.ones(10))


def test_bifurcation_parallel_keeps_failures(tmp_path):
    """Three stiffness values in two worker processes; k < 0 (huge) makes the run blow up.
    k = 32 = m w^2 is resonance: the section velocity is 0, the period must still be found."""
    values = [32.0, 80.0, -1e6]
    res = an.bifurcation(OSC, "forces[spring].k", values, period=T, signal=["slide", "mass.x", "swing"],
                         cycles=CYCLES, transient=TRANSIENT, sim_options=SIM, max_workers=2)
    assert res.signals == ["slide", "mass.x", "swing"]
    assert [r.value for r in res.runs] == values and len(res.runs) == 3
    for r, k in zip(res.runs[:2], values[:2]):
        assert r.status == "success", r.message
        x0, v0 = steady_point(k=k)
        X = F0 / abs(complex(k - M * W * W, C * W))
        assert np.max(np.abs(r.section.x - x0)) < 1e-6 * X
        assert np.max(np.abs(r.section.xdot - v0)) < 1e-6 * X * W
        assert r.classification.kind == "period-1"
        assert np.allclose(r.sections["mass.x"].points, r.section.points, rtol=0, atol=1e-14)
        y, yd = r.sections["swing"].x, r.sections["swing"].xdot      # on the swing's energy ellipse
        assert np.allclose((y / 0.1) ** 2 + (yd / (0.1 * np.sqrt(40.0))) ** 2, 1.0, rtol=0, atol=1e-8)
    assert abs(steady_point(k=32.0)[1]) < 1e-15
    bad = res.runs[2]
    assert bad.status == "failed" and "failed at t =" in bad.message and bad.classification.kind == "empty"
    assert res.failures == [(-1e6, "failed", bad.message)]
    assert len({r.stats["pid"] for r in res.runs}) == 2           # really ran in two processes
    p, y = res.points()
    assert len(p) == 2 * (CYCLES + 1) and set(p) == {32.0, 80.0}
    back = an.BifurcationResult.load(res.save(tmp_path / "bif.npz"))
    assert np.array_equal(back.points(signal="swing")[1], res.points(signal="swing")[1])
    assert [r.status for r in back.runs] == ["success", "success", "failed"]
    assert back.runs[0].classification == res.runs[0].classification and back.runs[2].message == bad.message


def test_bifurcation_parameter_forms_and_errors():
    # a mapping path -> factor: omega = w and amp = 0.5 w; the period follows w
    par = {"forces[push].law.terms[0].omega": 1.0, "forces[push].law.terms[0].amp": 0.5}
    res = an.bifurcation(OSC, par, [3.0, "abc", float("nan")], period=lambda w: 2 * np.pi / w if w == w else 1.0,
                         signal=("slide", "mass.x"), cycles=2, transient=TRANSIENT, sim_options=SIM,
                         executor="serial")
    ok, err, nan = res.runs
    assert ok.status == "success"
    x0, _ = steady_point(w=3.0, f0=1.5)
    assert np.max(np.abs(ok.section.x - x0)) < 1e-6 * abs(x0)
    assert np.allclose(ok.section.xdot, ok.section.x, atol=1e-14)   # the pair (x_spec, xdot_spec)
    assert err.status == "error" and "abc" in err.message
    assert nan.status == "error" and "not finite" in nan.message
    with pytest.raises(ModelFileError) as e:
        an.bifurcation(OSC, "forces[sprung].k", [1.0], period=T, signal="slide", executor="serial")
    assert "forces[sprung]" in str(e.value) and "spring" in str(e.value)
    with pytest.raises(ModelFileError) as e:
        an.bifurcation(OSC, "stiffness", [1.0], period=T, signal="slide", executor="serial")
    assert "forces" in str(e.value)
    with pytest.raises(InputError):
        an.bifurcation(OSC, "forces[spring].k", [1.0], period=-1.0, signal="slide", executor="serial")


def test_unknown_signal_names_choices(traj):
    with pytest.raises(InputError) as e:
        an.phase_portrait(traj, "slid")
    assert "slide" in str(e.value) and "spring.force" in str(e.value)
    with pytest.raises(InputError):
        an.phase_portrait(traj, "slide[1]")


def test_plots_return_what_they_draw(traj, tmp_path):
    sec = an.poincare(traj, T, "slide", skip_transient=TRANSIENT)
    fig, d = an.plot_phase_portrait(traj, "slide", section=sec, path=tmp_path / "pp.png")
    x, xd = an.phase_portrait(traj, "slide")
    assert np.array_equal(d["x"], x) and np.array_equal(d["section_xdot"], sec.xdot)
    assert (tmp_path / "pp.png").stat().st_size > 1000
    line = [ln for ln in fig.axes[0].lines if ln.get_gid() == "portrait"][0]
    assert np.array_equal(line.get_ydata(), xd)
    _, d = an.plot_poincare(sec)
    assert np.array_equal(d["x"], sec.x)
    runs = [an.BifurcationRun(0, 1.0, "success", "", {"slide": sec}), an.BifurcationRun(1, 2.0, "failed", "boom")]
    res = an.BifurcationResult("k", np.array([1.0, 2.0]), runs, ["slide"], np.array([T, T]))
    fig, d = an.plot_bifurcation(res, path=tmp_path / "bif.png")
    assert np.array_equal(d["p"], np.ones(len(sec))) and np.array_equal(d["y"], sec.xdot)
    assert list(d["failed"]) == [2.0]


def test_relative_rate_in_rotating_frame():
    """Rate of e = R1^T (p2 - p1) with frame 1 rotating (crank) against a spline derivative of
    e computed by forward kinematics on a dense, smooth run of the ideal four-bar."""
    import pinocchio as pin

    mech = pinclear.load(Path(pinclear.__file__).parent.parent / "urdf" / "four_bar.yaml")
    tr = pinclear.simulate(mech, 0.4, dt_out=5e-4, integrator="DOP853", rtol=1e-11)
    model, data = mech.model, mech.model.createData()
    f1, f2 = model.getFrameId("crank"), model.getFrameId("rocker")
    e = np.empty((len(tr.t), 3))
    for i, q in enumerate(tr.q):
        pin.framesForwardKinematics(model, data, q)
        e[i] = data.oMf[f1].rotation.T @ (data.oMf[f2].translation - data.oMf[f1].translation)
    rate = an.relative_rate(model, f1, f2, tr)
    from scipy.interpolate import CubicSpline

    fd = CubicSpline(tr.t, e)(tr.t, 1)
    inner = slice(10, -10)                                   # spline end conditions
    scale = np.max(np.abs(rate[:, :2]))
    assert scale > 0.1                                       # the crank really turns
    assert np.max(np.abs(rate[inner] - fd[inner])) < 1e-6 * scale


DW = DATA / "analysis_double_well.yaml"
DW_K, DW_H, DW_L0, DW_M, DW_C, DW_W = 8.0, 1.0, np.sqrt(2.0), 2.0, 0.6, 1.2


def _double_well_scipy(F, t_eval):
    """The same equation integrated on its own (SciPy, tight tolerance): the second method."""
    from scipy.integrate import solve_ivp

    def f(t, y):
        x, v = y
        r = np.hypot(x, DW_H)
        return [v, (-DW_K * (r - DW_L0) * x / r - DW_C * v + F * np.cos(DW_W * t)) / DW_M]

    s = solve_ivp(f, (0.0, t_eval[-1]), [1.0, 0.0], t_eval=t_eval, method="DOP853", rtol=1e-12, atol=1e-13)
    return s.y


def test_double_well_period_one_and_chaos():
    """Forced buckled-spring oscillator: one well, period-1 at F = 0.2 N; cross-well chaos at
    F = 1.4 N (0-1 test K ~ 1). The model is checked against SciPy on the same equation."""
    Tw = 2 * np.pi / DW_W
    te = an.section_times(Tw, 6)
    tr = pinclear.simulate(pinclear.load(DW), te[-1], t_eval=te, integrator="DOP853", rtol=1e-10)
    ref = _double_well_scipy(1.4, te)
    # chaos amplifies differences ~ e^(lambda t): over 6 periods they stay at the tolerance level
    assert np.max(np.abs(tr.q[:, 0] - ref[0])) < 1e-6 and np.max(np.abs(tr.v[:, 0] - ref[1])) < 1e-6

    res = an.bifurcation(DW, "forces[push].law.terms[0].amp", [0.2, 1.4], period=Tw, signal="slide",
                         cycles=150, transient=20, per_period=4,
                         sim_options=dict(integrator="DOP853", rtol=1e-8), max_workers=2)
    one, chaos = res.runs
    assert one.ok and chaos.ok
    assert one.classification.kind == "period-1"
    ref = _double_well_scipy(0.2, one.section.t)
    assert np.max(np.abs(one.section.x - ref[0])) < 1e-6 and np.max(np.abs(one.section.xdot - ref[1])) < 1e-6
    assert one.section.x.min() > 0                              # stays in the right-hand well
    c = chaos.classification
    assert c.kind == "irregular" and c.K > 0.9 and c.clusters == 151     # no Lyapunov confirmation asked
    assert chaos.section.x.min() < -0.5 < 1.0 < chaos.section.x.max()   # visits both wells


def test_cli_bifurcation_and_poincare(tmp_path, traj, capsys):
    import json

    rc = analyse_main(["bifurcation", str(OSC), "--param", "forces[push].law.terms[0].omega", "--param",
                      "forces[push].law.terms[0].amp*0.5", "--values", "3,6", "--period-from-speed",
                      "--signal", "slide", "--cycles", "2", "--transient", "12", "--integrator", "DOP853",
                      "--rtol", "1e-10", "--workers", "2", "--out", str(tmp_path / "bif")])
    assert rc == 0                      # 12 periods: the transient exp(-2t) is below 1e-10 at w = 6
    res = an.BifurcationResult.load(tmp_path / "bif" / "bifurcation.npz")
    for r in res.runs:
        x0, v0 = steady_point(w=r.value, f0=0.5 * r.value)
        assert np.max(np.abs(r.section.x - x0)) < 1e-6 * abs(x0) and r.classification.kind == "period-1"
    assert (tmp_path / "bif" / "bifurcation_slide.png").exists()
    assert [row["kind"] for row in json.loads((tmp_path / "bif" / "bifurcation.json").read_text())["slide"]] \
        == ["period-1", "period-1"]

    traj.save(tmp_path / "trajectory.npz")
    capsys.readouterr()
    rc = analyse_main(["poincare", str(tmp_path / "trajectory.npz"), "--file", str(OSC), "--period", repr(T),
                      "--signal", "slide", "--skip", str(TRANSIENT), "--out", str(tmp_path / "pc")])
    rep = json.loads(capsys.readouterr().out)
    assert rc == 0 and rep["slide"]["kind"] == "period-1" and rep["slide"]["interpolated"] == 0
    assert (tmp_path / "pc" / "poincare_slide.png").exists() and (tmp_path / "pc" / "phase_slide.png").exists()
    with pytest.raises(InputError):
        analyse_main(["bifurcation", str(OSC), "--param", "forces[push].law.terms[0].omega*x", "--values", "1",
                     "--period", "1", "--signal", "slide", "--out", str(tmp_path / "bad")])


def test_bifurcation_draws_the_largest_lyapunov_exponent(tmp_path):
    """With lyapunov=True every value also gets its largest Lyapunov exponent. The double well
    carries a second, undamped and uncoupled oscillator (the bob on "swing"), so a regular
    motion has exponent 0 (neutral), not the damping rate; the cross-well chaos at F = 1.4 N has
    a positive one. Measured over 50 periods: -0.003..-0.008 and 0.078..0.094 1/s across run
    lengths; the bounds leave room for the spread of finite-time estimates of a chaotic motion."""
    Tw = 2 * np.pi / DW_W
    res = an.bifurcation(DW, "forces[push].law.terms[0].amp", [0.2, 1.4], period=Tw, signal="slide",
                         cycles=40, transient=10, per_period=4, sim_options=dict(integrator="DOP853", rtol=1e-8),
                         max_workers=2, lyapunov=True)
    regular, chaotic = (r.stats["lyapunov"] for r in res.runs)
    assert abs(regular) < 0.03 and chaotic > 0.03
    # each exponent's 95 % interval beside it (issue 51): the neutral one holds 0
    (lo0, hi0), (lo1, hi1) = (r.stats["lyapunov_bound"] for r in res.runs)
    assert lo0 < regular < hi0 and lo0 < 0.0 < hi0 and lo1 < chaotic < hi1
    assert [row["lyapunov"] for row in res.table()] == [regular, chaotic]
    _, drawn = an.plot_bifurcation(res, path=tmp_path / "b.png")
    np.testing.assert_array_equal(drawn["lyapunov"][1], [regular, chaotic])


# --------------------------------------------------------------------------------------------
# Classification on known systems sampled like the papers' runs: RK45 at rtol 1e-6 (integrator
# noise), a few cycles after a short transient, one stroboscopic point per forcing period.
SIM_RTOL = 1e-6
from pinclear.analysis.classify import classify_state, integration_rtol  # noqa: E402

KW0, KW = 1.0, 1.3                       # natural and forcing frequency of the linear oscillator
KT = 2 * np.pi / KW
KZ = np.pi / KT                          # damping zeta*w0: the transient shrinks by e^-pi per period


def _strobe(rhs, period, cycles, y0, skip=2):
    """Section points (cycles + 1 - skip, 2) of a SciPy RK45 run at SIM_RTOL and its accepted
    + rejected steps per period (RK45: 6 evaluations a step)."""
    from scipy.integrate import solve_ivp

    te = np.arange(cycles + 1) * period
    s = solve_ivp(rhs, (0.0, te[-1]), y0, t_eval=te, rtol=SIM_RTOL, method="RK45")
    assert s.success
    return s.y.T[skip:], s.nfev / 6 / cycles


def _linear(force):
    return lambda t, y: [y[1], force(t) - 2 * KZ * y[1] - KW0 ** 2 * y[0]]


def test_integration_tolerance_covers_the_scatter_of_a_period_one_orbit():
    """Forced damped linear oscillator x'' + 2 z x' + w0^2 x = cos(w t): period-1 within the
    tolerance derived from the solver's rtol, at the analytic steady state; the scatter the
    integrator leaves is real (a tolerance at round-off would miss the period) and inside
    the one-period error bound sim_rtol * steps_per_period."""
    P, spp = _strobe(_linear(lambda t: np.cos(KW * t)), KT, 12, [0.0, 0.0])
    c = an.classify(P, sim_rtol=SIM_RTOL, steps_per_period=spp)
    assert (c.kind, c.period, c.clusters) == ("period-1", 1, 1)
    H = complex(KW0 ** 2 - KW ** 2, 2 * KZ * KW)             # x = Re(e^{i w t} / H)
    x_ss, v_ss = (1 / H).real, (1j * KW / H).real
    settled = P[4:]                                           # transient below e^-6pi ~ 1e-8
    scale = np.max(np.abs(P), axis=0)
    assert np.max(np.abs(settled - [x_ss, v_ss]) / scale) < integration_rtol(SIM_RTOL, spp)
    scatter = np.max(np.abs(np.diff(settled, axis=0)) / scale)
    assert 0 < scatter < integration_rtol(SIM_RTOL, spp)
    assert an.detect_period(settled, rtol=1e-13)[0] is None   # round-off tolerance: integrator noise shows


def test_period_two_and_quasi_periodic_forcing():
    """The same oscillator forced at w and w/2 repeats every second period (period-2); forced at
    w and an incommensurate g w (g = golden mean) its section fills a closed curve: never
    periodic; with few cycles that is 'unresolved' (not a false period-k), with 150 the 0-1
    test finds it regular."""
    P2, spp = _strobe(_linear(lambda t: np.cos(KW * t) + 0.5 * np.cos(KW * t / 2)), KT, 12, [0.0, 0.0])
    c2 = an.classify(P2, sim_rtol=SIM_RTOL, steps_per_period=spp)
    assert (c2.kind, c2.clusters) == ("period-2", 2)
    g = (np.sqrt(5) - 1) / 2
    quasi = _linear(lambda t: np.cos(KW * t) + 0.5 * np.cos(g * KW * t))
    Pq, spp = _strobe(quasi, KT, 12, [0.0, 0.0])
    cq = an.classify(Pq, sim_rtol=SIM_RTOL, steps_per_period=spp)
    assert cq.kind == "unresolved" and cq.period is None and "do not shrink" in cq.note
    Pq, spp = _strobe(quasi, KT, 150, [0.0, 0.0])
    cq = an.classify(Pq, sim_rtol=SIM_RTOL, steps_per_period=spp)
    assert cq.kind == "quasi-periodic" and cq.K < 0.1


def test_duffing_chaos_and_a_decaying_transient():
    """Ueda's forced Duffing oscillator x'' + 0.05 x' + x^3 = 7.5 cos t (chaotic attractor):
    no period in 11 cycles ('unresolved'), chaotic by the 0-1 test in 200. A weakly damped
    Duffing oscillator whose transient shrinks by e^(-0.1*2pi) = 0.53 per period is not yet
    periodic after 12 and the note says the differences shrink (run more cycles); after 40 it
    is period-1."""
    ueda = lambda t, y: [y[1], 7.5 * np.cos(t) - 0.05 * y[1] - y[0] ** 3]  # noqa: E731
    P, spp = _strobe(ueda, 2 * np.pi, 12, [3.0, 4.0])
    c = an.classify(P, sim_rtol=SIM_RTOL, steps_per_period=spp)
    assert c.kind == "unresolved" and c.clusters == len(P)
    P, spp = _strobe(ueda, 2 * np.pi, 200, [3.0, 4.0], skip=20)
    c = an.classify(P, sim_rtol=SIM_RTOL, steps_per_period=spp)
    assert c.kind == "irregular" and c.K > 0.9          # chaos needs a Lyapunov exponent too
    weak = lambda t, y: [y[1], 0.3 * np.cos(t) - 0.2 * y[1] - y[0] - y[0] ** 3]  # noqa: E731
    P, spp = _strobe(weak, 2 * np.pi, 12, [0.0, 0.0])
    c = an.classify(P, sim_rtol=SIM_RTOL, steps_per_period=spp)
    assert c.kind == "unresolved" and "shrink by about 0.5" in c.note
    P, spp = _strobe(weak, 2 * np.pi, 40, [0.0, 0.0])
    assert an.classify(P, sim_rtol=SIM_RTOL, steps_per_period=spp).kind == "period-1"


def test_settled_period_and_joint_classification():
    """A transient in the first points does not hide the period of the rest (at least half the
    sequence must repeat); a drifting coordinate makes the joint state non-periodic even when
    another coordinate is constant."""
    k = np.arange(12)
    seq = np.where(k < 4, 1.0 + 0.5 ** k, 1.0)
    assert an.detect_period(seq, rtol=1e-6, scale=[2.0]) == (None, 5)
    assert an.detect_period(seq, rtol=1e-6, scale=[2.0], settle=True) == (1, 1)
    assert an.classify(seq, rtol=1e-6, scale=[2.0]).note == "after a transient of 4 section points"
    late = np.where(k < 7, 1.0 + 0.5 ** k, 1.0)                 # settled over only 5 of 12 points
    assert an.detect_period(late, rtol=1e-6, scale=[2.0], settle=True)[0] is None
    mk = lambda x, xd: an.PoincareSection(k, k * 1.0, x, xd, 1.0, 0.0, "s", np.zeros(12, bool),  # noqa: E731
                                          scale=np.array([1.0, 1.0]))
    still = mk(np.full(12, 0.5), np.zeros(12))
    drift = mk(0.1 * np.cos(2.4 * k), 0.1 * np.sin(2.4 * k))
    assert an.classify(still).kind == "period-1"
    assert classify_state([still, drift]).kind == "unresolved"
    assert classify_state([still, still]).kind == "period-1"
    with pytest.raises(InputError):
        an.classify(seq, sim_rtol=1e-6)


def test_one_lyapunov_run_gives_every_recorded_length_exactly():
    """bifurcation(lyapunov_at=...): one loop, no ordinary run, and each length's exponent is the
    one a separate lyapunov=True run of that length reports, bit for bit (the double well's
    period 2 pi / 1.2 s does not sum exactly, so a shorter run's clipped chunk is a branch)."""
    Tw = 2 * np.pi / DW_W
    kw = dict(period=Tw, signal="slide", transient=2, per_period=4, executor="serial",
              sim_options=dict(integrator="DOP853", rtol=1e-8), lyapunov=True)
    par = "forces[push].law.terms[0].amp"
    one = an.bifurcation(DW, par, [1.4], cycles=5, lyapunov_at=[3, 5], **kw).runs[0]
    assert one.ok and not one.sections and "steps" not in one.stats        # no ordinary run
    for n in (3, 5):
        alone = an.bifurcation(DW, par, [1.4], cycles=n, **kw).runs[0]
        assert one.stats["lyapunov_at"][n] == alone.stats["lyapunov"]
        # each length's 95 % batch-means interval (issue 51) is centred on its exponent
        lo, hi = one.stats["lyapunov_bounds_at"][n]
        assert lo < one.stats["lyapunov_at"][n] < hi
    with pytest.raises(InputError, match="lyapunov_at"):
        an.bifurcation(DW, par, [1.4], cycles=5, lyapunov_at=[3, 6], **kw)
