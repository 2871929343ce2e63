"""A run's options as one object: :class:`Simulation` checks them once and runs them.

``pinclear.simulate(mech, t_end, ...)`` is ``Simulation(mech, t_end, ...).run()``. The options
(method and its options, integrator, tolerances, start, outputs, CPU budget, checkpoints,
callbacks) are checked here, before anything is computed, with the command line's rules
(pinclear.cli.args: finite numbers, positive where a time or a tolerance is meant); a bad one is
one InputError naming the argument. The rest of the run (Run, Trajectory, the checks after it)
reads the checked values and checks nothing again.
"""
from __future__ import annotations

import json
import math
import numbers
import warnings
from pathlib import Path

import numpy as np

from pinclear.core.bounded import read_text_bounded
from pinclear.core.errors import InputError
from pinclear.core.jit import compile_cpu
from pinclear.dynamics import formulations, stepping, validate
from pinclear.dynamics.stepping.run import Run, checked_method_state, method_state, run_clock
from pinclear.dynamics.stepping.state import EXTERNAL
from pinclear.dynamics.tolerances import RTOL_DEFAULT, RTOL_RANGE, default_atol
from pinclear.dynamics.trajectory import SUMMARY_SCHEMA, Checkpoint, Trajectory
from pinclear.model import kinematics

#: largest number of output samples a run may ask for (each keeps q, v, a, multipliers, outputs)
MAX_SAMPLES = 2_000_000
#: the stall test's default mean step: STALL_FRACTION of the run's span, at most STALL_MAX seconds
#: (a long run's stiff contacts, resolved with steps of ~1e-6 s, never look like a stall)
STALL_FRACTION, STALL_MAX = 1e-9, 1e-8
LOOPS = ("auto", "python")
OUTPUTS = ("compiled", "python")


def _bad(key, text):
    raise InputError(text, key=key)


def real(x, key, what="a finite number", optional=False, check=None):
    """``x`` when it is one real number (int, float, a NumPy scalar or 0-d array; not a bool, a
    text or an array of several) and ``check(x)`` holds; else one InputError naming ``key``."""
    if x is None and optional:
        return None
    if isinstance(x, np.ndarray) and x.ndim == 0:
        x = x[()]
    ok = isinstance(x, numbers.Real) and not isinstance(x, (bool, np.bool_))
    if ok:
        try:
            ok = not math.isnan(x) and (check is None or bool(check(x)))
        except (TypeError, ValueError):
            ok = False
    if not ok:
        _bad(key, f"{key} must be {what}, got {x!r}")
    return x


def _positive(x):
    return math.isfinite(x) and x > 0


class Simulation:
    """One run of ``mech`` from t0 to ``t_end``: the options of :func:`pinclear.simulate` (whose
    docstring describes each), checked when the object is made; :meth:`run` integrates and
    returns the Trajectory. ``t_end=None`` with ``template=True`` checks the options that do not
    depend on the span (pinclear.dynamics.simulate.Restarts: many runs of one set of options);
    :meth:`check_span` checks a span for them."""

    def __init__(self, mech, t_end, method="lagrange", integrator="RK45", rtol=RTOL_DEFAULT, atol=None, t_eval=None,
                 dt_out=None, q0=None, v0=None, t0=0.0, max_step=np.inf, h=None, first_step=None, assemble=True,
                 strict=False, max_cpu=None, progress=None, checkpoint=None, checkpoint_every=None, resume=None,
                 min_mean_step=None, loop="auto", start=None, fixed_step_tol=validate.FIXED_STEP_TOL,
                 outputs="compiled", template=False, **method_options):
        from pinclear.model.mechanism import Mechanism

        if not isinstance(mech, Mechanism):
            _bad("mech", f"mech must be a pinclear Mechanism (pinclear.load(...)), got {type(mech).__name__}")
        self.mech, self.method, self.integrator, self.method_options = mech, method, integrator, method_options
        self.integ = stepping.get(integrator)
        formulations.get(method)          # an unknown name refused before anything else is checked
        if start is None:
            start = "ideal" if q0 is None and v0 is None else "state"
        if start not in kinematics.STARTS:
            raise InputError(f"unknown start {start!r}", key="start", choices=kinematics.STARTS)
        if loop not in LOOPS:
            raise InputError(f"loop must be 'auto' or 'python', got {loop!r}", key="loop", choices=LOOPS)
        if outputs not in OUTPUTS:
            raise InputError(f"outputs must be 'compiled' or 'python', got {outputs!r}", key="outputs",
                             choices=OUTPUTS)
        self.start, self.loop, self.outputs = start, loop, outputs
        self._check_steps(rtol, atol, h, max_step, first_step)
        self.rtol, self.atol = rtol, default_atol(rtol, atol)
        self.h, self.max_step, self.first_step = h, max_step, first_step
        self.min_mean_step = real(min_mean_step, "min_mean_step", "a number of seconds >= 0 (0: no stall test)",
                                  optional=True, check=lambda x: math.isfinite(x) and x >= 0)
        self.max_cpu = real(max_cpu, "max_cpu", "a positive number of CPU seconds (None: no budget)",
                            optional=True, check=_positive)
        # 0: a checkpoint after every compiled chunk (the command line asks for a positive interval)
        self.checkpoint_every = real(checkpoint_every, "checkpoint_every", "a number of CPU seconds >= 0",
                                     optional=True, check=lambda x: math.isfinite(x) and x >= 0)
        tol = real(fixed_step_tol, "fixed_step_tol", "a number >= 0 (0 or None: no check)", optional=True,
                   check=lambda x: math.isfinite(x) and x >= 0)
        self.fixed_step_tol = tol or None
        for key, fn in (("progress", progress), ("checkpoint", checkpoint)):
            if fn is not None and not callable(fn):
                _bad(key, f"{key} must be a callable or None, got {type(fn).__name__}")
        self.progress, self.checkpoint, self.strict = progress, checkpoint, bool(strict)
        if resume is not None and not isinstance(resume, Checkpoint):
            raise InputError(f"resume must be a pinclear Checkpoint, got {type(resume).__name__}")
        self.resume, self.q0, self.v0, self.assemble = resume, q0, v0, assemble
        if template:
            return
        t0 = real(t0, "t0", "a finite time [s]", check=math.isfinite)
        if resume is not None:
            t0 = validate.number(resume.t0, "<checkpoint>", "t0")
        self.t0, self.t_end = t0, self.check_span(t0, t_end, t_eval, dt_out)
        self.t_eval = output_times(t0, self.t_end, dt_out) if t_eval is None else np.asarray(t_eval, float)
        self.form = self.formulation()

    # ------------------------------------------------------------------ checks
    def _check_steps(self, rtol, atol, h, max_step, first_step):
        integ = self.integ
        if integ.adaptive:
            real(rtol, "rtol", f"positive and lie in [{RTOL_RANGE[0]:g}, {RTOL_RANGE[1]:g}]",
                 check=lambda x: RTOL_RANGE[0] <= x <= RTOL_RANGE[1])
            if atol is not None:
                try:
                    a = np.asarray(atol, float)
                except (TypeError, ValueError):
                    a = None
                if a is None or a.ndim > 1 or a.size == 0 or not np.all(a > 0):
                    _bad("atol", f"atol must be positive (a number or one per state component), got {atol!r}")
        elif rtol is not None:
            real(rtol, "rtol", "a number (unused by a fixed-step integrator)")
        real(h, "h", "a positive number of seconds", optional=True, check=_positive)
        real(max_step, "max_step", "positive (seconds; inf for no limit)", optional=True, check=lambda x: x > 0)
        real(first_step, "first_step", "a positive number of seconds", optional=True, check=_positive)
        integ.check_options(h=h, max_step=max_step, first_step=first_step)

    def check_span(self, t0, t_end, t_eval=None, dt_out=None):
        """Check the run's span [t0, t_end] and its output times (t_eval or every dt_out); returns
        t_end (a 0-d array as its number)."""
        if isinstance(t_end, np.ndarray) and t_end.ndim == 0:
            t_end = t_end[()]
        ok = isinstance(t_end, numbers.Real) and not isinstance(t_end, (bool, np.bool_))
        if not ok or not np.isfinite(t0) or not np.isfinite(t_end) or t_end <= t0:
            _bad("t_end", f"t_end must be a finite time after t0 = {t0}, got {t_end!r}")
        h = self.h
        if not self.integ.adaptive and (t_end - t0) / h > MAX_SAMPLES * 50:
            _bad("h", f"RK4 with h = {h:g} s over {t_end - t0:g} s takes {(t_end - t0) / h:.3g} steps; give a larger h "
                      "or a shorter run")
        if dt_out is not None:
            real(dt_out, "dt_out", "a positive number of seconds", check=_positive)
            if (t_end - t0) / dt_out > MAX_SAMPLES:
                _bad("dt_out", f"dt_out = {dt_out:g} s asks for {(t_end - t0) / dt_out:.3g} output samples (at most "
                               f"{MAX_SAMPLES}); give a larger dt_out")
        if t_eval is not None:
            try:
                te = np.asarray(t_eval, float)
            except (TypeError, ValueError):
                te = np.zeros((0, 0))
            slack = 1e-12 * max(1.0, abs(t_end))
            if te.ndim != 1 or len(te) == 0 or not np.all(np.isfinite(te)) or np.any(np.diff(te) < 0) \
                    or te[0] < t0 - slack or te[-1] > t_end + slack:
                _bad("t_eval", "t_eval must be increasing, finite and inside [t0, t_end]")
            if len(te) > MAX_SAMPLES:
                _bad("t_eval", f"t_eval has {len(te)} samples (at most {MAX_SAMPLES})")
        return t_end

    def formulation(self):
        """A new formulation of the run's method with its options, checked against the integrator
        and the tolerances (a projecting method needs a state the integrator lets it correct;
        atol is one number or one per state component)."""
        form = formulations.get(self.method)(self.mech, **self.method_options)
        if form.supports_projection and not self.integ.corrects_state:
            fit = ", ".join(n for n, m in stepping.INTEGRATORS.items() if m.corrects_state)
            raise InputError(f"method {self.method!r} corrects the state after each step, which {self.integrator}'s "
                             f"internal history cannot absorb: use one of {fit}", key="integrator")
        n = len(form.ws.x)
        if self.atol is not None and np.ndim(self.atol) and np.size(self.atol) not in (1, n):
            _bad("atol", f"atol has {np.size(self.atol)} entries; give one number or {n} (one per state component of "
                         f"method {self.method!r}'s state)")
        return form

    def h_stall(self, t0, t_end) -> float:
        """The stall test's mean step (0: off; a fixed-step run has none)."""
        if not self.integ.adaptive:
            return 0.0
        mms = self.min_mean_step
        return min(STALL_FRACTION * (t_end - t0), STALL_MAX) if mms is None else float(mms)

    # ------------------------------------------------------------------ the run
    def make_run(self, form, traj, t0, t_end, t_eval, initial, cpu0, identity=None, rhs=None, callbacks=False) -> Run:
        """A Run (pinclear.dynamics.stepping.run) of these options over [t0, t_end]."""
        cb = {"progress": self.progress, "checkpoint": self.checkpoint,
              "checkpoint_every": self.checkpoint_every} if callbacks else {}
        return Run(form, self.integ, t_end=t_end, t_eval=t_eval, rtol=self.rtol, atol=self.atol, h=self.h,
                   max_step=self.max_step, h_stall=self.h_stall(t0, t_end), loop=self.loop, stats=traj.stats,
                   identity=identity, max_cpu=self.max_cpu, t0=t0, initial=initial, cpu0=cpu0, rhs=rhs, **cb)

    def trajectory(self, form, t_eval) -> Trajectory:
        traj = Trajectory.empty(self.mech, form, self.integrator, self.rtol, self.atol, t_eval)
        traj.meta["schema_version"] = SUMMARY_SCHEMA
        return traj

    def finish(self, traj, res, check_forces=False):
        """A Run's result written into its Trajectory, then (``check_forces``) the formulation's check
        that it applied every constraint force (FailureKind.UNAPPLIED) and the residual check of an
        adaptive run."""
        record(traj, res)
        if check_forces:
            self.form.check_run(traj)
        if traj.status == "success" and self.integ.adaptive:
            validate.check_residual(traj, self.mech, self.rtol, self.atol)

    def run(self) -> Trajectory:
        """Integrate; return the Trajectory (a failure: status 'failed', samples kept, a warning or,
        with strict, IntegrationError)."""
        mech, form, resume, t0, t_end, t_eval = self.mech, self.form, self.resume, self.t0, self.t_end, self.t_eval
        compile0, cpu0 = compile_cpu(), run_clock()
        identity = validate.run_identity(mech, method=self.method, method_options=self.method_options,
                                         integrator=self.integrator, rtol=self.rtol, atol=self.atol, t0=t0,
                                         t_end=t_end, t_eval=t_eval, h=self.h, max_step=self.max_step)
        if resume is not None:
            # a checkpoint is data: checked against this mechanism and this run before any compiled
            # code reads it (a wrong-length state would be written out of bounds)
            validate.check_checkpoint(resume, mech, resume.path or "<checkpoint>", identity, form.ws)
            q, v, z = resume.q, resume.v, resume.z
        else:
            q, v, z = initial_state(mech, form, self.q0, self.v0, t0, self.assemble, self.start)
        # redundant rows: found once at the start, dropped by formulations that need a full-rank S
        J = kinematics.jacobian(mech, form.ws, q, t0, with_drives=True)
        _, indep, redundant = kinematics.rank_analysis(J, mech.row_names())
        form.use_rows(indep)
        form.fit_start(t0, q, J, indep, self.rtol)
        traj = self.trajectory(form, t_eval)
        mob = kinematics.mobility(mech, q, form.ws)
        stats = traj.stats
        stats.update(mobility=mob["mobility"], redundant_constraints=len(mob["redundant_rows"]),
                     redundant_rows=mob["redundant_rows"], redundant_rows_with_drives=redundant,
                     closure_condition=mob["condition"])
        if resume is not None:
            for k in ("rhs_evals", "steps", "restarts", "cpu_s"):
                stats[k] = resume.stats.get(k, stats.get(k))
            stats["events"] = list(resume.stats.get("events", []))
            stats["resumed_at"] = float(resume.t)
        run = self.make_run(form, traj, t0, t_end, t_eval, (q, v, z), cpu0, identity=identity, callbacks=True)
        if resume is not None:
            run.seed_peaks(resume.stats.get("peaks"))
        stats["loop"] = loop_note(run)
        res = self._integrate(run, stats, q, v, z, cpu0)
        self.finish(traj, res, check_forces=True)
        if traj.status == "success" and not self.integ.adaptive and self.fixed_step_tol is not None \
                and resume is None:
            self._check_fixed_step(traj, q, v)
        stats["cpu_s_total"] = run_clock() - cpu0
        stats["compile_s"] = compile_cpu() - compile0
        if len(traj.t) > 1:
            stats["cpu_per_sim_s"] = stats["cpu_s"] / (traj.t[-1] - traj.t[0])
        if traj.status != "success":
            if self.strict:
                from pinclear.core.errors import IntegrationError

                raise IntegrationError(traj.message, trajectory=traj)
            warnings.warn(f"pinclear.simulate: {traj.message} ({len(traj.t)} of {len(t_eval)} samples kept)",
                          RuntimeWarning, stacklevel=3)
        return traj

    def _integrate(self, run, stats, q, v, z, cpu0):
        """The Run from the start, or from the resumed checkpoint (its saved matrices checked first)."""
        resume, integrator, reference = self.resume, self.integrator, self.outputs == "python"
        if resume is not None and run.tab.kind == EXTERNAL:
            # the checkpoint holds the state, the step size, the elements' states (onset speeds,
            # friction), the events and ROS34PW2's Jacobian; not SciPy's internal history
            stats["resume_note"] = (f"{integrator} (SciPy's) starts afresh at the resume point t = "
                                    f"{float(resume.t):.9g} s (its history and Jacobian are recomputed there): the "
                                    "continuation is not bit-identical to an uninterrupted run")
        stats["setup_cpu_s"] = run_clock() - cpu0          # assembly, rank analysis, stages (not integration)
        if resume is None:
            return run.integrate(self.t0, run.pack(q, v, z), self.first_step, [], True, reference=reference)
        resumed_state = checked_method_state(run, resume.method_state, resume.path or "<checkpoint>")
        if not resumed_state and method_state(run):
            stats["resume_note"] = (f"the checkpoint holds no {integrator} Jacobian (an older pinclear's): it is "
                                    f"recomputed at t = {float(resume.t):.9g} s and the continuation is not "
                                    "bit-identical to an uninterrupted run")
        return run.integrate(resume.t, run.pack(resume.q_now, resume.v_now, resume.z_now), resume.h_next,
                             resume.samples, False, reference=reference, resumed_state=resumed_state)

    def _check_fixed_step(self, traj, q, v):
        """validate.check_fixed_step with the same run at 2h (its CPU time reported apart)."""
        c0 = run_clock()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            coarse = Simulation(self.mech, self.t_end, method=self.method, integrator=self.integrator,
                                t_eval=self.t_eval, q0=q, v0=v, t0=self.t0, assemble=False, loop=self.loop,
                                h=2.0 * self.h, fixed_step_tol=None, **self.method_options).run()
        validate.check_fixed_step(traj, self.mech, coarse, self.h, self.fixed_step_tol)
        traj.stats.setdefault("fixed_step_check", {})["cpu_s"] = run_clock() - c0


def record(traj, res):
    """A Run's result (pinclear.dynamics.stepping.run.RunResult) written into its Trajectory."""
    traj.status, traj.failure = res.status, res.failure
    traj.message = res.failure.detail if res.failure else "reached t_end"
    if res.outputs is None:
        traj.fill_states(res.samples)
        traj.message += " (outputs not evaluated)"
    else:
        traj.write_outputs(res.samples, res.outputs)


def output_times(t0, t_end, dt_out=None):
    """Default output grid: every dt_out (default 500 intervals), ending exactly at t_end."""
    dt = dt_out or (t_end - t0) / 500
    t_eval = np.append(np.arange(t0, t_end, dt), t_end)
    if len(t_eval) > 1 and t_eval[-1] - t_eval[-2] < 1e-9 * dt:
        t_eval = np.delete(t_eval, -2)
    return t_eval


def initial_state(mech, form, q0=None, v0=None, t0=0.0, assemble=True, start="ideal"):
    """Assembled q, consistent v (by the named ``start``: pinclear.model.kinematics.start_state) and
    the force elements' initial internal states."""
    ws = form.ws
    try:
        q = np.array(mech.q0 if q0 is None else q0, float)
        v_guess = np.array(mech.v0 if v0 is None else v0, float)
    except (TypeError, ValueError):
        raise InputError(f"initial state: q0 and v0 must be arrays of numbers ({mech.nq} and {mech.nv})",
                         key="q0" if q0 is not None else "v0") from None
    if q.shape != (mech.nq,) or v_guess.shape != (mech.nv,):
        raise InputError(f"initial state: q needs {mech.nq} and v {mech.nv} numbers, got {q.size} and {v_guess.size}")
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v_guess))):
        raise InputError("initial state: q and v must be finite (found nan or inf)")
    if assemble:
        q, v = kinematics.start_state(mech, start, q, v_guess, t=t0, ws=ws)
    else:
        v = v_guess
    kinematics.update(mech, ws, q, v)
    # the elements' states, then the work meter (zero: work counts from the start)
    z = np.concatenate([f.z0(mech, ws, d, q, v) for f, d in zip(mech.forces, ws.force_data)] + [np.zeros(mech.n_work)])
    return q, v, z


def loop_note(run) -> str:
    """stats['loop']: how the run's evaluation ran, and what ran in Python (at Python's cost)."""
    b, m = run.built, run.method
    steps = f"; steps taken by SciPy's {m.name} in Python" if m.python_steps else ""
    if b.why:
        return f"python: {b.why}{steps}"
    return ("compiled" if not b.python else f"compiled; python stages: {'; '.join(b.python)}") + steps


def read_state(path, mech=None):
    """(q, v) of a state file: .npz (arrays q and v; no pickles) or .json ({"q": [...], "v":
    [...]}), one state each; checked against ``mech``'s sizes when given. For
    simulate(..., start="state", q0=q, v0=v) and ``pinclear simulate --start state FILE``."""
    path = Path(path)
    try:
        if path.suffix == ".json":
            # bounded regular file: a FIFO or a device never blocks
            raw = json.loads(read_text_bounded(path, 10_000_000, "start", "state"))
            if not isinstance(raw, dict):
                raise ValueError("expected a mapping with q and v")
            get = raw.get
        elif path.suffix == ".npz":
            arrays = validate.read_npz(path, "state file")             # headers checked before loading
            raw = {k: arrays[k] for k in ("q", "v") if k in arrays}
            get = raw.get
        else:
            raise InputError(f"{path}: a state file is .npz (arrays q, v) or .json ({{\"q\": [...], \"v\": [...]}})",
                             key="start")
        q, v = (None if get(k) is None else np.asarray(get(k), float) for k in ("q", "v"))
    except (OSError, ValueError, TypeError, OverflowError) as exc:     # Overflow: an integer beyond float
        if isinstance(exc, InputError):
            raise
        raise InputError(f"{path}: not a readable state file ({type(exc).__name__}: {exc})", key="start") from None
    for name, arr, n in (("q", q, mech.nq if mech else None), ("v", v, mech.nv if mech else None)):
        if arr is None:
            raise InputError(f"{path}: no {name!r} in the state file (it holds q and v)", key=f"start.{name}")
        if arr.ndim != 1 or (n is not None and arr.size != n) or not np.all(np.isfinite(arr)):
            raise InputError(f"{path}: {name} has shape {arr.shape}; a state file holds one state of "
                             f"{n if n is not None else 'nq/nv'} finite numbers (from a trajectory take one sample, "
                             f"e.g. np.savez('state.npz', q=tr.q[k], v=tr.v[k]))", key=f"start.{name}")
    return q, v
