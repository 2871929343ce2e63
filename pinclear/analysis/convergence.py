"""Is a reported number converged? Two checks a report runs before it prints a class or a span.

* :func:`transient_check`: a Poincaré classification judged again with a longer transient (the
  first ``extra`` section points dropped, e.g. 20 -> 40 periods): a class that changes was still
  carrying the start-up transient. It needs no new run.
* :func:`step_convergence`: a quantity read off a run's output grid (a force span, an acceleration
  peak differentiated from the samples) measured at successively finer output steps, with the
  change between steps, the observed order and a Richardson estimate of the finest value's error.
  A contact ringing near 250 Hz is sampled 2 times per period by a 2 ms grid: its extremes are not
  the integration's.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace

import numpy as np

from pinclear.analysis.classify import classify, classify_state
from pinclear.analysis.poincare import PoincareSection
from pinclear.core.errors import InputError


@dataclass
class TransientCheck:
    short: object           # Classification with the transient as given
    long: object            # Classification with ``extra`` more section points dropped
    extra: int
    agree: bool             # the same kind (and period) both ways
    note: str

    def as_dict(self):
        return {"short": self.short.kind, "long": self.long.kind, "extra": self.extra, "agree": self.agree,
                "note": self.note}


def _drop(section, extra):
    """``section`` without its first ``extra`` points (a PoincareSection keeps its scale: the
    attractor's extent, which a longer transient can only shrink)."""
    if isinstance(section, PoincareSection):
        k = slice(extra, None)
        return replace(section, k=section.k[k], t=section.t[k], x=section.x[k], xdot=section.xdot[k],
                       interpolated=section.interpolated[k])
    return np.asarray(section, float)[extra:]


def transient_check(sections, extra=20, **options) -> TransientCheck:
    """Classify ``sections`` (one PoincareSection, an (n,) / (n, d) array, or a list of sections
    for :func:`classify_state`) as given and again without their first ``extra`` section
    points, i.e. with ``extra`` more periods of transient left out (a diagram recorded after 20
    periods is judged after 40). ``options`` as for classify. The two agree when kind and period
    are the same; the longer-transient class is the one to report when they differ (the shorter
    one's first points may still carry the start-up), and the note says so."""
    extra = int(extra)
    if extra < 1:
        raise InputError(f"transient_check: extra is a number of section points >= 1, got {extra!r}")
    many = isinstance(sections, (list, tuple))
    fn = classify_state if many else classify
    n = min(len(s) for s in sections) if many else len(sections)
    if n <= extra:
        raise InputError(f"transient_check: {n} section points cannot lose {extra} and still be classified")
    short = fn(sections, **options)
    long = fn([_drop(s, extra) for s in sections] if many else _drop(sections, extra), **options)
    agree = short.kind == long.kind and short.period == long.period
    if agree:
        note = f"the same class ({short.kind}) with {extra} more transient periods left out"
    else:
        note = (f"{short.kind} becomes {long.kind} with {extra} more transient periods left out: the start-up had "
                "not decayed; the longer transient's class counts")
    return TransientCheck(short, long, extra, agree, note)


def transient_summary(checks):
    """One line over ``checks`` ({label: TransientCheck}): how many keep their class, and each
    one that moves."""
    if not checks:
        return "no transient check"
    moved = [f"{k}: {c.short.kind} -> {c.long.kind}" for k, c in checks.items() if not c.agree]
    extra = sorted({c.extra for c in checks.values()})
    head = (f"transient check (+{', '.join(map(str, extra))} periods): {len(checks) - len(moved)} of {len(checks)} "
            "keep their class")
    return head + ("; " + "; ".join(moved) if moved else "")


@dataclass
class StepConvergence:
    steps: list             # output steps, coarse to fine (s)
    values: dict            # {name: [value at each step]}
    changes: dict           # {name: [|v[i+1] - v[i]| / |v[i+1]|]} (relative change to the next finer step)
    order: dict             # {name: observed order from the last three steps (nan with fewer, or no decay)}
    error: dict             # {name: Richardson estimate of the finest value's error (relative; nan if none)}
    converged: dict         # {name: last change <= rtol}
    rtol: float

    @property
    def all_converged(self):
        return all(self.converged.values())

    def table(self):
        """Rows [name, step, value, change to the next finer] for a markdown table."""
        rows = []
        for name, vals in self.values.items():
            for i, (h, v) in enumerate(zip(self.steps, vals)):
                ch = self.changes[name][i] if i < len(vals) - 1 else float("nan")
                rows.append([name, h, v, ch])
        return rows

    def note(self, name):
        ch, p = self.changes[name][-1], self.order[name]
        state = "converged" if self.converged[name] else "NOT converged"
        o = f", observed order {p:.2g}" if math.isfinite(p) else ""
        return (f"{name}: {state} (change {ch:.2%} from output step {self.steps[-2]:.3g} s to {self.steps[-1]:.3g} s, "
                f"allowed {self.rtol:.0%}{o})")


def step_convergence(measure, steps, rtol=0.01) -> StepConvergence:
    """``measure(step)`` -> a number or {name: number} (e.g. a run's force spans read off an
    output grid of that step) at each of ``steps`` (at least 2), ordered coarse to fine.
    Each quantity is converged when its relative change between the two finest steps is at most
    ``rtol``. With three or more steps in a constant ratio r, the observed order is
    p = ln(|v1 - v2| / |v2 - v3|) / ln r over the finest three and the finest value's error is
    estimated as |v2 - v3| / (r^p - 1) (Richardson), relative to |v3|.
    Halving a grid keeps its old samples: a spike's sampled peak can then repeat from step to
    step by aliasing and read converged; give steps that are not nested (2e-3, 1.3e-3, 7e-4 s)
    for sampled extremes (no order is then estimated)."""
    steps = [float(h) for h in steps]
    if len(steps) < 2 or any(not (h > 0 and math.isfinite(h)) for h in steps):
        raise InputError(f"step_convergence: need at least two positive output steps, got {steps!r}")
    if any(b >= a for a, b in itertools.pairwise(steps)):
        raise InputError(f"step_convergence: give the output steps coarse to fine, got {steps!r}")
    if not rtol > 0:
        raise InputError(f"step_convergence: rtol must be positive, got {rtol!r}")
    raw = [measure(h) for h in steps]
    named = isinstance(raw[0], dict)
    names = list(raw[0]) if named else ["value"]
    values = {k: [float(r[k] if named else r) for r in raw] for k in names}
    changes, order, error, conv = {}, {}, {}, {}
    for k, v in values.items():
        ch = [abs(b - a) / abs(b) if b else (0.0 if a == b else math.inf) for a, b in itertools.pairwise(v)]
        changes[k], conv[k] = ch, bool(ch[-1] <= rtol)
        order[k] = error[k] = float("nan")
        if len(v) >= 3:
            r1, r2 = steps[-3] / steps[-2], steps[-2] / steps[-1]
            d1, d2 = abs(v[-2] - v[-3]), abs(v[-1] - v[-2])
            if abs(r1 - r2) <= 1e-9 * r2 and d2 > 0 and d1 > d2:
                p = math.log(d1 / d2) / math.log(r2)
                order[k] = p
                error[k] = d2 / (r2 ** p - 1) / abs(v[-1]) if v[-1] else float("nan")
            elif d2 == 0:
                error[k] = 0.0
    return StepConvergence(steps, values, changes, order, error, conv, float(rtol))


#: strides of :func:`sampled_convergence`, coarse to fine: no two consecutive ones nested (every
#: 2nd sample holds every 1st's peak half the time, every 3rd's never wholly), so a spike's sampled
#: peak cannot repeat by aliasing from one to the next; the finest is every 2nd sample, so the
#: table judges grids of 3 and 2 output steps and the run's own grid (every sample) is finer still
STRIDES = (10, 7, 5, 3, 2)


def sampled_convergence(t, measure, strides=STRIDES, rtol=0.01) -> StepConvergence:
    """:func:`step_convergence` of quantities read off one run's uniform samples ``t``:
    ``measure(index)`` -> a number or {name: number} from the samples ``index`` (every k-th one,
    k in ``strides``, coarse to fine), so one run gives the whole table (a quantity converged on
    grids of 3 and 2 output steps is converged on the run's own, finer grid). The samples come from the integrator's dense output at steps the output grid does not
    choose, so every k-th sample of a run at step dt is what a run at step k dt would record."""
    t = np.asarray(t, float)
    if len(t) < 2 * max(strides):
        raise InputError(f"sampled_convergence: {len(t)} samples are too few for a stride of {max(strides)}")
    dt = (t[-1] - t[0]) / (len(t) - 1)
    if np.max(np.abs(np.diff(t) - dt)) > 1e-6 * dt:
        raise InputError("sampled_convergence: the samples are not uniform in time")
    by_step = {k * dt: np.arange(0, len(t), k) for k in strides}
    return step_convergence(lambda h: measure(by_step[h]), list(by_step), rtol)


__all__ = ["STRIDES", "StepConvergence", "TransientCheck", "sampled_convergence", "step_convergence",
           "transient_check", "transient_summary"]
