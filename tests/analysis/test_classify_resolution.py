"""The classifier looks at amplitude and asks a Lyapunov exponent before it says chaos:
known-answer cases with a tiny chaotic component on a large periodic one (issue 39, item 4)."""
from __future__ import annotations

import numpy as np
import pytest

import pinclear.analysis as an
from pinclear.analysis.poincare import PoincareSection
from pinclear.core.errors import InputError


def logistic(n, x0=0.3, skip=100):
    x, out = x0, np.empty(n)
    for i in range(n + skip):
        x = 4.0 * x * (1.0 - x)
        if i >= skip:
            out[i - skip] = x
    return out


def lorenz(t, y, s=10.0, r=28.0, b=8.0 / 3.0):
    return [s * (y[1] - y[0]), y[0] * (r - y[2]) - y[1], y[0] * y[1] - b * y[2]]


def test_a_tiny_chaotic_wobble_on_a_large_orbit_is_below_resolution():
    # a journal held at 0.5 mm of a 0.5 mm clearance (the section's point of a period-1 orbit),
    # plus a chaotic wobble of amplitude eps (logistic map): eps = 3 um spans 0.6 % of the gap,
    # below the 1 % resolution. (Far smaller wobbles on so large an offset escape the 0-1 test itself:
    # K = 0.09 at eps = 0.1 um, 400 samples.)
    c, n = 5e-4, 1000
    wob = logistic(n) - 0.5
    for eps, expect in ((3e-6, "below resolution"), (2e-5, "irregular")):
        x = c + eps * wob
        res = an.CLEARANCE_FRACTION * c            # 5 um
        # the integration floor is far below the wobble, so without the resolution both read as chaos-like
        plain = an.classify(x, rtol=1e-6)
        assert plain.kind == "irregular" and plain.K > 0.9
        k = an.classify(x, rtol=1e-6, resolution=res)
        assert k.kind == expect, (eps, k)
        if expect == "below resolution":
            assert "below the resolution" in k.note and k.K is None
    # a period-1 orbit stays period-1 whatever the resolution (a point has no spread to judge)
    assert an.classify(np.full(100, c) + 1e-12 * wob[:100], rtol=1e-6, resolution=1.0).kind == "period-1"
    # a period-2 orbit whose two points differ by less than the resolution is below it; by more, period-2
    two = c + 1e-7 * (np.arange(100) % 2)
    assert an.classify(two, rtol=1e-6, resolution=5e-6).kind == "below resolution"
    assert an.classify(two, rtol=1e-6, resolution=5e-8).kind == "period-2"


def test_resolution_applies_to_positions_and_to_rates():
    """Issue 51: the rates are tested too, against omega x the position resolution (omega = 2 pi
    / the section's period). A section whose positions spread by 1e-8 (under a 1e-6 resolution)
    but whose rates spread by 0.1 (over 2 pi x 1e-6) is a motion, not a wobble; with the rate
    spread under 2 pi x 1e-6 it is below resolution."""
    n = 200
    wob = logistic(n) - 0.5
    k = np.arange(n)

    def sec(rate_amp):
        return PoincareSection(k=k, t=k.astype(float), x=1e-3 + 1e-8 * wob, xdot=rate_amp * wob, period=1.0,
                               phase=0.0, label="x", interpolated=np.zeros(n, bool), exact_rate=True,
                               scale=np.array([1e-3, max(rate_amp, 1e-9)]))
    loud, quiet = sec(0.1), sec(1e-6)            # rate spreads 0.1 and 1e-6 against 2 pi x 1e-6 = 6.3e-6
    assert an.classify(loud, rtol=1e-6, resolution=1e-6).kind == "irregular"
    assert an.classify_state([loud, loud], rtol=1e-6, resolution=1e-6).kind == "irregular"
    k_quiet = an.classify(quiet, rtol=1e-6, resolution=1e-6)
    assert k_quiet.kind == "below resolution" and "rate spread" in k_quiet.note
    assert an.classify_state([quiet, quiet], rtol=1e-6, resolution=1e-6).kind == "below resolution"
    # an explicit rate resolution overrides omega x resolution
    assert an.classify(loud, rtol=1e-6, resolution=1e-6, rate_resolution=1.0).kind == "below resolution"
    assert an.classify_state([loud, loud], rtol=1e-6, resolution=1e-6, rate_resolution=1.0).kind == "below resolution"
    assert an.classify_state([quiet, quiet], rtol=1e-6, resolution=1e-9).kind == "irregular"
    # a spline-differentiated rate is not exact: judged by x alone, as the period test does
    quiet_x = PoincareSection(k=k, t=k.astype(float), x=1e-3 + 1e-8 * wob, xdot=0.1 * wob, period=1.0, phase=0.0,
                              label="x", interpolated=np.zeros(n, bool), exact_rate=False, scale=np.array([1e-3, 0.1]))
    assert an.classify(quiet_x, rtol=1e-6, resolution=1e-6).kind == "below resolution"
    with pytest.raises(InputError):
        an.classify(np.c_[wob, wob], resolution=1e-6, rate_resolution=1.0)


def _two_frequency_section(clearance, a, w2, n=400):
    """A journal's eccentricity x(t) = 0.9 c + 0.1 c cos(W t) + a cos(w2 t) sampled once per
    driving period T = 2 pi / W (W = pi rad/s, paper 000's crank speed): a period-1 response
    with a second, incommensurate frequency w2 of small amplitude a. The section points are
    x_k = c + a cos(w2 k T) and xdot_k = -a w2 sin(w2 k T), exactly (a quasi-periodic torus);
    the scale is the signals' range over the run, as poincare() gives it."""
    W = np.pi
    T = 2 * np.pi / W
    k = np.arange(n)
    t = k * T
    x = 0.9 * clearance + 0.1 * clearance + a * np.cos(w2 * t)
    xd = -a * w2 * np.sin(w2 * t)
    scale = np.array([0.2 * clearance + 2 * a, 0.1 * clearance * W + a * w2])
    return PoincareSection(k=k, t=t, x=x, xdot=xd, period=T, phase=0.0, label="e", interpolated=np.zeros(n, bool),
                           exact_rate=True, scale=scale)


def test_a_quasi_periodic_rate_spread_is_not_below_resolution():
    """Paper 000's clearance diagram at 0.75 mm (resolution 1 % = 7.5 um): a second frequency
    of amplitude 2.5 um spreads the positions by 5 um, under the resolution, but at w2 = 2 pi x
    12.3 Hz the rates by 2 a w2 = 0.39 mm/s, 16 times omega x resolution = pi x 7.5 um/s =
    0.024 mm/s: the motion is quasi-periodic (0-1 test K ~ 0), as the paper's velocity
    diagram would show it, not 'below resolution'. The same amplitude at the slow second
    frequency w2 = 0.618 W spreads the rates by 0.0097 mm/s, under 0.024: below resolution."""
    c = 7.5e-4
    res = an.CLEARANCE_FRACTION * c
    fast = _two_frequency_section(c, 2.5e-6, 2 * np.pi * 12.3 * (1 + 1e-3 * np.sqrt(2)))
    assert np.ptp(fast.x) < res < np.ptp(fast.xdot) / np.pi
    k = an.classify(fast, rtol=1e-4, resolution=res)
    assert k.kind == "quasi-periodic" and k.K < 0.1, k
    slow = _two_frequency_section(c, 2.5e-6, (np.sqrt(5) - 1) / 2 * np.pi)
    assert np.ptp(slow.xdot) < np.pi * res
    assert an.classify(slow, rtol=1e-4, resolution=res).kind == "below resolution"


@pytest.mark.slow
def test_lorenz_chaos_is_confirmed_and_a_regular_motion_is_not():
    """Lorenz (sigma 10, r 28, b 8/3): largest exponent 0.906 1/s (Sprott, Chaos and Time-Series
    Analysis, 2003, table A.1); finite-time estimates over 150-300 s lie within ~10 % of it. A
    damped forced oscillator has a negative exponent (the damping rate), an undamped one zero:
    neither is confirmed."""
    y0 = [1.0, 1.0, 20.0]

    def est(rtol, t_end):
        return an.largest_lyapunov(lorenz, y0, t_end, renorm=0.5, transient=10.0, rtol=rtol, atol=1e-10).exponent

    ev = an.confirm_chaos(est, rtols=[1e-8, 1e-10], lengths=[150.0, 300.0], rel=0.25)
    assert ev.confirmed and abs(ev.exponent - 0.906) < 0.1 * 0.906, ev.estimates
    forced = lambda t, y: [y[1], np.cos(t) - 0.2 * y[1] - y[0]]           # noqa: E731
    ev2 = an.confirm_chaos(lambda r, t: an.largest_lyapunov(forced, [0.0, 0.0], t, renorm=1.0, rtol=r).exponent,
                           rtols=[1e-8], lengths=[40.0, 80.0])
    assert not ev2.confirmed and "not positive" in ev2.note and ev2.exponent < -0.05   # -0.1: half the damping
    # a chaotic-looking 0-1 result without a confirmed exponent is 'irregular', never 'chaotic'
    x = logistic(400)
    assert an.classify(x, lyapunov=ev2).kind == "irregular"
    assert an.classify(x, lyapunov=ev).kind == "chaotic"


def test_an_exponent_that_does_not_converge_is_not_chaos():
    ev = an.confirm_chaos(lambda r, t: {100.0: 0.05, 200.0: 0.01}[t], rtols=[1e-8], lengths=[100.0, 200.0])
    assert not ev.confirmed and "does not converge" in ev.note
