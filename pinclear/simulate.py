"""Forward simulation: SciPy's OdeSolver classes stepped one step at a time, so that events
(contact onset/separation) are located, projection can act after accepted steps, a failure
keeps everything computed so far, and configurations stay on Pinocchio's Lie group.

State x = [qc, v, z]: qc is q itself when the tree is Euclidean (revolute/prismatic joints
only); otherwise a chart dq around an anchor, q = pin.integrate(anchor, dq), re-anchored when
|dq| grows, with d(dq)/dt = (d integrate / d dq)^-1 v.
"""
from __future__ import annotations

import bisect
import math

import time
import warnings

import numpy as np
import pinocchio as pin
from scipy.optimize import brentq

from . import energy, fastloop, formulations, integrators, kinematics, validate
from ._jit import compile_cpu
from ._kernels import BRENT_STATE, brent_next, brent_start
from .errors import InputError, RankLossError
from .trajectory import Checkpoint, Trajectory

INTEGRATORS = tuple(integrators.INTEGRATORS)

#: simulate()'s relative tolerance when none is given (bifurcation() derives its period tolerance from it)
RTOL_DEFAULT = 1e-8

#: largest number of output samples a run may ask for (each keeps q, v, a, multipliers, outputs)
MAX_SAMPLES = 2_000_000
#: stall test of adaptive runs: the window of accepted steps whose mean step is compared with
#: ``min_mean_step`` (default STALL_FRACTION of the run's span, at most STALL_MAX seconds, so
#: that a long run's stiff contacts, resolved with steps of ~1e-6 s, never look like a stall)
STALL_STEPS = 1000
STALL_FRACTION = 1e-9
STALL_MAX = 1e-8


class OdeSystem:
    """The ODE right-hand side over the state x = [qc, v, z] for a formulation."""

    def __init__(self, form):
        self.form = form
        mech = form.mech
        self.mech = mech
        self.euclidean = mech.euclidean
        self.zdot = form.ws.zdot
        self.nq_state = mech.nq if mech.euclidean else mech.nv
        self.nv, self.nz = mech.nv, mech.nz
        self.meters = bool(mech.n_work)     # the drive work meter of the energy audit (pinclear.energy)
        self.anchor = None
        self.nfev = 0
        self.bad = 0            # consecutive non-finite evaluations
        self.rank_loss = None   # the RankLossError/LinAlgError of the last evaluation, if any
        self.rejects_nonfinite = False   # the integrator rejects a step on NaN (Integrator contract 4)
        self.strict = False     # raise on the first non-finite evaluation

    def q_of(self, x):
        qc = x[: self.nq_state]
        return qc if self.mech.euclidean else pin.integrate(self.mech.model, self.anchor, qc)

    def pack(self, q, v, z):
        if self.mech.euclidean:
            qc = q
        else:
            self.anchor = q.copy()
            qc = np.zeros(self.nv)
        return np.concatenate([qc, v, z])

    def split(self, x):
        n = self.nq_state
        return self.q_of(x), x[n:n + self.nv], x[n + self.nv:]

    def __call__(self, t, x):
        self.nfev += 1
        n, nv = self.nq_state, self.nv
        v = x[n:n + nv]
        if self.euclidean:
            q, dq = x[:n], v
        else:
            q = pin.integrate(self.mech.model, self.anchor, x[:n])
            dq = np.linalg.solve(pin.dIntegrate(self.mech.model, self.anchor, x[:n], pin.ARG1), v)
        form = self.form
        try:
            a = form.accelerations(t, q, v, x[n + nv:])
        except (RankLossError, np.linalg.LinAlgError) as exc:
            # a trial stage of a too-long step can land on a singular configuration (or a state
            # so wrong its linear algebra fails) that the motion never reaches: reject the step
            # like an overflow. One the steps keep meeting as they shrink is the motion's own;
            # the run then ends with it (simulate).
            if not self.rejects_nonfinite:
                raise
            self.bad += 1
            self.rank_loss = exc
            if self.strict or self.bad > MAX_NONFINITE:
                raise
            return np.full(len(x), np.nan)
        if self.meters:
            energy.meter_rates(form, v, self.zdot)
        if not form.finite(a):
            # a too-long trial step into a stiff contact overflows; SciPy's RK solvers reject it
            # and shrink the step. At a solver's first evaluation, or when it keeps happening, stop
            # (SciPy's initial-step selection would loop forever on NaN).
            self.bad += 1
            if self.strict or self.bad > MAX_NONFINITE:
                raise FloatingPointError(f"at t = {t:.9g} s: {NONFINITE_MESSAGE}")
        elif self.bad:
            self.bad = 0
            self.rank_loss = None
        return np.concatenate((dq, a, self.zdot))


def _check_inputs(t_end, t0, rtol, atol, integ, h, max_step, first_step, t_eval, dt_out):
    if not np.isfinite(t0) or not np.isfinite(t_end) or t_end <= t0:
        raise InputError(f"t_end must be a finite time after t0 = {t0}, got {t_end!r}")
    if integ.adaptive:
        if rtol is None or not RTOL_RANGE[0] <= rtol <= RTOL_RANGE[1]:
            raise InputError(f"rtol must be positive and lie in [{RTOL_RANGE[0]:g}, {RTOL_RANGE[1]:g}], got {rtol!r}")
        if atol is not None and not np.all(np.asarray(atol, float) > 0):
            raise InputError(f"atol must be positive, got {atol!r}")
    if h is not None and not (np.isfinite(h) and h > 0):
        raise InputError(f"step h must be a positive number of seconds, got {h!r}")
    if max_step is not None and not max_step > 0:
        raise InputError(f"max_step must be positive (seconds; inf for no limit), got {max_step!r}")
    if first_step is not None and not (np.isfinite(first_step) and first_step > 0):
        raise InputError(f"first_step must be a positive number of seconds, got {first_step!r}")
    integ.check_options(h=h, max_step=max_step, first_step=first_step)
    if not integ.adaptive and (t_end - t0) / h > MAX_SAMPLES * 50:
        raise InputError(f"RK4 with h = {h:g} s over {t_end - t0:g} s takes {(t_end - t0) / h:.3g} steps; "
                         "give a larger h or a shorter run")
    if dt_out is not None:
        if not (np.isfinite(dt_out) and dt_out > 0):
            raise InputError(f"dt_out must be a positive number of seconds, got {dt_out!r}")
        if (t_end - t0) / dt_out > MAX_SAMPLES:
            raise InputError(f"dt_out = {dt_out:g} s asks for {(t_end - t0) / dt_out:.3g} output samples "
                             f"(at most {MAX_SAMPLES}); give a larger dt_out")
    if t_eval is not None:
        te = np.asarray(t_eval, float)
        slack = 1e-12 * max(1.0, abs(t_end))
        if te.ndim != 1 or len(te) == 0 or not np.all(np.isfinite(te)) or np.any(np.diff(te) < 0) \
                or te[0] < t0 - slack or te[-1] > t_end + slack:
            raise InputError("t_eval must be increasing, finite and inside [t0, t_end]")
        if len(te) > MAX_SAMPLES:
            raise InputError(f"t_eval has {len(te)} samples (at most {MAX_SAMPLES})")


#: rtol outside this range is either below double precision or no error control at all
RTOL_RANGE = (1e-14, 1e-1)


def output_times(t0, t_end, dt_out=None):
    """Default output grid: every dt_out (default 500 intervals), ending exactly at t_end."""
    dt = dt_out or (t_end - t0) / 500
    t_eval = np.append(np.arange(t0, t_end, dt), t_end)
    if len(t_eval) > 1 and t_eval[-1] - t_eval[-2] < 1e-9 * dt:
        t_eval = np.delete(t_eval, -2)
    return t_eval


def initial_state(mech, form, q0=None, v0=None, t0=0.0, assemble=True):
    """Assembled q, consistent v and the force elements' initial internal states."""
    ws = form.ws
    q = np.array(mech.q0 if q0 is None else q0, float)
    v_guess = np.array(mech.v0 if v0 is None else v0, float)
    if q.shape != (mech.nq,) or v_guess.shape != (mech.nv,):
        raise InputError(f"initial state: q needs {mech.nq} and v {mech.nv} numbers, got {q.size} and {v_guess.size}")
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v_guess))):
        raise InputError("initial state: q and v must be finite (found nan or inf)")
    if assemble:
        q = kinematics.assemble(mech, q, t=t0, ws=ws)
        v = kinematics.consistent_velocity(mech, q, v_guess, t=t0, ws=ws)
    else:
        v = v_guess
    kinematics.update(mech, ws, q, v)
    # the elements' states, then the work meter (zero: work counts from the start)
    z = np.concatenate([f.z0(mech, ws, d, q, v) for f, d in zip(mech.forces, ws.force_data)]
                       + [np.zeros(mech.n_work)])
    return q, v, z


def _run_clock() -> float:
    """This process's CPU time less the time numba spent compiling kernels: a run's cpu_s, its
    max_cpu budget and its checkpoint interval count the run, not the once-per-machine compile
    (reported apart as stats['compile_s'], see pinclear._jit)."""
    return time.process_time() - compile_cpu()


def simulate(mech, t_end, method="lagrange", integrator="RK45", rtol=RTOL_DEFAULT, atol=None, t_eval=None,
             dt_out=None, q0=None, v0=None, t0=0.0, max_step=np.inf, h=None, first_step=None,
             assemble=True, strict=False, max_cpu=None, progress=None, checkpoint=None,
             checkpoint_every=None, resume=None, min_mean_step=None, loop="auto", **method_options) -> Trajectory:
    """Integrate the forward dynamics of ``mech`` from t0 to t_end; return a Trajectory.

    method: lagrange | projection | pinocchio | proximal | manifold (see pinclear.formulations).
    integrator: RK45 | DOP853 | Radau | BDF | LSODA | RK4 (fixed step h).
    Output at t_eval, or every dt_out (default 500 intervals). A failure (step-size collapse,
    rank loss, non-finite state, an exception in a user function, max_cpu exceeded) ends the run
    with status 'failed', a message saying when and why, and every sample computed so far;
    KeyboardInterrupt (SIGINT) ends it as 'interrupted', samples kept. strict=True raises
    IntegrationError instead (the trajectory attached).

    min_mean_step: an adaptive run whose last STALL_STEPS (1000) accepted steps average less than
    this (default 1e-9 of t_end - t0, at most 1e-8 s; 0 turns the test off) fails as a step-size
    collapse. SciPy stops only at steps of ~1e-15 t, so a run whose steps shrink onto a
    configuration they cannot pass (a singular passage, a contact law the tolerance cannot
    resolve) would otherwise grind on for hours with steps of 1e-11 s.

    loop: "auto" runs the integration in pinclear's compiled loop when the run allows it
    (pinclear.fastloop: RK45, method lagrange, compiled laws; same steps, same states),
    "python" always steps from Python. ``stats['loop']`` says which ran and why.

    progress: callable(t) for every accepted step (the compiled loop reports the steps of a chunk,
    at most fastloop.CHUNK, in order after it). checkpoint: callable(Checkpoint) every
    ``checkpoint_every`` CPU seconds and when the run ends early; ``resume`` (a Checkpoint)
    continues such a run exactly where it stopped (same steps, same samples).
    """
    integ = integrators.get(integrator)
    if loop not in ("auto", "python"):
        raise InputError(f"loop must be 'auto' or 'python', got {loop!r}", key="loop", choices=("auto", "python"))
    if atol is None:
        atol = rtol * 1e-2 if rtol is not None else None
    _check_inputs(t_end, t0, rtol, atol, integ, h, max_step, first_step, t_eval, dt_out)
    if min_mean_step is not None and not (np.isfinite(min_mean_step) and min_mean_step >= 0):
        raise InputError(f"min_mean_step must be a number of seconds >= 0 (0: no stall test), got {min_mean_step!r}",
                         key="min_mean_step")
    Form = formulations.get(method)
    form = Form(mech, **method_options)
    if form.supports_projection and not integ.corrects_state:
        raise InputError(f"method {method!r} corrects the state after each step, which {integrator}'s internal "
                         "history cannot absorb: use RK45, DOP853, Radau, BDF or RK4")
    compile0 = compile_cpu()
    cpu0 = _run_clock()
    ws = form.ws
    sysf = OdeSystem(form)
    sysf.rejects_nonfinite = integ.rejects_nonfinite
    if resume is not None:
        if not isinstance(resume, Checkpoint):
            raise InputError(f"resume must be a pinclear Checkpoint, got {type(resume).__name__}")
        t0 = validate.number(resume.t0, "<checkpoint>", "t0")
    t_eval = output_times(t0, t_end, dt_out) if t_eval is None else np.asarray(t_eval, float)
    identity = validate.run_identity(mech, method=method, method_options=method_options, integrator=integrator,
                                     rtol=rtol, atol=atol, t0=t0, t_end=t_end, t_eval=t_eval, h=h, max_step=max_step)
    if resume is not None:
        # a checkpoint is data: checked against this mechanism and this run before any
        # compiled code reads it (a wrong-length state would be written out of bounds)
        validate.check_checkpoint(resume, mech, getattr(resume, "path", "<checkpoint>"), identity, ws)
        q, v, z = resume.q, resume.v, resume.z
    else:
        q, v, z = initial_state(mech, form, q0, v0, t0, assemble)
    # redundant rows: found once at the start, dropped by formulations that need a full-rank S
    J = kinematics.jacobian(mech, ws, q, t0, with_drives=True)
    rank, indep, redundant = kinematics.rank_analysis(J, mech.row_names())
    form.use_rows(indep)
    kinematics.update(mech, ws, q, v)

    traj = Trajectory.empty(mech, form, integrator, rtol, atol, t_eval)
    mob = kinematics.mobility(mech, q, ws)
    traj.stats.update(mobility=mob["mobility"], redundant_constraints=len(mob["redundant_rows"]),
                      redundant_rows=mob["redundant_rows"], redundant_rows_with_drives=redundant,
                      closure_condition=mob["condition"])
    stats = traj.stats
    samples = []            # (t, q, v, z) at output times
    out_i = 0
    t_start, x = t0, sysf.pack(q, v, z)
    step_hint = first_step
    if resume is not None:
        samples = list(resume.samples)
        out_i = int(np.searchsorted(t_eval, resume.samples[-1][0], side="right")) if resume.samples else 0
        t_start, x = resume.t, sysf.pack(resume.q_now, resume.v_now, resume.z_now)
        step_hint = resume.h_next
        for k in ("rhs_evals", "steps", "restarts", "cpu_s"):
            stats[k] = resume.stats.get(k, stats.get(k))
        stats["events"] = list(resume.stats.get("events", []))
        stats["resumed_at"] = float(resume.t)
    nfev0, cpu_prior = stats["rhs_evals"], stats["cpu_s"]
    # event channels per force element, evaluated together (one kinematics pass per element)
    events = [(fi, f, np.array([e[1] for e in f.events])) for fi, f in enumerate(mech.forces) if f.events]
    # event values depend on position only (ForceElement contract 7)
    update_for_events = (kinematics.update_placements if all(f.event_level == "placements" for _, f, _ in events)
                         else kinematics.update_positions)

    t_list = t_eval.tolist()          # bisect on a list: a step's output search costs ~0.3 us

    def event_vals(fi, f, t, x):
        q_, v_, z_ = sysf.split(x)
        update_for_events(mech, ws, q_)
        return np.array(f.event_values(mech, ws, ws.force_data[fi], t, q_, v_, z_[mech.z_slices[fi]]), float)

    def all_events(t, x):
        return [event_vals(fi, f, t, x) for fi, f, _ in events]

    def sample(ts, xs):
        """An output sample; projection formulations put it on the manifold like the steps."""
        qs, vs, zs = sysf.split(xs)
        if form.supports_projection:
            qs, vs = form.project(ts, qs, vs)
        return ts, np.array(qs), np.array(vs), np.array(zs)

    def samples_until(dense, i, j):
        """Samples i..j-1 from one call of a step's dense output; returns the next index."""
        if j > i:
            X = dense(t_eval[i:j]).reshape(len(x), -1)
            for k in range(j - i):
                samples.append(sample(t_eval[i + k], X[:, k]))
        return max(i, j)

    atol_solver = atol
    if mech.n_work and integ.adaptive and atol is not None:
        # the drive work meter is a quadrature (nothing depends on it): out of the error test, as
        # CVODES treats quadratures by default. In it, its near-zero start made atol steer the
        # steps, and DOP853's error norm (err5^2 / sqrt(err5^2 + 0.01 err3^2)) shrank with the
        # spiky power's err3, lengthening every step (pinclear.energy)
        atol_solver = np.broadcast_to(np.asarray(atol, float), (sysf.nq_state + mech.nv + mech.nz,)).copy()
        atol_solver[sysf.nq_state + mech.nv + mech.z_work.start] = np.inf

    def make_solver(t_from, x_from, hint=None):
        sysf.strict = True          # a non-finite first evaluation would hang SciPy's step selection
        try:
            return integ.start(sysf if fast is None else fast.fun, t_from, x_from, t_end, rtol=rtol, atol=atol_solver,
                               max_step=max_step, first_step=hint, h=h)
        finally:
            sysf.strict = False

    good = None     # (t, q, v, z, next step, samples, events) after the last completed step

    def rhs_evals():
        return nfev0 + sysf.nfev + (fast.evals if fast is not None else 0)

    def mark_good(solver):
        # every step: keep it cheap (the state is split only when a checkpoint is written)
        nonlocal good
        good = (float(solver.t), solver.y.copy(), sysf.anchor, _next_step(solver), len(samples),
                len(stats["events"]))

    def save_checkpoint():
        """Hand the state after the last completed step to the checkpoint callback; samples or
        events recorded past it (an interrupt inside a step) are dropped so a resume redoes them."""
        if good is None:
            return
        tg, xg, anchor, hg, ns, ne = good
        saved, sysf.anchor = sysf.anchor, anchor
        qg, vg, zg = (np.array(a) for a in sysf.split(xg))
        sysf.anchor = saved
        del samples[ns:]
        del stats["events"][ne:]
        if checkpoint is None:
            return
        stats["rhs_evals"] = rhs_evals()
        stats["cpu_s"] = cpu_prior + _run_clock() - cpu0
        checkpoint(Checkpoint(t0=t0, q=q, v=v, z=z, t=tg, q_now=qg, v_now=vg, z_now=zg, h_next=hg,
                              samples=list(samples), stats=dict(stats, events=list(stats["events"])),
                              identity=identity))

    status, message = "success", "reached t_end"
    h_default = min(STALL_FRACTION * (t_end - t0), STALL_MAX)
    h_stall = (h_default if min_mean_step is None else float(min_mean_step)) if integ.adaptive else 0.0
    why_python = "asked for (loop='python')" if loop == "python" else fastloop.eligible(form, integrator)
    fast, chunk_ts = None, []      # chunk_ts: accepted steps of a compiled chunk not yet reported
    if not why_python:
        try:
            fast = fastloop.build(form, sysf, events, t_eval, h_stall)
        except Exception as exc:     # a defect of the compiled path must not cost the run
            why_python = f"the compiled loop could not be built ({type(exc).__name__}: {exc})"
            warnings.warn(f"pinclear.simulate: {why_python}", RuntimeWarning, stacklevel=2)
    stats["loop"] = "compiled" if not why_python else f"python: {why_python}"
    t_ring, n_acc = np.empty(STALL_STEPS), 0      # solver.t after the last STALL_STEPS accepted steps
    last_ckpt = _run_clock()
    stats["setup_cpu_s"] = last_ckpt - cpu0       # assembly, rank analysis, buffers (not integration)

    def bookkeeping(times):
        """After the accepted steps that reached ``times`` (one step, or a compiled chunk):
        progress, checkpoints, the CPU budget. Returns the failure message when the budget is
        spent."""
        nonlocal last_ckpt
        mark_good(solver)
        if progress is not None:
            stop = False
            for tp in times:
                stop = progress(tp) or stop
            if stop and solver.status == "running":
                raise KeyboardInterrupt     # the caller asked to stop (a signal handler, a GUI)
        now = _run_clock()
        if checkpoint_every is not None and now - last_ckpt >= checkpoint_every and solver.status == "running":
            save_checkpoint()
            last_ckpt = now
        if max_cpu is not None and now - cpu0 > max_cpu and solver.status == "running":
            save_checkpoint()
            return f"stopped at t = {solver.t:.9g} s: CPU budget max_cpu = {max_cpu} s exhausted"
        return None

    def stall_message(t_new, t_back):
        return (f"integrator {integrator} stalled at t = {t_new:.9g} s: its last {STALL_STEPS} steps "
                f"advanced t by {t_new - t_back:.3g} s (mean step below min_mean_step = {h_stall:.3g} s; "
                "step-size collapse: a singular configuration or a contact the tolerance cannot resolve; "
                "try another method, a looser rtol, or Radau/BDF for stiff contact)")

    try:
        solver = make_solver(t_start, x, step_hint)
        while out_i < len(t_eval) and t_eval[out_i] <= t_start + 1e-15:
            samples.append(sample(t_eval[out_i], x.copy()))
            out_i += 1
        ev_prev = all_events(t_start, x)
        mark_good(solver)
        while solver.status == "running":
            t_old = solver.t
            if fast is not None:
                n_before = n_acc
                code, out_j, n_acc, nsteps = fast.advance(solver, out_i, ev_prev, t_ring, n_acc)
                chunk_ts = t_ring[np.arange(n_before, n_acc) % STALL_STEPS].tolist()
                samples.extend(fast.sample_rows(out_i, out_j))
                out_i = out_j
                if code in (fastloop.QUIET, fastloop.FINISHED, fastloop.STALLED):
                    stats["steps"] += nsteps
                    failure = bookkeeping(chunk_ts + ([float(solver.t)] if code == fastloop.STALLED else []))
                    chunk_ts = []
                    if failure:
                        status, message = "failed", failure
                        break
                    if code == fastloop.STALLED:
                        status, message = "failed", stall_message(solver.t, t_ring[n_acc % STALL_STEPS])
                        save_checkpoint()
                        break
                    continue
                # the chunk's last step (or the next one) needs the simulator's own handling
                stats["steps"] += nsteps - 1 if code == fastloop.HANDLE else nsteps
                if code == fastloop.HANDLE:
                    t_old, msg = solver.t_old, None
                else:
                    t_old = solver.t
                    msg = solver.step()
                    if fast.stale():        # the step chose other constraint rows
                        evals, fast = fast.evals, fastloop.build(form, sysf, events, t_eval, h_stall)
                        fast.evals, solver._rhs = evals, fast.fun
            else:
                msg = solver.step()
            if solver.status == "failed":
                if sysf.rank_loss is not None:      # the steps shrank onto a singular configuration
                    raise sysf.rank_loss
                if sysf.bad:                        # ... or onto non-finite accelerations
                    raise FloatingPointError(f"at t = {solver.t:.9g} s: {NONFINITE_MESSAGE}")
                status = "failed"
                h_last = solver.step_size if solver.step_size is not None else float("nan")
                message = (f"integrator {integrator} failed at t = {solver.t:.9g} s: {msg} "
                           f"(step-size collapse, last step {h_last:.3g} s; the problem may be stiff: "
                           "try Radau/BDF, or the contact stiffness/tolerance)")
                break
            stats["steps"] += 1
            t_new = solver.t
            if form.pivot_dip():
                dense_s = solver.dense_output()
                try:
                    _locate_singular_passage(form, sysf, dense_s, t_old, t_new, fast, solver)
                except RankLossError as exc:       # keep the samples before the singular time
                    out_i = samples_until(dense_s, out_i, bisect.bisect_left(t_list, exc.t))
                    raise
            form.reset_pivot_monitor()
            if not math.isfinite(solver.y.sum()):
                status, message = "failed", f"non-finite state at t = {t_new:.9g} s"
                break
            # built on first use: most steps neither cross an event nor reach an output time
            dense = _LazyDense(solver)
            # ---- events: earliest sign change in this step
            hit = None
            if events:
                g_new = all_events(t_new, solver.y)
                for (fi, f, dirs), g0, g1 in zip(events, ev_prev, g_new):
                    for k in _crossings(g0, g1, dirs):
                        te = brentq(lambda s, fi=fi, f=f, k=k: event_vals(fi, f, s, dense(s))[k], t_old, t_new,
                                    xtol=1e-14, rtol=4 * np.finfo(float).eps)
                        if hit is None or te < hit[0]:
                            hit = (te, fi, int(k), f)
                ev_prev = g_new
            t_stop = hit[0] if hit else t_new
            out_i = samples_until(dense, out_i, bisect.bisect_right(t_list, t_stop))
            restart, hint = False, solver.step_size
            if hit:
                te, fi, k, f = hit
                xe = dense(te)
                qe, ve, ze = sysf.split(xe)
                ze = ze.copy()
                kinematics.update(mech, ws, qe, ve)
                sl = mech.z_slices[fi]
                ze[sl] = f.handle_event(k, mech, ws, ws.force_data[fi], te, qe, ve, ze[sl])
                stats["events"].append({"t": float(te), "element": f.name, "event": f.events[k][0]})
                x_restart, t_restart, restart = sysf.pack(qe, ve, ze), te, True
                # an impact changes the time scale: let the integrator choose its first step again
                hint = None
                ev_prev = all_events(te, x_restart)
                # the handled channel sits at zero right after its event: step off it in its sense
                ev_prev[[e[0] for e in events].index(fi)][k] = 0.0
            elif form.supports_projection:
                q1, v1, z1 = sysf.split(solver.y)
                q1, v1 = form.project(t_new, q1, v1)
                x_restart, t_restart = sysf.pack(q1, v1, z1), t_new
                integ.reset_state(solver, sysf, x_restart, t_new)
            elif not mech.euclidean and np.linalg.norm(solver.y[: sysf.nq_state], np.inf) > 0.5:
                q1, v1, z1 = sysf.split(solver.y)
                x_restart, t_restart, restart = sysf.pack(q1, v1, z1), t_new, True
            if restart:
                stats["restarts"] += 1
                if t_restart < t_end:
                    solver = make_solver(t_restart, x_restart, hint)
            failure = bookkeeping(chunk_ts + [float(solver.t)])
            chunk_ts = []
            if failure:
                status, message = "failed", failure
                break
            k = n_acc % STALL_STEPS
            if n_acc >= STALL_STEPS and t_new - t_ring[k] < STALL_STEPS * h_stall and solver.status == "running":
                status, message = "failed", stall_message(t_new, t_ring[k])
                save_checkpoint()
                break
            t_ring[k], n_acc = t_new, n_acc + 1
    except KeyboardInterrupt:
        status = "interrupted"
        save_checkpoint()
        message = (f"interrupted at t = {good[0] if good else t0:.9g} s (SIGINT/SIGTERM); "
                   "continue with simulate(..., resume=checkpoint) / the same pinclear simulate command and "
                   "--resume DIR")
    except RankLossError as exc:
        status, message = "failed", str(exc)
        stats["rank_loss"] = {"t": exc.t, "rank": exc.rank, "rows": exc.rows, "cond": exc.cond}
    except FloatingPointError as exc:
        status, message = "failed", f"integrator {integrator} failed {exc}"
    except np.linalg.LinAlgError as exc:
        status, message = "failed", (f"linear algebra failure (singular matrix) after t = {_last_t(samples, t0):.9g} s: "
                                     f"{exc}")
    except (ZeroDivisionError, OverflowError, ArithmeticError) as exc:
        status, message = "failed", (f"non-finite or invalid value after t = {_last_t(samples, t0):.9g} s: "
                                     f"{type(exc).__name__}: {exc}")
    except Exception as exc:  # a user function (drive law, python hook) raised: keep the samples
        # (a PinclearError too: a trusted law may raise one; the run is not bad input)
        status, message = "failed", (f"a function raised {type(exc).__name__} after t = "
                                     f"{_last_t(samples, t0):.9g} s: {exc}")
    stats["rhs_evals"] = rhs_evals()
    stats["cpu_s"] = cpu_prior + _run_clock() - cpu0
    if form.row_changes:
        stats["row_changes"] = [{"t": tc, "dropped": names} for tc, names in form.row_changes]
    traj.status, traj.message = status, message
    try:
        traj.fill(samples, form)
    except KeyboardInterrupt:
        traj.fill_states(samples)
        traj.status, traj.message = "interrupted", message + " (outputs not evaluated)"
    if traj.status == "success" and integ.adaptive and _check_residual(traj, mech, rtol, atol):
        status, message = traj.status, traj.message
    stats["cpu_s_total"] = _run_clock() - cpu0
    stats["compile_s"] = compile_cpu() - compile0
    if len(traj.t) > 1:
        stats["cpu_per_sim_s"] = stats["cpu_s"] / (traj.t[-1] - traj.t[0])
    if status != "success":
        if strict:
            from .errors import IntegrationError

            raise IntegrationError(traj.message, trajectory=traj)
        warnings.warn(f"pinclear.simulate: {message} ({len(samples)} of {len(t_eval)} samples kept)",
                      RuntimeWarning, stacklevel=2)
    return traj


def _check_residual(traj, mech, rtol, atol):
    """Honest status: a run whose closure residual exceeds the bound its tolerances allow
    (pinclear.validate.residual_bound) ends as failed, samples kept, naming the residual, when it
    first exceeded the bound, and the bound (docs/security.md, 'honest status'). True if so."""
    if not len(traj.t) or not mech.compiled.m:
        return False
    res = np.nan_to_num(traj.residual, nan=0.0)
    bound = validate.residual_bound(mech, rtol, atol, traj.stats.get("steps", 0),
                                    q_scale=float(np.max(np.abs(traj.q), initial=1.0)))
    bound += float(res[0])                 # what the assembly left at the start
    if np.all(res <= bound):
        return False
    k = int(np.argmax(res > bound))
    traj.stats["constraint_violation"] = {"t": float(traj.t[k]), "max_residual": float(res.max()),
                                          "bound": bound}
    traj.status = "failed"
    traj.message = (f"constraint violated: closure residual {res.max():.3g} exceeds {bound:.3g}, the bound "
                    f"rtol = {rtol:g} allows over {traj.stats.get('steps', 0)} steps (first at t = "
                    f"{traj.t[k]:.9g} s); the motion left its constraint manifold (a singular start, a "
                    "huge initial velocity, an ill-conditioned mass matrix?): try method projection or a "
                    f"smaller rtol (samples kept up to t = {traj.t[-1]:.6g} s)")
    return True


def _crossings(g0, g1, dirs):
    """Channels whose event value changed sign in a step, in the sense they watch (direction +1:
    rising, -1: falling, 0: both); plain Python over a handful of channels beats NumPy's calls."""
    out = []
    for k, (a, b, d) in enumerate(zip(g0.tolist(), g1.tolist(), dirs.tolist())):
        if (a < 0 <= b and d >= 0) or (a > 0 >= b and d <= 0):
            out.append(k)
    return out


class _LazyDense:
    """The solver's dense output of its last step, interpolated on first call."""

    __slots__ = ("solver", "interp")

    def __init__(self, solver):
        self.solver, self.interp = solver, None

    def __call__(self, t):
        if self.interp is None:
            self.interp = self.solver.dense_output()
        return self.interp(t)


def _next_step(solver):
    """The step size the solver would try next (so a resumed run takes the same steps)."""
    for name in ("h_abs", "h_fixed"):
        if name in vars(solver):
            return float(vars(solver)[name])
    return solver.step_size


#: consecutive non-finite right-hand sides tolerated (rejected trial steps) before failing
MAX_NONFINITE = 50
NONFINITE_MESSAGE = ("non-finite accelerations (check parameters, stiffness, and that the mass matrix is "
                     "positive definite)")


def _locate_singular_passage(form, sysf, dense, t_old, t_new, fast=None, solver=None):
    """Minimise the pivot ratio along the step's dense output; a rank loss there raises
    RankLossError at its time, instead of letting the step jump branches silently. Every
    evaluation counts as a right-hand side. With the compiled loop (``fast``) the search runs
    compiled and stops at an evaluation Python must take (a rank loss to report, rows to choose
    again); Python takes it, and searches again itself if it did not raise."""
    xatol = 1e-13 * max(1.0, t_new)

    def ratio(s):
        q, v, z = sysf.split(dense(s))
        sysf.nfev += 1
        form.reset_pivot_monitor()
        form.accelerations(s, q, v, z)         # raises RankLossError below the rank threshold
        return form.pivot_ratio()

    if fast is not None:
        s, x, python = fast.locate(solver, xatol)
        if not python:
            return
        if x is not None:                      # the compiled search counted this evaluation
            q, v, z = sysf.split(x)
            form.reset_pivot_monitor()
            form.accelerations(s, q, v, z)
    st = np.empty(BRENT_STATE)
    s, done = brent_start(t_old, t_new, xatol, st), False
    while not done:
        s, done = brent_next(st, ratio(s), fastloop.LOCATE_MAXITER)


def _last_t(samples, t0):
    return samples[-1][0] if samples else t0
