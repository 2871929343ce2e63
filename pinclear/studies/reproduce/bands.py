"""Uncertainty bands of the reproductions: the spread of a row's result over the plausible range
of the reconstructed inputs (pinclear/reproduce/reconstructed.yaml, docs/papers.md).

The design is one-at-a-time (every input at each end of its range, or each of its choices, the
others nominal) plus a small space-filling sample (a Latin hypercube over the numeric inputs,
categorical ones drawn in turn). The points run through the sweep machinery's job runner
(:func:`pinclear.analysis.sweeps.run_jobs` on :func:`pinclear.analysis.sweeps.make_executor`: local processes or a
Dask cluster). A CPU budget bounds the design: the one-at-a-time points first, then as many
space-filling points as the budget leaves at the stated cost per point; the report says how
many ran.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from pinclear.core.errors import InputError, ModelFileError

FILE = Path(__file__).with_name("reconstructed.yaml")
#: space-filling points asked for when the budget allows
LHS_POINTS = 8


def reconstructed_inputs(paper, file=FILE, keyed=True):
    """The reconstructed inputs of ``paper`` (a list of dicts), checked: each has a name, a
    reason and a range or choices; ``keyed``: only those the bands can vary (a key)."""
    import yaml

    data = yaml.safe_load(Path(file).read_text())
    if str(paper) not in data:
        raise ModelFileError(file, str(paper), "no reconstructed inputs for this paper", choices=sorted(data))
    out = []
    for i, e in enumerate(data[str(paper)]):
        where = f"{paper}[{i}]"
        for k in ("name", "reason", "nominal"):
            if k not in e:
                raise ModelFileError(file, f"{where}.{k}", "missing")
        if ("range" in e) == ("choices" in e):
            raise ModelFileError(file, where, "give exactly one of range / choices", choices=["range", "choices"])
        if e.get("key") and "range" in e:
            lo, hi = e["range"]
            if not float(lo) <= float(e["nominal"]) <= float(hi):
                raise ModelFileError(file, f"{where}.range", f"nominal {e['nominal']} outside {e['range']}")
        if e.get("key") or not keyed:
            out.append(e)
    return out


def design(inputs, n_lhs=LHS_POINTS, seed=0):
    """[(label, {key: value})]: the nominal point, one-at-a-time ends, then ``n_lhs`` Latin
    hypercube points (numeric inputs uniform over their range; categorical in turn)."""
    nominal = {e["key"]: e["nominal"] for e in inputs}
    pts = [("nominal", dict(nominal))]
    for e in inputs:
        ends = e["choices"] if "choices" in e else e["range"]
        for v in ends:
            if v != e["nominal"]:
                pts.append((f"{e['name']} = {v}", {**nominal, e["key"]: v}))
    rng = np.random.default_rng(seed)
    num = [e for e in inputs if "range" in e]
    if n_lhs > 0 and num:
        u = (np.argsort(rng.random((len(num), n_lhs)), axis=1) + rng.random((len(num), n_lhs))) / n_lhs
        for k in range(n_lhs):
            p = dict(nominal)
            for i, e in enumerate(num):
                lo, hi = map(float, e["range"])
                p[e["key"]] = lo + u[i, k] * (hi - lo)
            for j, e in enumerate(x for x in inputs if "choices" in x):
                p[e["key"]] = e["choices"][(k + j) % len(e["choices"])]
            pts.append((f"space-filling {k + 1}", p))
    return pts


def within_budget(points, cost, budget):
    """The points the CPU ``budget`` (s) affords at ``cost`` CPU s per point: the nominal and
    one-at-a-time points always (they are the band's least), then space-filling points."""
    if budget is None:
        return list(points)
    if not budget > 0:
        raise InputError(f"--budget must be a positive number of CPU seconds, got {budget!r}")
    core = [p for p in points if not p[0].startswith("space-filling")]
    extra = [p for p in points if p[0].startswith("space-filling")]
    n = max(0, int((budget - cost * len(core)) // max(cost, 1e-9)))
    return core + extra[:n]


def run_points(fn, points, workers=None, scheduler=None):
    """{label: fn(values) or the exception text} over ``points`` on one executor."""
    from pinclear.analysis.sweeps import make_executor, run_jobs

    if scheduler is None and (workers or 1) == 1:
        ex, close = "serial", None
    else:
        ex, close = make_executor(workers, scheduler)
    got = {}
    try:
        run_jobs(fn, [v for _, v in points], ex, lambda job, res: got.__setitem__(_key(job), res),
                 lambda job, exc: got.__setitem__(_key(job), f"{type(exc).__name__}: {exc}"))
    finally:
        if close is not None:
            close()
    return {label: got.get(_key(v)) for label, v in points}


def _key(values):
    return tuple(sorted((k, str(v)) for k, v in values.items()))


def spread(results, fields):
    """{field: (lo, hi)} over the results that are dicts (failed points left out)."""
    ok = [r for r in results.values() if isinstance(r, dict)]
    return {f: (min(r[f] for r in ok), max(r[f] for r in ok)) for f in fields if ok and all(f in r for r in ok)}
