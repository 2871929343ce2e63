"""Forward simulation: ``simulate(mech, t_end, method, integrator, ...)`` -> Trajectory.

simulate checks the inputs, assembles the initial state, and hands the integration to a
pinclear.dynamics.stepping.run.Run: compiled step logic over the run's stages (docs/design.md, "The
stepping engine"). A failure keeps every sample computed so far and says when and why, as text
(``message``) and as data (``failure``: a pinclear.core.failures.Failure(kind, t, detail)).
"""
from __future__ import annotations

import warnings

import numpy as np

from pinclear.core.errors import InputError
from pinclear.core.jit import compile_cpu
from pinclear.dynamics import formulations, stepping, validate
from pinclear.dynamics.stepping.run import Run, checked_method_state, method_state, run_clock
from pinclear.dynamics.stepping.state import EXTERNAL
from pinclear.dynamics.trajectory import Checkpoint, Trajectory
from pinclear.model import kinematics

INTEGRATORS = stepping.INTEGRATORS       # the registry itself (pinclear.core.registry): added ones included
#: simulate()'s relative tolerance when none is given (bifurcation() derives its period tolerance from it)
RTOL_DEFAULT = 1e-8
#: rtol outside this range is either below double precision or no error control at all
RTOL_RANGE = (1e-14, 1e-1)
#: largest number of output samples a run may ask for (each keeps q, v, a, multipliers, outputs)
MAX_SAMPLES = 2_000_000
#: the stall test's default mean step: STALL_FRACTION of the run's span, at most STALL_MAX seconds
#: (a long run's stiff contacts, resolved with steps of ~1e-6 s, never look like a stall)
STALL_FRACTION, STALL_MAX = 1e-9, 1e-8


def _check_inputs(t_end, t0, rtol, atol, integ, h, max_step, first_step, t_eval, dt_out):
    def bad(key, text):
        raise InputError(text, key=key)
    if not np.isfinite(t0) or not np.isfinite(t_end) or t_end <= t0:
        bad("t_end", f"t_end must be a finite time after t0 = {t0}, got {t_end!r}")
    if integ.adaptive:
        if rtol is None or not RTOL_RANGE[0] <= rtol <= RTOL_RANGE[1]:
            bad("rtol", f"rtol must be positive and lie in [{RTOL_RANGE[0]:g}, {RTOL_RANGE[1]:g}], got {rtol!r}")
        if atol is not None and not np.all(np.asarray(atol, float) > 0):
            bad("atol", f"atol must be positive, got {atol!r}")
    if h is not None and not (np.isfinite(h) and h > 0):
        bad("h", f"step h must be a positive number of seconds, got {h!r}")
    if max_step is not None and not max_step > 0:
        bad("max_step", f"max_step must be positive (seconds; inf for no limit), got {max_step!r}")
    if first_step is not None and not (np.isfinite(first_step) and first_step > 0):
        bad("first_step", f"first_step must be a positive number of seconds, got {first_step!r}")
    integ.check_options(h=h, max_step=max_step, first_step=first_step)
    if not integ.adaptive and (t_end - t0) / h > MAX_SAMPLES * 50:
        bad("h", f"RK4 with h = {h:g} s over {t_end - t0:g} s takes {(t_end - t0) / h:.3g} steps; give a larger h "
                 "or a shorter run")
    if dt_out is not None:
        if not (np.isfinite(dt_out) and dt_out > 0):
            bad("dt_out", f"dt_out must be a positive number of seconds, got {dt_out!r}")
        if (t_end - t0) / dt_out > MAX_SAMPLES:
            bad("dt_out", f"dt_out = {dt_out:g} s asks for {(t_end - t0) / dt_out:.3g} output samples (at most "
                          f"{MAX_SAMPLES}); give a larger dt_out")
    if t_eval is not None:
        te = np.asarray(t_eval, float)
        slack = 1e-12 * max(1.0, abs(t_end))
        if te.ndim != 1 or len(te) == 0 or not np.all(np.isfinite(te)) or np.any(np.diff(te) < 0) \
                or te[0] < t0 - slack or te[-1] > t_end + slack:
            bad("t_eval", "t_eval must be increasing, finite and inside [t0, t_end]")
        if len(te) > MAX_SAMPLES:
            bad("t_eval", f"t_eval has {len(te)} samples (at most {MAX_SAMPLES})")


def _check_options(loop, outputs):
    if loop not in ("auto", "python"):
        raise InputError(f"loop must be 'auto' or 'python', got {loop!r}", key="loop", choices=("auto", "python"))
    if outputs not in ("compiled", "python"):
        raise InputError(f"outputs must be 'compiled' or 'python', got {outputs!r}", key="outputs",
                         choices=("compiled", "python"))


def _check_stall(min_mean_step):
    if min_mean_step is not None and not (np.isfinite(min_mean_step) and min_mean_step >= 0):
        raise InputError(f"min_mean_step must be a number of seconds >= 0 (0: no stall test), got {min_mean_step!r}",
                         key="min_mean_step")


def _check_pair(form, integ, method, integrator):
    """A formulation that projects needs an integrator whose state may be corrected."""
    if form.supports_projection and not integ.corrects_state:
        fit = ", ".join(n for n, m in stepping.INTEGRATORS.items() if m.corrects_state)
        raise InputError(f"method {method!r} corrects the state after each step, which {integrator}'s internal "
                         f"history cannot absorb: use one of {fit}", key="integrator")


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
    q = np.array(mech.q0 if q0 is None else q0, float)
    v_guess = np.array(mech.v0 if v0 is None else v0, float)
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


def simulate(mech, t_end, method="lagrange", integrator="RK45", rtol=RTOL_DEFAULT, atol=None, t_eval=None,
             dt_out=None, q0=None, v0=None, t0=0.0, max_step=np.inf, h=None, first_step=None, assemble=True,
             strict=False, max_cpu=None, progress=None, checkpoint=None, checkpoint_every=None, resume=None,
             min_mean_step=None, loop="auto", start=None, fixed_step_tol=validate.FIXED_STEP_TOL,
             outputs="compiled", **method_options) -> Trajectory:
    """Integrate the forward dynamics of ``mech`` from t0 to t_end; return a Trajectory.

    method: lagrange | projection | pinocchio | proximal | manifold (pinclear.dynamics.formulations).
    integrator: RK45 | DOP853 | ROS34PW2 | RK4 (fixed step h) | Radau | BDF | LSODA (SciPy's, stepped
    from Python) (pinclear.dynamics.stepping). Output at t_eval, or every dt_out (default 500 intervals). A
    failure (step-size collapse, rank loss, non-finite state, an exception in a user function,
    max_cpu exceeded) ends the run with status 'failed', a message saying when and why, the same
    as data in ``traj.failure`` and every sample so far; SIGINT ends it as 'interrupted', samples
    kept. strict=True raises IntegrationError instead (the trajectory attached).

    fixed_step_tol: a fixed-step run (RK4) is checked after it ends (pinclear.dynamics.validate.
    check_fixed_step): the same run at 2h gives a step-doubling error estimate, and the estimate,
    the closure residual (relative to the mechanism's size) and the energy audit's error must stay
    below this, else the run fails with its samples kept. None skips the check (and the run at 2h).

    min_mean_step: an adaptive run whose last 1000 accepted steps average less than this (default
    1e-9 of t_end - t0, at most 1e-8 s; 0 turns the test off) fails as a step-size collapse:
    steps shrinking onto a configuration they cannot pass would otherwise grind on for hours.

    loop: "auto" evaluates every plug-in through its compiled stage where it declares one (a
    Python stage otherwise, named in ``stats['loop']``); "python" evaluates the right-hand side
    through the plug-ins' Python methods (the reference; the same step logic).

    outputs: "compiled" records the samples' outputs in one compiled pass where the plug-ins
    allow it; "python" sample by sample through the plug-ins' Python methods (the reference,
    pinclear.dynamics.stepping.outputs).

    progress: callable(t) for every accepted step (reported after each compiled chunk of at most
    pinclear.dynamics.stepping.run.CHUNK steps). checkpoint: callable(Checkpoint) every
    ``checkpoint_every`` CPU seconds and when the run ends early; ``resume`` (a Checkpoint)
    continues such a run exactly where it stopped (same steps, same samples).

    start: the state at t0 (pinclear.model.kinematics.start_state): "ideal" (the default without q0
    and v0: the ideal mechanism's assembled state and velocity, every clearance centred with
    zero relative velocity, as the papers start), "rest", "least-energy" (the clearance
    mechanism's velocity of least kinetic energy: a start-up impact) or "state" (the default
    when q0 or v0 is given: that state, the sidecar's initial q or v for the one not given,
    assembled onto the clearance mechanism's own constraints only, so an off-centre or moving
    journal stays so; :func:`read_state` reads a state from a file). The other starts take q0
    and v0 as the guesses they assemble from. Without clearances all starts but "rest" agree.
    """
    integ = stepping.get(integrator)
    if start is None:
        start = "ideal" if q0 is None and v0 is None else "state"
    if start not in kinematics.STARTS:
        raise InputError(f"unknown start {start!r}", key="start", choices=kinematics.STARTS)
    _check_options(loop, outputs)
    atol = rtol * 1e-2 if atol is None and rtol is not None else atol
    _check_inputs(t_end, t0, rtol, atol, integ, h, max_step, first_step, t_eval, dt_out)
    _check_stall(min_mean_step)
    form = formulations.get(method)(mech, **method_options)
    _check_pair(form, integ, method, integrator)
    compile0, cpu0 = compile_cpu(), run_clock()
    if resume is not None:
        if not isinstance(resume, Checkpoint):
            raise InputError(f"resume must be a pinclear Checkpoint, got {type(resume).__name__}")
        t0 = validate.number(resume.t0, "<checkpoint>", "t0")
    t_eval = output_times(t0, t_end, dt_out) if t_eval is None else np.asarray(t_eval, float)
    identity = validate.run_identity(mech, method=method, method_options=method_options, integrator=integrator,
                                     rtol=rtol, atol=atol, t0=t0, t_end=t_end, t_eval=t_eval, h=h, max_step=max_step)
    if resume is not None:
        # a checkpoint is data: checked against this mechanism and this run before any compiled
        # code reads it (a wrong-length state would be written out of bounds)
        validate.check_checkpoint(resume, mech, resume.path or "<checkpoint>", identity, form.ws)
        q, v, z = resume.q, resume.v, resume.z
    else:
        q, v, z = initial_state(mech, form, q0, v0, t0, assemble, start)
    # redundant rows: found once at the start, dropped by formulations that need a full-rank S
    J = kinematics.jacobian(mech, form.ws, q, t0, with_drives=True)
    _, indep, redundant = kinematics.rank_analysis(J, mech.row_names())
    form.use_rows(indep)
    form.fit_start(t0, q, J, indep, rtol)
    traj = Trajectory.empty(mech, form, integrator, rtol, atol, t_eval)
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
    h_stall = min(STALL_FRACTION * (t_end - t0), STALL_MAX) if min_mean_step is None else float(min_mean_step)
    run = Run(form, integ, t_end=t_end, t_eval=t_eval, rtol=rtol, atol=atol, h=h, max_step=max_step,
              h_stall=h_stall if integ.adaptive else 0.0, loop=loop, stats=stats, identity=identity, progress=progress,
              checkpoint=checkpoint, checkpoint_every=checkpoint_every, max_cpu=max_cpu, t0=t0, initial=(q, v, z),
              cpu0=cpu0)
    if resume is not None:
        run.seed_peaks(resume.stats.get("peaks"))
    stats["loop"] = _loop_note(run)
    if resume is not None and run.tab.kind == EXTERNAL:
        # the checkpoint holds the state, the step size, the elements' states (onset speeds,
        # friction), the events and ROS34PW2's Jacobian; not SciPy's internal history
        stats["resume_note"] = (f"{integrator} (SciPy's) starts afresh at the resume point t = {float(resume.t):.9g} "
                                "s (its history and Jacobian are recomputed there): the continuation is not "
                                "bit-identical to an uninterrupted run")
    stats["setup_cpu_s"] = run_clock() - cpu0          # assembly, rank analysis, stages (not integration)
    resumed_state = None
    if resume is not None:         # the integrator's saved matrices, checked before anything runs
        resumed_state = checked_method_state(run, resume.method_state, resume.path or "<checkpoint>")
        if not resumed_state and method_state(run):
            stats["resume_note"] = (f"the checkpoint holds no {integrator} Jacobian (an older pinclear's): it is "
                                    f"recomputed at t = {float(resume.t):.9g} s and the continuation is not "
                                    "bit-identical to an uninterrupted run")
        res = run.integrate(resume.t, run.pack(resume.q_now, resume.v_now, resume.z_now), resume.h_next,
                            resume.samples, False, reference=outputs == "python", resumed_state=resumed_state)
    else:
        res = run.integrate(t0, run.pack(q, v, z), first_step, [], True, reference=outputs == "python")
    _record(traj, res)
    form.check_run(traj)               # a force the method left unapplied: failed (FailureKind.UNAPPLIED)
    if traj.status == "success" and integ.adaptive:
        validate.check_residual(traj, mech, rtol, atol)
    elif traj.status == "success" and fixed_step_tol is not None and resume is None:
        _check_fixed_step(traj, mech, t_end, dict(method=method, integrator=integrator, t_eval=t_eval, q0=q, v0=v,
                                                  t0=t0, assemble=False, loop=loop, **method_options),
                          h, fixed_step_tol)
    stats["cpu_s_total"] = run_clock() - cpu0
    stats["compile_s"] = compile_cpu() - compile0
    if len(traj.t) > 1:
        stats["cpu_per_sim_s"] = stats["cpu_s"] / (traj.t[-1] - traj.t[0])
    if traj.status != "success":
        if strict:
            from pinclear.core.errors import IntegrationError

            raise IntegrationError(traj.message, trajectory=traj)
        warnings.warn(f"pinclear.simulate: {traj.message} ({len(traj.t)} of {len(t_eval)} samples kept)",
                      RuntimeWarning, stacklevel=2)
    return traj


def _record(traj, res):
    """A Run's result (pinclear.dynamics.stepping.run.RunResult) written into its Trajectory."""
    traj.status, traj.failure = res.status, res.failure
    traj.message = res.failure.detail if res.failure else "reached t_end"
    if res.outputs is None:
        traj.fill_states(res.samples)
        traj.message += " (outputs not evaluated)"
    else:
        traj.write_outputs(res.samples, res.outputs)


#: formulations whose evaluation depends on the state and the kept constraint rows alone (no warm
#: start carried between evaluations, no option fitted to the start state): :class:`Restarts`
#: keeps their workspace and compiled evaluation from one run to the next (tests/analysis/test_lyapunov.py
#: compares its runs with simulate()'s bit for bit). Not proximal (fit_start raises its iteration
#: count from each start, and a kept form keeps the raised count) nor, until a test compares them,
#: the manifold method (its projection reuses the last evaluation's factors: ManifoldWork)
KEEPS_ALIVE = frozenset({"lagrange"})


class Restarts:
    """Many short runs of one mechanism, each restarted from a given state: ``run(t, q, v, z,
    t_end)`` returns the Trajectory sampled at [t, t_end] that ``simulate(mech, t_end, t0=t,
    t_eval=[t, t_end], resume=Checkpoint(t0=t, q=q, v=v, z=z, t=t, q_now=q, v_now=v, z_now=z,
    h_next=None), **options)`` returns, bit for bit (the same first-step choice, steps and
    samples), without that call's set-up on every run (the Benettin loop's renormalisation
    chunks, pinclear.analysis.lyapunov). For a method in KEEPS_ALIVE the options are checked
    once and the formulation, its compiled evaluation and the output pass are built once and
    kept while each start's independent constraint rows (found again at every start, as
    simulate() does) are those they were built for; any other method runs each start through
    simulate(). The states are the caller's own run's, so they are not checked as a checkpoint
    file's are (no identity digest); the statistics are each run's own."""

    #: the options of simulate() a Restarts run takes (the rest are the method's options)
    OPTIONS = ("method", "integrator", "rtol", "atol", "max_step", "h", "loop", "outputs", "min_mean_step", "max_cpu")

    @classmethod
    def unserved(cls, options) -> list:
        """The simulate() options among ``options`` that a Restarts run does not take (a
        progress callback, checkpoints, strict...): such runs go through simulate()."""
        import inspect

        named = inspect.signature(simulate).parameters
        return sorted(k for k in options if k in named and k not in cls.OPTIONS)

    def __init__(self, mech, method="lagrange", integrator="RK45", rtol=RTOL_DEFAULT, atol=None, max_step=np.inf,
                 h=None, loop="auto", outputs="compiled", min_mean_step=None, max_cpu=None, **method_options):
        if self.unserved(method_options):
            raise InputError(f"Restarts: {', '.join(self.unserved(method_options))} not taken (simulate()'s only)",
                             choices=self.OPTIONS)
        self.mech, self.method_options = mech, method_options
        self.options = dict(method=method, integrator=integrator, rtol=rtol, atol=atol, max_step=max_step, h=h,
                            loop=loop, outputs=outputs, min_mean_step=min_mean_step, max_cpu=max_cpu)
        self.keep = method in KEEPS_ALIVE
        if self.keep:                # simulate()'s checks of what does not change from run to run
            self.integ = stepping.get(integrator)
            _check_options(loop, outputs)
            _check_stall(min_mean_step)
            self.atol = rtol * 1e-2 if atol is None and rtol is not None else atol
            self.pieces = self._fresh()

    def _fresh(self):
        """New kept pieces: {"rows": the independent rows they serve (None: not chosen yet),
        "form", "rhs": the Evaluation, "record": the output pass (both made by the first run)}."""
        o = self.options
        form = formulations.get(o["method"])(self.mech, **self.method_options)
        _check_pair(form, self.integ, o["method"], o["integrator"])
        return {"rows": None, "form": form, "rhs": None, "record": None}

    def _start(self, t, q):
        """The kept pieces, the formulation set for a run from (t, q) as simulate() sets a new
        one: its independent rows at q, then its fit; new pieces when the rows are not theirs."""
        mech = self.mech
        for _ in range(2):
            p = self.pieces
            J = kinematics.jacobian(mech, p["form"].ws, q, t, with_drives=True)
            _, indep, _ = kinematics.rank_analysis(J, mech.row_names())
            key = tuple(int(r) for r in indep)
            if p["rows"] in (None, key):
                break
            self.pieces = self._fresh()
        p["rows"] = key
        form = p["form"]
        form.use_rows(indep)
        form.fit_start(t, q, J, indep, self.options["rtol"])
        form.row_changes.clear()      # this run's (stats)
        form.errors.clear()
        return p

    def run(self, t, q, v, z, t_end) -> Trajectory:
        """The run from (t, q, v, z) to t_end, sampled at t and t_end (see the class doc)."""
        o, mech = self.options, self.mech
        if not self.keep:
            ck = Checkpoint(t0=t, q=q, v=v, z=z, t=t, q_now=q, v_now=v, z_now=z, h_next=None)
            return simulate(mech, t_end, t0=t, t_eval=[t, t_end], resume=ck, **o, **self.method_options)
        integ, rtol, atol = self.integ, o["rtol"], self.atol
        t_eval = np.array([t, t_end], float)
        _check_inputs(t_end, t, rtol, atol, integ, o["h"], o["max_step"], None, t_eval, None)
        cpu0 = run_clock()
        p = self._start(t, q)
        form, rhs = p["form"], p["rhs"]
        traj = Trajectory.empty(mech, form, o["integrator"], rtol, atol, t_eval)
        mms = o["min_mean_step"]
        h_stall = min(STALL_FRACTION * (t_end - t), STALL_MAX) if mms is None else float(mms)
        if rhs is not None:
            rhs.system.count[0] = 0                      # this run's evaluations (stats)
        run = Run(form, integ, t_end=t_end, t_eval=t_eval, rtol=rtol, atol=atol, h=o["h"], max_step=o["max_step"],
                  h_stall=h_stall if integ.adaptive else 0.0, loop=o["loop"], stats=traj.stats, identity=None,
                  max_cpu=o["max_cpu"], t0=t, initial=(q, v, z), cpu0=cpu0, rhs=rhs)
        run.record = p["record"]
        res = run.integrate(t, run.pack(q, v, z), None, [], False, reference=o["outputs"] == "python")
        p["rhs"], p["record"] = run.rhs, run.record
        _record(traj, res)
        if traj.status == "success" and integ.adaptive:
            validate.check_residual(traj, mech, rtol, atol)
        return traj


def _check_fixed_step(traj, mech, t_end, kw, h, tol):
    """validate.check_fixed_step with the same run at 2h (its CPU time reported apart)."""
    c0 = run_clock()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        coarse = simulate(mech, t_end, h=2.0 * h, fixed_step_tol=None, **kw)
    validate.check_fixed_step(traj, mech, coarse, h, tol)
    traj.stats.setdefault("fixed_step_check", {})["cpu_s"] = run_clock() - c0


def read_state(path, mech=None):
    """(q, v) of a state file: .npz (arrays q and v; no pickles) or .json ({"q": [...], "v":
    [...]}), one state each; checked against ``mech``'s sizes when given. For
    simulate(..., start="state", q0=q, v0=v) and ``pinclear simulate --start state FILE``."""
    import json
    from pathlib import Path

    from pinclear.core.bounded import read_text_bounded

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


def _loop_note(run) -> str:
    """stats['loop']: how the run's evaluation ran, and what ran in Python (at Python's cost)."""
    b, m = run.built, run.method
    steps = f"; steps taken by SciPy's {m.name} in Python" if m.python_steps else ""
    if b.why:
        return f"python: {b.why}{steps}"
    return ("compiled" if not b.python else f"compiled; python stages: {'; '.join(b.python)}") + steps
