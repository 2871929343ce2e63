"""One integration as an object: the compiled chunks of steps and what only Python does between
them (pinclear.simulate builds a Run and calls :meth:`Run.execute`).

Between chunks Python reports progress, writes checkpoints, watches the CPU budget and handles
what a chunk hands back: an event's effect on the element's internal state (then a restart at
the event), constraint rows to choose again, a new chart anchor, and failures. A failure is kept
as data, ``failure = Failure(kind, t, detail)`` with kind a FailureKind (pinclear.core.failures), next to
its message.
"""
from __future__ import annotations

import time
from typing import Any, NamedTuple

import numpy as np

from pinclear.core.errors import RankLossError
from pinclear.core.failures import Failure, FailureKind
from pinclear.core.jit import compile_cpu
from pinclear.dynamics.stepping import chunk as C
from pinclear.dynamics.stepping.build import Evaluation
from pinclear.dynamics.stepping.checks import reset_monitor
from pinclear.dynamics.stepping.outputs import Outputs, Samples, compiled_outputs, compiled_ready, python_outputs
from pinclear.dynamics.stepping.state import (
    ATOL,
    BAD,
    CHART,
    CODE_BAD,
    DIRS,
    EVENT_K,
    H_ABS,
    H_FIXED,
    H_STALL,
    MAX_STEP,
    N_ACC,
    NI,
    NO_RESELECT,
    NR,
    OUT_I,
    PK_MAX,
    PK_T,
    RTOL,
    STEPS,
    T_BAD,
    T_BOUND,
    T_EVENT,
    XB,
    XE,
    T,
    Y,
    new_steps,
)
from pinclear.dynamics.trajectory import Checkpoint
from pinclear.model import kinematics

#: accepted steps per compiled call; between calls Python looks at progress, checkpoints and
#: the CPU budget (a chunk of a clearance run takes well under a millisecond)
CHUNK = 128
#: without a progress callback a chunk doubles, up to CHUNK_MAX steps, while one takes less than
#: CHUNK_CPU seconds: each return to Python costs ~0.1 ms (1-2 % of a clearance run's integration
#: at 128 steps a chunk, benchmarks/bench_reproduce_runs.md); the budget, checkpoints and an
#: interrupt still come every CHUNK_CPU or so. The steps do not depend on the chunks.
CHUNK_MAX, CHUNK_CPU = 4096, 0.05
#: the stall test's window of accepted steps (pinclear.simulate documents the test)
STALL_STEPS = 1000
NONFINITE_MESSAGE = ("non-finite accelerations (check parameters, stiffness, and that the mass matrix is "
                     "positive definite)")
EPS = np.finfo(float).eps


def run_clock() -> float:
    """This process's CPU time less the time numba spent compiling kernels: a run's cpu_s, its
    max_cpu budget and its checkpoint interval count the run, not the once-per-machine compile
    (reported apart as stats['compile_s'], see pinclear.core.jit)."""
    return time.process_time() - compile_cpu()


def dof_names(model) -> list:
    """A name per velocity coordinate: the joint's, with [k] for a joint of several dofs."""
    names = []
    for j in range(1, model.njoints):
        nv = model.joints[j].nv
        names += [model.names[j]] if nv == 1 else [f"{model.names[j]}[{k}]" for k in range(nv)]
    return names


def peak_names(mech) -> list:
    """(kind, name) of the columns of Steps.pk: the drives, the dofs, the clearances."""
    return ([("drive_forces", d.name) for d in mech.drives] + [("accelerations", n) for n in dof_names(mech.model)]
            + [("contact_forces", f.name) for f in mech.clearances])


class RunResult(NamedTuple):
    """What a Run hands back (Run.integrate): 'success', 'failed' or 'interrupted'; the Failure
    (pinclear.core.failures) or None; the samples (pinclear.dynamics.stepping.outputs.Samples); their outputs
    (pinclear.dynamics.stepping.outputs.Outputs; None when an interrupt stopped them); the statistics; the
    method's own state at the end (pinclear.dynamics.stepping.base.MethodState)."""
    status: str
    failure: Failure | None
    samples: Samples
    outputs: Outputs | None
    stats: dict
    method: Any = None


def failure_of(exc, integrator, t_last) -> Failure:
    """The Failure (kind, t, message) of the exception that ended a run (``t_last``: the time of
    its last sample)."""
    if isinstance(exc, Stop):
        return Failure(exc.kind, exc.t, str(exc))
    if isinstance(exc, RankLossError):
        return Failure(FailureKind.RANK_LOSS, exc.t, str(exc))
    if isinstance(exc, FloatingPointError):
        return Failure(FailureKind.NONFINITE, t_last, f"integrator {integrator} failed {exc}")
    if isinstance(exc, np.linalg.LinAlgError):
        return Failure(FailureKind.SINGULAR, t_last,
                       f"linear algebra failure (singular matrix) after t = {t_last:.9g} s: {exc}")
    if isinstance(exc, ArithmeticError):
        return Failure(FailureKind.NONFINITE, t_last, f"non-finite or invalid value after t = {t_last:.9g} s: "
                                                      f"{type(exc).__name__}: {exc}")
    # a user function (drive law, python hook) raised; a PinclearError too: a trusted law may
    # raise one, the run is not bad input
    return Failure(FailureKind.EXCEPTION, t_last,
                   f"a function raised {type(exc).__name__} after t = {t_last:.9g} s: {exc}")


class Stop(Exception):
    """A failure found by the run itself: (FailureKind, t, message)."""

    def __init__(self, kind, t, message):
        super().__init__(message)
        self.kind, self.t = kind, t


class Run:
    """An integration of ``form``'s mechanism with ``method`` (pinclear.dynamics.stepping.base.Method)."""

    def __init__(self, form, method, *, t_end, t_eval, rtol, atol, h, max_step, h_stall, loop, stats, identity,
                 t0, initial, cpu0, progress=None, checkpoint=None, checkpoint_every=None, max_cpu=None, rhs=None):
        """``t0``, ``initial`` = (q, v, z): the run's start (a resumed run's original one, which its
        checkpoints keep); ``cpu0``: run_clock() when the caller started the run (set-up counts in
        cpu_s_total, not cpu_s); ``stats``: the statistics so far (a resumed run's: its cpu_s and
        rhs_evals continue); ``rhs``: an Evaluation of ``form`` kept from an earlier run
        (pinclear.dynamics.simulate.Restarts), else one is built."""
        self.form, self.mech, self.method = form, form.mech, method
        self.stats, self.identity = stats, identity
        self.t0, self.initial = t0, initial
        self.cpu0, self.cpu_prior, self.evals0 = cpu0, stats["cpu_s"], stats["rhs_evals"]
        self.progress, self.checkpoint, self.checkpoint_every, self.max_cpu = progress, checkpoint, checkpoint_every, max_cpu
        self.rhs = Evaluation(form, loop) if rhs is None else rhs
        self.errors, self.anchor, self.built, self.system = self.rhs.errors, self.rhs.anchor, self.rhs.built, self.rhs.system
        self.pack, self.split = self.rhs.pack, self.rhs.split
        mech, n = self.mech, len(form.ws.x)
        self.nc = self.rhs.nc
        self.t_eval = np.ascontiguousarray(t_eval, float)
        r, i = np.zeros(NR), np.zeros(NI, dtype=np.int64)
        r[T_BOUND], r[MAX_STEP], r[H_STALL] = t_end, np.inf if max_step is None else max_step, h_stall
        r[RTOL] = max(rtol, 100 * EPS) if rtol is not None else 0.0     # as SciPy: tighter only stalls
        r[H_FIXED] = h or 0.0
        i[CHART] = int(not mech.euclidean)
        atol_v = np.ascontiguousarray(np.broadcast_to(np.asarray(0.0 if atol is None else atol, float), (n,)))
        if mech.n_work:
            # the drive work meter is a quadrature (nothing depends on it): out of the error test, as
            # CVODES treats quadratures by default (pinclear.dynamics.energy)
            atol_v[self.nc + mech.nv + mech.z_work.start] = np.inf
        self.st = st = new_steps(n, len(self.built.channels), t_eval, method.rows, method.work, C.SEARCH_STATE,
                                 STALL_STEPS, len(mech.drives) + mech.nv + len(mech.clearances))
        st.r[:] = r
        st.i[:] = i
        st.V[ATOL] = atol_v
        st.G[DIRS] = [float(c[2]) for c in self.built.channels]
        reset_monitor(st.r, *form.monitor())
        #: what the method owns in this run (its coefficients, work array W and driver)
        self.own = method.setup(self)
        self.st = st._replace(W=self.own.W)
        self.tab = self.own.tab
        self.n_collected = 0         # output samples written so far (their rows in st.samples)
        self.record = None           # the compiled output pass's stages, made on first use
        self.good = None             # the state after the last completed chunk (checkpoints)

    # ----------------------------------------------------------------- driving
    def start(self, t, x, hint=None, zero=-1):
        """(Re)start at (t, x): the compiled start (f there, the first step unless SciPy's
        chooses it or ``hint`` gives it, the event values), then the method's restart."""
        code = C.start(self.system, self.tab, self.st, float(t), np.ascontiguousarray(x, float),
                       -1.0 if hint is None else float(hint), int(zero))
        self.method.restart(self.own, self.st, t, x, hint)
        if code != C.QUIET:
            self.fail(code)

    def execute(self, t, x, hint, samples, first, resumed_state=None):
        """Integrate from (t, x) to t_end; ``samples``: those of a resumed run, ``resumed_state``
        its method_state. Raises Stop (or the exception a Python stage raised) on failure; the
        samples so far stay (``samples()``)."""
        st = self.st
        nc, nv = self.nc, self.mech.nv
        self.q_rows = st.samples[:, :nc] if self.mech.euclidean else np.zeros((len(self.t_eval), self.mech.nq))
        for k, (_, q, v, z) in enumerate(samples):
            self.q_rows[k], st.samples[k, nc:nc + nv], st.samples[k, nc + nv:] = q, v, z
        st.i[OUT_I] = self.n_collected = len(samples)
        self.start(t, x, hint)
        if resumed_state:
            self.method.restore_state(self.own, resumed_state)
        if first:
            while st.i[OUT_I] < len(self.t_eval) and self.t_eval[st.i[OUT_I]] <= t + 1e-15:
                st.samples[st.i[OUT_I]] = st.V[Y]
                st.i[OUT_I] += 1
        self.collect()
        self.mark_good()
        self.last_ckpt = clock = run_clock()
        code = C.QUIET if st.r[T] < st.r[T_BOUND] else C.FINISHED
        chunk = CHUNK
        while code != C.FINISHED:
            n_acc, steps = st.i[N_ACC], st.i[STEPS]
            code = C.advance(self.system, self.tab, st, chunk)
            self.stats["steps"] += int(st.i[STEPS] - steps)
            self.collect()
            times = st.ring[np.arange(n_acc, st.i[N_ACC]) % STALL_STEPS].tolist()
            if code == C.EVENT:
                # handled before the bookkeeping: a checkpoint taken now holds the restart at the
                # event (its effect on z applied, the event recorded), never the state at the end
                # of the step past it, which the run itself discards (issue 42: a resume from
                # there lost the event and drifted)
                code = self.handle_event()
            self.bookkeeping(times + ([float(st.r[T])] if code == C.STALLED else []))
            chunk, clock = self.next_chunk(chunk, clock)
            if code == C.ASK_ROWS:
                st.i[NO_RESELECT] = not self.form.reselect_rows(float(st.r[T_BAD]))
            elif code == C.RECHART:
                q, v, z = self.split(st.V[Y])
                self.stats["restarts"] += 1
                self.start(st.r[T], self.pack(q, v, z), st.r[H_ABS])
            elif code not in (C.QUIET, C.FINISHED):
                self.fail(code)

    def next_chunk(self, chunk, clock):
        """(most steps of the next chunk, the clock now) after a chunk that started at ``clock``:
        doubled up to CHUNK_MAX while a chunk takes under CHUNK_CPU, CHUNK with a progress
        callback (which may ask the run to stop: it hears the answer after each chunk)."""
        now = run_clock()
        if self.progress is None and now - clock < CHUNK_CPU:
            chunk = min(2 * chunk, CHUNK_MAX)
        return chunk, now

    def integrate(self, t, x, hint, samples, first, reference=False, resumed_state=None) -> RunResult:
        """The whole run from (t, x) (``execute``'s arguments) as one RunResult: its status and
        failure (every exception of the integration, a user function's included, ends it as
        data, the samples kept; SIGINT as 'interrupted' after a checkpoint), the samples with
        their outputs (``reference``: the per-sample Python path) and the run's statistics."""
        status, failure, stats = "success", None, self.stats
        try:
            self.execute(t, x, hint, samples, first, resumed_state)
        except KeyboardInterrupt:
            self.save_checkpoint()
            t_at = self.good[0] if self.good else t
            status, failure = "interrupted", Failure(FailureKind.INTERRUPTED, t_at, (
                f"interrupted at t = {t_at:.9g} s (SIGINT/SIGTERM); continue with simulate(..., resume=checkpoint) / "
                "the same pinclear simulate command and --resume DIR"))
        except Exception as exc:        # every failure, a user function's exception included: keep the samples
            n = self.n_collected
            status, failure = "failed", failure_of(exc, self.method.name, float(self.t_eval[n - 1]) if n else t)
            if isinstance(exc, RankLossError):
                stats["rank_loss"] = {"t": exc.t, "rank": exc.rank, "rows": exc.rows, "cond": exc.cond}
        stats["rhs_evals"] = self.evaluations()
        stats["cpu_s"] = self.cpu_prior + run_clock() - self.cpu0
        stats.update(self.method.stats(self.own, self.st))
        stats["peaks"] = self.peaks()
        stats["clearances"] = [f.describe() for f in self.mech.clearances]
        if self.form.row_changes:
            stats["row_changes"] = [{"t": tc, "dropped": names} for tc, names in self.form.row_changes]
        kept, outs = self.sample_arrays(), None
        try:
            kept, outs = self.outputs(reference)
        except KeyboardInterrupt:
            status = "interrupted"
            failure = failure or Failure(FailureKind.INTERRUPTED, None, "interrupted while the outputs were evaluated")
        except Exception as exc:
            # a user function raised at a sample on the per-sample Python path (a sample's own
            # numeric failure is kept in Outputs.failures instead): as the integration's, its
            # exception becomes the run's Failure and the samples stay
            if failure is None:
                n = self.n_collected
                status, failure = "failed", failure_of(exc, self.method.name, float(self.t_eval[n - 1]) if n else t)
        return RunResult(status, failure, kept, outs, stats, self.own)

    def collect(self):
        """The configurations of the samples the last chunk wrote: a non-Euclidean tree's rows
        hold chart coordinates around the current anchor, so they are projected (when the
        formulation projects) and mapped to q now; v and z stay in the sample rows."""
        if not self.mech.euclidean:
            for k in range(self.n_collected, int(self.st.i[OUT_I])):
                self.project_row(k)
                self.q_rows[k] = self.split(self.st.samples[k])[0]
        self.n_collected = int(self.st.i[OUT_I])

    def outputs(self, reference=False):
        """(samples, pinclear.dynamics.stepping.outputs.Outputs): the samples as a run's outputs, a
        projecting formulation's moved onto the constraint manifold first, and everything
        recorded at them, in one compiled pass where the run's plug-ins allow it (``reference``:
        the per-sample Python path). After the integration and outside its cpu_s (in
        cpu_s_total): samples never feed back into the steps, so where a run samples more often
        than it steps the projections would otherwise dominate its cost per evaluation (0.5 s of
        3-UPRU+UP: 6 steps, 101 samples). Checkpoints keep the rows as integrated, so a resumed
        run projects exactly as an uninterrupted one. (A non-Euclidean tree's samples are
        projected as they are collected: see collect.)"""
        samples = self.sample_arrays()
        if reference or compiled_ready(self):
            if self.mech.euclidean:
                for k in range(self.n_collected):
                    self.project_row(k)
            return samples, python_outputs(self.form, samples)
        return samples, compiled_outputs(self, self.st.samples[:self.n_collected], samples)

    def peaks(self) -> dict:
        """The run's peaks from the integration (pinclear.dynamics.stepping.peaks) by name: {"drive_forces":
        {drive: {"value", "t"}}, "accelerations": {dof: ...}, "contact_forces": {clearance: ...}};
        None for a quantity no accepted state has shown yet."""
        pk = self.st.pk
        out = {"drive_forces": {}, "accelerations": {}, "contact_forces": {}}
        for j, (kind, name) in enumerate(peak_names(self.mech)):
            out[kind][name] = None if not pk[PK_MAX, j] >= 0.0 else {"value": float(pk[PK_MAX, j]),
                                                                      "t": float(pk[PK_T, j])}
        return out

    def seed_peaks(self, peaks):
        """The peaks of the run a checkpoint continues (``peaks()``'s mapping), so a resumed run
        reports the peaks of the whole run."""
        if not isinstance(peaks, dict):
            return
        pk = self.st.pk
        for j, (kind, name) in enumerate(peak_names(self.mech)):
            rec = (peaks.get(kind) or {}).get(name)
            if isinstance(rec, dict) and isinstance(rec.get("value"), float) and isinstance(rec.get("t"), float):
                pk[PK_MAX, j], pk[PK_T, j] = rec["value"], rec["t"]

    def project_row(self, k):
        """Sample k moved onto the constraint manifold (a no-op without projection stages)."""
        if self.system.project.shape[0] and not C.project(self.system, self.t_eval[k], self.st.samples[k]) >= 0.0:
            q, v, _ = self.split(self.st.samples[k])
            self.form.project(self.t_eval[k], q, v)                # raises the Python path's error

    def sample_arrays(self) -> Samples:
        """The output samples so far as arrays, views of the rows."""
        n, nc, nv = self.n_collected, self.nc, self.mech.nv
        X = self.st.samples[:n]
        return Samples(self.t_eval[:n], self.q_rows[:n], X[:, nc:nc + nv], X[:, nc + nv:])

    def samples(self, n=None):
        """The output samples so far (the first n) as (t, q, v, z) tuples, views of the rows."""
        n = self.n_collected if n is None else n
        X, nc, nv = self.st.samples[:n], self.nc, self.mech.nv
        return list(zip(self.t_eval[:n].tolist(), self.q_rows[:n], X[:, nc:nc + nv], X[:, nc + nv:]))

    def handle_event(self):
        """The event the chunk located: the element's handle_event at its time and state, then a
        restart there (an impact changes the time scale: the first step is chosen anew)."""
        st, mech, ws = self.st, self.mech, self.form.ws
        k, te = int(st.i[EVENT_K]), float(st.r[T_EVENT])
        fi, ch, _ = self.built.channels[k]
        f, sl = mech.forces[fi], mech.z_slices[fi]
        q, v, z = (np.array(a) for a in self.split(st.V[XE]))
        kinematics.update(mech, ws, q, v)
        z[sl] = f.handle_event(ch, mech, ws, ws.force_data[fi], te, q, v, z[sl])
        self.stats["events"].append({"t": te, "element": f.name, "event": f.events[ch][0]})
        self.stats["restarts"] += 1
        if te >= st.r[T_BOUND]:
            return C.FINISHED
        self.start(te, self.pack(q, v, z), None, k)
        return C.QUIET

    # ----------------------------------------------------------------- bookkeeping
    def mark_good(self):
        st = self.st
        self.good = (float(st.r[T]), st.V[Y].copy(), self.anchor[0], float(st.r[H_ABS]), self.n_collected,
                     len(self.stats["events"]), method_state(self))

    def bookkeeping(self, times):
        """After a chunk: progress, checkpoints, the CPU budget (a Stop when spent)."""
        self.mark_good()
        if self.progress is not None:
            stop = False
            for tp in times:
                stop = self.progress(tp) or stop
            if stop:
                raise KeyboardInterrupt       # the caller asked to stop (a signal handler, a GUI)
        now = run_clock()
        if self.checkpoint_every is not None and now - self.last_ckpt >= self.checkpoint_every:
            self.save_checkpoint()
            self.last_ckpt = now
        if self.max_cpu is not None and now - self.cpu0 > self.max_cpu and self.st.r[T] < self.st.r[T_BOUND]:
            self.save_checkpoint()
            raise Stop(FailureKind.BUDGET, float(self.st.r[T]),
                       f"stopped at t = {self.st.r[T]:.9g} s: CPU budget max_cpu = {self.max_cpu} s exhausted")

    def save_checkpoint(self):
        """Hand the state after the last completed chunk to the checkpoint callback; samples or
        events recorded past it (an interrupt inside a chunk's handling) are dropped so a
        resume redoes them."""
        if self.good is None:
            return
        tg, xg, anchor, hg, ns, ne, ms = self.good
        self.n_collected = self.st.i[OUT_I] = ns
        del self.stats["events"][ne:]
        if self.checkpoint is None:
            return
        qg, vg, zg = (np.array(a) for a in self.split(xg, anchor))
        self.stats["rhs_evals"] = self.evaluations()
        self.stats["cpu_s"] = self.cpu_prior + run_clock() - self.cpu0
        self.stats["peaks"] = self.peaks()
        q0, v0, z0 = self.initial
        self.checkpoint(Checkpoint(t0=self.t0, q=q0, v=v0, z=z0, t=tg, q_now=qg, v_now=vg, z_now=zg, h_next=hg,
                                   samples=[(t, q.copy(), v.copy(), z.copy()) for t, q, v, z in self.samples()],
                                   stats=dict(self.stats, events=list(self.stats["events"])),
                                   identity=self.identity, method_state=ms))

    def evaluations(self):
        return self.evals0 + int(self.system.count[0])

    # ----------------------------------------------------------------- failures
    def fail(self, code):
        """Raise what a chunk's failure code means (the Python path's own error where it has one)."""
        st = self.st
        if code == C.PYTHON_ERROR:
            raise self.errors[0]
        t = float(st.r[T])
        if code in (C.START_FAILED, C.BAD_EVALUATIONS, C.RANK_LOSS) or (code == C.STEP_TOO_SMALL and st.i[BAD]):
            self.python_error(float(st.r[T_BAD]), st.V[XB].copy())
        if code == C.STEP_TOO_SMALL:
            msg = getattr(self.own.driver, "message", "") or "Required step size is less than spacing between numbers."
            raise Stop(FailureKind.STEP_SIZE, t,
                       f"integrator {self.method.name} failed at t = {t:.9g} s: {msg} (step-size collapse, last step "
                       f"{st.r[H_ABS]:.3g} s; the problem may be stiff: try ROS34PW2, or the contact stiffness/tolerance)")
        if code == C.STALLED:
            self.save_checkpoint()
            t_back = st.ring[st.i[N_ACC] % STALL_STEPS]
            raise Stop(FailureKind.STEP_SIZE, t,
                       f"integrator {self.method.name} stalled at t = {t:.9g} s: its last {STALL_STEPS} steps "
                       f"advanced t by {t - t_back:.3g} s (mean step below min_mean_step = {st.r[H_STALL]:.3g} s; "
                       "step-size collapse: a singular configuration or a contact the tolerance cannot resolve; "
                       "try another method, a looser rtol, or ROS34PW2 for stiff contact)")
        if code == C.NONFINITE_STATE:
            raise Stop(FailureKind.NONFINITE, t, f"non-finite state at t = {t:.9g} s")
        if code == C.PROJECTION_FAILED:
            q, v, _ = self.split(st.V[Y])
            self.form.project(t, q, v)
            raise Stop(FailureKind.NONFINITE, t, f"the projection onto the constraint manifold failed at t = {t:.9g} s")
        raise Stop(FailureKind.EXCEPTION, t, f"the step logic stopped with code {code} at t = {t:.9g} s")

    def python_error(self, t, x):
        """The Python path's error at a bad evaluation (t, x): a RankLossError or LinAlgError from
        the formulation, else a FloatingPointError for non-finite accelerations."""
        q, v, z = self.split(x)
        if self.st.r[CODE_BAD] != self.st.r[CODE_BAD] or self.st.r[CODE_BAD] >= -1.0:
            self.form.accelerations(t, np.array(q), np.array(v), np.array(z))
        raise FloatingPointError(f"at t = {t:.9g} s: {NONFINITE_MESSAGE}")


# ----------------------------------------------------------------- the method's state in checkpoints
def method_state(run) -> dict:
    """What the integrator carries from one step to the next beyond the state and the step size,
    for checkpoints, so a resumed run takes the same steps (Method.saved_state: ROS34PW2's
    Jacobian)."""
    return run.method.saved_state(run.own)


def checked_method_state(run, state, path="<checkpoint>") -> dict:
    """A checkpoint's method_state checked as data before the run starts (the shapes of this
    run's matrices, finite values, then the method's own check); InputError naming the file
    otherwise. An empty one (a checkpoint of an older pinclear) is accepted: the method then
    starts afresh at the resume point."""
    from pinclear.core.errors import InputError

    if not state:
        return {}
    want = method_state(run)
    shapes = {k: np.shape(v) for k, v in want.items()}
    got = {k: np.shape(v) for k, v in state.items()}
    if shapes != got:
        raise InputError(f"{path}: the integrator's saved state has arrays {got}, this run's {run.method.name} "
                         f"needs {shapes}: the checkpoint does not belong to this run")
    if not all(np.all(np.isfinite(v)) for v in state.values()):
        raise InputError(f"{path}: the integrator's saved state holds nan or inf")
    return run.method.check_saved_state(run.own, state, path)
