"""Largest Lyapunov exponent by two nearby trajectories with renormalisation (Benettin, Galgani,
Giorgilli and Strelcyn, Meccanica 15, 1980): a companion trajectory starts d0 away from the
reference; every ``renorm`` seconds the separation d is measured, ln(d / d0) accumulated and the
companion put back at distance d0 along the separation. The exponent is the accumulated sum over
the time elapsed after the transient. It complements the 0-1 test (classify.chaos_01): lambda >
0 is exponential divergence (chaos), lambda ~ 0 a regular motion, lambda < 0 a stable attractor.

One loop serves plain ODE systems (:func:`largest_lyapunov`) and mechanisms
(:func:`mechanism_lyapunov`), where the companion lives on the configuration manifold
(pin.integrate / pin.difference), is put back onto the closure constraints after every
renormalisation, and carries the force elements' internal states of the reference.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from pinclear.core.errors import InputError, PinclearError

#: batches of the batch-means confidence bound: 10 to 30 is the usual choice (Schmeiser, Oper. Res.
#: 30, 1982): fewer widens the Student t quantile, more shortens each batch below the local
#: exponents' correlation time (a few renormalisations) and the batch means stop being independent
BATCHES = 10


@dataclass
class LyapunovResult:
    exponent: float                 # 1/s
    t: np.ndarray                   # renormalisation times after the transient
    running: np.ndarray             # the estimate up to each of those times (its convergence)
    renormalisations: int
    ends: dict = field(default_factory=dict)     # {end time: exponent} of benettin(ends=...)'s shorter runs
    #: per counted chunk (after the transient): its local exponent ln(d / d0) / dt (1/s) and its length dt (s)
    local: np.ndarray = field(default_factory=lambda: np.zeros(0))
    dt: np.ndarray = field(default_factory=lambda: np.zeros(0))
    #: {end time: (lo, hi)}: the batch-means confidence bound (batch_means_bound) of each of ``ends``' runs
    end_bounds: dict = field(default_factory=dict)

    def bound(self, level=0.95, batches=BATCHES):
        """(lo, hi): the ``level`` confidence interval of the exponent from the batch means of the
        chunks' local exponents (:func:`batch_means_bound`)."""
        return batch_means_bound(self.local, self.dt, level, batches)[1:]

    def as_dict(self):
        lo, hi = self.bound() if len(self.local) else (float("nan"), float("nan"))
        return {"exponent": self.exponent, "renormalisations": self.renormalisations, "lower": lo, "upper": hi,
                "final_spread": float(np.ptp(self.running[len(self.running) // 2:])) if len(self.running) else None}


def batch_means_bound(local, dt, level=0.95, batches=BATCHES):
    """(exponent, lo, hi): the finite-time exponent of the chunks with local exponents ``local``
    (ln(d / d0) / dt each) and lengths ``dt``, and its two-sided ``level`` confidence interval by
    batch means: the chunks in ``batches`` contiguous batches, each batch's exponent
    b_j = sum(ln) / sum(dt); half-width t_{(1 + level) / 2, B - 1} s_b / sqrt(B) (Student t, s_b
    the batches' standard deviation). Consecutive local exponents are correlated (a chunk that
    stretches the separation hands the next one a companion already along the unstable
    direction); batches much longer than that correlation are nearly independent, so the
    interval is honest where a per-chunk standard error would be far too narrow.
    Fewer chunks than two per batch: B shrinks to half the chunk count; under 2 batches the
    bound is (nan, nan): an exponent with no spread measured decides nothing."""
    from scipy.stats import t as student

    local, dt = np.asarray(local, float), np.asarray(dt, float)
    if len(local) != len(dt):
        raise InputError(f"batch_means_bound: {len(local)} local exponents but {len(dt)} chunk lengths")
    if not 0 < level < 1:
        raise InputError(f"batch_means_bound: level must lie in (0, 1), got {level!r}")
    logs = local * dt
    lam = float(logs.sum() / dt.sum()) if len(dt) and dt.sum() > 0 else float("nan")
    B = min(int(batches), len(local) // 2)
    if B < 2 or not np.all(np.isfinite(logs)):
        return lam, float("nan"), float("nan")
    parts = np.array_split(np.arange(len(local)), B)
    b = np.array([logs[i].sum() / dt[i].sum() for i in parts])
    half = float(student.ppf(0.5 + level / 2, B - 1) * b.std(ddof=1) / math.sqrt(B))
    return lam, lam - half, lam + half


class LyapunovFailed(InputError):
    """The Benettin loop stopped (``cause``: a failed run, a separation that collapsed);
    ``partial`` holds the estimate up to the last renormalisation reached (nothing computed is lost)."""

    def __init__(self, cause, partial):
        super().__init__(str(cause))
        self.cause, self.partial = cause, partial


def benettin(advance, separation, renormalise, ref, comp, t0, t_end, renorm, d0, transient, ends=()):
    """The Benettin loop. advance(state, t, dt) -> state at t + dt; separation(ref, comp) -> d;
    renormalise(ref, comp, factor, t) -> the companion at ``factor`` times its separation.

    ends: earlier end times whose exponents the same loop also gives (result.ends), each the
    exponent a loop ending there reports, bit for bit: the loop advances in the same renorm
    chunks from t0 whatever its end, so a shorter loop's chunks are this one's except its last,
    which it clips to end - t; when that clip differs from this chunk (the rounding of the summed
    times), the clipped chunk is run as a branch (one chunk more)."""
    if not (renorm > 0 and d0 > 0 and t_end > t0 + transient):
        raise InputError(f"lyapunov: need renorm > 0, d0 > 0 and t_end > t0 + transient, got renorm = {renorm}, "
                         f"d0 = {d0}, t_end = {t_end}, transient = {transient}")
    n = _chunks(t0, t_end, renorm)
    last = {}                                  # chunk index -> the ends whose last chunk it is
    for e in ends:
        if not (t0 + transient < e <= t_end):
            raise InputError(f"lyapunov: an end time must lie after the transient and by t_end, got {e}")
        last.setdefault(_chunks(t0, e, renorm) - 1, []).append(e)
    acc, elapsed, ts, run, got = 0.0, 0.0, [], [], {}
    loc, dts, bounds = [], [], {}
    t = t0

    def partial():
        return LyapunovResult(acc / elapsed if elapsed else float("nan"), np.array(ts), np.array(run), len(ts),
                              dict(got), np.array(loc), np.array(dts), dict(bounds))

    def bound_with(last=None):
        """The batch-means bound of the chunks so far, with the clipped last chunk ``last`` = (ln, dt) added."""
        lc, dd = list(loc), list(dts)
        if last is not None:
            lc.append(last[0] / last[1])
            dd.append(last[1])
        return batch_means_bound(lc, dd)[1:]

    def counted(a, el, t_after, d, dt):
        """(sum, time, whether counted) after a chunk of dt ending at t_after with separation d:
        chunks ending within the transient are not counted."""
        if t_after > t0 + transient + 1e-12 * renorm:
            return a + math.log(d / d0), el + dt, True
        return a, el, False

    def branch(de, e):
        """The exponent of a loop whose last chunk is [t, t + de] (NaN where that loop fails); its
        bound goes to bounds[e]."""
        try:
            d = separation(advance(ref, t, de), advance(comp, t, de))
        except PinclearError:
            return float("nan")
        if not (d > 0 and math.isfinite(d)):
            return float("nan")
        a, el, after = counted(acc, elapsed, t + de, d, de)
        bounds[e] = bound_with((math.log(d / d0), de) if after else None)
        return a / el if el else float("nan")

    for i in range(n):
        dt = min(renorm, t_end - t)
        for e in last.get(i, ()):
            if min(renorm, e - t) != dt:       # the shorter loop's last chunk is clipped
                got[e] = branch(min(renorm, e - t), e)
        try:
            ref, comp = advance(ref, t, dt), advance(comp, t, dt)
        except PinclearError as exc:
            raise LyapunovFailed(exc, partial()) from exc
        t += dt
        d = separation(ref, comp)
        if not (d > 0 and math.isfinite(d)):
            raise LyapunovFailed(InputError(f"lyapunov: separation {d!r} at t = {t:.6g} s (d0 too small for the "
                                            "integration tolerance, or a failed run)"), partial())
        acc, elapsed, after = counted(acc, elapsed, t, d, dt)
        if after:
            ts.append(t)
            run.append(acc / elapsed)
            loc.append(math.log(d / d0) / dt)
            dts.append(dt)
        for e in last.get(i, ()):
            if e not in got:
                got[e] = acc / elapsed if elapsed else float("nan")
                bounds[e] = bound_with()
        try:
            comp = renormalise(ref, comp, d0 / d, t)
        except PinclearError as exc:
            raise LyapunovFailed(exc, partial()) from exc
    return partial()


def _chunks(t0, t_end, renorm):
    """The number of renormalisation chunks of a loop from t0 to t_end."""
    return int(math.ceil((t_end - t0) / renorm - 1e-9))


def largest_lyapunov(fun, y0, t_end, renorm=0.5, d0=1e-8, transient=0.0, t0=0.0, direction=None, rtol=1e-10,
                     atol=1e-12, method="DOP853", ends=()) -> LyapunovResult:
    """Largest Lyapunov exponent of dy/dt = fun(t, y) along the trajectory from y0 (``ends``:
    also the exponents of runs ending at those earlier times, see :func:`benettin`)."""
    from scipy.integrate import solve_ivp

    y0 = np.asarray(y0, float)
    u = np.ones_like(y0) if direction is None else np.asarray(direction, float)
    u = u / np.linalg.norm(u)

    def advance(y, t, dt):
        sol = solve_ivp(fun, (t, t + dt), y, method=method, rtol=rtol, atol=atol)
        if sol.status != 0:
            raise InputError(f"lyapunov: integration failed at t = {sol.t[-1]:.6g} s: {sol.message}")
        return sol.y[:, -1]

    return benettin(advance, lambda a, b: float(np.linalg.norm(b - a)),
                    lambda a, b, f, t: a + f * (b - a), y0, y0 + d0 * u, t0, t_end, renorm, d0, transient, ends)


def mechanism_lyapunov(mech, t_end, renorm=0.05, d0=1e-7, transient=0.0, q0=None, v0=None, seed=0, ends=(),
                       keep_alive=True, **sim_options) -> LyapunovResult:
    """Largest Lyapunov exponent of a mechanism's motion (state: q on its manifold, v), with
    pinclear's simulator (``sim_options``: method, integrator, rtol...). The companion starts in
    a random tangent direction (``seed``) and, like every renormalised companion, is assembled
    onto the closures and given a consistent velocity, so only admissible motions are compared.
    ``ends``: also the exponents of runs ending at those earlier times (result.ends).

    Each chunk of each trajectory is the run ``simulate(mech, t + dt, t0=t, t_eval=[t, t + dt],
    resume=Checkpoint(...at (t, q, v, z), h_next=None))`` gives; ``keep_alive`` (the default)
    runs the chunks as pinclear.dynamics.simulate.Restarts runs, which keep the set-up between chunks and
    give the same end states bit for bit; False calls simulate() per chunk (the reference)."""
    import pinocchio as pin

    from pinclear.dynamics.simulate import Restarts, simulate
    from pinclear.dynamics.trajectory import Checkpoint
    from pinclear.model.kinematics import assemble, consistent_velocity

    model = mech.model
    sim = {"rtol": 1e-9, **sim_options}
    for k in ("t_eval", "dt_out", "resume", "t0", "q0", "v0"):
        if k in sim:
            raise InputError(f"mechanism_lyapunov: sim_options may not set {k!r}")

    restarts = Restarts(mech, **sim) if keep_alive and not Restarts.unserved(sim) else None

    def advance(state, t, dt):
        q, v, z = state
        if restarts is not None:
            tr = restarts.run(t, q, v, z, t + dt)
        else:
            ck = Checkpoint(t0=t, q=q, v=v, z=z, t=t, q_now=q, v_now=v, z_now=z, h_next=None)
            tr = simulate(mech, t + dt, t0=t, t_eval=[t, t + dt], resume=ck, **sim)
        if tr.status != "success":
            raise InputError(f"lyapunov: the run from t = {t:.6g} s failed: {tr.message}")
        return tr.q[-1].copy(), tr.v[-1].copy(), tr.z[-1].copy()

    def separation(a, b):
        return float(np.sqrt(np.sum(pin.difference(model, a[0], b[0]) ** 2) + np.sum((b[1] - a[1]) ** 2)))

    # one workspace for every renormalisation's assembly (each evaluates at its own q and t)
    ws = mech.workspace() if keep_alive else None

    def place(ref, dq, dv, t):
        q = assemble(mech, pin.integrate(model, ref[0], dq), t=t, ws=ws)
        return q, consistent_velocity(mech, q, ref[1] + dv, t=t, ws=ws), ref[2].copy()

    def renormalise(a, b, f, t):
        return place(a, f * pin.difference(model, a[0], b[0]), f * (b[1] - a[1]), t)

    # the reference: assembled and consistent at t0 (a zero-length first run does it), z from the elements
    first = simulate(mech, 1e-9, q0=q0, v0=v0, t_eval=[0.0, 1e-9], **sim)
    ref = (first.q[0].copy(), first.v[0].copy(), first.z[0].copy())
    rng = np.random.default_rng(seed)
    u = rng.standard_normal(2 * model.nv)
    u *= d0 / np.linalg.norm(u)
    comp = place(ref, u[:model.nv], u[model.nv:], 0.0)
    return benettin(advance, separation, renormalise, ref, comp, 0.0, t_end, renorm, d0, transient, ends)


@dataclass
class ChaosEvidence:
    """Largest Lyapunov exponents of one motion at several integration tolerances and run lengths,
    and what they decide. With confidence bounds (each estimate's batch-means interval,
    :func:`batch_means_bound`): ``lower`` is the least lower bound and ``upper`` the greatest upper
    bound over every tolerance and length; chaos is confirmed when lower > 0 (the exponent is
    positive with 95 % confidence whichever tolerance and length are trusted) and the motion is
    ``regular`` when upper < 0 (a stable attractor). Without bounds (plain exponents) the older
    rule: every estimate positive and their spread within ``rel`` of their mean."""
    estimates: list                 # [(rtol, t_end, exponent)]
    confirmed: bool
    note: str
    lower: float = float("nan")     # min over the estimates of their lower confidence bounds (1/s)
    upper: float = float("nan")     # max over the estimates of their upper confidence bounds (1/s)
    level: float = 0.95
    failed: bool = False            # an estimate failed: nothing is decided

    @property
    def exponent(self):
        return float(np.mean([e for _, _, e in self.estimates])) if self.estimates else float("nan")

    @property
    def regular(self):
        """The largest exponent is negative with the bounds' confidence (upper bound < 0)."""
        return bool(not self.failed and self.upper < 0)

    @property
    def verdict(self):
        """'chaotic' | 'regular' (negative exponent, upper bound < 0) | 'failed' | 'undecided'
        (the bounds straddle zero: a zero exponent, e.g. quasi-periodic, or too short a run)."""
        if self.failed:
            return "failed"
        return "chaotic" if self.confirmed else "regular" if self.regular else "undecided"

    def as_dict(self):
        return {"exponent": self.exponent, "lower": self.lower, "upper": self.upper, "level": self.level,
                "verdict": self.verdict, "estimates": [list(e) for e in self.estimates], "note": self.note}


def _split(value):
    """(exponent, lo, hi) of an estimate given as a number or as (exponent, lo, hi)."""
    if isinstance(value, (tuple, list, np.ndarray)):
        if len(value) != 3:
            raise InputError(f"confirm_chaos: an estimate is an exponent or (exponent, lo, hi), got {value!r}")
        return tuple(float(x) for x in value)
    return float(value), None, None


def confirm_chaos(estimate, rtols, lengths, rel=0.25, level=0.95) -> ChaosEvidence:
    """Chaos evidence from ``estimate(rtol, t_end)`` at every pair of the given tolerances and run
    lengths. An estimate is the exponent (1/s) or (exponent, lo, hi), its ``level`` confidence
    interval (LyapunovResult.bound / end_bounds).

    With intervals: confirmed when the least lower bound is > 0; ``regular`` when the greatest
    upper bound is < 0. The exponents' spread over tolerance and length is reported, but it no
    longer decides: four positive exponents 34 % apart whose every lower bound is positive are
    chaos (a finite-time exponent of an impacting system converges slowly; its sign is the
    question). Without intervals (plain numbers): confirmed when every exponent is positive and
    max - min <= rel x mean: a regular motion's finite-time exponents scatter about zero (some
    negative, or a spread as large as their mean), a chaotic one's settle on one positive value."""
    if not rtols or not lengths or not rel > 0:
        raise InputError(f"confirm_chaos: need tolerances, run lengths and rel > 0, got {rtols!r}, {lengths!r}, {rel!r}")
    raw = [(float(r), float(t), _split(estimate(r, t))) for r in rtols for t in lengths]
    est = [(r, t, e[0]) for r, t, e in raw]
    vals = np.array([e for _, _, e in est])
    text = ", ".join(f"{e:.3g}" for e in vals)
    if not np.all(np.isfinite(vals)):
        return ChaosEvidence(est, False, "a Lyapunov estimate failed", level=level, failed=True)
    mean, span = float(vals.mean()), float(np.ptp(vals))
    spread = f"spread {span / abs(mean):.0%} of the mean" if mean else f"spread {span:.3g} 1/s"
    if all(e[1] is not None for _, _, e in raw):
        los = np.array([e[1] for _, _, e in raw])
        his = np.array([e[2] for _, _, e in raw])
        if not (np.all(np.isfinite(los)) and np.all(np.isfinite(his))):
            return ChaosEvidence(est, False, f"a Lyapunov confidence bound could not be formed (too few "
                                             f"renormalisations; exponents {text} 1/s)", level=level, failed=True)
        lo, hi = float(los.min()), float(his.max())
        pct = f"{100 * level:.0f} %"
        if lo > 0:
            return ChaosEvidence(est, True, f"largest Lyapunov exponent {mean:.3g} 1/s, {pct} lower bound {lo:.3g} "
                                            f"1/s > 0 (least over rtol x length; estimates {text}, {spread})",
                                 lo, hi, level)
        if hi < 0:
            return ChaosEvidence(est, False, f"largest Lyapunov exponent {mean:.3g} 1/s, {pct} upper bound {hi:.3g} "
                                             f"1/s < 0: a stable attractor (greatest over rtol x length; estimates "
                                             f"{text})", lo, hi, level)
        return ChaosEvidence(est, False, f"largest Lyapunov exponent not positive with {pct} confidence: "
                                         f"{mean:.3g} 1/s, bounds [{lo:.3g}, {hi:.3g}] 1/s over rtol x length "
                                         f"contain 0 (estimates {text})", lo, hi, level)
    if np.any(vals <= 0):
        return ChaosEvidence(est, False, f"largest Lyapunov exponent not positive at every tolerance and length "
                                         f"({text} 1/s)", level=level)
    if span > rel * mean:
        return ChaosEvidence(est, False, f"largest Lyapunov exponent does not converge ({text} 1/s: {spread}, "
                                         f"allowed {rel:.0%})", level=level)
    return ChaosEvidence(est, True, f"largest Lyapunov exponent {mean:.3g} 1/s, converged over tolerance and run length "
                                    f"({text})", level=level)
