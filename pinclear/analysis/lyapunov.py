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


@dataclass
class LyapunovResult:
    exponent: float                 # 1/s
    t: np.ndarray                   # renormalisation times after the transient
    running: np.ndarray             # the estimate up to each of those times (its convergence)
    renormalisations: int
    ends: dict = field(default_factory=dict)     # {end time: exponent} of benettin(ends=...)'s shorter runs

    def as_dict(self):
        return {"exponent": self.exponent, "renormalisations": self.renormalisations,
                "final_spread": float(np.ptp(self.running[len(self.running) // 2:])) if len(self.running) else None}


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
    t = t0

    def partial():
        return LyapunovResult(acc / elapsed if elapsed else float("nan"), np.array(ts), np.array(run), len(ts),
                              dict(got))

    def counted(a, el, t_after, d, dt):
        """(sum, time, whether counted) after a chunk of dt ending at t_after with separation d:
        chunks ending within the transient are not counted."""
        if t_after > t0 + transient + 1e-12 * renorm:
            return a + math.log(d / d0), el + dt, True
        return a, el, False

    def branch(de):
        """The exponent of a loop whose last chunk is [t, t + de] (NaN where that loop fails)."""
        try:
            d = separation(advance(ref, t, de), advance(comp, t, de))
        except PinclearError:
            return float("nan")
        if not (d > 0 and math.isfinite(d)):
            return float("nan")
        a, el, _ = counted(acc, elapsed, t + de, d, de)
        return a / el if el else float("nan")

    for i in range(n):
        dt = min(renorm, t_end - t)
        for e in last.get(i, ()):
            if min(renorm, e - t) != dt:       # the shorter loop's last chunk is clipped
                got[e] = branch(min(renorm, e - t))
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
        for e in last.get(i, ()):
            got.setdefault(e, acc / elapsed if elapsed else float("nan"))
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
    and whether they confirm chaos: every estimate positive and their spread within ``rel`` of
    their mean (the estimate converges with tolerance and run length)."""
    estimates: list                 # [(rtol, t_end, exponent)]
    confirmed: bool
    note: str

    @property
    def exponent(self):
        return float(np.mean([e for _, _, e in self.estimates])) if self.estimates else float("nan")


def confirm_chaos(estimate, rtols, lengths, rel=0.25) -> ChaosEvidence:
    """Chaos evidence from ``estimate(rtol, t_end) -> exponent (1/s)`` at every pair of the given
    tolerances and run lengths. Confirmed when every exponent is positive and max - min <= rel x
    mean: a regular motion's finite-time exponents scatter about zero (some negative, or a spread
    as large as their mean), a chaotic one's settle on one positive value."""
    if not rtols or not lengths or not rel > 0:
        raise InputError(f"confirm_chaos: need tolerances, run lengths and rel > 0, got {rtols!r}, {lengths!r}, {rel!r}")
    est = [(float(r), float(t), float(estimate(r, t))) for r in rtols for t in lengths]
    vals = np.array([e for _, _, e in est])
    if not np.all(np.isfinite(vals)):
        return ChaosEvidence(est, False, "a Lyapunov estimate failed")
    mean, span = float(vals.mean()), float(np.ptp(vals))
    text = ", ".join(f"{e:.3g}" for e in vals)
    if np.any(vals <= 0):
        return ChaosEvidence(est, False, f"largest Lyapunov exponent not positive at every tolerance and length ({text} 1/s)")
    if span > rel * mean:
        return ChaosEvidence(est, False, f"largest Lyapunov exponent does not converge ({text} 1/s: spread "
                                         f"{span / mean:.0%} of the mean, allowed {rel:.0%})")
    return ChaosEvidence(est, True, f"largest Lyapunov exponent {mean:.3g} 1/s, converged over tolerance and run length "
                                    f"({text})")
