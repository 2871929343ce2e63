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
"""
from __future__ import annotations

import math
import os
import pickle
import re
import sys
import tempfile
import time
import warnings
from concurrent.futures import Executor, ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin
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


def _frame_series(model, fid, traj):
    """World position, LWA linear velocity and classical acceleration of a frame origin."""
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
    return PoincareSection(k, ts, x, xd, period, phase, s.label, ~hit, s.exact_rate)


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


def chaos_01(phi, n_c=100, n_cut=None, seed=0, return_all=False):
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
    as regular: feed it stroboscopic samples, not dense output; noise reads as chaos. A sequence
    that is constant to rounding (a fixed point) returns K = 0 by definition, because D_c is
    then identically zero and its correlation with n meaningless.
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
    spread = np.std(phi)
    if spread <= 1e-12 * max(1.0, float(np.max(np.abs(phi)))):
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
    k <= max_period. Otherwise, with at least ``min_samples_01`` samples, the 0-1 test on each
    coordinate (the largest K counts): K > chaos_threshold (default CHAOS_THRESHOLD = 0.5)
    "chaotic", else "quasi-periodic"; ``note`` says "ambiguous" when 0.1 <= K <= 0.9. With fewer
    samples the motion is "unresolved".
    """
    thr = CHAOS_THRESHOLD if chaos_threshold is None else float(chaos_threshold)
    P = section.points if isinstance(section, PoincareSection) else np.asarray(section, float)
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
    K = max(chaos_01(P[:, j]) for j in range(P.shape[1]))
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
    import yaml

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
            if spec in opts and factor != 1.0:
                raise InputError(f"parameter {spec!r} is a scene option: a factor other than 1 makes no sense")
            overrides.append((spec, factor))
        else:
            raise ModelFileError(file, spec, "not a sidecar key path, clearance key (NAME.key) or scene option",
                                 choices=sorted(TOP_KEYS) + [f"{c}.<key>" for c in clr] + opts)
    return patches, overrides


def _load_variant(path, patches, overrides, value, load_kw):
    """The mechanism of ``path`` with the parameter set to ``value``."""
    import yaml

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
    section: PoincareSection | None = None
    portrait: tuple | None = None         # (t, x, xdot) after the transient, if requested
    stats: dict = field(default_factory=dict)
    classification: Classification | None = None

    @property
    def ok(self):
        return self.status == "success"


@dataclass
class BifurcationResult:
    parameter: object
    values: np.ndarray
    runs: list
    signal: object
    period: np.ndarray                    # driving period per value

    def points(self, coordinate="xdot", include_failed=False):
        """(parameter, ordinate) pairs of all Poincaré samples, ready for a scatter plot.
        coordinate: 'x' or 'xdot' (papers 000/002 plot the relative velocity: 'xdot')."""
        if coordinate not in ("x", "xdot"):
            raise InputError(f"coordinate must be 'x' or 'xdot', got {coordinate!r}")
        ps, ys = [], []
        for r in self.runs:
            if r.section is None or (not r.ok and not include_failed):
                continue
            y = getattr(r.section, coordinate)
            ps.append(np.full(len(y), float(r.value)))
            ys.append(y)
        if not ps:
            return np.zeros(0), np.zeros(0)
        return np.concatenate(ps), np.concatenate(ys)

    @property
    def failures(self):
        return [(r.value, r.status, r.message) for r in self.runs if not r.ok]

    def table(self):
        """One dict per value: value, status, kind, period, K, samples, cpu_s, message."""
        rows = []
        for r in self.runs:
            c = r.classification
            rows.append({"value": r.value, "status": r.status, "kind": c.kind if c else None,
                         "period": c.period if c else None, "K": c.K if c else None,
                         "samples": len(r.section) if r.section is not None else 0,
                         "cpu_s": r.stats.get("cpu_s"), "message": r.message})
        return rows


def _run_one(job):
    """Worker: build the variant, simulate on the section grid, take the Poincaré samples."""
    from .simulate import simulate

    t_start = time.perf_counter()
    i, value = job["index"], job["value"]
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
        sec = poincare(traj, T, job["signal"], phase=job["phase"], skip_transient=job["transient"],
                       t0=job["t0"], mech=mech) if len(traj.t) else None
        portrait = None
        if job["keep_portrait"] and len(traj.t):
            s = series(traj, job["signal"], mech)
            keep = s.t >= job["t0"] + job["phase"] + job["transient"] * T - 1e-9 * T
            portrait = (s.t[keep], s.x[keep], s.xdot[keep])
        stats = {k: traj.stats.get(k) for k in ("cpu_s", "rhs_evals", "steps") if k in traj.stats}
        stats["events"] = len(traj.stats.get("events", []))
        stats["wall_s"] = time.perf_counter() - t_start
        return BifurcationRun(i, value, "success" if traj.status == "success" else "failed", traj.message,
                              sec, portrait, stats)
    except Exception as exc:                  # every failure is a result, never a lost value
        return BifurcationRun(i, value, "error", f"{type(exc).__name__}: {exc}",
                              stats={"wall_s": time.perf_counter() - t_start})


def bifurcation(model, parameter, values, period, signal, cycles=100, transient=20, phase=0.0, t0=0.0,
                per_period=1, keep_portrait=False, sim_options=None, load_options=None,
                executor=None, max_workers=None, progress=None, classify_options=None) -> BifurcationResult:
    """Poincaré samples of ``signal`` for each parameter value (a bifurcation diagram).

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
        exactly on the section (``per_period`` samples per period, for keep_portrait).
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
    values = list(values)
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
    if int(transient) < 0 or int(cycles) < 1:
        raise InputError(f"need transient >= 0 and cycles >= 1, got {transient}, {cycles}")
    periods = []
    for v in values:
        T = float(period(v)) if callable(period) else float(period)
        if not T > 0 or not math.isfinite(T):
            raise InputError(f"period for value {v!r} is {T!r}: must be a positive number of seconds")
        periods.append(T)
    base = dict(factory=None, path=None, patches=None, overrides=None, load_kw=load_kw, phase=float(phase),
                t0=float(t0), transient=int(transient), cycles=int(cycles), per_period=int(per_period),
                signal=signal, sim_kw=sim_kw, keep_portrait=bool(keep_portrait))
    if callable(model):
        base["factory"] = model
    else:
        path = Path(model)
        if not path.exists():
            raise ModelFileError(str(path), "path", "no such file")
        patches, overrides = _classify_parameter(path, parameter, load_kw)
        base.update(path=str(path), patches=patches, overrides=overrides)
    jobs = [dict(base, index=i, value=v, period=T) for i, (v, T) in enumerate(zip(values, periods))]

    if progress is True:
        def progress(done, total, run):   # noqa: F811 - the default reporter
            print(f"bifurcation {done}/{total}: {parameter}={run.value!r} {run.status} "
                  f"({run.stats.get('wall_s', 0):.1f} s)", file=sys.stderr, flush=True)

    runs: list = [None] * len(jobs)
    done = 0

    def finish(run):
        nonlocal done
        runs[run.index] = run
        done += 1
        if progress:
            progress(done, len(jobs), run)

    if executor == "serial":
        for job in jobs:
            finish(_run_one(job))
    else:
        if executor is not None and not isinstance(executor, Executor):
            raise InputError(f"executor must be None, 'serial' or a concurrent.futures.Executor, got {executor!r}")
        try:
            pickle.dumps(jobs[0])
        except Exception as exc:
            raise InputError(f"bifurcation: the job cannot be sent to worker processes ({exc}); use module-level "
                             "functions for the factory, signal and laws, or executor='serial'") from None
        own = executor is None
        ex = ProcessPoolExecutor(max_workers=max_workers or min(os.cpu_count() or 1, len(jobs))) if own else executor
        try:
            futs = {ex.submit(_run_one, job): job for job in jobs}
            from concurrent.futures import as_completed

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
    for r in runs:
        if r.section is not None and len(r.section):
            sc = copt.pop("scale", None)
            scale = sc
            if scale is None and r.portrait is not None and len(r.portrait[1]):
                scale = [np.ptp(r.portrait[1]), np.ptp(r.portrait[2])]
            r.classification = classify(r.section, scale=scale, **copt)
            if sc is not None:
                copt["scale"] = sc
        else:
            r.classification = classify(np.zeros((0, 2)))
    return BifurcationResult(parameter, np.asarray(values, dtype=object if any(isinstance(v, str) for v in values)
                                                    else float),
                             runs, signal, np.asarray(periods))


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


def plot_bifurcation(result: BifurcationResult, coordinate="xdot", ax=None, path=None, label=None):
    """Bifurcation diagram: Poincaré samples of every successful run against the parameter;
    failed values are marked with red crosses on the axis. Returns (figure, arrays plotted)."""
    p, y = result.points(coordinate)
    fig, ax = _figure(ax, (7, 4.5))
    ax.plot(p, y, ",", color="k", gid="bifurcation", rasterized=len(p) > 20000)
    if len(p) < 5000:
        ax.plot(p, y, ".", ms=2, color="k")
    failed = np.array([float(r.value) for r in result.runs if not r.ok and _is_number(r.value)])
    if len(failed):
        ybase = np.full(len(failed), np.min(y) if len(y) else 0.0)
        ax.plot(failed, ybase, "x", color="r", gid="failed", label="run failed")
        ax.legend(fontsize=8)
    name = label or (result.parameter if isinstance(result.parameter, str) else "parameter")
    ax.set_xlabel(str(name))
    sig = result.signal if isinstance(result.signal, str) else "signal"
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
