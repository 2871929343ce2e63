"""pinclear.analysis.convergence: the transient-length check of a Poincaré class and the
output-step convergence of a quantity read off a grid (issue 51, item 5), on cases whose answer
is known in closed form."""
from __future__ import annotations

import math

import numpy as np
import pytest

from pinclear.analysis.convergence import step_convergence, transient_check, transient_summary
from pinclear.analysis.poincare import PoincareSection
from pinclear.core.errors import InputError


def _decaying(n=100, rate=0.85):
    """Section points of a period-1 orbit reached through a transient 0.5 rate^k cos(2 k): with
    rtol 1e-4 of the scale (~1.5) the consecutive differences fall under the tolerance near
    k = ln(1.5e-4 / 1) / ln(0.85) ~ 54, so the settled tail holds ~46 of 100 points (less than
    the half classify asks for) and 46 of 80 once 20 more points are left out. Read after the
    short transient, the still-decaying points fake a period-3 (cos 2k nearly repeats every 3
    points, 6 rad being 2 pi - 0.28, so s[k+3] - s[k] falls under the tolerance ~9 points
    earlier than s[k+1] - s[k])."""
    k = np.arange(n)
    return 1.0 + 0.5 * rate ** k * np.cos(2.0 * k)


def test_a_class_that_changes_with_a_longer_transient_is_flagged():
    x = _decaying()
    chk = transient_check(x, extra=20, rtol=1e-4)
    assert chk.short.kind == "period-3" and chk.long.kind == "period-1"
    assert not chk.agree and "the longer transient's class counts" in chk.note
    # a settled period-2 orbit keeps its class
    two = 1.0 + 0.1 * (np.arange(100) % 2)
    ok = transient_check(two, extra=20, rtol=1e-4)
    assert ok.agree and ok.short.kind == ok.long.kind == "period-2"
    line = transient_summary({"0.5 mm": chk, "0.6 mm": ok})
    assert line.startswith("transient check (+20 periods): 1 of 2 keep their class") and "0.5 mm: " in line


def test_sections_and_lists_of_sections_are_cut_alike():
    x = _decaying()
    n = len(x)
    k = np.arange(n)
    sec = PoincareSection(k=k, t=k * 2.0, x=x, xdot=np.zeros(n), period=2.0, phase=0.0, label="e",
                          interpolated=np.zeros(n, bool), exact_rate=False, scale=np.array([1.5, 0.0]))
    one = transient_check(sec, extra=20, rtol=1e-4)
    both = transient_check([sec, sec], extra=20, rtol=1e-4)
    assert one.long.kind == both.long.kind == "period-1" and not one.agree and not both.agree
    assert one.long.n == n - 20
    with pytest.raises(InputError):
        transient_check(x[:10], extra=20)
    with pytest.raises(InputError):
        transient_check(x, extra=0)


def test_step_convergence_finds_the_trapezoid_rules_order_and_error():
    """The trapezoid rule on exp over [0, 1]: error (e - 1) h^2 / 12 to leading order, so the
    observed order is 2 and Richardson's estimate of the finest value's error is its true error
    to O(h^2) (here within 1 %)."""
    def trapezoid(h):
        t = np.linspace(0.0, 1.0, round(1.0 / h) + 1)
        y = np.exp(t)
        return {"integral": float(np.sum((y[1:] + y[:-1]) * np.diff(t)) / 2), "constant": 2.0}

    sc = step_convergence(trapezoid, [0.1, 0.05, 0.025], rtol=1e-3)
    assert sc.order["integral"] == pytest.approx(2.0, abs=0.01)
    true = (sc.values["integral"][-1] - (math.e - 1)) / (math.e - 1)
    assert sc.error["integral"] == pytest.approx(true, rel=0.01)
    assert sc.converged["integral"] and sc.all_converged and sc.error["constant"] == 0.0
    assert "converged" in sc.note("integral") and len(sc.table()) == 6
    # 1 % between the two finest steps against an allowed 0.5 %: not converged
    sc2 = step_convergence(lambda h: 1.0 + h, [0.04, 0.02, 0.01], rtol=0.005)
    assert not sc2.converged["value"] and "NOT converged" in sc2.note("value")
    with pytest.raises(InputError):
        step_convergence(lambda h: 1.0, [1e-3, 2e-3])          # fine to coarse
    with pytest.raises(InputError):
        step_convergence(lambda h: 1.0, [1e-3])


def test_sampled_convergence_reads_coarser_grids_off_one_run():
    """A 5 ms spike (a half-sine of 5 ms, peak 1 at t = 0.30015 s) sampled every 1e-4 s: every k-th
    sample is the grid of step k x 1e-4 s, whose largest sample is cos(pi d / 5 ms) for d the
    distance of its nearest sample to the crest. Each value equals that closed form; the two
    finest (every 3rd, 2nd sample: d = 1.5e-4 and 0.5e-4 s) give 0.99556 and 0.99951, a change
    of 0.4 %: the check passes at 1 % and fails at 0.01 %."""
    from pinclear.analysis.convergence import STRIDES, sampled_convergence

    t = np.arange(0.0, 0.6 + 1e-12, 1e-4)
    t0, w = 0.30015, 5e-3
    y = np.where(np.abs(t - t0) < w / 2, np.cos(np.pi * (t - t0) / w), 0.0)
    sc = sampled_convergence(t, lambda i: float(np.max(y[i])), rtol=0.01)
    for k, v in zip(STRIDES, sc.values["value"]):
        d = np.min(np.abs(t[::k] - t0))
        assert v == pytest.approx(np.cos(np.pi * d / w), abs=1e-12)
    assert sc.steps == pytest.approx([k * 1e-4 for k in STRIDES])
    assert sc.converged["value"]
    assert not sampled_convergence(t, lambda i: float(np.max(y[i])), rtol=1e-4).converged["value"]
    with pytest.raises(InputError, match="not uniform"):
        sampled_convergence(np.append(t, 0.7), lambda i: 0.0)
    with pytest.raises(InputError, match="too few"):
        sampled_convergence(t[:5], lambda i: 0.0)
