"""Uncertainty bands of the reproductions: the spread of a row's result over the plausible range
of the reconstructed inputs (pinclear/reproduce/reconstructed.yaml, docs/papers.md).

The design is one-at-a-time (every input at each end of its range, or each of its choices, the
others nominal) plus a small space-filling sample (a Latin hypercube over the numeric inputs,
categorical ones drawn in turn). The points run through the sweep machinery's job runner
(:func:`pinclear.sweeps.run_jobs` on :func:`pinclear.sweeps.make_executor`: local processes or a
Dask cluster). A CPU budget bounds the design: the one-at-a-time points first, then as many
space-filling points as the budget leaves at the stated cost per point; the report says how
many ran.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError, ModelFileError

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
    from ..sweeps import make_executor, run_jobs

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


# ------------------------------------------------------------------------------- paper 004
#: a 004 design point's cost (CPU s, three cases x three readings at 2001 samples; measured ~3 s)
COST_004 = 5.0
_JOINTS_004 = {"com:ups_swing": [f"ups{i}_u2" for i in range(1, 5)], "com:ups_rod": [f"ups{i}_p" for i in range(1, 5)],
               "com:upr_swing": ["upr_u2"], "com:upr_rod": ["upr_p"]}


def paper004_point(values, n=2001):
    """The peaks of paper 004's three cases under each reading of the motion law, with the limb
    centres of mass moved along their rods and the platform's along its normal (module-level:
    it pickles to worker processes)."""
    import pinocchio as pin

    from .. import screw
    from ..mechanisms import four_ups_upr as mod
    from . import paper004 as p4

    mech = mod.load()
    model = mech.model
    for key, joints in _JOINTS_004.items():
        for name in joints:
            j = model.getJointId(name)
            y = model.inertias[j]
            model.inertias[j] = pin.Inertia(y.mass, np.asarray(y.lever) * float(values[key]), y.inertia)
    j = model.getJointId("upr_r")
    y = model.inertias[j]
    model.inertias[j] = pin.Inertia(y.mass, np.asarray(y.lever) + np.array([0.0, 0.0, float(values["com:platform"])]),
                                    y.inertia)
    system = screw.screw_system(mech)
    out = {}
    for reading in p4.READINGS:
        cases = p4.case_peaks(mech, system, n, reading)
        for label, (res, _) in cases.items():
            pk, lo, hi, _ = p4.peak_of(res)
            out[f"{reading}|{label}|lo"], out[f"{reading}|{label}|hi"] = lo, hi
        limbs, plat = cases["high speed, with limbs"][0], cases["high speed, platform only"][0]
        if not plat.crossings:
            out[f"{reading}|limbs share|lo"] = out[f"{reading}|limbs share|hi"] = float(
                np.abs(limbs.tau).max() / np.abs(plat.tau).max())
    return out


def paper004_bands(n, workers=None, scheduler=None, budget=None):
    """({(reading, case): (lo, hi, what)}, sensitivity table) of paper 004 over its inputs."""
    from . import paper004 as p4

    inputs = reconstructed_inputs("004")
    pts = within_budget(design(inputs), COST_004, budget)
    res = run_points(_Point004(n), pts, workers, scheduler)
    what = f"{len(pts)} input sets: {sum(not p[0].startswith('space') for p in pts)} one-at-a-time, " \
           f"{sum(p[0].startswith('space') for p in pts)} space-filling"
    bands, rows = {}, []
    keys = [(r, c) for r in p4.READINGS for c in list(p4.PAPER_PEAKS) + ["limbs share"]]
    for reading, case in keys:
        lo = [v[f"{reading}|{case}|lo"] for v in res.values() if isinstance(v, dict) and f"{reading}|{case}|lo" in v]
        hi = [v[f"{reading}|{case}|hi"] for v in res.values() if isinstance(v, dict) and f"{reading}|{case}|hi" in v]
        if lo:
            bands[(reading, case)] = (min(lo), max(hi), what)
    for label, v in res.items():
        if isinstance(v, dict):
            rows.append([label] + [v.get(f"{r}|{c}|hi", float("nan")) for r in p4.READINGS
                                   for c in ("low speed, platform only", "high speed, with limbs")])
        else:
            rows.append([label, str(v)] + [float("nan")] * (2 * len(p4.READINGS) - 1))
    table = {"title": "bands (--bands): the peaks over the reconstructed inputs of reconstructed.yaml",
             "columns": ["input set"] + [f"{c.split(',')[0]} {c.split(', ')[1]}, {r} [N]" for r in p4.READINGS
                                         for c in ("low speed, platform only", "high speed, with limbs")],
             "rows": rows,
             "note": f"{what}; a law with singular crossings lists its peak at the largest cut-off"}
    return bands, table


class _Point004:
    """paper004_point at another sample count (picklable)."""

    def __init__(self, n):
        self.n = n

    def __call__(self, values):
        return paper004_point(values, self.n)


# ------------------------------------------------------------------------------- paper 002
def _run002(job):
    """One A 0.5 mm run of paper 002's sec. 3 at a design point (module-level: it pickles):
    the slider's shift at the ideal peak and the impact and acceleration peaks."""
    import pinclear

    from ..models import model_path
    from . import paper002 as p2

    over = {k.format(j="A"): v for k, v in job["values"].items()}
    mech = pinclear.load(model_path("nine_bar"), clearances=["A"], overrides=over)
    tr = pinclear.simulate(mech, job["t_end"], method="lagrange", integrator="RK45", rtol=p2.RTOL, dt_out=job["dt"],
                           q0=job["q0"], v0=job["v0"])
    x, v, a = p2._slider(tr)
    i_d, i_v = job["i_d"], job["i_v"]
    late = tr.t >= p2.STEADY
    return {"A shift d": 1e3 * float(x[i_d] - job["x_ideal"]), "A shift v": 1e3 * float(abs(v[i_v]) - job["v_ideal"]),
            "A 0.5 mm impact force peak": p2._peak(tr.t, tr.outputs["A.fn"])[0],
            "A 0.5 mm acceleration peak steady": p2._peak(tr.t[late], a[late])[0],
            "status": tr.status, "cpu": tr.stats.get("cpu_s")}


def paper002_bands(out, s, executor, q0, v0, budget=None, cost=None):
    """({row key: (lo, hi, what)}, table) of paper 002's A 0.5 mm rows over the keyed inputs of
    reconstructed.yaml; ``cost``: CPU s of one run (the centred A 0.5 mm run's), for the budget."""
    import pinclear

    from ..models import model_path
    from ..sweeps import run_jobs
    from . import paper002 as p2

    inputs = reconstructed_inputs("002")
    pts = within_budget(design(inputs), float(cost or 60.0), budget)
    ideal = pinclear.simulate(pinclear.load(model_path("nine_bar")), s["response t_end [s]"], rtol=p2.RTOL,
                              dt_out=s["output step [s]"])
    xi, vi, _ = p2._slider(ideal)
    _, t_d = p2._peak(ideal.t, xi, 1.0)
    _, t_v = p2._peak(ideal.t, vi, 1.0)
    i_d, i_v = int(np.argmin(np.abs(ideal.t - t_d))), int(np.argmin(np.abs(ideal.t - t_v)))
    base = {"t_end": s["response t_end [s]"], "dt": s["output step [s]"], "q0": list(q0), "v0": list(v0),
            "i_d": i_d, "i_v": i_v, "x_ideal": float(xi[i_d]), "v_ideal": float(abs(vi[i_v]))}
    jobs = [dict(base, label=label, values=values) for label, values in pts]
    got = {}
    run_jobs(_run002, jobs, executor, lambda job, res: got.__setitem__(job["label"], res),
             lambda job, exc: got.__setitem__(job["label"], f"{type(exc).__name__}: {exc}"))
    ok = {k: v for k, v in got.items() if isinstance(v, dict) and v["status"] == "success"}
    n_sf = sum(label.startswith("space") for label, _ in pts)
    what = f"{len(ok)} of {len(pts)} input sets ({len(pts) - n_sf} one-at-a-time, {n_sf} space-filling)"
    fields = ("A shift d", "A shift v", "A 0.5 mm impact force peak", "A 0.5 mm acceleration peak steady")
    bands = {f: (lo, hi, what) for f, (lo, hi) in spread(ok, fields).items()}
    rows = [[label] + ([got[label].get(f, float("nan")) for f in fields] + [got[label]["status"]]
                       if isinstance(got.get(label), dict) else [float("nan")] * len(fields) + [str(got.get(label))])
            for label, _ in pts]
    return bands, {"title": "bands (--bands): the A 0.5 mm run over the reconstructed inputs of reconstructed.yaml",
                   "columns": ["input set", "displacement shift [mm]", "velocity change [mm/s]", "impact peak [N]",
                               "steady acceleration peak [m/s^2]", "status"],
                   "rows": rows, "note": what + "; inputs without an override key (link dimensions) wait for a "
                                                "regenerated linkage"}


# ------------------------------------------------------------------------------- paper 000
def mechanism000(values, mu, clearance):
    """The S2-clearance model with one design point's reconstructed inputs (reconstructed.yaml
    '000': override keys S2.*, the friction ramp's v0 with v1 = 10 v0, gravity's sign, the mass
    factors of the moving platform and of the rods)."""
    from ..models import model_path
    from ..sidecar import load
    from .paper000 import scale_body

    over = {"S2.mu": mu, "S2.clearance": clearance}
    for k, v in values.items():
        if k == "S2.friction_law.v0":
            over["S2.friction_law"] = {"type": "modified_coulomb", "v0": float(v), "v1": 10.0 * float(v)}
        elif k.startswith("S2."):
            over[k] = v
    mech = load(model_path("four_ups_upu"), clearances=["S2"], overrides=over)
    mech.model.gravity.linear = float(values.get("gravity_sign", 1.0)) * np.asarray(mech.model.gravity.linear)
    for key, bodies in (("mass:moving_platform", ("moving_platform",)),
                        ("mass:rods", tuple(f"rod{i}_{p}" for i in range(1, 6) for p in ("lower", "upper")))):
        for body in bodies:
            scale_body(mech.model, body, float(values.get(key, 1.0)))
    return mech


def _run000(job):
    """Paper 000's measured quantities at one design point (module-level: it pickles): the raw
    contact-force span per mu and the platform's X offset over the response window, and the
    clearance's motion at mu 0.01 (classified with the clearance's resolution)."""
    from .. import analysis
    from ..mechanisms import four_ups_upu as mod
    from ..simulate import simulate
    from . import paper000 as p0

    s, T, out = job["s"], p0.T, {}
    t_end = s["force_periods"] * T
    t_eval = np.arange(t_end - s["window_periods"] * T, t_end + 1e-12, s["dt_out"])
    t_eval[-1] = min(t_eval[-1], t_end)
    for mu in p0.PAPER_FORCE:
        mech = mechanism000(job["values"], mu, s["clearance"])
        tr = simulate(mech, t_end, t_eval=t_eval)
        if tr.status != "success":
            return {"status": f"mu {mu}: {tr.status}: {tr.message}"}
        F = np.linalg.norm(tr.outputs["S2.normal_force"] + tr.outputs["S2.friction_force"], axis=1)
        out[f"span {mu:g}"] = float(F.max() - F.min())
        law_x = np.array([mod.platform_position(t)[0][0] for t in tr.t])
        out[f"x offset {mu:g}"] = 1e3 * abs(float(np.mean(analysis.series(tr, "platform.x", mech).x - law_x)))
    mech = mechanism000(job["values"], p0.SENS_MU, s["clearance"])
    n = s["transient"] + s["cycles"]
    times = analysis.section_times(T, n, per_period=4)
    tr = simulate(mech, float(times[-1]), t_eval=times)
    if tr.status != "success":
        return {"status": f"mu {p0.SENS_MU}: {tr.status}: {tr.message}"}
    sec = analysis.poincare(tr, T, "S2.eccentricity[1]", skip_transient=s["transient"], mech=mech)
    c = analysis.classify(sec, resolution=analysis.CLEARANCE_FRACTION * s["clearance"], sim_rtol=1e-8,
                          steps_per_period=max(tr.stats.get("steps", n), 1) / n)
    out["kind 0.01"] = c.kind
    out["status"] = "success"
    return out


#: CPU s of one paper 000 design point (quick: 4 + 13 periods x 4 runs, measured ~12 s; full ~20x)
COST_000 = {"quick": 15.0, "full": 300.0}


def paper000_bands(s, executor, budget=None, quick=True):
    """({row key: (lo, hi, what) or (kinds, what)}, table) of paper 000 over reconstructed.yaml."""
    from ..sweeps import run_jobs

    pts = within_budget(design(reconstructed_inputs("000")), COST_000["quick" if quick else "full"], budget)
    got = {}
    run_jobs(_run000, [{"label": lb, "values": v, "s": dict(s)} for lb, v in pts], executor,
             lambda job, res: got.__setitem__(job["label"], res),
             lambda job, exc: got.__setitem__(job["label"], {"status": f"{type(exc).__name__}: {exc}"}))
    ok = {k: v for k, v in got.items() if v.get("status") == "success"}
    n_sf = sum(lb.startswith("space") for lb, _ in pts)
    what = f"{len(ok)} of {len(pts)} input sets ({len(pts) - n_sf} one-at-a-time, {n_sf} space-filling)"
    fields = [k for k in next(iter(ok.values()), {}) if k not in ("status", "kind 0.01")]
    bands = {f: (lo, hi, what) for f, (lo, hi) in spread(ok, fields).items()}
    bands["kind 0.01"] = (sorted({v["kind 0.01"] for v in ok.values()}), what)
    from .paper000 import smallest_spans

    bands["smallest span"] = (sorted({k for v in ok.values() for k in smallest_spans(
        {float(m): v[f"span {m}"] for m in ("0.05", "0.1", "0.15")})}), what)
    cols = ["span 0.05", "span 0.1", "span 0.15", "x offset 0.05", "x offset 0.1", "kind 0.01"]
    rows = [[lb] + [got[lb].get(c, float("nan")) for c in cols] + [got[lb]["status"]] for lb, _ in pts]
    return bands, {"title": "bands (--bands): paper 000's measured quantities over the reconstructed inputs",
                   "columns": ["input set", "force span mu 0.05 [N]", "force span mu 0.1 [N]", "force span mu 0.15 [N]",
                               "X offset mu 0.05 [mm]", "X offset mu 0.1 [mm]", "clearance Y at mu 0.01", "status"],
                   "rows": rows, "note": what + "; the platform joint angles wait for a regenerated model"}
