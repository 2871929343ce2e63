"""pinclear.studies.reproduce.chaos: the studies' 'irregular' runs become 'chaotic' only with a positive
Lyapunov exponent that agrees over both tolerances and both run lengths (analysis.lyapunov's rule),
the paper's named values are checked first, and the limit is kept and reported."""
from pathlib import Path
from types import SimpleNamespace

import pytest

from pinclear.analysis.classify import Classification
from pinclear.studies.reproduce import chaos


def irregular(K):
    return Classification("irregular", None, 0, K, 100, "0-1 test only, chaos not confirmed: no largest Lyapunov "
                                                         "exponent computed")


def fake_rerun(exponent, calls):
    """A rerun whose exponent over n recorded cycles is exponent(value, rtol, n) (one run per
    tolerance gives every length: stats['lyapunov_at']); records what it was asked."""
    def rerun(values, rtol, lengths):
        calls.append((tuple(values), rtol, tuple(lengths)))
        return SimpleNamespace(runs=[SimpleNamespace(value=v, ok=True, stats={"lyapunov_at": {
            n: exponent(v, rtol, n) for n in lengths}}) for v in values])
    return rerun


def test_confirmed_unconfirmed_and_regular_runs():
    kinds = {0.1: {"A": irregular(0.95), "B": Classification("period-1", 1, 1, None, 100, "")},
             0.2: {"A": irregular(0.9), "B": irregular(0.8)},
             0.3: {"A": Classification("period-2", 2, 2, None, 100, "")}}
    # 0.1: converged positive exponent; 0.2: drifts with the run length (a regular motion's
    # finite-time exponent decays like 1/t)
    calls = []
    rerun = fake_rerun(lambda v, r, n: 3.0 + 1e-3 * n if v == 0.1 else 4.0 / n, calls)
    notes = chaos.confirm_irregular(kinds, rerun, 1e-8, 100, lambda v: 2.0, limit=5)
    assert kinds[0.1]["A"].kind == "chaotic" and kinds[0.1]["B"].kind == "period-1"
    assert kinds[0.2]["A"].kind == "irregular" and "does not converge" in kinds[0.2]["A"].note
    assert kinds[0.3]["A"].kind == "period-2"
    # one run per tolerance, each giving both lengths, over the irregular values only
    assert sorted((r, n) for _, r, n in calls) == sorted((1e-8 * f, (25, 50)) for f in chaos.RTOL_FACTORS)
    assert all(set(v) == {0.1, 0.2} for v, _, _ in calls)
    assert len(notes) == 2 and "chaotic" in notes[0] and "not confirmed" in notes[1]


def test_negative_exponent_and_failed_estimate_never_confirm():
    kinds = {1.0: {"A": irregular(0.99)}, 2.0: {"A": irregular(0.99)}}
    rerun = fake_rerun(lambda v, r, n: (-0.5 if r < 1e-8 else 2.0) if v == 1.0 else None, [])
    chaos.confirm_irregular(kinds, rerun, 1e-8, 40, lambda v: 1.0, limit=5)
    assert kinds[1.0]["A"].kind == "irregular" and "not positive" in kinds[1.0]["A"].note
    assert kinds[2.0]["A"].kind == "irregular" and "failed" in kinds[2.0]["A"].note


def test_priority_first_then_largest_K_and_the_limit_is_reported():
    kinds = {v: {"A": irregular(K)} for v, K in ((0.01, 0.6), (0.05, 0.99), (0.02, 0.7), (0.09, 0.8))}
    calls = []
    notes = chaos.confirm_irregular(kinds, fake_rerun(lambda v, r, n: 1.0, calls), 1e-6, 100, lambda v: 1.0,
                                    limit=3, priority=(0.02, 0.01))
    assert list(calls[0][0]) == [0.02, 0.01, 0.05]
    assert kinds[0.09]["A"].kind == "irregular" and kinds[0.05]["A"].kind == "chaotic"
    assert "not given the Lyapunov check" in notes[0] and "0.09" in notes[0]


def test_labels_as_values():
    kinds = {"baseline": {"A": irregular(0.9)}}
    chaos.confirm_irregular(kinds, fake_rerun(lambda v, r, n: 1.0, []), 1e-8, 100, lambda v: 1.0, limit=1)
    assert kinds["baseline"]["A"].kind == "chaotic"


def test_priorities_match_rounded_keys():
    """A study keys its values rounded (paper 002: round(3 pi, 9)); its priority 3 pi is exact and
    must still come first (the full 002 study checked two other speeds first when it did not)."""
    import math

    kinds = {round(v, 9): {"A": irregular(K)} for v, K in ((3 * math.pi, 0.6), (2.7 * math.pi, 0.99))}
    calls = []
    chaos.confirm_irregular(kinds, fake_rerun(lambda v, r, n: 1.0, calls), 1e-6, 100, lambda v: 1.0, limit=1,
                            priority=(2 * math.pi, 3 * math.pi))
    assert list(calls[0][0]) == [round(3 * math.pi, 9)]


def test_a_length_the_run_did_not_reach_is_a_failed_estimate():
    """A loop that stopped between the two lengths keeps the shorter one's exponent; the missing
    one makes the check fail (never confirmed), as a separate failed run did."""
    kinds = {0.5: {"A": irregular(0.99)}}

    def rerun(values, rtol, lengths):
        return SimpleNamespace(runs=[SimpleNamespace(value=v, ok=False, stats={"lyapunov_at": {
            lengths[0]: 1.0, lengths[1]: float("nan")}}) for v in values])
    notes = chaos.confirm_irregular(kinds, rerun, 1e-8, 100, lambda v: 1.0, limit=1)
    assert kinds[0.5]["A"].kind == "irregular" and "failed" in kinds[0.5]["A"].note and "not confirmed" in notes[0]


def fake_bounded_rerun(table, calls):
    """A rerun as analysis.bifurcation gives it since issue 51: stats['lyapunov_bounds_at'] =
    {n: (lo, hi)} beside the exponents. table(value, rtol, n) -> (exponent, lo, hi)."""
    def rerun(values, rtol, lengths):
        calls.append((tuple(values), rtol, tuple(lengths)))
        runs = []
        for v in values:
            got = {n: table(v, rtol, n) for n in lengths}
            runs.append(SimpleNamespace(value=v, ok=True, stats={"lyapunov_at": {n: e[0] for n, e in got.items()},
                                                                 "lyapunov_bounds_at": {n: e[1:] for n, e in
                                                                                        got.items()}}))
        return SimpleNamespace(runs=runs)
    return rerun


def test_positive_exponents_34_percent_apart_are_chaos_by_their_lower_bound():
    """Paper 002 at 0.8 mm (issue 51): the four estimates 4.57 / 4.72 / 3.85 / 3.33 1/s over two
    tolerances x two lengths differ by 34 % of their mean. By the old convergence rule (25 %) the
    row stayed 'irregular'; positivity is the question, and with every 95 % lower bound above 0
    (least 1.9 1/s) it is chaotic. The same exponents without bounds keep the old rule."""
    est = {(1e-8, 25): (4.57, 3.1, 6.0), (1e-8, 50): (4.72, 3.8, 5.6),
           (1e-9, 25): (3.85, 1.9, 5.8), (1e-9, 50): (3.33, 2.4, 4.3)}
    kinds = {0.8: {"A": irregular(0.97)}}
    notes = chaos.confirm_irregular(kinds, fake_bounded_rerun(lambda v, r, n: est[(round(r, 12), n)], []), 1e-8,
                                    100, lambda v: 1.0, limit=1)
    c = kinds[0.8]["A"]
    assert c.kind == "chaotic" and "lower bound 1.9" in c.note and "chaotic" in notes[0]
    assert c.evidence.lower == 1.9 and c.evidence.upper == 6.0 and c.evidence.verdict == "chaotic"
    assert c.as_dict()["lyapunov"]["lower"] == 1.9
    assert chaos.exponent_text(c.evidence) == "λ1 = 4.12 1/s (95 % lower bound 1.9 1/s)"
    plain = {0.8: {"A": irregular(0.97)}}
    chaos.confirm_irregular(plain, fake_rerun(lambda v, r, n: est[(round(r, 12), n)][0], []), 1e-8, 100,
                            lambda v: 1.0, limit=1)
    assert plain[0.8]["A"].kind == "irregular" and "does not converge" in plain[0.8]["A"].note


def test_a_lower_bound_at_or_below_zero_anywhere_keeps_it_irregular():
    """The minimum over tolerances and lengths decides: one estimate whose interval reaches 0
    (the short run at the fine tolerance) is enough to leave chaos unconfirmed."""
    kinds = {0.3: {"A": irregular(0.9)}}
    table = lambda v, r, n: (0.8, -0.1, 1.7) if (r < 1e-8 and n == 25) else (1.0, 0.4, 1.6)
    chaos.confirm_irregular(kinds, fake_bounded_rerun(table, []), 1e-8, 100, lambda v: 1.0, limit=1)
    assert kinds[0.3]["A"].kind == "irregular" and "contain 0" in kinds[0.3]["A"].note
    # a bound the loop could not form (too few renormalisations) decides nothing
    kinds = {0.3: {"A": irregular(0.9)}}
    chaos.confirm_irregular(kinds, fake_bounded_rerun(lambda v, r, n: (1.0, float("nan"), float("nan")), []), 1e-8,
                            100, lambda v: 1.0, limit=1)
    assert kinds[0.3]["A"].kind == "irregular" and "could not be formed" in kinds[0.3]["A"].note


def test_a_regular_row_gets_its_negative_exponent_and_upper_bound():
    """lyapunov_evidence serves any value (a period-1 row contradicting a paper's chaos): a
    negative exponent whose every upper bound is below 0 is a stable attractor."""
    calls = []
    table = lambda v, r, n: (-0.52, -0.7, -0.31) if v == 0.01 else (0.02, -0.2, 0.25)
    ev = chaos.lyapunov_evidence([0.01, 0.05], fake_bounded_rerun(table, calls), 1e-8, 100)
    assert ev[0.01].regular and ev[0.01].verdict == "regular" and ev[0.01].upper == -0.31
    assert chaos.exponent_text(ev[0.01]) == "λ1 = -0.52 1/s (95 % upper bound -0.31 1/s)"
    assert ev[0.05].verdict == "undecided" and not ev[0.05].regular
    assert chaos.exponent_text(ev[0.05]) == "λ1 = 0.02 1/s (95 % bounds -0.2 to 0.25 1/s)"
    # the same reruns as confirm_irregular: one per tolerance, each giving both lengths
    assert sorted((r, n) for _, r, n in calls) == sorted((1e-8 * f, (25, 50)) for f in chaos.RTOL_FACTORS)
    assert chaos.lyapunov_evidence([], None, 1e-8, 100) == {}


@pytest.mark.slow
def test_the_double_well_decides_by_its_bounds_end_to_end():
    """The whole path on a real model (analysis.bifurcation's lyapunov_at runs -> their bounds ->
    lyapunov_evidence): the forced double well of tests/data carries an undamped, uncoupled second
    oscillator, so its regular motion at F = 0.2 N has exponent 0 exactly (a neutral direction):
    the interval must hold 0 (undecided, neither chaos nor a stable attractor); its cross-well
    chaos at F = 1.4 N must have a positive least lower bound. About 4 s of CPU."""
    import numpy as np

    import pinclear.analysis as an

    dw = Path(__file__).parents[1] / "data" / "analysis_double_well.yaml"
    Tw = 2 * np.pi / 1.2

    def rerun(vals, rtol, lengths):
        return an.bifurcation(dw, "forces[push].law.terms[0].amp", vals, period=Tw, signal="slide",
                              cycles=max(lengths), transient=10, per_period=4, executor="serial",
                              sim_options={"integrator": "DOP853", "rtol": rtol}, lyapunov=True, lyapunov_at=lengths)

    ev = chaos.lyapunov_evidence([0.2, 1.4], rerun, 1e-8, 80)
    assert ev[0.2].lower < 0.0 < ev[0.2].upper and ev[0.2].verdict == "undecided"
    assert ev[1.4].lower > 0.0 and ev[1.4].verdict == "chaotic"
