"""Chaos confirmed, not only suspected: the studies' 'irregular' runs given a Lyapunov check.

The 0-1 test (classify) flags any motion whose Poincaré points wander; a paper's "chaotic" needs
more. Each study hands the values it classified 'irregular' to :func:`confirm_irregular`, which
runs them again with the largest Lyapunov exponent estimated (analysis.bifurcation(...,
lyapunov=True, lyapunov_at=lengths): the companion renormalised four times per period, the
transient left out) at two integration tolerances and two run lengths, and asks
analysis.lyapunov.confirm_chaos whether the exponent is positive: its least 95 % lower bound
(batch means of the chunks' local exponents) over the tolerances and lengths above zero. Confirmed runs
become 'chaotic', the rest stay 'irregular' with the exponents in their note. One loop per
tolerance gives both lengths (the shorter one's exponent is the running estimate at its end), at
about two ordinary runs of the longer length, so a study confirms at most ``limit`` values, the
ones its central-claim rows read first.
"""
from __future__ import annotations

from pinclear.analysis.classify import NOT_CONFIRMED, beyond_threshold
from pinclear.analysis.lyapunov import confirm_chaos

#: the study's rtol times these: the exponent must not move with the tolerance
RTOL_FACTORS = (1.0, 0.1)
#: fractions of the study's recorded cycles: the exponent must not move with the run length
LENGTH_FRACTIONS = (0.25, 0.5)


def _key(v):
    """A value as a lookup key: numbers rounded (they come back from worker processes), labels as given."""
    try:
        return round(float(v), 12)
    except (TypeError, ValueError):
        return v


def _same(a, b):
    """The same parameter value: labels equal, numbers within 1e-8 relative (a study's keys are
    rounded, e.g. 3 pi to 9 digits, while its priorities are exact)."""
    try:
        a, b = float(a), float(b)
    except (TypeError, ValueError):
        return a == b
    return abs(a - b) <= 1e-8 * max(1.0, abs(a), abs(b))


def _label(v):
    return f"{v:.4g}" if isinstance(v, (int, float)) else str(v)


def irregular_values(kinds, priority=()):
    """The values of ``kinds`` ({value: {signal: Classification or None}}) with an 'irregular'
    signal, the ``priority`` values first (in their order), then by the largest 0-1 K."""
    def k_of(v):
        return max((c.K or 0.0) for c in kinds[v].values() if c is not None and c.kind == "irregular")

    irr = [v for v, c in kinds.items() if any(x is not None and x.kind == "irregular" for x in c.values())]
    first = [v for p in priority for v in irr if _same(v, p)]
    return first + sorted((v for v in irr if v not in first), key=k_of, reverse=True)


def confirm_irregular(kinds, rerun, rtol, cycles, period, limit, priority=()):
    """Reclassify, in place, the irregular runs of one diagram with Lyapunov evidence.

    kinds: {value: {signal: Classification}} (the study's own classification); rerun(values,
    rtol, lengths) -> BifurcationResult of those values run again with lyapunov=True,
    lyapunov_at=lengths at that tolerance (cycles = max(lengths), the study's own transient),
    whose runs carry stats['lyapunov_at'] = {n: exponent} and, from analysis.bifurcation,
    stats['lyapunov_bounds_at'] = {n: (lo, hi)} (the batch-means 95 % interval: chaos is then
    decided by the least lower bound, analysis.lyapunov.confirm_chaos); rtol: the study's;
    cycles: its recorded cycles; period(value) -> s. Returns notes (one per value looked at,
    and one naming the values left unconfirmed for the limit)."""
    todo = irregular_values(kinds, priority)
    notes = []
    if len(todo) > limit:
        notes.append(f"{len(todo) - limit} irregular value(s) not given the Lyapunov check (the study's limit is "
                     f"{limit}): " + ", ".join(_label(v) for v in todo[limit:]))
    todo = todo[:limit]
    if not todo:
        return notes
    evidence = lyapunov_evidence(todo, rerun, rtol, cycles)
    lengths = _lengths(cycles)
    for v in todo:
        ev = evidence[v]
        for sig, c in kinds[v].items():
            if c is not None and c.kind == "irregular":
                kinds[v][sig] = with_evidence(c, ev)
        notes.append(f"{_label(v)}: Lyapunov check over rtol {', '.join(f'{rtol * f:g}' for f in RTOL_FACTORS)} x "
                     f"{' and '.join(str(n) for n in lengths)} recorded periods ({period(v):.4g} s each): "
                     f"{'chaotic' if ev.confirmed else 'not confirmed'}: {ev.note}")
    return notes


def _lengths(cycles):
    return [max(1, round(f * cycles)) for f in LENGTH_FRACTIONS]


def lyapunov_evidence(values, rerun, rtol, cycles):
    """{value: ChaosEvidence} for any ``values`` (regular ones too: a row whose regular motion
    contradicts a paper's chaos states its negative exponent and upper bound, ev.regular), from
    the same reruns as :func:`confirm_irregular` (``rerun`` as there): one run per tolerance of
    RTOL_FACTORS, each giving every length of LENGTH_FRACTIONS x ``cycles``."""
    values = list(values)
    if not values:
        return {}
    exps = {}                                  # (value, rtol, recorded cycles) -> exponent or (exponent, lo, hi)
    lengths = _lengths(cycles)
    for fac in RTOL_FACTORS:
        # one run per tolerance serves every length: the shorter lengths' exponents are the
        # running estimate at their end (analysis.lyapunov.LyapunovResult.ends)
        res = rerun(values, rtol * fac, lengths)
        for r in res.runs:
            at = r.stats.get("lyapunov_at") or {}
            bounds = r.stats.get("lyapunov_bounds_at")
            for n in lengths:
                lam = at.get(n)
                lam = float("nan") if lam is None else float(lam)
                if bounds is not None:
                    lo, hi = bounds.get(n) or (float("nan"), float("nan"))
                    lam = (lam, float(lo), float(hi))
                exps[(_key(r.value), rtol * fac, n)] = lam
    return {v: confirm_chaos(lambda r, n, v=v: exps.get((_key(v), r, int(n)), float("nan")),
                             [rtol * f for f in RTOL_FACTORS], lengths) for v in values}


def exponent_text(ev):
    """A report cell for Lyapunov evidence: 'λ1 = 4.1 1/s (95 % lower bound 2.9 1/s)' when chaotic,
    'λ1 = -0.52 1/s (95 % upper bound -0.31 1/s)' when regular, both bounds otherwise."""
    if ev is None:
        return "no exponent computed"
    if ev.failed:
        return "Lyapunov estimate failed"
    lam, pct = f"λ1 = {ev.exponent:.3g} 1/s", f"{100 * ev.level:.0f} %"
    if ev.lower != ev.lower:                   # plain exponents, no bounds
        return lam
    if ev.confirmed:
        return f"{lam} ({pct} lower bound {ev.lower:.3g} 1/s)"
    if ev.regular:
        return f"{lam} ({pct} upper bound {ev.upper:.3g} 1/s)"
    return f"{lam} ({pct} bounds {ev.lower:.3g} to {ev.upper:.3g} 1/s)"


def with_evidence(c, evidence):
    """The 'irregular' classification ``c`` given Lyapunov ``evidence``, by classify's own rule
    (analysis.classify.beyond_threshold)."""
    return beyond_threshold(c.clusters, c.K, c.n, c.note.split(NOT_CONFIRMED)[0].rstrip("; "), evidence)
