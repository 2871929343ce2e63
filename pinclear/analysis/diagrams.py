"""Parameter sweeps and bifurcation diagrams over load()'s overrides, in worker processes."""
from __future__ import annotations

import json
import math
import os
import pickle
import sys
import time
import warnings
from concurrent.futures import Executor, ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from pinclear.analysis.classify import Classification, classify
from pinclear.analysis.poincare import PoincareSection, poincare, section_times
from pinclear.analysis.signals import series
from pinclear.analysis.sweeps import MAX_SWEEP_POINTS, make_executor, run_jobs
from pinclear.core.errors import InputError, ModelFileError
from pinclear.core.safeio import savez as atomic_savez


def _parameter_overrides(path, parameter, load_kw):
    """The parameter spec as load() overrides: a key path, a clearance key NAME.key or a scene
    option (pinclear's one parameter language), or a mapping of such keys to factors. Checked by
    loading the mechanism once, which names the file, the key and the valid choices."""
    from pinclear.io.sidecar import load

    items = parameter.items() if isinstance(parameter, dict) else [(parameter, 1.0)]
    out = []
    for spec, factor in items:
        if not isinstance(spec, str):
            raise InputError(f"parameter must be a string key or a mapping key -> factor, got {spec!r}")
        out.append((spec, float(factor)))
    probe = dict(load_kw.get("overrides") or {})
    for spec, _ in out:
        probe.setdefault(spec, _current_value(path, spec))
    load(path, **{**load_kw, "overrides": probe})           # raises on an unknown or inactive key
    return out


def _current_value(path, spec):
    """The value a key currently has (so the validating load changes nothing); None if unknown."""
    from pinclear.io.sidecar import parse_key_path, read_yaml

    doc = read_yaml(path)
    try:
        cur = doc
        for kind, tok in parse_key_path(spec):
            if kind == "key":
                cur = cur[tok]
            elif tok.lstrip("-").isdigit():
                cur = cur[int(tok)]
            else:
                cur = next(e for e in cur if isinstance(e, dict) and e.get("name") == tok)
        return cur
    except (KeyError, IndexError, TypeError, StopIteration, ModelFileError):
        pass
    name, _, key = spec.partition(".")
    for c in doc.get("clearances") or []:
        if isinstance(c, dict) and c.get("name") == name and key in c:
            return c[key]
    opt = (doc.get("options") or {}).get(spec)
    return opt.get("default") if isinstance(opt, dict) else 0.0


def _load_variant(path, overrides, value, load_kw):
    """The mechanism of ``path`` with the parameter set to ``value`` (load()'s overrides)."""
    from pinclear.io.sidecar import load

    ov = dict(load_kw.get("overrides") or {})
    for spec, factor in overrides:
        ov[spec] = value if factor == 1.0 else factor * value
    return load(path, **{**load_kw, "overrides": ov or None})


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

    def lyapunov(self):
        """(values, largest Lyapunov exponents) of the runs that estimated one."""
        pts = [(float(r.value), r.stats["lyapunov"]) for r in self.runs if "lyapunov" in r.stats]
        return (np.array([p for p, _ in pts]), np.array([x for _, x in pts])) if pts else (np.zeros(0), np.zeros(0))

    def table(self, signal=None):
        """One dict per value: value, status, kind, period, K, samples, cpu_s, message."""
        key = self._key(signal)
        rows = []
        for r in self.runs:
            c, sec = r.classifications.get(key), r.sections.get(key)
            rows.append({"value": r.value, "status": r.status, "kind": c.kind if c else None,
                         "period": c.period if c else None, "K": c.K if c else None,
                         "lyapunov": r.stats.get("lyapunov"),
                         "samples": len(sec) if sec is not None else 0,
                         "cpu_s": r.stats.get("cpu_s"), "message": r.message})
        return rows


    # ------------------------------------------------------------------ I/O
    def save(self, path):
        """NPZ: every run's Poincaré samples (and portraits) + JSON metadata (statuses, messages,
        classifications, stats). :meth:`load` reads it back for re-plotting."""
        from pinclear.dynamics.trajectory import jsonable

        path = Path(path)
        path.parent.mkdir(parents=True, exist_ok=True)
        arrays = {"values": np.asarray(self.values, float) if all(is_number(v) for v in self.values)
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
        arrays["meta"] = np.array(json.dumps(jsonable(meta)))
        return atomic_savez(path, arrays)

    @classmethod
    def load(cls, path):
        """A diagram written by :meth:`save`, read as data (pinclear.dynamics.validate: headers and declared
        sizes before loading, no objects); a truncated, oversized or foreign file is an
        InputError naming it, never a traceback."""
        from pinclear.dynamics import validate as V

        arrays = V.read_npz(path, "bifurcation result")
        meta = V.read_meta(arrays, path, "bifurcation result")
        try:
            return cls._from_arrays(arrays, meta)
        except (KeyError, TypeError, ValueError, AttributeError, IndexError) as exc:
            raise V.file_error(path, f"not a readable bifurcation result ({type(exc).__name__}: "
                               f"{' '.join(str(exc).split())[:200]})") from None

    @classmethod
    def _from_arrays(cls, d, meta):
        runs = []
        for m in meta["runs"]:
            i = m["index"]
            secs = {}
            for key, sm in m["sections"].items():
                a = {f: d[f"sec/{i}/{key}/{f}"] for f in ("k", "t", "x", "xdot", "interpolated", "scale")}
                secs[key] = PoincareSection(a["k"], a["t"], a["x"], a["xdot"], sm["period"], sm["phase"], sm["label"],
                                            a["interpolated"], sm["exact_rate"], a["scale"])
            pors = {key: tuple(d[f"por/{i}/{key}/{f}"] for f in ("t", "x", "xdot"))
                    for key in meta["signals"] if f"por/{i}/{key}/t" in d}
            cls_ = {k: Classification(**c) for k, c in m["classifications"].items()}
            runs.append(BifurcationRun(i, m["value"], m["status"], m["message"], secs, pors, m["stats"], cls_))
        values = np.array([r.value for r in runs], dtype=float if all(is_number(r.value) for r in runs) else object)
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
    from pinclear.dynamics.simulate import simulate

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
            mech = _load_variant(job["path"], job["overrides"], value, job["load_kw"])
        T, cyc = job["period"], job["transient"] + job["cycles"]
        t_eval = section_times(T, cyc, job["phase"], job["t0"], job["per_period"])
        if job["lyapunov_at"]:
            return _lyapunov_only(job, mech, float(t_eval[-1]), t_start)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)     # a failed run is reported, not warned
            traj = simulate(mech, float(t_eval[-1]), t_eval=t_eval, t0=job["t0"], **job["sim_kw"])
        sections, portraits = _sections(job, traj, mech)
        stats = {k: traj.stats.get(k) for k in ("cpu_s", "rhs_evals", "steps") if k in traj.stats}
        if job["lyapunov"] and traj.status == "success":
            # the same run's time span, the companion renormalised four times per period
            try:
                lres = _lyapunov(job, mech, float(t_eval[-1]))
                # its 95 % batch-means interval (analysis.lyapunov.batch_means_bound) beside it
                stats["lyapunov"], stats["lyapunov_bound"] = lres.exponent, tuple(lres.bound())
            except Exception as exc:              # reported with the run, the sections are kept
                stats["lyapunov_error"] = f"{type(exc).__name__}: {exc}"
        stats["events"] = len(traj.stats.get("events", []))
        stats["wall_s"] = time.perf_counter() - t_start
        stats["pid"] = os.getpid()
        return BifurcationRun(i, value, "success" if traj.status == "success" else "failed", traj.message,
                              sections, portraits, stats)
    except Exception as exc:                  # every failure is a result, never a lost value
        return BifurcationRun(i, value, "error", f"{type(exc).__name__}: {exc}",
                              stats={"wall_s": time.perf_counter() - t_start, "pid": os.getpid()})


def _sections(job, traj, mech):
    """({signal key: PoincareSection}, {signal key: portrait}) of one run: each signal resolved
    once (signals.series) for both, the signals sharing their frame kinematics (one memo)."""
    sections, portraits, memo = {}, {}, {}
    for sig in job["signals"] if len(traj.t) else ():
        key = signal_key(sig)
        s = series(traj, sig, mech, memo)
        sections[key] = poincare(traj, job["period"], sig, phase=job["phase"], skip_transient=job["transient"],
                                 t0=job["t0"], mech=mech, resolved=s)
        if job["keep_portrait"]:
            keep = s.t >= job["t0"] + job["phase"] + job["transient"] * job["period"] - 1e-9 * job["period"]
            portraits[key] = (s.t[keep], s.x[keep], s.xdot[keep])
    return sections, portraits


def _lyapunov(job, mech, t_end, ends=()):
    """The largest Lyapunov exponent over [0, t_end], the companion renormalised four times per
    period, the transient left out (analysis.lyapunov.mechanism_lyapunov)."""
    from pinclear.analysis.lyapunov import mechanism_lyapunov

    sim = {k: v for k, v in job["sim_kw"].items() if k not in ("max_cpu",)}
    return mechanism_lyapunov(mech, t_end, renorm=job["period"] / 4, transient=job["transient"] * job["period"],
                              ends=ends, **sim)


def _lyapunov_only(job, mech, t_end, t_start):
    """A run of ``lyapunov_at``: only the exponents, no samples. One Benettin loop over the
    longest span gives every shorter span's exponent as its running estimate there
    (analysis.lyapunov.benettin's ends, bit for bit), so the recorded-cycle counts
    share one loop instead of one ordinary run and one loop each. stats['lyapunov_at'] = {n:
    exponent over transient + n periods}, stats['lyapunov_bounds_at'] = {n: (lo, hi)} their 95 %
    intervals, stats['lyapunov'] the longest's; a loop that stops
    keeps the exponents of the spans it finished ('failed', with the reason)."""
    from pinclear.analysis.lyapunov import LyapunovFailed

    T, status, message, stats = job["period"], "success", "", {}
    # each span's end computed as its own run computes it (section_times' last time)
    ends = {n: float(section_times(T, job["transient"] + n, job["phase"], job["t0"], job["per_period"])[-1])
            for n in job["lyapunov_at"]}
    try:
        res = _lyapunov(job, mech, t_end, ends=tuple(ends.values()))
    except LyapunovFailed as exc:
        res, status, message = exc.partial, "failed", f"{type(exc.cause).__name__}: {exc.cause}"
        stats["lyapunov_error"] = message
    stats["lyapunov_at"] = {n: res.ends.get(e, float("nan")) for n, e in ends.items()}
    # each span's 95 % batch-means interval (analysis.lyapunov.batch_means_bound): chaos is decided by its sign
    stats["lyapunov_bounds_at"] = {n: tuple(res.end_bounds.get(e, (float("nan"), float("nan"))))
                                   for n, e in ends.items()}
    if status == "success":
        stats["lyapunov"] = res.exponent
    stats.update(wall_s=time.perf_counter() - t_start, pid=os.getpid())
    return BifurcationRun(job["index"], job["value"], status, message, stats=stats)


def bifurcation(model, parameter, values, period, signal, cycles=100, transient=20, phase=0.0, t0=0.0,
                per_period=8, keep_portrait=False, sim_options=None, load_options=None,
                executor=None, max_workers=None, progress=None, classify_options=None,
                lyapunov=False, lyapunov_at=None) -> BifurcationResult:
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
    lyapunov: also estimate the largest Lyapunov exponent of each value's motion over the same
        span (analysis.mechanism_lyapunov, companion renormalised 4 times per period, the
        transient left out; it costs about two more runs): ``run.stats["lyapunov"]`` (1/s),
        drawn by plot_bifurcation beside the samples, and ``run.stats["lyapunov_bound"]`` its
        95 % interval (lo, hi).
    lyapunov_at: recorded-cycle counts (each <= cycles): the runs then estimate only the
        exponents, without the ordinary run and its samples: one loop over transient + cycles
        periods gives ``run.stats["lyapunov_at"][n]``, the exponent a run of transient + n
        periods reports (the same renormalisations; pinclear.studies.reproduce.chaos checks convergence
        with it).
    Every value yields a BifurcationRun: a run that stops early is 'failed' with its message and
    partial samples, one that cannot start (bad value, assembly error) is 'error'.
    """
    values, sim_kw, load_kw, signals, keys, lyapunov_at = _checked(values, signal, transient, cycles, sim_options,
                                                                   load_options, lyapunov, lyapunov_at)
    periods, bad_period = _periods(values, period)
    base = dict(factory=None, path=None, patches=None, overrides=None, load_kw=load_kw, phase=float(phase),
                t0=float(t0), transient=int(transient), cycles=int(cycles), per_period=int(per_period),
                signals=signals, sim_kw=sim_kw, keep_portrait=bool(keep_portrait), lyapunov=bool(lyapunov),
                lyapunov_at=lyapunov_at)
    if callable(model):
        base["factory"] = model
    else:
        path = Path(model)
        if not path.exists():
            raise ModelFileError(str(path), "path", "no such file")
        if path.suffix.lower() == ".urdf":
            raise InputError(f"bifurcation needs a sidecar (.yaml) whose parameter it can change, got {path}")
        base.update(path=str(path), overrides=_parameter_overrides(path, parameter, load_kw))
    jobs = [dict(base, index=i, value=v, period=T) for i, (v, T) in enumerate(zip(values, periods))
            if i not in bad_period]

    if progress is True:
        def progress(done, total, run):   # noqa: F811 - the default reporter
            why = "" if run.ok else f": {run.message}"
            print(f"bifurcation {done}/{total}: {_label(parameter, run.value)}: {run.status} "
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
    _execute(jobs, executor, max_workers, finish)
    _classify_runs(runs, keys, sim_kw, classify_options, int(transient) + int(cycles))
    numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in values)
    return BifurcationResult(parameter, np.asarray(values, dtype=float if numeric else object), runs, keys,
                             np.asarray(periods))


def _checked(values, signal, transient, cycles, sim_options, load_options, lyapunov, lyapunov_at):
    """bifurcation()'s arguments checked: (values as plain scalars, sim_kw, load_kw, signals, their
    keys, lyapunov_at sorted)."""
    # plain Python scalars: they go into YAML and pickles, and print readably
    values = [v.item() if isinstance(v, np.generic) else v for v in values]
    if not values:
        raise InputError("bifurcation: no parameter values given")
    if len(values) > MAX_SWEEP_POINTS:
        raise InputError(f"bifurcation: {len(values)} parameter values, more than one diagram may have (at most "
                         f"{MAX_SWEEP_POINTS}); split the range")
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
    lyapunov_at = sorted({int(n) for n in lyapunov_at}) if lyapunov_at else []
    if lyapunov_at and not (lyapunov and 1 <= lyapunov_at[0] and lyapunov_at[-1] <= int(cycles)):
        raise InputError(f"lyapunov_at needs lyapunov=True and recorded-cycle counts in 1..{int(cycles)}, got "
                         f"{lyapunov_at}")
    return values, sim_kw, load_kw, signals, keys, lyapunov_at


def _periods(values, period):
    """(each value's period, {index: why its period is unusable}): a callable period's failure is
    that value's, reported with its run; a bad fixed period is an InputError."""
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
    return periods, bad_period


def _execute(jobs, executor, max_workers, finish):
    """Every job through _run_one on ``executor`` (None: a process pool made and shut down here),
    ``finish(run)`` called with each BifurcationRun as it ends."""
    if executor is not None and executor != "serial" and not isinstance(executor, Executor):
        raise InputError(f"executor must be None, 'serial' or a concurrent.futures.Executor, got {executor!r}")
    try:
        if executor is None or isinstance(executor, ProcessPoolExecutor):
            pickle.dumps(jobs[0] if jobs else None)
    except Exception as exc:
        raise InputError(f"bifurcation: the job cannot be sent to worker processes ({exc}); use module-level "
                         "functions for the factory, signal and laws, or executor='serial'") from None
    close = None
    ex = executor
    if ex is None and jobs:
        ex, close = make_executor(max_workers, jobs=len(jobs))
    try:
        run_jobs(_run_one, jobs, ex, lambda job, run: finish(run),
                 lambda job, exc: finish(BifurcationRun(job["index"], job["value"], "error",
                                                        f"{type(exc).__name__}: {exc}")))
    except BaseException:
        if close is not None:           # an interrupt: the workers end now, not after their runs
            close(abort=True)
            close = None
        raise
    finally:
        if close is not None:
            close()


def _classify_runs(runs, keys, sim_kw, classify_options, periods_run):
    """Each run's sections classified (pinclear.analysis.classify), each signal apart;
    ``periods_run``: transient + cycles."""
    copt = dict(classify_options or {})
    fixed_scale = copt.pop("scale", None)
    # "the same point" within the run's own error bound (classify.integration_rtol) unless the
    # caller fixed a tolerance; a fixed-step integrator has no rtol to derive it from
    derive = (not {"rtol", "sim_rtol", "steps_per_period"} & set(copt)
              and sim_kw.get("integrator", "RK45") != "RK4")
    if derive:
        from pinclear.dynamics.simulate import RTOL_DEFAULT as rtol_default
    for r in runs:
        opts = dict(copt)
        if derive and r.stats.get("steps"):
            opts.update(sim_rtol=float(sim_kw.get("rtol", rtol_default)),
                        steps_per_period=r.stats["steps"] / periods_run)
        for key in keys:
            sec = r.sections.get(key)
            r.classifications[key] = classify(sec if sec is not None else np.zeros((0, 2)),
                                              scale=fixed_scale, **opts)

def _label(parameter, value):
    """The point in the user's terms: ``A.clearance = 1e-05, B.clearance = 1e-05`` for a mapping
    of keys to factors, ``S2.mu = 0.1`` for one key."""
    from pinclear.analysis.sweeps import describe_point

    if isinstance(parameter, dict):
        return describe_point({k: value if f == 1.0 else f * value for k, f in parameter.items()})
    return describe_point({str(parameter): value})


def is_number(v):
    try:
        return math.isfinite(float(v))
    except (TypeError, ValueError):
        return False
