"""Stroboscopic Poincaré sections of a signal, sampled exactly on the section times."""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.interpolate import CubicHermiteSpline, CubicSpline

from pinclear.analysis.signals import series
from pinclear.core.errors import InputError

#: section points of one map or one run's section times: ~0.5 GB of arrays at this size
MAX_SECTION_POINTS = 10_000_000


def check_section_count(sections, samples, period, span):
    """Refuse, before anything is allocated, a Poincaré map with more section points than the
    run's samples can resolve (a period shorter than a quarter of the mean sample spacing only
    interpolates between samples) or than MAX_SECTION_POINTS. `analyse poincare --period 1e-9`
    allocated until the kernel killed it (23 GB)."""
    limit = min(MAX_SECTION_POINTS, 4 * samples + 1000)
    if not sections <= limit:                    # NaN and inf included
        raise InputError(f"--period {period:.6g} s gives {sections:.3g} section points over the run's {span:.6g} s "
                         f"of {samples} samples (at most {limit}: a period shorter than the sample spacing is not "
                         "resolved by the samples); give the driving period, or simulate with a finer --dt-out")


def section_times(period, cycles, phase=0.0, t0=0.0, per_period=1):
    """Output times for :func:`pinclear.simulate` (``t_eval``) that contain the Poincaré
    section t0 + phase + k*period, k = 0..cycles, exactly, plus ``per_period - 1`` samples in
    between for the phase portrait. Pass ``t_end = times[-1]``."""
    period, per_period, cycles = float(period), int(per_period), int(cycles)
    if not period > 0 or not math.isfinite(period):
        raise InputError(f"period must be a positive number of seconds, got {period!r}")
    if per_period < 1 or cycles < 1:
        raise InputError(f"need cycles >= 1 and per_period >= 1, got {cycles}, {per_period}")
    if cycles * per_period > MAX_SECTION_POINTS:
        raise InputError(f"cycles x per_period = {cycles} x {per_period} output times, more than "
                         f"{MAX_SECTION_POINTS}: refused before allocating")
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


def poincare(traj, period, signal, phase=0.0, skip_transient=0, t0=0.0, mech=None, match_tol=1e-9, resolved=None):
    """Poincaré (stroboscopic) map of ``signal``: samples at t = t0 + k*period + phase for every
    k >= skip_transient (a number of periods) whose time lies within the run.

    Output samples within ``match_tol * period`` of a section time are used as they are;
    others are interpolated (cubic Hermite with the exact rate, and the second derivative
    where the signal has one) and flagged. Simulate with ``t_eval=section_times(...)`` to
    avoid interpolation altogether. ``resolved``: the Series of ``signal`` on ``traj`` when the
    caller has it already (signals.series; a bifurcation run reuses it for its phase portrait).
    """
    period = float(period)
    if not period > 0 or not math.isfinite(period):
        raise InputError(f"period must be a positive number of seconds, got {period!r}")
    if skip_transient < 0:
        raise InputError(f"skip_transient is a number of periods >= 0, got {skip_transient!r}")
    s = series(traj, signal, mech) if resolved is None else resolved
    t = s.t
    empty = PoincareSection(np.zeros(0, int), np.zeros(0), np.zeros(0), np.zeros(0), period, phase, s.label,
                            np.zeros(0, bool), s.exact_rate)
    if len(t) == 0:
        return empty
    tol = match_tol * period
    with np.errstate(over="ignore"):              # a count that overflows is inf, refused below
        count = np.float64(t[-1] - t[0]) / period
    check_section_count(count, len(t), period, t[-1] - t[0])
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


def aligned_dt_out(period, t, phase=0.0):
    """The output interval that puts every section time phase + k period on an output sample
    (simulate's grid runs from t0 in steps of dt_out): period / n, not coarser than the run's
    median sample interval, preferring a short decimal (n up to twice the least); also requires phase to be a multiple of it
    (None when it is not: then give a phase that is). For the hint of a section that had to be
    interpolated."""
    t = np.asarray(t, float)
    dt = float(np.median(np.diff(t))) if len(t) > 1 else period
    n0 = max(1, int(np.ceil(period / dt - 1e-9)))
    # the first n whose period / n has a short decimal form (a value a user can type), else n0
    step = next((period / n for n in range(n0, 2 * n0 + 1) if float(f"{period / n:.6g}") == period / n), period / n0)
    k = (phase - (t[0] if len(t) else 0.0)) / step
    return step if abs(k - round(k)) < 1e-9 * max(1.0, abs(k)) else None
