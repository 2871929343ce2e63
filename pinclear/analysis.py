"""Nonlinear analysis of simulated runs: phase portraits, Poincaré maps, bifurcation diagrams
and a classification of the motion (period-k / quasi-periodic / chaotic).

Papers 000 and 002 judge the motion of a clearance joint and of the platform from phase
trajectories, stroboscopic Poincaré maps (one point per driving period) and bifurcation
diagrams (Poincaré samples of a relative velocity against a swept parameter: friction
coefficient, clearance size, driving speed). This module produces those three objects from
:class:`pinclear.Trajectory` runs and adds two things the papers do by eye:

* :func:`detect_period`: the period k of the Poincaré sequence (smallest shift that maps it
  onto itself within a tolerance) and the number of distinct clusters;
* :func:`chaos_01`: the 0-1 test for chaos of Gottwald & Melbourne (Proc. R. Soc. A 460, 2004;
  correlation method and modified mean-square displacement of SIAM J. Appl. Dyn. Syst. 8, 2009):
  K ~ 0 for regular (periodic or quasi-periodic) motion, K ~ 1 for chaotic motion.

Signals (the ``signal`` argument) name a scalar coordinate of a run and its exact rate:

* a joint name, ``"crank"`` or ``"joint[k]"`` for component k of a multi-DoF joint
  (nq = nv joints): q and v;
* a frame coordinate ``"<frame>.x|y|z"`` (``"platform.z"`` uses the sidecar's platform frame):
  world position of the frame origin and its linear velocity (Pinocchio LOCAL_WORLD_ALIGNED);
* a force-element output ``"<element>.<output>"`` or ``"<element>.<output>[k]"``, e.g.
  ``"S2.eccentricity[1]"``: the recorded output; for ``eccentricity`` of a clearance joint the
  rate is the exact relative velocity of journal/ball and bearing/socket centres in the
  bearing frame, for other outputs (and drive forces named as in ``traj.lam``) it is the
  derivative of a cubic spline through the samples (approximate, flagged ``exact_rate=False``);
* a pair ``(x_spec, xdot_spec)`` of two such names, or a callable ``f(traj) -> x`` or
  ``-> (x, xdot)`` (module-level, so it pickles for :func:`bifurcation`'s worker processes).

Poincaré sections are taken at t = t0 + k T + phase. Simulating with ``t_eval`` from
:func:`section_times` puts output samples exactly on the section, so no interpolation error
enters (the samples are the integrator's own dense output); otherwise samples are interpolated
with cubic Hermite polynomials (using the signal's rate) and flagged ``interpolated``.

:func:`bifurcation` runs one simulation per parameter value in worker processes, keeps every
failure as a result, and classifies each value; :func:`plot_phase_portrait`,
:func:`plot_poincare` and :func:`plot_bifurcation` draw on matplotlib Figures (no pyplot,
no GUI backend) and return the arrays they drew. Command line (:func:`cli_main`):
``python -m pinclear.analysis bifurcation|poincare ...``.
"""
from __future__ import annotations

import json
import math
import os
import pickle
import re
import sys
import tempfile
import time
import warnings
import weakref
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin
import yaml
from scipy.interpolate import CubicHermiteSpline, CubicSpline

from .errors import InputError, ModelFileError

LWA = pin.LOCAL_WORLD_ALIGNED
_AXES = {"x": 0, "y": 1, "z": 2}
_INDEX = re.compile(r"^(.*)\[(-?\d+)\]$")


# =============================================================================== signals
@dataclass
class Series:
    """A scalar signal of a run: x(t), its rate xdot(t) and, where known, its second derivative."""

    t: np.ndarray
    x: np.ndarray
    xdot: np.ndarray
    xddot: np.ndarray | None
    label: str
    exact_rate: bool = True


def _split_index(spec: str):
    m = _INDEX.match(spec)
    return (m.group(1), int(m.group(2))) if m else (spec, None)


def _spline_rate(t, x):
    if len(t) < 2:
        return np.zeros_like(x)
    if len(t) < 4:
        return np.gradient(x, t)
    return CubicSpline(t, x)(t, 1)


# per-trajectory kinematics, so that x, y and z of one frame cost one pass over the samples
_KIN_CACHE: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def _cached(traj, key, compute):
    try:
        store = _KIN_CACHE.setdefault(traj, {})
    except TypeError:                           # not weak-referenceable: no caching
        return compute()
    stamp = (key, len(traj.t), traj.t[-1] if len(traj.t) else None)
    if stamp not in store:
        store[stamp] = compute()
    return store[stamp]


def _frame_series(model, fid, traj):
    """World position, LWA linear velocity and classical acceleration of a frame origin."""
    return _cached(traj, ("frame", id(model), fid), lambda: _frame_series_uncached(model, fid, traj))


def _frame_series_uncached(model, fid, traj):
    data = model.createData()
    n = len(traj.t)
    P, V, A = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    acc = traj.a if traj.a.shape == traj.v.shape and np.all(np.isfinite(traj.a)) else np.zeros_like(traj.v)
    for k in range(n):                     # one forward pass per sample; Pinocchio has no batch API
        pin.forwardKinematics(model, data, traj.q[k], traj.v[k], acc[k])
        P[k] = pin.updateFramePlacement(model, data, fid).translation
        V[k] = pin.getFrameVelocity(model, data, fid, LWA).linear
        A[k] = pin.getFrameClassicalAcceleration(model, data, fid, LWA).linear
    return P, V, A


def _relative_rate(model, f1, f2, traj):
    """d/dt of e = R1^T (p2 - p1) (the eccentricity in body 1's frame):
    R1^T (v2 - v1 - w1 x (p2 - p1)), with origin velocities and w1 in world axes."""
    return _cached(traj, ("relative", id(model), f1, f2), lambda: _relative_rate_uncached(model, f1, f2, traj))


def _relative_rate_uncached(model, f1, f2, traj):
    data = model.createData()
    n = len(traj.t)
    out = np.empty((n, 3))
    for k in range(n):
        pin.forwardKinematics(model, data, traj.q[k], traj.v[k])
        M1 = pin.updateFramePlacement(model, data, f1)
        M2 = pin.updateFramePlacement(model, data, f2)
        v1 = pin.getFrameVelocity(model, data, f1, LWA)
        v2 = pin.getFrameVelocity(model, data, f2, LWA)
        d = M2.translation - M1.translation
        out[k] = M1.rotation.T @ (v2.linear - v1.linear - np.cross(v1.angular, d))
    return out


def _signal_choices(traj, mech):
    model = mech.model if mech is not None else None
    ch = []
    if model is not None:
        ch += [f"joint {n}" for n in list(model.names)[1:]]
        ch += [f"{f.name}.x|y|z" for f in model.frames if f.type in (pin.FrameType.BODY, pin.FrameType.OP_FRAME)]
        if mech.platform_frame is not None:
            ch.append("platform.x|y|z")
    ch += [f"output {k}" for k in traj.outputs]
    ch += [f"multiplier {k}" for k in traj.lam]
    return ch


def series(traj, signal, mech=None) -> Series:
    """Resolve ``signal`` (see the module docstring) on the samples of ``traj``."""
    mech = mech if mech is not None else getattr(traj, "mech", None)
    t = np.asarray(traj.t, float)
    if callable(signal):
        out = signal(traj)
        label = getattr(signal, "__name__", "signal")
        if isinstance(out, tuple) and len(out) == 2:
            return Series(t, np.asarray(out[0], float), np.asarray(out[1], float), None, label)
        x = np.asarray(out, float)
        return Series(t, x, _spline_rate(t, x), None, label, exact_rate=False)
    if isinstance(signal, (tuple, list)):
        if len(signal) != 2:
            raise InputError(f"a signal pair is (x_spec, xdot_spec), got {signal!r}")
        sx, sv = series(traj, signal[0], mech), series(traj, signal[1], mech)
        return Series(t, sx.x, sv.x, sv.xdot, f"{sx.label} / {sv.label}", exact_rate=True)
    if not isinstance(signal, str):
        raise InputError(f"signal must be a name, a (x, xdot) pair of names or a callable, got {signal!r}")
    base, idx = _split_index(signal)
    model = mech.model if mech is not None else None
    # ---- joint coordinate
    if model is not None and base != "universe" and model.existJointName(base):
        jm = model.joints[model.getJointId(base)]
        if jm.nq != jm.nv:
            raise InputError(f"signal {signal!r}: joint {base!r} ({jm.shortname()}) has nq != nv, its "
                             "coordinates are not plain numbers: use a frame coordinate '<frame>.x|y|z'")
        k = 0 if idx is None else idx
        if not 0 <= k < jm.nv:
            raise InputError(f"signal {signal!r}: joint {base!r} has {jm.nv} coordinate(s), index {k} is out of range")
        a = traj.a[:, jm.idx_v + k] if traj.a.shape == traj.v.shape else None
        return Series(t, traj.q[:, jm.idx_q + k].copy(), traj.v[:, jm.idx_v + k].copy(), a, signal)
    # ---- force-element output
    if base in traj.outputs:
        arr = np.asarray(traj.outputs[base], float)
        if arr.ndim == 2:
            if idx is None:
                if arr.shape[1] != 1:
                    raise InputError(f"signal {signal!r}: output {base!r} has {arr.shape[1]} components: "
                                     f"add an index, e.g. '{base}[1]'")
                idx = 0
            if not -arr.shape[1] <= idx < arr.shape[1]:
                raise InputError(f"signal {signal!r}: output {base!r} has {arr.shape[1]} components")
            x = arr[:, idx].copy()
        else:
            x = arr.reshape(len(t)).copy()
        elem_name, _, what = base.rpartition(".")
        elem = None
        if mech is not None:
            elem = next((f for f in mech.forces if getattr(f, "name", None) == elem_name), None)
        if what == "eccentricity" and elem is not None and hasattr(elem, "f1") and hasattr(elem, "f2") \
                and arr.ndim == 2 and arr.shape[1] == 3:
            rate = _relative_rate(model, elem.f1, elem.f2, traj)[:, idx]
            return Series(t, x, rate, None, signal)
        return Series(t, x, _spline_rate(t, x), None, signal, exact_rate=False)
    # ---- constraint multiplier (drive force, closure row)
    if signal in traj.lam:
        x = np.asarray(traj.lam[signal], float).copy()
        return Series(t, x, _spline_rate(t, x), None, signal, exact_rate=False)
    # ---- frame coordinate
    fname, _, comp = signal.rpartition(".")
    if model is not None and comp in _AXES and fname:
        fid = None
        if fname == "platform" and mech.platform_frame is not None and not model.existFrame("platform"):
            fid = mech.platform_frame
        elif model.existFrame(fname):
            fid = model.getFrameId(fname)
        if fid is not None:
            P, V, A = _frame_series(model, fid, traj)
            c = _AXES[comp]
            return Series(t, P[:, c], V[:, c], A[:, c], signal)
    if mech is None:
        raise InputError(f"signal {signal!r}: not an output of the run ({', '.join(traj.outputs) or 'none'}) and "
                         "the trajectory carries no mechanism: pass mech= to resolve joints and frames")
    ch = _signal_choices(traj, mech)
    shown = ", ".join(ch[:30]) + (f", ... ({len(ch) - 30} more)" if len(ch) > 30 else "")
    raise InputError(f"unknown signal {signal!r} (valid: {shown})")


def phase_portrait(traj, signal, mech=None, t_min=None):
    """(x, xdot) arrays of ``signal`` over the samples of ``traj`` (from ``t_min`` on)."""
    s = series(traj, signal, mech)
    keep = slice(None) if t_min is None else s.t >= t_min
    return s.x[keep], s.xdot[keep]


# =============================================================================== Poincaré
def section_times(period, cycles, phase=0.0, t0=0.0, per_period=1):
    """Output times for :func:`pinclear.simulate` (``t_eval``) that contain the Poincaré
    section t0 + phase + k*period, k = 0..cycles, exactly, plus ``per_period - 1`` samples in
    between for the phase portrait. Pass ``t_end = times[-1]``."""
    period, per_period, cycles = float(period), int(per_period), int(cycles)
    if not period > 0 or not math.isfinite(period):
        raise InputError(f"period must be a positive number of seconds, got {period!r}")
    if per_period < 1 or cycles < 1:
        raise InputError(f"need cycles >= 1 and per_period >= 1, got {cycles}, {per_period}")
    j = np.arange(cycles * per_period + 1)
    # (j / per_period) is an exact integer k at the section: the same float as t0 + phase + k*period
    return t0 + phase + (j / per_period) * period


@dataclass
class PoincareSection:
    """Stroboscopic samples: cycle index k, time t_k = t0 + phase + k*period, x and xdot there."""

    k: np.ndarray
    t: np.ndarray
    x: np.ndarray
    xdot: np.ndarray
    period: float
    phase: float
    label: str
    interpolated: np.ndarray          # bool per sample: True where no output sample sat on t_k
    exact_rate: bool = True
    #: per coordinate (x, xdot): the larger of the signal's range over the run after the
    #: transient (the attractor's extent) and max |section|; the default scale of classify()
    scale: np.ndarray = field(default_factory=lambda: np.zeros(2))

    @property
    def points(self) -> np.ndarray:
        return np.column_stack([self.x, self.xdot])

    def __len__(self):
        return len(self.t)


def poincare(traj, period, signal, phase=0.0, skip_transient=0, t0=0.0, mech=None, match_tol=1e-9):
    """Poincaré (stroboscopic) map of ``signal``: samples at t = t0 + k*period + phase for every
    k >= skip_transient (a number of periods) whose time lies within the run.

    Output samples within ``match_tol * period`` of a section time are used as they are;
    others are interpolated (cubic Hermite with the exact rate, and the second derivative
    where the signal has one) and flagged. Simulate with ``t_eval=section_times(...)`` to
    avoid interpolation altogether.
    """
    period = float(period)
    if not period > 0 or not math.isfinite(period):
        raise InputError(f"period must be a positive number of seconds, got {period!r}")
    if skip_transient < 0:
        raise InputError(f"skip_transient is a number of periods >= 0, got {skip_transient!r}")
    s = series(traj, signal, mech)
    t = s.t
    empty = PoincareSection(np.zeros(0, int), np.zeros(0), np.zeros(0), np.zeros(0), period, phase, s.label,
                            np.zeros(0, bool), s.exact_rate)
    if len(t) == 0:
        return empty
    tol = match_tol * period
    k_lo = max(int(math.ceil((t[0] - tol - t0 - phase) / period)), int(math.ceil(skip_transient)))
    k_hi = int(math.floor((t[-1] + tol - t0 - phase) / period))
    if k_hi < k_lo:
        return empty
    k = np.arange(k_lo, k_hi + 1)
    ts = t0 + phase + k.astype(float) * period
    i = np.clip(np.searchsorted(t, ts), 1, max(len(t) - 1, 1))
    i0 = np.where(np.abs(t[i - 1] - ts) <= np.abs(t[np.minimum(i, len(t) - 1)] - ts), i - 1,
                  np.minimum(i, len(t) - 1))
    hit = np.abs(t[i0] - ts) <= tol
    x, xd = s.x[i0].astype(float), s.xdot[i0].astype(float)
    if not hit.all():
        if len(t) < 2:
            raise InputError("a single output sample cannot be interpolated onto the section")
        tu, first = np.unique(t, return_index=True)
        miss = ~hit
        x[miss] = CubicHermiteSpline(tu, s.x[first], s.xdot[first])(ts[miss])
        if s.xddot is not None and np.all(np.isfinite(s.xddot)):
            xd[miss] = CubicHermiteSpline(tu, s.xdot[first], s.xddot[first])(ts[miss])
        else:
            xd[miss] = CubicSpline(tu, s.xdot[first])(ts[miss])
    keep = t >= t0 + phase + skip_transient * period - tol
    scale = np.maximum([np.ptp(s.x[keep]) if keep.any() else 0.0, np.ptp(s.xdot[keep]) if keep.any() else 0.0],
                       [np.max(np.abs(x)), np.max(np.abs(xd))])
    return PoincareSection(k, ts, x, xd, period, phase, s.label, ~hit, s.exact_rate, scale)


# =============================================================================== classification
def detect_period(points, rtol=1e-4, atol=0.0, scale=None, max_period=16):
    """Period of a Poincaré sequence and its number of distinct clusters.

    points: (n,) or (n, d). Two points are "the same" when every coordinate differs by at most
    ``atol + rtol * scale`` (scale per coordinate: the given ``scale``, default max |points|).
    The period is the smallest p <= max_period with |s[i+p] - s[i]| within tolerance for all i
    (at least p such comparisons are required, so n >= 2p); None if there is none.
    Returns (period, n_clusters); clusters are counted greedily against cluster seeds.
    """
    P = np.asarray(points, float)
    if P.ndim == 1:
        P = P[:, None]
    n = len(P)
    if n == 0:
        return None, 0
    if scale is None:
        scale = np.max(np.abs(P), axis=0)
    tol = atol + rtol * np.broadcast_to(np.asarray(scale, float), (P.shape[1],))
    tol = np.where(tol > 0, tol, np.finfo(float).tiny)
    S = P / tol                                   # equal within tolerance <=> |dS|_inf <= 1
    seeds = []
    for p in S:
        if not seeds or np.min(np.max(np.abs(np.asarray(seeds) - p), axis=1)) > 1.0:
            seeds.append(p)
    period = None
    for p in range(1, min(max_period, n // 2) + 1):
        if np.max(np.abs(S[p:] - S[:-p])) <= 1.0:
            period = p
            break
    return period, len(seeds)


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
    kind: str                 # "period-k" | "quasi-periodic" | "chaotic" | "unresolved" | "empty"
    period: int | None
    clusters: int
    K: float | None           # 0-1 test result (None when a period was found or too few samples)
    n: int
    note: str = ""

    def as_dict(self):
        return {"kind": self.kind, "period": self.period, "clusters": self.clusters, "K": self.K, "n": self.n,
                "note": self.note}


def classify(section, rtol=1e-4, atol=0.0, scale=None, max_period=16, min_samples_01=40, chaos_threshold=None):
    """Classify a Poincaré section (PoincareSection or an (n,) / (n, d) array).

    First the period (:func:`detect_period`): "period-k" if the sequence repeats with period
    k <= max_period, points being equal within atol + rtol * scale (scale per coordinate:
    default the section's ``scale``, the attractor's extent, so a point near x = 0 is judged
    against the size of the orbit, not against itself). rtol must exceed the run-to-run
    scatter the integration tolerance leaves in the section points. Otherwise, with at least
    ``min_samples_01`` samples, the 0-1 test on each coordinate (the largest K counts):
    K > chaos_threshold (default CHAOS_THRESHOLD = 0.5) "chaotic", else "quasi-periodic";
    ``note`` says "ambiguous" when 0.1 <= K <= 0.9. With fewer samples: "unresolved".
    A section whose rate is not exact (spline-differentiated output) is judged by x alone.
    """
    thr = CHAOS_THRESHOLD if chaos_threshold is None else float(chaos_threshold)
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
    period, clusters = detect_period(P, rtol=rtol, atol=atol, scale=scale, max_period=max_period)
    if period is not None:
        return Classification(f"period-{period}", period, clusters, None, n)
    if n < min_samples_01:
        return Classification("unresolved", None, clusters, None, n,
                              f"no period <= {min(max_period, n // 2)} and too few samples ({n} < "
                              f"{min_samples_01}) for the 0-1 test")
    sc = np.broadcast_to(np.max(np.abs(P), axis=0) if scale is None else np.asarray(scale, float), (P.shape[1],))
    # spread within the period tolerance is a fixed point to this resolution
    K = max(chaos_01(P[:, j], flat_tol=atol + rtol * sc[j]) for j in range(P.shape[1]))
    kind = "chaotic" if K > thr else "quasi-periodic"
    note = "ambiguous (0.1 <= K <= 0.9): longer runs or a smaller tolerance may decide" if 0.1 <= K <= 0.9 else ""
    return Classification(kind, None, clusters, K, n, note)


# =============================================================================== bifurcation
_TOKEN = re.compile(r"([^.\[\]]+)|\[([^\]]*)\]")


def _parse_path(path: str):
    """'drives[crank1_drive].law.coeffs[1]' -> [('key','drives'), ('sel','crank1_drive'), ...]."""
    toks, pos = [], 0
    for m in _TOKEN.finditer(path):
        gap = path[pos:m.start()]
        if gap not in ("", "."):
            raise InputError(f"cannot parse parameter path {path!r} at {gap!r}")
        toks.append(("key", m.group(1)) if m.group(1) is not None else ("sel", m.group(2)))
        pos = m.end()
    if path[pos:] or not toks:
        raise InputError(f"cannot parse parameter path {path!r}")
    return toks


def _walk_set(doc, toks, value, file, path):
    """Set ``value`` at the token path inside the sidecar dict ``doc`` (validating every step)."""
    cur = doc
    for i, (kind, tok) in enumerate(toks):
        last = i == len(toks) - 1
        where = path if last else "".join(f".{t}" if k == "key" else f"[{t}]" for k, t in toks[:i + 1]).lstrip(".")
        if kind == "key":
            if not isinstance(cur, dict):
                raise ModelFileError(file, where, f"{tok!r} indexes a {type(cur).__name__}, not a mapping")
            if last:
                cur[tok] = value
                return
            if tok not in cur:
                raise ModelFileError(file, where, "no such key", choices=list(cur))
            cur = cur[tok]
        else:
            if not isinstance(cur, list):
                raise ModelFileError(file, where, f"[{tok}] selects from a list, found a {type(cur).__name__}")
            if re.fullmatch(r"-?\d+", tok):
                j = int(tok)
                if not -len(cur) <= j < len(cur):
                    raise ModelFileError(file, where, f"index {j} out of range (list of {len(cur)})")
            else:
                names = [e.get("name") for e in cur if isinstance(e, dict)]
                if tok not in names:
                    raise ModelFileError(file, where, f"no entry named {tok!r}", choices=[n for n in names if n])
                j = names.index(tok)
            if last:
                cur[j] = value
                return
            cur = cur[j]


def _classify_parameter(path, parameter, load_kw):
    """Split the parameter spec into sidecar-path patches and load() overrides; validate both."""
    from .sidecar import TOP_KEYS

    file = str(path)
    doc = yaml.safe_load(Path(path).read_text())
    if not isinstance(doc, dict):
        raise ModelFileError(file, "yaml", "the sidecar is not a mapping")
    items = parameter.items() if isinstance(parameter, dict) else [(parameter, 1.0)]
    clr = [c.get("name") for c in doc.get("clearances") or [] if isinstance(c, dict)]
    opts = list((doc.get("options") or {}))
    patches, overrides = [], []
    for spec, factor in items:
        if not isinstance(spec, str):
            raise InputError(f"parameter must be a string path or a mapping path -> factor, got {spec!r}")
        factor = float(factor)
        head = spec.split(".", 1)[0].split("[", 1)[0]
        if head in TOP_KEYS:
            toks = _parse_path(spec)
            _walk_set(yaml.safe_load(Path(path).read_text()), toks, 0.0, file, spec)   # validate the path
            patches.append((toks, spec, factor))
        elif head in clr or spec in opts:
            active = {c.get("name") for c in doc.get("clearances") or [] if isinstance(c, dict) and c.get("active")}
            if head in clr and head not in active | set(load_kw.get("clearances") or ()):
                # an override of an inactive clearance changes nothing: every run would be the same
                raise InputError(f"parameter {spec!r}: clearance joint {head!r} is not active in {file}: "
                                 f"activate it with load_options=dict(clearances=[{head!r}]) (CLI: --clearance {head})")
            if spec in opts and factor != 1.0:
                raise InputError(f"parameter {spec!r} is a scene option: a factor other than 1 makes no sense")
            overrides.append((spec, factor))
        else:
            raise ModelFileError(file, spec, "not a sidecar key path, clearance key (NAME.key) or scene option",
                                 choices=sorted(TOP_KEYS) + [f"{c}.<key>" for c in clr] + opts)
    return patches, overrides


def _load_variant(path, patches, overrides, value, load_kw):
    """The mechanism of ``path`` with the parameter set to ``value``."""
    from .sidecar import load

    ov = dict(load_kw.get("overrides") or {})
    for spec, factor in overrides:
        ov[spec] = value if factor == 1.0 else factor * value
    kw = {k: v for k, v in load_kw.items() if k != "overrides"}
    if not patches:
        return load(path, overrides=ov or None, **kw)
    doc = yaml.safe_load(Path(path).read_text())
    for toks, spec, factor in patches:
        _walk_set(doc, toks, value if factor == 1.0 else factor * value, str(path), spec)
    doc["urdf"] = str((Path(path).parent / doc["urdf"]).resolve())
    with tempfile.TemporaryDirectory(prefix="pinclear_bif_") as tmp:
        p = Path(tmp) / Path(path).name
        p.write_text(yaml.safe_dump(doc, sort_keys=False))
        mech = load(p, overrides=ov or None, **kw)
    return mech.replace(path=str(path))


@dataclass
class BifurcationRun:
    """One parameter value: status 'success' | 'failed' (the simulation stopped early; the
    samples computed so far are kept) | 'error' (no run: bad value, assembly failure...)."""

    index: int
    value: object
    status: str
    message: str
    sections: dict = field(default_factory=dict)          # signal key -> PoincareSection
    portraits: dict = field(default_factory=dict)         # signal key -> (t, x, xdot) after the transient
    stats: dict = field(default_factory=dict)
    classifications: dict = field(default_factory=dict)   # signal key -> Classification

    @property
    def ok(self):
        return self.status == "success"

    @property
    def section(self):
        """The section of the first signal (None if the run produced none)."""
        return next(iter(self.sections.values()), None)

    @property
    def classification(self):
        return next(iter(self.classifications.values()), None)


@dataclass
class BifurcationResult:
    parameter: object
    values: np.ndarray
    runs: list
    signals: list                         # signal keys, in the order given
    period: np.ndarray                    # driving period per value

    def _key(self, signal):
        if signal is None:
            return self.signals[0]
        key = signal_key(signal)
        if key not in self.signals:
            raise InputError(f"signal {key!r} was not recorded (recorded: {', '.join(self.signals)})")
        return key

    def points(self, coordinate="xdot", include_failed=False, signal=None):
        """(parameter, ordinate) pairs of all Poincaré samples of ``signal`` (default: the first),
        ready for a scatter plot. coordinate: 'x' or 'xdot' (papers 000/002 plot the relative
        velocity: 'xdot'). Failed runs' partial samples only with include_failed."""
        if coordinate not in ("x", "xdot"):
            raise InputError(f"coordinate must be 'x' or 'xdot', got {coordinate!r}")
        key = self._key(signal)
        ps, ys = [], []
        for r in self.runs:
            sec = r.sections.get(key)
            if sec is None or (not r.ok and not include_failed):
                continue
            y = getattr(sec, coordinate)
            ps.append(np.full(len(y), float(r.value)))
            ys.append(y)
        if not ps:
            return np.zeros(0), np.zeros(0)
        return np.concatenate(ps), np.concatenate(ys)

    @property
    def failures(self):
        return [(r.value, r.status, r.message) for r in self.runs if not r.ok]

    def table(self, signal=None):
        """One dict per value: value, status, kind, period, K, samples, cpu_s, message."""
        key = self._key(signal)
        rows = []
        for r in self.runs:
            c, sec = r.classifications.get(key), r.sections.get(key)
            rows.append({"value": r.value, "status": r.status, "kind": c.kind if c else None,
                         "period": c.period if c else None, "K": c.K if c else None,
                         "samples": len(sec) if sec is not None else 0,
                         "cpu_s": r.stats.get("cpu_s"), "message": r.message})
        return rows


    # ------------------------------------------------------------------ I/O
    def save(self, path):
        """NPZ: every run's Poincaré samples (and portraits) + JSON metadata (statuses, messages,
        classifications, stats). :meth:`load` reads it back for re-plotting."""
        from .trajectory import _jsonable

        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        arrays = {"values": np.asarray(self.values, float) if all(_is_number(v) for v in self.values)
                  else np.zeros(0), "period": self.period}
        runs = []
        for r in self.runs:
            for key, sec in r.sections.items():
                for f in ("k", "t", "x", "xdot", "interpolated", "scale"):
                    arrays[f"sec/{r.index}/{key}/{f}"] = getattr(sec, f)
            for key, (t, x, xd) in r.portraits.items():
                arrays[f"por/{r.index}/{key}/t"], arrays[f"por/{r.index}/{key}/x"] = t, x
                arrays[f"por/{r.index}/{key}/xdot"] = xd
            runs.append({"index": r.index, "value": r.value, "status": r.status, "message": r.message,
                         "stats": r.stats, "sections": {k: {"period": sc.period, "phase": sc.phase, "label": sc.label,
                                                            "exact_rate": sc.exact_rate}
                                                        for k, sc in r.sections.items()},
                         "classifications": {k: c.as_dict() for k, c in r.classifications.items()}})
        meta = {"parameter": self.parameter if isinstance(self.parameter, (str, dict)) else repr(self.parameter),
                "signals": self.signals, "runs": runs}
        arrays["meta"] = np.array(json.dumps(_jsonable(meta)))
        np.savez_compressed(path, **arrays)
        return path

    @classmethod
    def load(cls, path):
        d = np.load(path, allow_pickle=False)
        meta = json.loads(str(d["meta"]))
        runs = []
        for m in meta["runs"]:
            i = m["index"]
            secs = {}
            for key, sm in m["sections"].items():
                a = {f: d[f"sec/{i}/{key}/{f}"] for f in ("k", "t", "x", "xdot", "interpolated", "scale")}
                secs[key] = PoincareSection(a["k"], a["t"], a["x"], a["xdot"], sm["period"], sm["phase"], sm["label"],
                                            a["interpolated"], sm["exact_rate"], a["scale"])
            pors = {key: tuple(d[f"por/{i}/{key}/{f}"] for f in ("t", "x", "xdot"))
                    for key in meta["signals"] if f"por/{i}/{key}/t" in d.files}
            cls_ = {k: Classification(**c) for k, c in m["classifications"].items()}
            runs.append(BifurcationRun(i, m["value"], m["status"], m["message"], secs, pors, m["stats"], cls_))
        values = np.array([r.value for r in runs], dtype=float if all(_is_number(r.value) for r in runs) else object)
        return cls(meta["parameter"], values, runs, meta["signals"], d["period"])


def signal_key(signal) -> str:
    """The name a signal is recorded under: the string itself, 'x|xdot' for a pair, the
    callable's __name__."""
    if callable(signal):
        return getattr(signal, "__name__", repr(signal))
    if isinstance(signal, (tuple, list)):
        return "|".join(map(str, signal))
    return str(signal)


def _run_one(job):
    """Worker: build the variant, simulate on the section grid, take the Poincaré samples."""
    from .simulate import simulate

    t_start = time.perf_counter()
    i, value = job["index"], job["value"]
    if isinstance(value, (float, np.floating)) and not math.isfinite(value):
        # a NaN/inf parameter only poisons the integrator (SciPy's first-step choice never ends)
        return BifurcationRun(i, value, "error", f"parameter value {value!r} is not finite",
                              stats={"wall_s": 0.0, "pid": os.getpid()})
    try:
        if job["factory"] is not None:
            mech = job["factory"](value)
        else:
            mech = _load_variant(job["path"], job["patches"], job["overrides"], value, job["load_kw"])
        T, cyc = job["period"], job["transient"] + job["cycles"]
        t_eval = section_times(T, cyc, job["phase"], job["t0"], job["per_period"])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)     # a failed run is reported, not warned
            traj = simulate(mech, float(t_eval[-1]), t_eval=t_eval, t0=job["t0"], **job["sim_kw"])
        sections, portraits = {}, {}
        for sig in job["signals"] if len(traj.t) else ():
            key = signal_key(sig)
            sections[key] = poincare(traj, T, sig, phase=job["phase"], skip_transient=job["transient"],
                                     t0=job["t0"], mech=mech)
            if job["keep_portrait"]:
                s = series(traj, sig, mech)
                keep = s.t >= job["t0"] + job["phase"] + job["transient"] * T - 1e-9 * T
                portraits[key] = (s.t[keep], s.x[keep], s.xdot[keep])
        stats = {k: traj.stats.get(k) for k in ("cpu_s", "rhs_evals", "steps") if k in traj.stats}
        stats["events"] = len(traj.stats.get("events", []))
        stats["wall_s"] = time.perf_counter() - t_start
        stats["pid"] = os.getpid()
        return BifurcationRun(i, value, "success" if traj.status == "success" else "failed", traj.message,
                              sections, portraits, stats)
    except Exception as exc:                  # every failure is a result, never a lost value
        return BifurcationRun(i, value, "error", f"{type(exc).__name__}: {exc}",
                              stats={"wall_s": time.perf_counter() - t_start, "pid": os.getpid()})


def bifurcation(model, parameter, values, period, signal, cycles=100, transient=20, phase=0.0, t0=0.0,
                per_period=8, keep_portrait=False, sim_options=None, load_options=None,
                executor=None, max_workers=None, progress=None, classify_options=None) -> BifurcationResult:
    """Poincaré samples of ``signal`` for each parameter value (a bifurcation diagram).

    signal: one signal (see the module docstring) or a list of them, all sampled from the same
        runs (e.g. platform x, y, z and clearance eccentricity components as in paper 000); a
        tuple is one (x_spec, xdot_spec) pair, not a list of signals.

    model: a sidecar path, or a factory ``f(value) -> Mechanism`` (module-level so it pickles
        to worker processes; ``parameter`` is then only a label).
    parameter (with a sidecar path):
        * a clearance key ``"S2.mu"``, ``"S2.clearance"`` or a scene option (load() overrides);
        * a key path inside the sidecar, list entries by name or index:
          ``"forces[spring].k"``, ``"drives[crank1_drive].law.coeffs[1]"``, ``"gravity[2]"``;
        * a mapping {path: factor}: every path set to factor*value, e.g. both cranks of paper
          002 at +w and -w: ``{"drives[crank1_drive].law.coeffs[1]": 1,
          "drives[crank4_drive].law.coeffs[1]": -1}``.
    period: driving period (s), or ``f(value) -> period`` (evaluated here, e.g. 2 pi / w).
    cycles, transient: periods recorded after ``transient`` periods are dropped
        (paper 002: 100 cycles). Each run simulates (transient + cycles) periods with output
        exactly on the section and ``per_period`` samples per period; those samples give the
        attractor's extent (the scale of the period-detection tolerance, see :func:`classify`)
        and, with keep_portrait, the phase portrait.
    sim_options: keyword arguments of :func:`pinclear.simulate` (method, integrator, rtol,
        max_cpu to bound a run...). load_options: of :func:`pinclear.load` (options,
        clearances=[...], overrides for fixed keys).
    executor: None -> a ProcessPoolExecutor(max_workers or os.cpu_count()) made and shut down
        here; an Executor instance (kept open); or "serial" (in this process, for debugging or
        unpicklable factories).
    progress: None, True (one line per finished run on stderr) or f(done, total, run).
    Every value yields a BifurcationRun: a run that stops early is 'failed' with its message and
    partial samples, one that cannot start (bad value, assembly error) is 'error'.
    """
    # plain Python scalars: they go into YAML and pickles, and print readably
    values = [v.item() if isinstance(v, np.generic) else v for v in values]
    if not values:
        raise InputError("bifurcation: no parameter values given")
    sim_kw = dict(sim_options or {})
    for k in ("t_end", "t_eval", "dt_out", "t0", "strict"):
        if k in sim_kw:
            raise InputError(f"sim_options may not set {k!r}: the bifurcation run chooses it")
    load_kw = dict(load_options or {})
    bad = set(load_kw) - {"options", "overrides", "clearances"}
    if bad:
        raise InputError(f"unknown load option {sorted(bad)[0]!r} (valid: clearances, options, overrides)")
    signals = list(signal) if isinstance(signal, list) else [signal]
    keys = [signal_key(sg) for sg in signals]
    if len(set(keys)) != len(keys):
        raise InputError(f"signals recorded twice: {keys}")
    if int(transient) < 0 or int(cycles) < 1:
        raise InputError(f"need transient >= 0 and cycles >= 1, got {transient}, {cycles}")
    periods, bad_period = [], {}
    for i, v in enumerate(values):
        try:
            T = float(period(v)) if callable(period) else float(period)
        except Exception as exc:              # this value's fault: reported with its run
            periods.append(float("nan"))
            bad_period[i] = f"period({v!r}) failed: {type(exc).__name__}: {exc}"
            continue
        if not T > 0 or not math.isfinite(T):
            if not callable(period):
                raise InputError(f"period must be a positive number of seconds, got {period!r}")
            bad_period[i] = f"period({v!r}) = {T!r}: must be a positive number of seconds"
        periods.append(T)
    base = dict(factory=None, path=None, patches=None, overrides=None, load_kw=load_kw, phase=float(phase),
                t0=float(t0), transient=int(transient), cycles=int(cycles), per_period=int(per_period),
                signals=signals, sim_kw=sim_kw, keep_portrait=bool(keep_portrait))
    if callable(model):
        base["factory"] = model
    else:
        path = Path(model)
        if not path.exists():
            raise ModelFileError(str(path), "path", "no such file")
        if path.suffix.lower() == ".urdf":
            raise InputError(f"bifurcation needs a sidecar (.yaml) whose parameter it can change, got {path}")
        patches, overrides = _classify_parameter(path, parameter, load_kw)
        base.update(path=str(path), patches=patches, overrides=overrides)
    jobs = [dict(base, index=i, value=v, period=T) for i, (v, T) in enumerate(zip(values, periods))
            if i not in bad_period]

    if progress is True:
        def progress(done, total, run):   # noqa: F811 - the default reporter
            why = "" if run.ok else f": {run.message}"
            print(f"bifurcation {done}/{total}: {parameter} = {run.value!r} {run.status} "
                  f"({run.stats.get('wall_s', 0):.1f} s){why}", file=sys.stderr, flush=True)

    runs: list = [None] * len(values)
    done = 0

    def finish(run):
        nonlocal done
        runs[run.index] = run
        done += 1
        if progress:
            progress(done, len(values), run)

    for i, msg in bad_period.items():
        finish(BifurcationRun(i, values[i], "error", msg))

    if executor == "serial":
        for job in jobs:
            finish(_run_one(job))
    else:
        if executor is not None and not isinstance(executor, Executor):
            raise InputError(f"executor must be None, 'serial' or a concurrent.futures.Executor, got {executor!r}")
        try:
            if executor is None or isinstance(executor, ProcessPoolExecutor):
                pickle.dumps(jobs[0] if jobs else None)
        except Exception as exc:
            raise InputError(f"bifurcation: the job cannot be sent to worker processes ({exc}); use module-level "
                             "functions for the factory, signal and laws, or executor='serial'") from None
        own = executor is None
        n_workers = max_workers or max(1, min(os.cpu_count() or 1, len(jobs)))
        ex = ProcessPoolExecutor(max_workers=n_workers) if own else executor
        try:
            futs = {ex.submit(_run_one, job): job for job in jobs}
            for fut in as_completed(futs):
                job = futs[fut]
                try:
                    run = fut.result()
                except Exception as exc:       # worker died (BrokenProcessPool, pickling of the result...)
                    run = BifurcationRun(job["index"], job["value"], "error", f"{type(exc).__name__}: {exc}")
                finish(run)
        finally:
            if own:
                ex.shutdown(wait=True, cancel_futures=True)
    copt = dict(classify_options or {})
    fixed_scale = copt.pop("scale", None)
    for r in runs:
        for key in keys:
            sec = r.sections.get(key)
            r.classifications[key] = classify(sec if sec is not None else np.zeros((0, 2)),
                                              scale=fixed_scale, **copt)
    numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)
    return BifurcationResult(parameter, np.asarray(values, dtype=float if numeric else object), runs, keys,
                             np.asarray(periods))


# =============================================================================== plots
def _figure(ax, figsize):
    if ax is not None:
        return ax.figure, ax
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    return fig, fig.subplots()


def plot_phase_portrait(x, xdot=None, section=None, label="", ax=None, path=None, mech=None, t_min=None):
    """Phase portrait (x, xdot); ``x`` may be a Trajectory with ``xdot`` the signal spec.
    Poincaré samples (``section``) are overlaid as dots. Returns (figure, arrays plotted)."""
    if hasattr(x, "t") and hasattr(x, "q"):
        if xdot is None:
            raise InputError("plot_phase_portrait(traj, signal): give the signal")
        label = label or (xdot if isinstance(xdot, str) else "signal")
        x, xdot = phase_portrait(x, xdot, mech=mech, t_min=t_min)
    x, xdot = np.asarray(x, float), np.asarray(xdot, float)
    fig, ax = _figure(ax, (5, 4.5))
    ax.plot(x, xdot, lw=0.6, color="C0", gid="portrait")
    data = {"x": x, "xdot": xdot}
    if section is not None:
        ax.plot(section.x, section.xdot, "o", ms=3, color="C3", gid="section", label="Poincaré")
        data.update(section_x=section.x, section_xdot=section.xdot)
        ax.legend(fontsize=8)
    ax.set_xlabel(label or "x")
    ax.set_ylabel(f"d/dt {label}" if label else "xdot")
    ax.set_title("phase portrait")
    ax.grid(alpha=0.3)
    if path is not None:
        fig.savefig(path, dpi=120, bbox_inches="tight")
    return fig, data


def plot_poincare(section: PoincareSection, ax=None, path=None):
    """Poincaré map: (x, xdot) at the section times. Returns (figure, arrays plotted)."""
    fig, ax = _figure(ax, (5, 4.5))
    ax.plot(section.x, section.xdot, ".", ms=4, color="C3", gid="section")
    ax.set_xlabel(section.label)
    ax.set_ylabel(f"d/dt {section.label}")
    ax.set_title(f"Poincaré map (T = {section.period:.6g} s, phase {section.phase:.3g} s, {len(section)} points)")
    ax.grid(alpha=0.3)
    if path is not None:
        fig.savefig(path, dpi=120, bbox_inches="tight")
    return fig, {"x": section.x, "xdot": section.xdot}


def plot_bifurcation(result: BifurcationResult, coordinate="xdot", signal=None, ax=None, path=None, label=None):
    """Bifurcation diagram: Poincaré samples of ``signal`` (default: the first recorded) of
    every successful run against the parameter; failed values are marked with red crosses at
    the bottom of the plot. Returns (figure, arrays plotted)."""
    p, y = result.points(coordinate, signal=signal)
    fig, ax = _figure(ax, (7, 4.5))
    many = len(p) > 5000
    ax.plot(p, y, "," if many else ".", ms=2, color="k", gid="bifurcation", rasterized=many)
    failed = np.array([float(r.value) for r in result.runs if not r.ok and _is_number(r.value)])
    if len(failed):
        ybase = np.full(len(failed), np.min(y) if len(y) else 0.0)
        ax.plot(failed, ybase, "x", color="r", gid="failed", label="run failed")
        ax.legend(fontsize=8)
    name = label or (result.parameter if isinstance(result.parameter, str) else "parameter")
    ax.set_xlabel(str(name))
    sig = result._key(signal)
    ax.set_ylabel(f"d/dt {sig}" if coordinate == "xdot" else sig)
    ax.set_title("bifurcation diagram (Poincaré samples)")
    ax.grid(alpha=0.3)
    if path is not None:
        fig.savefig(path, dpi=120, bbox_inches="tight")
    return fig, {"p": p, "y": y, "failed": failed}


def _is_number(v):
    try:
        return math.isfinite(float(v))
    except (TypeError, ValueError):
        return False


# =============================================================================== command line
def _values_arg(text):
    """'a:b:n' (n values from a to b) or a comma-separated list of YAML scalars."""
    if ":" in text and "," not in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise InputError(f"--values: expected 'start:stop:count', got {text!r}")
        try:
            return list(np.linspace(float(parts[0]), float(parts[1]), int(parts[2])))
        except ValueError:
            raise InputError(f"--values: expected 'start:stop:count', got {text!r}") from None
    return [yaml.safe_load(v) for v in text.split(",")]


def _param_arg(items):
    """--param PATH or PATH*FACTOR (repeatable) -> a string or a mapping path -> factor."""
    par = {}
    for it in items:
        path, factor = it, 1.0
        if "*" in it.rpartition("]")[2]:          # a '*' inside [...] would be part of a name
            path, _, fac = it.rpartition("*")
            try:
                factor = float(fac)
            except ValueError:
                raise InputError(f"--param: factor in {it!r} is not a number") from None
        par[path] = factor
    return next(iter(par)) if len(par) == 1 and next(iter(par.values())) == 1.0 else par


def _kv(items, what):
    from .cli import parse_kv

    return parse_kv(items, what)


def _tag(key):
    return re.sub(r"[^A-Za-z0-9_-]+", "_", key).strip("_")


def _period_of_speed(w):
    return 2 * math.pi / abs(float(w))


def cli_main(argv) -> int:
    """`pinclear analyse bifurcation|poincare ...` (see --help)."""
    import argparse
    import json

    ap = argparse.ArgumentParser(prog="pinclear analyse",
                                 description="phase portraits, Poincaré maps and bifurcation diagrams")
    sub = ap.add_subparsers(dest="cmd", required=True)
    b = sub.add_parser("bifurcation", help="Poincaré samples against a swept parameter (parallel runs)")
    b.add_argument("file", help="mechanism sidecar (urdf/NAME.yaml)")
    b.add_argument("--param", action="append", required=True, metavar="PATH[*FACTOR]",
                   help="swept key: NAME.key of a clearance (S2.mu), a scene option or a sidecar path "
                        "(forces[spring].k, drives[crank1_drive].law.coeffs[1]); repeat to set several keys, "
                        "each to FACTOR*value")
    b.add_argument("--values", required=True, help="'start:stop:count' or a comma list")
    grp = b.add_mutually_exclusive_group(required=True)
    grp.add_argument("--period", type=float, help="driving period [s]")
    grp.add_argument("--period-from-speed", action="store_true",
                     help="the swept value is a driving speed w [rad/s]: period 2 pi / |w|")
    b.add_argument("--signal", action="append", required=True,
                   help="joint name, FRAME.x|y|z, ELEMENT.output[k] (e.g. S2.eccentricity[1]); repeatable")
    b.add_argument("--cycles", type=int, default=100)
    b.add_argument("--transient", type=int, default=20)
    b.add_argument("--phase", type=float, default=0.0, help="section phase [s] within the period")
    b.add_argument("--per-period", type=int, default=8, help="output samples per period")
    b.add_argument("--clearance", action="append", metavar="NAME", help="activate a clearance joint")
    b.add_argument("--set", action="append", metavar="NAME.KEY=VALUE", help="fixed override (repeatable)")
    b.add_argument("--option", action="append", metavar="KEY=VALUE", help="scene option (repeatable)")
    b.add_argument("--method", default="lagrange")
    b.add_argument("--integrator", default="RK45")
    b.add_argument("--rtol", type=float, default=1e-6)
    b.add_argument("--max-cpu", type=float, default=None, help="CPU seconds per run before it is stopped")
    b.add_argument("--workers", type=int, default=None, help="worker processes (default: all cores)")
    b.add_argument("--out", default="out")
    p = sub.add_parser("poincare", help="phase portrait + Poincaré map of a saved run (trajectory.npz)")
    p.add_argument("trajectory", help="trajectory.npz written by `pinclear simulate`")
    p.add_argument("--file", help="mechanism sidecar (default: the one recorded in the run)")
    p.add_argument("--clearance", action="append", metavar="NAME", help="clearance joints active in the run")
    p.add_argument("--period", type=float, required=True, help="driving period [s]")
    p.add_argument("--signal", action="append", required=True, help="as for bifurcation; repeatable")
    p.add_argument("--skip", type=int, default=0, help="transient periods to drop")
    p.add_argument("--phase", type=float, default=0.0)
    p.add_argument("--out", default="out")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    if args.cmd == "bifurcation":
        sim = dict(method=args.method, integrator=args.integrator, rtol=args.rtol)
        if args.max_cpu:
            sim["max_cpu"] = args.max_cpu
        load_kw = dict(clearances=args.clearance or None, options=_kv(args.option, "--option") or None,
                       overrides=_kv(args.set, "--set") or None)
        res = bifurcation(args.file, _param_arg(args.param), _values_arg(args.values),
                          period=_period_of_speed if args.period_from_speed else args.period,
                          signal=list(args.signal), cycles=args.cycles, transient=args.transient, phase=args.phase,
                          per_period=args.per_period, sim_options=sim,
                          load_options={k: v for k, v in load_kw.items() if v}, max_workers=args.workers,
                          progress=True)
        res.save(out / "bifurcation.npz")
        label = ", ".join(args.param)
        for key in res.signals:
            plot_bifurcation(res, signal=key, label=label, path=out / f"bifurcation_{_tag(key)}.png")
        table = {key: res.table(signal=key) for key in res.signals}
        (out / "bifurcation.json").write_text(json.dumps(table, indent=2, default=str))
        for key in res.signals:
            print(f"{key}:")
            for row in table[key]:
                K = "" if row["K"] is None else f" K={row['K']:.2f}"
                print(f"  {row['value']!s:>12} {row['status']:8} {row['kind'] or '-'}{K}"
                      + ("" if row["status"] == "success" else f"  ({row['message']})"))
        print(f"wrote {out}/bifurcation.npz, bifurcation.json and the figures")
        return 0 if not res.failures else 1

    from .sidecar import load
    from .trajectory import Trajectory

    tr0 = Trajectory.load(args.trajectory)
    path = args.file or tr0.mech_path
    if not path:
        raise InputError(f"{args.trajectory}: no mechanism file recorded in the run: give --file")
    if args.clearance is None:
        sc = yaml.safe_load(Path(path).read_text()) or {}
        names = {c.get("name") for c in sc.get("clearances") or [] if isinstance(c, dict)}
        ran = {f.get("name") for f in tr0.meta.get("mechanism", {}).get("forces", [])}
        args.clearance = sorted(names & ran)
    mech = load(path, clearances=args.clearance or None)
    traj = Trajectory.load(args.trajectory, mech=mech)
    report = {}
    for sig in args.signal:
        sec = poincare(traj, args.period, sig, phase=args.phase, skip_transient=args.skip, mech=mech)
        x, xd = phase_portrait(traj, sig, mech=mech, t_min=args.phase + args.skip * args.period)
        plot_phase_portrait(x, xd, section=sec, label=sig, path=out / f"phase_{_tag(sig)}.png")
        plot_poincare(sec, path=out / f"poincare_{_tag(sig)}.png")
        c = classify(sec)
        report[sig] = dict(c.as_dict(), samples=len(sec), interpolated=int(sec.interpolated.sum()))
    (out / "poincare.json").write_text(json.dumps(report, indent=2, default=str))
    print(json.dumps(report, indent=2, default=str))
    return 0


if __name__ == "__main__":
    try:
        sys.exit(cli_main(sys.argv[1:]))
    except (InputError, ModelFileError) as exc:
        print(f"pinclear: error: {exc}", file=sys.stderr)
        sys.exit(2)
