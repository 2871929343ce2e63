"""pinclear.studies.reproduce.chaos: the studies' 'irregular' runs become 'chaotic' only with a positive
Lyapunov exponent that agrees over both tolerances and both run lengths (analysis.lyapunov's rule),
the paper's named values are checked first, and the limit is kept and reported."""
from types import SimpleNamespace

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
