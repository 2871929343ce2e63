"""Largest Lyapunov exponent (Benettin's two trajectories with renormalisation) against values
known in closed form or published: a linear system, the Lorenz attractor, an inverted pendulum."""
from __future__ import annotations

import numpy as np
import pytest

import pinclear
from pinclear.analysis import largest_lyapunov, mechanism_lyapunov


def test_linear_system_exponent_is_its_largest_eigenvalue_real_part():
    A = np.array([[0.3, -2.0, 0.0], [2.0, 0.3, 0.0], [0.0, 0.0, -1.0]])     # spiral out at 0.3/s
    res = largest_lyapunov(lambda t, y: A @ y, [1.0, 0.0, 1.0], 20.0, renorm=0.5, transient=2.0)
    assert res.exponent == pytest.approx(0.3, abs=2e-3)      # the rotation leaves a bounded log-ratio


def test_lorenz_exponent_equals_the_published_value():
    """Lorenz (sigma 10, rho 28, beta 8/3): 0.9056 (Sprott, Chaos and Time-Series Analysis, 2003).
    A finite run estimates it with a spread: 8 runs of 200 time units from nearby starts gave
    0.906 +- 0.007 (max deviation 0.014); the bound 0.035 is five of those standard deviations."""
    def lorenz(t, y):
        return np.array([10.0 * (y[1] - y[0]), y[0] * (28.0 - y[2]) - y[1], y[0] * y[1] - 8.0 / 3.0 * y[2]])
    res = largest_lyapunov(lorenz, [1.0, 1.0, 20.0], 220.0, renorm=0.5, transient=20.0, rtol=1e-8, atol=1e-10)
    assert res.exponent == pytest.approx(0.9056, abs=0.035)
    assert res.renormalisations == 400 and res.t[-1] == pytest.approx(220.0)


def test_inverted_pendulum_diverges_at_its_linearised_rate():
    """The planar pendulum balanced upside down: small motions grow as exp(lambda t) with
    lambda = sqrt(m g c / I_pivot), from the model's own inertia. The companion is assembled
    onto the pin closure after every renormalisation."""
    mech = pinclear.load("clr_planar_pendulum")
    q0 = mech.q0.copy()
    q0[mech.model.joints[3].idx_q] = np.pi
    res = mechanism_lyapunov(mech, 3.0, renorm=0.1, transient=0.5, q0=q0)
    body = mech.model.inertias[3]
    c = body.lever
    I_pivot = body.inertia[2, 2] + body.mass * (c[0] ** 2 + c[1] ** 2)
    lam = np.sqrt(body.mass * 9.81 * np.hypot(c[0], c[1]) / I_pivot)
    assert res.exponent == pytest.approx(lam, rel=5e-3)


def _lorenz(t, y):
    return np.array([10.0 * (y[1] - y[0]), y[0] * (28.0 - y[2]) - y[1], y[0] * y[1] - 8.0 / 3.0 * y[2]])


@pytest.mark.parametrize("renorm", [0.5, 0.3, 0.7])
def test_a_longer_loop_gives_the_shorter_runs_exponents_bit_for_bit(renorm):
    """benettin(ends=...): one loop gives the exponent a shorter run reports, exactly. 0.5 sums
    to 3.0 exactly; 0.3 and 0.7 do not (6 x 0.3 summed falls short of 1.8 by an ulp, so the
    shorter run clips its last chunk and the longer loop runs that chunk as a branch). An
    off-by-one chunk or a mismatched transient moves a Lorenz exponent by ~1e-2, far above 0."""
    kw = dict(renorm=renorm, transient=renorm, rtol=1e-8, atol=1e-10)
    short, mid, t_long = 6 * renorm, 11 * renorm, 18 * renorm
    alone = {t: largest_lyapunov(_lorenz, [1.0, 1.0, 20.0], t, **kw).exponent for t in (short, mid, t_long)}
    both = largest_lyapunov(_lorenz, [1.0, 1.0, 20.0], t_long, ends=(short, mid, t_long), **kw)
    assert both.ends == alone
    # asking for ends does not change the longer loop's own estimate or its convergence record
    plain = largest_lyapunov(_lorenz, [1.0, 1.0, 20.0], t_long, **kw)
    assert both.exponent == plain.exponent and np.array_equal(both.running, plain.running)


def test_a_loop_that_stops_keeps_the_exponents_of_the_ends_it_passed():
    from pinclear.analysis.lyapunov import LyapunovFailed, benettin
    from pinclear.core.errors import IntegrationError

    def advance(y, t, dt):
        if t >= 2.0:
            raise IntegrationError("step size underflow")
        return y * np.exp(0.4 * dt)              # separation grows at exactly 0.4/s

    with pytest.raises(LyapunovFailed) as exc:
        benettin(advance, lambda a, b: float(np.linalg.norm(b - a)), lambda a, b, f, t: a + f * (b - a),
                 np.ones(2), np.ones(2) * (1 + 1e-8), 0.0, 4.0, 0.5, float(np.sqrt(2)) * 1e-8, 0.5, ends=(1.5, 3.0))
    assert exc.value.partial.ends[1.5] == pytest.approx(0.4, rel=1e-6) and 3.0 not in exc.value.partial.ends
    assert isinstance(exc.value.cause, IntegrationError)


@pytest.mark.parametrize("scene", ["four_ups_upu", "slider_crank_clearance"])
def test_kept_alive_chunks_give_the_per_chunk_simulate_exponents_bit_for_bit(scene, monkeypatch):
    """mechanism_lyapunov's chunks as pinclear.dynamics.simulate.Restarts runs (formulation and compiled
    evaluation kept) against one simulate(..., resume=Checkpoint) call per chunk: the same first
    steps, steps and end states, so every running estimate is equal bit for bit. 4UPS-UPU + S2
    (paper 000: a spherical clearance with 3 internal states, redundant closure rows dropped,
    mu 0.01, impacts) over 2 periods of 2 s; Flores' slider-crank with its pin clearance P (a
    drive with its work meter state) over 3 crank turns. A wrong first step, a stale row choice
    or a leftover internal state moves the exponents at the first chunk."""
    import pinclear.dynamics.stepping.run as R

    if scene == "four_ups_upu":
        mech = pinclear.load(scene, clearances=["S2"], overrides={"S2.mu": 0.01})
        T, periods, rtol = 2.0, 2, 1e-6
    else:
        mech = pinclear.load(scene, clearances=["P"])
        T, periods, rtol = 2 * np.pi / 523.5987755982989, 3, 1e-7
    assert mech.nz > 0 and mech.m > 0 and mech.clearances
    kw = dict(renorm=T / 4, transient=T, rtol=rtol)
    built = []
    make = R.Evaluation
    monkeypatch.setattr(R, "Evaluation", lambda *a, **k: built.append(1) or make(*a, **k))
    old = mechanism_lyapunov(mech, periods * T, keep_alive=False, **kw)
    n_old = len(built)
    new = mechanism_lyapunov(mech, periods * T, **kw)
    n_new = len(built) - n_old
    assert old.renormalisations == new.renormalisations == 4 * (periods - 1)
    assert np.array_equal(old.t, new.t) and np.array_equal(old.running, new.running)
    assert old.exponent == new.exponent and np.isfinite(new.exponent)
    # the per-chunk path builds an evaluation for every chunk of both trajectories (and the
    # start's run); the kept one builds it once beside that start run
    assert n_old == 2 * 4 * periods + 1 and n_new == 2


@pytest.mark.parametrize("method", ["lagrange", "manifold"])
def test_restarts_runs_equal_resumed_simulate_runs_when_the_rows_change(method):
    """pinclear.dynamics.simulate.Restarts against simulate(..., resume=Checkpoint(h_next=None)) on
    Bricard's linkage, whose independent constraint rows by the rank analysis differ between its
    start (4 of 5) and t = 0.02 s (all 5; lagrange's solve then finds the rank loss the overclosed
    linkage has, and both paths fail with the same message): the kept pieces are renewed when a
    start's rows are not theirs and kept when they are, and every run keeps the same samples bit
    for bit. manifold (not in KEEPS_ALIVE) runs through simulate() itself."""
    import warnings

    from pinclear.dynamics.simulate import KEEPS_ALIVE, Restarts
    from pinclear.dynamics.trajectory import Checkpoint

    mech = pinclear.load("a04_bricard")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        ref = pinclear.simulate(mech, 0.05, rtol=1e-8, t_eval=np.linspace(0.0, 0.05, 11))
    starts = [0, 4, 6, 0]                    # t = 0 (4 rows), 0.02 and 0.03 s (5 rows), 0 again
    r = Restarts(mech, method=method, rtol=1e-8)
    rows, renewed, status = [], [], []
    for k in starts:
        t, q, v, z = float(ref.t[k]), ref.q[k], ref.v[k], ref.z[k]
        ck = Checkpoint(t0=t, q=q, v=v, z=z, t=t, q_now=q, v_now=v, z_now=z, h_next=None)
        old = pinclear.simulate(mech, t + 0.01, t0=t, t_eval=[t, t + 0.01], resume=ck, method=method, rtol=1e-8)
        before = r.pieces["form"] if r.keep else None
        new = r.run(t, q, v, z, t + 0.01)
        assert new.status == old.status and new.message == old.message
        status.append(new.status)
        assert np.array_equal(new.t, old.t)
        for a in ("q", "v", "z"):
            assert np.array_equal(getattr(new, a), getattr(old, a))
        if r.keep:
            rows.append(len(r.pieces["rows"]))
            renewed.append(r.pieces["form"] is not before)
    if method in KEEPS_ALIVE:
        assert rows == [4, 5, 5, 4] and renewed == [False, True, False, True]
        assert status == ["success", "failed", "failed", "success"]
    else:
        assert not r.keep and status == ["success"] * 4


# --------------------------------------------------------------------------------------------
# Confidence bounds (issue 51, item 4): the exponent's 95 % interval from the batch means of the
# chunks' local exponents decides chaos (lower bound > 0) and a stable attractor (upper bound < 0).

def _rk4_advance(f, h):
    """advance(y, t, dt) by classical RK4 with steps of at most h (a fixed-step integrator, cheap
    enough for a fast test; its error at h = 0.005 on Lorenz moves the exponent by < 1e-3)."""
    def advance(y, t, dt):
        n = max(1, int(np.ceil(dt / h - 1e-9)))
        s = dt / n
        for _ in range(n):
            k1 = f(y)
            k2 = f(y + 0.5 * s * k1)
            k3 = f(y + 0.5 * s * k2)
            k4 = f(y + s * k3)
            y = y + s / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
            t += s
        return y
    return advance


def _loop(f, y0, t_end, renorm, transient, h, ends=()):
    from pinclear.analysis.lyapunov import benettin

    y0 = np.asarray(y0, float)
    u = np.ones_like(y0) / np.sqrt(len(y0))
    return benettin(_rk4_advance(f, h), lambda a, b: float(np.linalg.norm(b - a)), lambda a, b, f_, t: a + f_ * (b - a),
                    y0, y0 + 1e-8 * u, 0.0, t_end, renorm, 1e-8, transient, ends)


def test_lorenz_lower_bound_is_positive_and_the_interval_holds_the_published_value():
    """Lorenz (sigma 10, rho 28, beta 8/3), lambda1 = 0.9056 (Sprott 2003). Over 60 time units
    after a transient of 10 the batch-means interval (10 batches of 6 time units) must hold the
    published value and its lower bound must be positive by a wide margin (a 6-unit exponent of
    Lorenz scatters by ~0.15, so the half-width is ~2.26 x 0.15 / sqrt(10) ~ 0.11; 0.5 leaves
    4 of them). RK4 at h = 0.02 (a tenth of the fastest time scale, 1/(sigma + 1))."""
    def lorenz(y):
        return np.array([10.0 * (y[1] - y[0]), y[0] * (28.0 - y[2]) - y[1], y[0] * y[1] - 8.0 / 3.0 * y[2]])
    res = _loop(lorenz, [1.0, 1.0, 20.0], 70.0, 0.5, 10.0, 0.02, ends=(30.0,))
    lo, hi = res.bound()
    assert lo < 0.9056 < hi and lo > 0.5 and hi - lo < 0.5
    assert len(res.local) == len(res.dt) == res.renormalisations == 120
    # the loop's exponent is the dt-weighted mean of its local exponents
    assert float(np.sum(res.local * res.dt) / np.sum(res.dt)) == pytest.approx(res.exponent, rel=1e-12)
    # the shorter run's bound is the bound a loop ending there computes on its own chunks
    alone = _loop(lorenz, [1.0, 1.0, 20.0], 30.0, 0.5, 10.0, 0.02)
    assert res.end_bounds[30.0] == pytest.approx(alone.bound(), rel=1e-12)
    assert res.ends[30.0] == alone.exponent


def test_damped_oscillator_exponent_is_minus_zeta_omega_with_a_negative_upper_bound():
    """x'' + 2 zeta w x' + w^2 x = 0 (zeta 0.1, w 2): every separation decays as exp(-zeta w t)
    times a bounded rotation, so lambda = -zeta w = -0.2 1/s; the finite-time estimate carries
    the rotation's bounded log-ratio / T. The interval must hold -0.2 and lie below 0."""
    z, w = 0.1, 2.0
    f = lambda y: np.array([y[1], -2 * z * w * y[1] - w * w * y[0]])
    res = _loop(f, [1.0, 0.0], 82.0, 0.3, 2.0, 0.01)
    lo, hi = res.bound()
    assert lo < -z * w < hi < 0
    assert res.exponent == pytest.approx(-z * w, abs=0.03)
    from pinclear.analysis.lyapunov import confirm_chaos
    ev = confirm_chaos(lambda r, t: (res.exponent, lo, hi), [1e-8], [82.0])
    assert ev.regular and ev.verdict == "regular" and not ev.confirmed and "upper bound" in ev.note


def test_a_neutral_motion_straddles_zero_and_decides_nothing():
    """Two undamped oscillators at incommensurate frequencies (a quasi-periodic torus): lambda = 0;
    the interval holds 0, so the motion is neither chaotic nor a stable attractor."""
    f = lambda y: np.array([y[1], -y[0], y[3], -2.0 * y[2]])
    res = _loop(f, [1.0, 0.0, 0.5, 0.0], 60.0, 0.37, 1.0, 0.02)
    lo, hi = res.bound()
    assert lo < 0.0 < hi
    from pinclear.analysis.lyapunov import confirm_chaos
    ev = confirm_chaos(lambda r, t: (res.exponent, lo, hi), [1e-8], [60.0])
    assert ev.verdict == "undecided" and "contain 0" in ev.note


def test_batch_means_interval_covers_the_mean_of_a_correlated_sequence():
    """Coverage on a sequence with a known mean and correlation: local 'exponents' an AR(1)
    process (coefficient 0.6, a correlation time of 2 chunks) around mu = 1. Over 400
    replications of 400 chunks the 95 % interval must hold mu in 95 % of them: a binomial 3-sigma
    band at n = 400 is +- 3.3 %, so [0.91, 0.99]. A per-chunk standard error (ignoring the
    correlation, too narrow by sqrt((1 + 0.6) / (1 - 0.6)) = 2) covers ~67 % and would fail."""
    from pinclear.analysis.lyapunov import batch_means_bound

    rng = np.random.default_rng(1)
    n, reps, phi = 400, 400, 0.6
    e = rng.standard_normal((reps, n))
    x = np.empty_like(e)
    x[:, 0] = e[:, 0] / np.sqrt(1 - phi ** 2)
    for i in range(1, n):
        x[:, i] = phi * x[:, i - 1] + e[:, i]
    hit = 0
    for row in 1.0 + x:
        lam, lo, hi = batch_means_bound(row, np.full(n, 0.25))
        assert lam == pytest.approx(row.mean(), rel=1e-12)
        hit += lo < 1.0 < hi
    assert 0.91 <= hit / reps <= 0.99


def test_too_few_chunks_give_no_bound_and_bad_input_is_refused():
    from pinclear.analysis.lyapunov import batch_means_bound
    from pinclear.core.errors import InputError

    lam, lo, hi = batch_means_bound([1.0, 2.0, 3.0], [1.0, 1.0, 1.0])      # 3 chunks: 1 batch of 2
    assert lam == pytest.approx(2.0) and np.isnan(lo) and np.isnan(hi)
    assert np.isfinite(batch_means_bound([1.0, 2.0, 3.0, 4.0], [1.0] * 4)[1])   # 2 batches of 2
    with pytest.raises(InputError):
        batch_means_bound([1.0, 2.0], [1.0])
    with pytest.raises(InputError):
        batch_means_bound([1.0, 2.0], [1.0, 1.0], level=1.5)
