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
