"""Forward simulation: ``simulate(mech, t_end, method, integrator, ...)`` -> Trajectory.

simulate is :class:`pinclear.dynamics.simulation.Simulation`'s options checked once, then its
run: the initial state assembled and the integration handed to a
pinclear.dynamics.stepping.run.Run (compiled step logic over the run's stages, docs/design.md,
"The stepping engine"). A failure keeps every sample computed so far and says when and why, as
text (``message``) and as data (``failure``: a pinclear.core.failures.Failure(kind, t, detail)).
"""
from __future__ import annotations

import numpy as np

from pinclear.core.errors import InputError
from pinclear.dynamics import stepping, validate
from pinclear.dynamics.simulation import (  # noqa: F401  (the names simulate's users import from here)
    MAX_SAMPLES,
    STALL_FRACTION,
    STALL_MAX,
    SUMMARY_SCHEMA,
    Simulation,
    initial_state,
    output_times,
    read_state,
)
from pinclear.dynamics.stepping.run import run_clock
from pinclear.dynamics.tolerances import RTOL_DEFAULT, RTOL_RANGE, default_atol  # noqa: F401
from pinclear.dynamics.trajectory import Checkpoint, Trajectory
from pinclear.model import kinematics

INTEGRATORS = stepping.INTEGRATORS       # the registry itself (pinclear.core.registry): added ones included


def simulate(mech, t_end, method="lagrange", integrator="RK45", rtol=RTOL_DEFAULT, atol=None, t_eval=None,
             dt_out=None, q0=None, v0=None, t0=0.0, max_step=np.inf, h=None, first_step=None, assemble=True,
             strict=False, max_cpu=None, progress=None, checkpoint=None, checkpoint_every=None, resume=None,
             min_mean_step=None, loop="auto", start=None, fixed_step_tol=validate.FIXED_STEP_TOL,
             outputs="compiled", **method_options) -> Trajectory:
    """Integrate the forward dynamics of ``mech`` from t0 to t_end; return a Trajectory.

    Every option is checked before anything is computed; a bad one raises one InputError
    naming it. A failure (step-size collapse, rank loss, non-finite state, an exception in a
    user function, max_cpu exceeded) ends the run with status 'failed', a message saying when
    and why, the same as data in ``traj.failure`` and every sample so far; SIGINT ends it as
    'interrupted', samples kept.

    Parameters
    ----------
    mech : Mechanism
        The mechanism (``pinclear.load(...)``).
    t_end : float
        End time [s], after t0.
    method : str
        Formulation: lagrange | projection | pinocchio | proximal | manifold, or a registered one
        (pinclear.dynamics.formulations).
    integrator : str
        RK45 | DOP853 | ROS34PW2 | RK4 (fixed step ``h``) | Radau | BDF | LSODA (SciPy's, stepped
        from Python), or a registered one (pinclear.core.registry.INTEGRATORS).
    rtol, atol : float, float or array, optional
        Tolerances of the adaptive integrators; rtol in RTOL_RANGE; atol defaults to
        :func:`pinclear.dynamics.tolerances.default_atol` (rtol x 1e-2), else one positive number
        or one per state component.
    t_eval : array, optional
        Output times, increasing, inside [t0, t_end]. Default: every ``dt_out``.
    dt_out : float, optional
        Output interval [s] (default: 500 intervals).
    q0, v0 : array, optional
        Initial configuration (nq) and velocity (nv), or the guesses the start assembles from.
    t0 : float
        Start time [s].
    max_step, h, first_step : float, optional
        Largest step (inf: none), the fixed step of RK4, the first step of an adaptive run [s].
    assemble : bool
        Assemble (q0, v0) onto the constraints by ``start``; False takes them as they are.
    strict : bool
        Raise IntegrationError (the trajectory attached) instead of returning a failed run.
    max_cpu : float, optional
        CPU budget [s] of the integration, compilation excluded: past it the run fails, samples
        kept.
    progress : callable, optional
        ``progress(t)`` for every accepted step (reported after each compiled chunk of at most
        pinclear.dynamics.stepping.run.CHUNK steps); a true return value stops the run as
        interrupted.
    checkpoint, checkpoint_every : callable, float, optional
        ``checkpoint(Checkpoint)`` every ``checkpoint_every`` CPU seconds and when the run ends
        early.
    resume : Checkpoint, optional
        Continue such a run exactly where it stopped (same steps, same samples).
    min_mean_step : float, optional
        An adaptive run whose last 1000 accepted steps average less than this (default 1e-9 of
        t_end - t0, at most 1e-8 s; 0 turns the test off) fails as a step-size collapse: steps
        shrinking onto a configuration they cannot pass would otherwise grind on for hours.
    loop : {"auto", "python"}
        "auto" evaluates every plug-in through its compiled stage where it declares one (a
        Python stage otherwise, named in ``stats['loop']``); "python" through the plug-ins'
        Python methods (the reference; the same step logic).
    start : str, optional
        The state at t0 (pinclear.model.kinematics.start_state): "ideal" (the default without q0
        and v0: the ideal mechanism's assembled state and velocity, every clearance centred with
        zero relative velocity, as the papers start), "rest", "least-energy" (the clearance
        mechanism's velocity of least kinetic energy: a start-up impact) or "state" (the default
        when q0 or v0 is given: that state, the sidecar's initial q or v for the one not given,
        assembled onto the clearance mechanism's own constraints only, so an off-centre or
        moving journal stays so; :func:`read_state` reads one from a file). Without clearances
        all starts but "rest" agree.
    fixed_step_tol : float, optional
        A fixed-step run (RK4) is checked after it ends (pinclear.dynamics.validate.
        check_fixed_step): the same run at 2h gives a step-doubling error estimate, and the
        estimate, the closure residual (relative to the mechanism's size) and the energy audit's
        error must stay below this, else the run fails with its samples kept. None or 0 skips
        the check (and the run at 2h).
    outputs : {"compiled", "python"}
        Record the samples' outputs in one compiled pass where the plug-ins allow it, or sample
        by sample through the plug-ins' Python methods (the reference,
        pinclear.dynamics.stepping.outputs).
    **method_options
        The formulation's own options (e.g. projection's alpha, beta).

    Returns
    -------
    Trajectory
        Samples, outputs, statistics and the status of the run (``traj.meta["schema_version"]`` is
        SUMMARY_SCHEMA).
    """
    return Simulation(mech, t_end, method=method, integrator=integrator, rtol=rtol, atol=atol, t_eval=t_eval,
                      dt_out=dt_out, q0=q0, v0=v0, t0=t0, max_step=max_step, h=h, first_step=first_step,
                      assemble=assemble, strict=strict, max_cpu=max_cpu, progress=progress, checkpoint=checkpoint,
                      checkpoint_every=checkpoint_every, resume=resume, min_mean_step=min_mean_step, loop=loop,
                      start=start, fixed_step_tol=fixed_step_tol, outputs=outputs, **method_options).run()


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
        # the options checked once (the span of each run is checked by each run)
        self.sim = Simulation(mech, None, template=True, **self.options, **method_options)
        self.keep = method in KEEPS_ALIVE
        if self.keep:
            self.pieces = self._fresh()

    def _fresh(self):
        """New kept pieces: {"rows": the independent rows they serve (None: not chosen yet),
        "form", "rhs": the Evaluation, "record": the output pass (both made by the first run)}."""
        return {"rows": None, "form": self.sim.formulation(), "rhs": None, "record": None}

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
        form.fit_start(t, q, J, indep, self.sim.rtol)
        form.row_changes.clear()      # this run's (stats)
        form.errors.clear()
        return p

    def run(self, t, q, v, z, t_end) -> Trajectory:
        """The run from (t, q, v, z) to t_end, sampled at t and t_end (see the class doc)."""
        sim = self.sim
        if not self.keep:
            ck = Checkpoint(t0=t, q=q, v=v, z=z, t=t, q_now=q, v_now=v, z_now=z, h_next=None)
            return simulate(self.mech, t_end, t0=t, t_eval=[t, t_end], resume=ck, **self.options,
                            **self.method_options)
        t_eval = np.array([t, t_end], float)
        t_end = sim.check_span(t, t_end, t_eval)
        cpu0 = run_clock()
        p = self._start(t, q)
        form, rhs = p["form"], p["rhs"]
        traj = sim.trajectory(form, t_eval)
        if rhs is not None:
            rhs.system.count[0] = 0                      # this run's evaluations (stats)
        run = sim.make_run(form, traj, t, t_end, t_eval, (q, v, z), cpu0, rhs=rhs)
        run.record = p["record"]
        res = run.integrate(t, run.pack(q, v, z), None, [], False, reference=sim.outputs == "python")
        p["rhs"], p["record"] = run.rhs, run.record
        sim.finish(traj, res)
        return traj
