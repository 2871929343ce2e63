"""Classification of a Poincaré sequence: period-k detection, the physical resolution, the 0-1
test, and chaos only where a largest Lyapunov exponent positive with confidence confirms it.

Kinds: ``period-k``; ``below resolution`` (no period-1, but the points spread less than the
stated resolution, e.g. a fraction of the joint's clearance, and their rates less than the rate
that resolution makes at the driving frequency: a wobble too small to call a motion of its own,
never reported as chaos); ``quasi-periodic`` (0-1 test K <= threshold);
``irregular`` (K above the threshold, chaos not confirmed: no Lyapunov exponent given, or it is
not positive with confidence); ``chaotic`` (K above the threshold AND a largest Lyapunov exponent
whose 95 % lower bound, the least over integration tolerances and run lengths, is positive,
:func:`pinclear.analysis.lyapunov.confirm_chaos`);
``unresolved`` (too few samples); ``empty``."""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pinclear.analysis.poincare import PoincareSection
from pinclear.core.errors import InputError


def detect_period(points, rtol=1e-4, atol=0.0, scale=None, max_period=16, settle=False):
    """Period of a Poincaré sequence and its number of distinct clusters.

    points: (n,) or (n, d). Two points are "the same" when every coordinate differs by at most
    ``atol + rtol * scale`` (scale per coordinate: the given ``scale``, default max |points|).
    The period is the smallest p <= max_period with |s[i+p] - s[i]| within tolerance for all i
    (at least p such comparisons are required, so n >= 2p); None if there is none.
    settle=True allows a transient: the comparisons must hold from some index i0 on, and the
    settled tail s[i0:] must hold at least half the sequence (and 2p points), so a run whose
    first cycles still carry the start-up transient is judged by the cycles after it.
    Returns (period, n_clusters); clusters are counted greedily against cluster seeds (over the
    settled tail when a period was found with settle=True). :func:`settled_period` also returns i0.
    """
    period, clusters, _ = settled_period(points, rtol, atol, scale, max_period, settle)
    return period, clusters


def settled_period(points, rtol=1e-4, atol=0.0, scale=None, max_period=16, settle=True):
    """(period, n_clusters, i0) as :func:`detect_period`; i0 is the first section point of the
    settled tail (0 when every comparison holds)."""
    P = np.asarray(points, float)
    if P.ndim == 1:
        P = P[:, None]
    n = len(P)
    if n == 0:
        return None, 0, 0
    if scale is None:
        scale = np.max(np.abs(P), axis=0)
    tol = atol + rtol * np.broadcast_to(np.asarray(scale, float), (P.shape[1],))
    tol = np.where(tol > 0, tol, np.finfo(float).tiny)
    S = P / tol                                   # equal within tolerance <=> |dS|_inf <= 1
    period, i0 = None, 0
    for p in range(1, min(max_period, n // 2) + 1):
        bad = np.flatnonzero(np.max(np.abs(S[p:] - S[:-p]), axis=1) > 1.0)
        if not len(bad):
            period = p
            break
        if settle:
            start = int(bad[-1]) + 1              # every comparison s[i+p] ~ s[i] holds for i >= start
            if n - start >= max(2 * p, (n + 1) // 2):
                period, i0 = p, start
                break
    seeds = []
    for p in S[i0:]:
        if not seeds or np.min(np.max(np.abs(np.asarray(seeds) - p), axis=1)) > 1.0:
            seeds.append(p)
    return period, len(seeds), i0


def integration_rtol(sim_rtol, steps_per_period):
    """Relative tolerance for "the same Poincaré point" in a run integrated with relative
    tolerance ``sim_rtol`` taking ``steps_per_period`` steps per driving period.

    The solver bounds each step's local error by about sim_rtol times the state's size; one
    period's global error, and so the part of it that differs from one cycle to the next (the
    step sequence is chosen afresh each cycle), is at most the sum over its steps:
    sim_rtol * steps_per_period of the signal's scale. A periodic orbit's section points
    scatter well inside this bound (tests/analysis/test_analysis.py measures it on a forced linear
    oscillator; the nine-bar with 0.01 mm clearances at rtol 1e-6 scatters by 1e-6 of its
    scale against a bound of 4e-3); points further apart than it are not resolved as
    different by the integration. The bound grows with the step count: a run with many steps
    per period (hard impacts) resolves only coarser structure; tighten rtol to see finer.
    """
    sim_rtol, steps = float(sim_rtol), float(steps_per_period)
    if not (math.isfinite(sim_rtol) and sim_rtol > 0):
        raise InputError(f"sim_rtol must be a positive number, got {sim_rtol!r}")
    if not (math.isfinite(steps) and steps > 0):
        raise InputError(f"steps_per_period must be a positive number, got {steps_per_period!r}")
    return sim_rtol * max(1.0, steps)


def chaos_01(phi, n_c=100, n_cut=None, seed=0, flat_tol=None, return_all=False):
    """0-1 test for chaos (Gottwald & Melbourne 2004; 2009 modified mean-square displacement,
    correlation method) on a scalar sequence phi(j), e.g. Poincaré samples.

    For n_c frequencies c drawn uniformly in (pi/5, 4pi/5) (away from resonances):
    p_c(n) = sum_j phi(j) cos(j c), q_c(n) = sum_j phi(j) sin(j c);
    M_c(n) = <|p_c(j+n) - p_c(j)|^2 + |q_c(j+n) - q_c(j)|^2>_j, n <= n_cut (default N/10);
    D_c(n) = M_c(n) - <phi>^2 (1 - cos nc)/(1 - cos c) (the bounded oscillatory part);
    K_c = corr(n, D_c(n)); K = median over c.
    K ~ 0: regular (periodic or quasi-periodic); K ~ 1: chaotic (diffusive growth of p, q).

    Limitations: needs a long sequence (N >= ~100 for a hint, >= 1000 for a clear answer);
    intermediate values appear for short series, for weak chaos, and for transients left in the
    data; a continuous signal sampled far finer than its correlation time (oversampled) reads
    as regular: feed it stroboscopic samples, not dense output; noise, and a slow drift (an
    unfinished transient), read as chaos. A sequence whose standard deviation is at most
    ``flat_tol`` (default 1e-6 max |phi|: integration noise around a fixed point) returns
    K = 0, regular, by definition: D_c is then noise and its correlation with n meaningless.
    """
    phi = np.asarray(phi, float).ravel()
    if not np.all(np.isfinite(phi)):
        raise InputError("chaos_01: the sequence contains non-finite values")
    N = len(phi)
    if N < 20:
        raise InputError(f"chaos_01 needs at least 20 samples, got {N}")
    n_cut = max(N // 10, 2) if n_cut is None else int(n_cut)
    if not 2 <= n_cut < N:
        raise InputError(f"n_cut must be in [2, {N - 1}], got {n_cut}")
    flat = 1e-6 * float(np.max(np.abs(phi))) if flat_tol is None else float(flat_tol)
    if np.std(phi) <= flat:
        return (0.0, np.zeros(n_c)) if return_all else 0.0
    c = np.random.default_rng(seed).uniform(np.pi / 5, 4 * np.pi / 5, n_c)
    arg = np.outer(c, np.arange(1, N + 1))
    Pc = np.cumsum(phi * np.cos(arg), axis=1)
    Qc = np.cumsum(phi * np.sin(arg), axis=1)
    n = np.arange(1, n_cut + 1)
    M = np.empty((n_c, n_cut))
    for i, m in enumerate(n):
        dP = Pc[:, m:] - Pc[:, :-m]
        dQ = Qc[:, m:] - Qc[:, :-m]
        M[:, i] = np.einsum("ij,ij->i", dP, dP) + np.einsum("ij,ij->i", dQ, dQ)
        M[:, i] /= N - m
    D = M - phi.mean() ** 2 * (1 - np.cos(np.outer(c, n))) / (1 - np.cos(c))[:, None]
    nn = n - n.mean()
    Dc = D - D.mean(axis=1, keepdims=True)
    den = np.sqrt((nn @ nn) * np.einsum("ij,ij->i", Dc, Dc))
    Kc = np.divide(Dc @ nn, den, out=np.zeros(n_c), where=den > 0)
    K = float(np.median(Kc))
    return (K, Kc) if return_all else K


#: K above this is reported as chaotic; clear answers are K < 0.1 or K > 0.9 (see chaos_01)
CHAOS_THRESHOLD = 0.5


@dataclass
class Classification:
    kind: str                 # "period-k" | "below resolution" | "quasi-periodic" | "irregular" | "chaotic" |
                              # "unresolved" | "empty"
    period: int | None
    clusters: int
    K: float | None           # 0-1 test result (None when a period was found or too few samples)
    n: int
    note: str = ""
    evidence: object = None   # the Lyapunov evidence (analysis.lyapunov.ChaosEvidence) that decided it, if any

    def as_dict(self):
        out = {"kind": self.kind, "period": self.period, "clusters": self.clusters, "K": self.K, "n": self.n,
               "note": self.note}
        if self.evidence is not None:
            out["lyapunov"] = self.evidence.as_dict()
        return out


#: the default resolution of a clearance joint's response: Poincaré spreads below this fraction of
#: the clearance are 'below resolution' (1 %: 5 um of a 0.5 mm gap, the scale of surface roughness
#: and of the contact's own elastic penetration, below which a rigid-body clearance model says
#: nothing physical)
CLEARANCE_FRACTION = 0.01


def classify(section, rtol=None, atol=0.0, scale=None, max_period=16, min_samples_01=40, chaos_threshold=None,
             sim_rtol=None, steps_per_period=None, resolution=None, lyapunov=None, rate_resolution=None):
    """Classify a Poincaré section (PoincareSection or an (n,) / (n, d) array).

    First the period (:func:`detect_period` with settle=True): "period-k" if the sequence
    repeats with period k <= max_period from some section point on, over at least its second
    half (the first points may still carry the start-up transient; ``note`` then says how
    many), points being equal within atol + rtol * scale (scale per coordinate: default the
    section's ``scale``, the attractor's extent, so a point near x = 0 is judged against the
    size of the orbit, not against itself).

    rtol must exceed the cycle-to-cycle scatter the integration leaves in the section points.
    Give the run's integration tolerance ``sim_rtol`` and its ``steps_per_period`` (accepted
    steps over the run / periods simulated) and rtol is derived from them
    (:func:`integration_rtol`: sim_rtol * steps_per_period, the bound of one period's global
    error); without them rtol defaults to 1e-4. Otherwise, with at least ``min_samples_01``
    samples, the 0-1 test on each coordinate (the largest K counts): K > chaos_threshold
    (default CHAOS_THRESHOLD = 0.5) "chaotic", else "quasi-periodic"; ``note`` says "ambiguous"
    when 0.1 <= K <= 0.9. With fewer samples: "unresolved", and ``note`` says whether the
    cycle-to-cycle differences still shrink (a transient decaying towards a periodic orbit:
    run more cycles) or not.
    A section whose rate is not exact (spline-differentiated output) is judged by x alone.

    resolution: the physical resolution of the positions (same unit; e.g. CLEARANCE_FRACTION x
    the clearance): a sequence that is not period-1 but whose coordinates all spread (max - min)
    less than their resolution is "below resolution". For a PoincareSection it applies to x, and
    ``rate_resolution`` (default omega x resolution, omega = 2 pi / the section's period: the
    rate of a wobble of the resolution's size at the driving frequency) to an exact rate: the
    papers' diagrams plot velocities, and a motion whose positions hardly move while its rates
    spread (a second frequency above the driving one) is a motion, not a wobble. For an array
    it applies to every column (give an array with inf for columns it does not apply to).
    lyapunov: a :class:`pinclear.analysis.lyapunov.ChaosEvidence` (or None): K above the threshold
    is "chaotic" only when it confirms chaos, else "irregular".
    """
    thr = CHAOS_THRESHOLD if chaos_threshold is None else float(chaos_threshold)
    if (sim_rtol is None) != (steps_per_period is None):
        raise InputError("classify: give sim_rtol and steps_per_period together (the tolerance is derived from both)")
    if sim_rtol is not None:
        derived = integration_rtol(sim_rtol, steps_per_period)
        rtol = derived if rtol is None else max(float(rtol), derived)
    elif rtol is None:
        rtol = 1e-4
    if isinstance(section, PoincareSection):
        P = section.points
        if scale is None and np.any(section.scale > 0):
            scale = section.scale
        if not section.exact_rate:
            # a spline-differentiated rate carries end and sampling errors that differ from cycle
            # to cycle: judge by x alone
            P = P[:, :1]
            scale = None if scale is None else np.broadcast_to(np.asarray(scale, float), (2,))[:1]
    else:
        P = np.asarray(section, float)
    if P.ndim == 1:
        P = P[:, None]
    n = len(P)
    if n == 0:
        return Classification("empty", None, 0, None, 0, "no Poincaré samples")
    period, clusters, i0 = settled_period(P, rtol=rtol, atol=atol, scale=scale, max_period=max_period)
    if period != 1 and resolution is not None:
        small = _below(P[i0:] if period else P, resolution, section, rate_resolution)
        if small is not None:
            what = f"period-{period} at the integration tolerance, " if period else ""
            return Classification("below resolution", period, clusters, None, n,
                                  f"{what}Poincaré spread {small[0]:.3g} below the resolution {small[1]:.3g}"
                                  + small[2])
    if period is not None:
        note = f"after a transient of {i0} section points" if i0 else ""
        if clusters < period:
            # the period is where the whole sequence repeats; clusters count distinct points, and
            # two points of one period within the tolerance of each other are one cluster
            note = "; ".join(x for x in (note, f"{clusters} distinct clusters for period {period}: some of the "
                                         f"{period} section points of one period lie within the period tolerance of "
                                         "each other (the orbit passes close to one point of the section twice per "
                                         "period); the period, where the sequence repeats, is the classification")
                             if x)
        return Classification(f"period-{period}", period, clusters, None, n, note)
    if n < min_samples_01:
        return Classification("unresolved", None, clusters, None, n,
                              f"no period <= {min(max_period, n // 2)} and too few samples ({n} < "
                              f"{min_samples_01}) for the 0-1 test{_trend(P, scale)}")
    sc = _coordinate_scale(P, scale)
    # spread within the period tolerance is a fixed point to this resolution
    K = max(chaos_01(P[:, j], flat_tol=atol + rtol * sc[j]) for j in range(P.shape[1]))
    note = "ambiguous (0.1 <= K <= 0.9): longer runs or a smaller tolerance may decide" if 0.1 <= K <= 0.9 else ""
    if K <= thr:
        return Classification("quasi-periodic", None, clusters, K, n, note)
    return beyond_threshold(clusters, K, n, note, lyapunov)


#: how an 'irregular' note starts its reason (pinclear.studies.reproduce.chaos strips it to add evidence)
NOT_CONFIRMED = "0-1 test only, chaos not confirmed: "


def beyond_threshold(clusters, K, n, note, lyapunov):
    """The class of a section whose 0-1 test K exceeds the threshold: 'chaotic' only when the
    Lyapunov evidence confirms it, else 'irregular' with the reason in the note."""
    if lyapunov is not None and lyapunov.confirmed:
        return Classification("chaotic", None, clusters, K, n, "; ".join(x for x in (note, lyapunov.note) if x),
                              lyapunov)
    why = lyapunov.note if lyapunov is not None else "no largest Lyapunov exponent computed"
    return Classification("irregular", None, clusters, K, n, "; ".join(x for x in (note, NOT_CONFIRMED + why) if x),
                          lyapunov)


def _below(P, resolution, section, rate_resolution=None):
    """(spread, resolution, rate text) when every coordinate of P with a finite resolution spreads
    less than it, else None. A PoincareSection's positions are its first column; its exact rate
    (second column) is judged against ``rate_resolution``, default omega x resolution."""
    res = np.asarray(resolution, float)
    rate_text = ""
    if isinstance(section, PoincareSection):
        x_res = float(np.broadcast_to(res, (1,))[0])
        extra = np.full(P.shape[1] - 1, np.inf)
        if P.shape[1] > 1:
            r_res = (2.0 * math.pi / section.period * x_res) if rate_resolution is None else float(rate_resolution)
            extra[0] = r_res
            r_spread = float(np.ptp(P[:, 1])) if len(P) else 0.0
            rate_text = f"; rate spread {r_spread:.3g} below {r_res:.3g}"
        res = np.concatenate([[x_res], extra])
    elif rate_resolution is not None:
        raise InputError("classify: rate_resolution applies to a PoincareSection; for an array give each column's "
                         "resolution in ``resolution``")
    res = np.broadcast_to(res, (P.shape[1],))
    cols = np.isfinite(res)
    if not cols.any() or not len(P):
        return None
    spread = np.ptp(P[:, cols], axis=0)
    if np.all(spread < res[cols]):
        if isinstance(section, PoincareSection):
            return float(spread[0]), float(res[0]), rate_text
        return float(np.max(spread)), float(np.min(res[cols])), rate_text
    return None


def _coordinate_scale(P, scale):
    """Per-coordinate scale of an (n, d) sequence: the given ``scale``, default max |P|."""
    return np.broadcast_to(np.max(np.abs(P), axis=0) if scale is None else np.asarray(scale, float), (P.shape[1],))


def _trend(P, scale):
    """'; ... shrink by about r per cycle' when the cycle-to-cycle differences decay (a transient
    still decaying towards a periodic orbit: more cycles may find the period), judged by a
    log-linear fit whose slope is negative by more than two standard errors."""
    if len(P) < 5:
        return ""
    sc = _coordinate_scale(P, scale)
    d = np.max(np.abs(np.diff(P, axis=0)) / np.where(sc > 0, sc, 1.0), axis=1)
    if np.any(d <= 0):
        return ""
    i = np.arange(len(d), dtype=float)
    fit = np.polyfit(i, np.log(d), 1, full=True)
    slope, res = fit[0][0], fit[1]
    dof = len(d) - 2
    resid = float(res[0]) if len(res) else 0.0
    se = math.sqrt(resid / dof / np.sum((i - i.mean()) ** 2)) if dof > 0 else math.inf
    r = math.exp(slope)
    if slope + 2 * se < 0:
        return (f"; the differences between consecutive section points shrink by about {r:.2g} per cycle "
                f"(last {d[-1]:.2g} of the scale): a transient still decaying, more cycles may find a period")
    return f"; the differences between consecutive section points do not shrink (about {r:.2g} per cycle)"


def classify_state(sections, **options):
    """Classify one run from several signals' Poincaré sections at once (e.g. both components of
    two journals' eccentricities): the motion is period-k only if every coordinate repeats with
    period k, as for the section of the full state; a coordinate that hardly moves (a journal
    pressed against one side of its bearing) cannot make a drifting run look periodic. Points
    are stacked coordinate by coordinate with each section's own scale; ``options`` as for
    :func:`classify`. The 0-1 test's K is the largest over all coordinates. A scalar
    ``resolution`` applies to each section's position column and omega x resolution (omega =
    2 pi / the section's period) to its exact rate, as :func:`classify` does for one section
    (``rate_resolution`` overrides the latter)."""
    secs = [s for s in sections if s is not None and len(s)]
    if not secs:
        return classify(np.zeros((0, 2)), **options)
    n = min(len(s) for s in secs)
    cols, scales = [], []
    for s in secs:
        k = 2 if s.exact_rate else 1          # a spline-differentiated rate is judged by x alone
        cols.append(s.points[-n:, :k])
        sc = s.scale[:k] if np.any(s.scale > 0) else np.max(np.abs(s.points[-n:, :k]), axis=0)
        scales.append(sc)
    if "scale" in options and options["scale"] is not None:
        raise InputError("classify_state takes each section's own scale; do not pass scale")
    options.pop("scale", None)
    res = options.pop("resolution", None)
    rate_res = options.pop("rate_resolution", None)
    if res is not None and np.ndim(res) == 0:
        res = np.concatenate([[float(res)] + [(2.0 * math.pi / s.period * float(res)) if rate_res is None
                                              else float(rate_res)] * (c.shape[1] - 1)
                              for s, c in zip(secs, cols)])
    elif rate_res is not None:
        raise InputError("classify_state: rate_resolution goes with a scalar resolution")
    return classify(np.hstack(cols), scale=np.concatenate(scales), resolution=res, **options)
