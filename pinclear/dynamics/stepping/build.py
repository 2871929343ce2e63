"""A run's System from its formulation: the stages of one evaluation, compiled where the plug-ins
declare a compiled form (Formulation contract 7, ForceElement contract 10, compiled drive laws),
Python stages elsewhere.

The evaluation, in order: the drive laws; the formulation's ``before`` stages; Pinocchio's
passes; the placements of the frames the kernels read; zeroing the applied forces; every force
element; the formulation's solve; the drive work meter. Events: the placements (or the
position passes), then every element's event values. Projection: the formulation's.

``loop="python"`` evaluates the whole right-hand side, the events and the projection through
the plug-ins' Python methods (one Python stage each): the reference the compiled stages are
tested against, and the debugging path. The step logic is the same.
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin

from pinclear.core.call import ERROR, NONFINITE, RANK
from pinclear.core.errors import RankLossError
from pinclear.core.jit import njit
from pinclear.core.stage import bind, python_stage
from pinclear.dynamics import energy
from pinclear.dynamics.stepping.system import System, evaluate
from pinclear.model import kinematics, native
from pinclear.model.frames import joint_placements, joint_placements_jacobians


@njit(cache=True)
def zero(x):
    """x = 0 (the applied forces before the elements add theirs)."""
    x[:] = 0.0


class Built:
    """A run's System, its stages (kept alive: they own the buffers' tables) and what runs in
    Python (``python``: names of the Python stages; ``why``: the reason the whole evaluation does)."""

    def __init__(self, system, stages, python, why, channels):
        self.system, self.stages, self.python, self.why, self.channels = system, stages, python, why, channels


class Evaluation:
    """A formulation's right-hand side f(t, x) as a run evaluates it, with the state layout:
    ``pack(q, v, z)`` -> x (a new chart anchored at q on a non-Euclidean tree), ``split(x)``,
    ``f(t, x)`` -> dx. For benchmarks and analysis; a Run holds one."""

    def __init__(self, form, loop="auto"):
        self.form, self.mech = form, form.mech
        # one list for every Python stage's exception: the formulation's (its own drive and
        # projection stages report there too)
        self.errors, self.anchor = form.errors, [None]
        self.built = build(form, loop, self.errors, self.anchor)
        self.system = self.built.system
        self.nc = len(form.ws.x) - self.mech.nv - self.mech.nz

    def pack(self, q, v, z):
        if self.mech.euclidean:
            c = q
        else:
            self.anchor[0] = np.array(q, float)
            c = np.zeros(self.mech.nv)
        return np.concatenate([c, v, z])

    def split(self, x, anchor=None):
        nc, nv = self.nc, self.mech.nv
        c = x[:nc]
        q = c if self.mech.euclidean else pin.integrate(self.mech.model, self.anchor[0] if anchor is None else anchor, c)
        return q, x[nc:nc + nv], x[nc + nv:]

    def __call__(self, t, x):
        """dx = f(t, x); raises what a Python stage raised; returns NaN where the formulation
        reports a rank loss or overflow (see ``code``)."""
        x = np.ascontiguousarray(x, float)
        dx = np.empty(len(x))
        self.code = evaluate(self.system, float(t), x, dx)
        if self.code == ERROR:
            raise self.errors.pop()
        return dx


def _table(stages):
    return np.array([[s.fn, s.ctx] for s in stages], dtype=np.int64).reshape(len(stages), 2)


def event_channels(mech):
    """(element index, channel index, direction) of every event channel, in the run's order."""
    return [(fi, k, d) for fi, f in enumerate(mech.forces) for k, (_, d) in enumerate(f.events)]


def build(form, loop, errors, anchor=None) -> Built:
    """The System of one run of ``form`` (see the module doc). ``errors``: the list a Python
    stage appends its exception to; ``anchor``: the chart's anchor holder of a non-Euclidean
    tree (a one-element list, see Chart)."""
    mech, ws = form.mech, form.ws
    channels = event_channels(mech)
    g = np.zeros(len(channels))
    why = ""
    if loop == "python":
        why = "asked for (loop='python')"
    elif not mech.euclidean:
        why = "configurations on a Lie group other than R^n (free-flyer, spherical or planar joints)"
    elif form.compiled() is None:
        why = f"method {form.name!r} has no compiled form"
    chart = None if mech.euclidean else Chart(mech, ws, anchor)
    if why:
        stages, events, project = _python_stages(form, errors, g, chart)
        python = [s.name for s in stages + events + project]
    else:
        stages, events, project = _compiled_stages(form, errors, g)
        python = [s.name for s in stages + events + project if s.ctx == 0]
    peaks, pval = _peak_stages(form, errors, chart, why)
    python += [s.name for s in peaks if s.ctx == 0]
    crate = chart.rate if chart is not None else np.zeros(0)
    system = System(_table(stages), _table(events), _table(project), ws.x, ws.a, ws.zdot, g, crate,
                    np.zeros(1, dtype=np.int64), ws.lam, np.arange(mech.compiled.m, mech.m, dtype=np.int64),
                    _table(peaks), pval)
    return Built(system, stages + events + project + peaks, python, why, channels)


def _peak_stages(form, errors, chart, why):
    """(stages, buffer): the stages writing each clearance's total normal force at the state
    buffer into the buffer (pinclear.dynamics.stepping.peaks): the position-level placements and joint
    Jacobian, then each joint's force kernel and its sum (ClearanceJoint.peak_kernel); one
    Python stage where the evaluation runs in Python or a joint has no compiled form."""
    mech, ws = form.mech, form.ws
    clr = [i for i, f in enumerate(mech.forces) if f.is_clearance]
    pval = np.zeros(len(clr))
    if not clr:
        return [], pval
    made = [] if why else [mech.forces[i].peak_kernel(mech, ws, ws.force_data[i], ws.z_views[i], ws.zdot_views[i],
                                                      pval, k) for k, i in enumerate(clr)]
    if made and ws.fk.chain is not None and all(m is not None for m in made):
        stages = [bind(joint_placements_jacobians, ws.fk.placement_args(ws.q) + (ws.J6,),
                       name="peaks: placements and joint Jacobians")]
        for i, (force, total) in zip(clr, made):
            stages += [bind(*force, name=f"peaks: force {mech.forces[i].name}"),
                       bind(*total, name=f"peaks: {mech.forces[i].name} normal force")]
        return stages, pval

    def python_peaks(t):
        if chart is not None:
            chart.load(ws.x)
        q, v = ws.q.copy(), ws.v.copy()
        kinematics.update(mech, ws, q, v)
        for k, i in enumerate(clr):
            f = mech.forces[i]
            pval[k] = float(f.outputs(mech, ws, ws.force_data[i], t, q, v, ws.z_views[i].copy())["fn"])
        return np.inf
    return [python_stage(python_peaks, errors, name="contact-force peaks (Python)")], pval


def placements_stage(mech, ws, errors):
    """The stage computing the joint placements the kernels read (ws.fk), after the passes."""
    fk = ws.fk
    if fk.chain is not None:
        return bind(joint_placements, fk.placement_args(ws.q), name="placements")

    def copy_placements(t):
        fk.load_placements(ws.data, ws.q)
        return np.inf
    return python_stage(copy_placements, errors, name="placements (copied from Pinocchio's data)")


def _compiled_stages(form, errors, g):
    mech, ws = form.mech, form.ws
    comp = form.compiled()
    # the drive values first: they depend on t alone, and a formulation's ``before`` stages (the
    # manifold's projection) read them; the formulation's own drive stages report to its errors,
    # the run's list (Evaluation)
    made = [f.force_kernel(mech, ws, d, z, zdot)
            for f, d, z, zdot in zip(mech.forces, ws.force_data, ws.z_views, ws.zdot_views)]
    frames = any(m is None for m in made)          # an element in Python reads data.oMf
    stages = list(form.drive_stages()) + list(comp.before) + [native.passes_stage(mech, ws, comp.mass, errors, frames)]
    if native.available() and comp.placements:
        stages.append(placements_stage(mech, ws, errors))
    if mech.forces:
        stages.append(bind(zero, (ws.tau,), name="zero forces"))
    for fi, (f, d) in enumerate(zip(mech.forces, ws.force_data)):
        z, zdot = ws.z_views[fi], ws.zdot_views[fi]
        if made[fi] is not None:
            stages.append(bind(made[fi][0], made[fi][1], name=f"force {f.name}"))
            continue

        def python_force(t, f=f, d=d, z=z, zdot=zdot):
            f.add_force(mech, ws, d, t, ws.q, ws.v, z, ws.tau, zdot)
            return np.inf
        stages.append(python_stage(python_force, errors, name=f"force {f.name} ({type(f).__name__}.add_force)"))
    stages += list(comp.solve)
    if mech.n_work:
        stages.append(bind(energy.drive_power, (ws.lam, 1, np.arange(mech.m, dtype=np.int64), ws.v,
                                                mech.driverows.iv, mech.compiled.m, ws.zdot, mech.z_work.start),
                           name="drive work meter"))
    events = []
    if len(g):
        if all(f.event_level == "placements" for f in mech.forces if f.events) and ws.fk.chain is not None:
            events.append(bind(joint_placements, ws.fk.placement_args(ws.q), name="placements"))
        else:
            def positions(t):
                kinematics.update_positions(mech, ws, ws.q)
                return np.inf
            events.append(python_stage(positions, errors, name="position passes (events)"))
        k0 = 0
        for fi, (f, d) in enumerate(zip(mech.forces, ws.force_data)):
            if not f.events:
                continue
            gi = g[k0:k0 + len(f.events)]
            k0 += len(f.events)
            made = f.event_kernel(mech, ws, d, gi)
            if made is not None:
                events.append(bind(made[0], made[1], name=f"events {f.name}"))
                continue

            def python_events(t, f=f, d=d, fi=fi, gi=gi):
                gi[:] = f.event_values(mech, ws, d, t, ws.q, ws.v, ws.z_views[fi])
                return np.inf
            events.append(python_stage(python_events, errors, name=f"events {f.name} (Python)"))
    project = list(comp.project)
    if form.supports_projection and not project:
        project = [_python_project(form, errors, None)]
    return stages, events, project


def _python_project(form, errors, chart):
    ws = form.ws

    def python_project(t):
        if chart is not None:
            chart.load(ws.x)
        q, v = form.project(t, ws.q.copy(), ws.v.copy())
        ws.q[:], ws.v[:] = q, v
        if chart is not None:
            chart.store(ws.x)
        return np.inf
    return python_stage(python_project, errors, name=f"{form.name} projection (Python)")


def _python_stages(form, errors, g, chart):
    """One Python stage each for the right-hand side, the events and the projection."""
    mech, ws = form.mech, form.ws

    def python_rhs(t):
        if chart is not None:
            chart.load(ws.x)
        try:
            ws.a[:] = form.accelerations(t, ws.q, ws.v, ws.z)
        except (RankLossError, np.linalg.LinAlgError):
            ws.a[:] = np.nan
            return RANK
        if mech.n_work:
            energy.meter_rates(form, ws.v, ws.zdot)
        return form.code if np.isfinite(ws.a.sum() + ws.zdot.sum()) else NONFINITE
    stages = [python_stage(python_rhs, errors, name=f"{form.name} right-hand side (Python)")]
    events = []
    if len(g):
        def python_events(t):
            if chart is not None:
                chart.load(ws.x)
            q = ws.q.copy()
            kinematics.update_positions(mech, ws, q)
            k0 = 0
            for fi, (f, d) in enumerate(zip(mech.forces, ws.force_data)):
                if f.events:
                    g[k0:k0 + len(f.events)] = f.event_values(mech, ws, d, t, q, ws.v, ws.z_views[fi])
                    k0 += len(f.events)
            return np.inf
        events.append(python_stage(python_events, errors, name="events (Python)"))
    project = [_python_project(form, errors, chart)] if form.supports_projection else []
    return stages, events, project


class Chart:
    """Configurations of a non-Euclidean tree in the state as a chart around an anchor:
    q = pin.integrate(anchor, c), dc/dt = (d integrate / d c)^-1 v. The run moves the anchor
    when |c| grows (pinclear.dynamics.stepping.chunk.CHART_LIMIT)."""

    def __init__(self, mech, ws, anchor):
        self.mech, self.ws, self.anchor = mech, ws, anchor
        self.rate = np.zeros(mech.nv)

    def load(self, x):
        """ws.q from the chart coordinates in x, and the chart's rate."""
        mech, nv = self.mech, self.mech.nv
        c = x[:nv]
        self.ws.q[:] = pin.integrate(mech.model, self.anchor[0], c)
        self.rate[:] = np.linalg.solve(pin.dIntegrate(mech.model, self.anchor[0], c, pin.ARG1), x[nv:2 * nv])

    def store(self, x):
        """The chart coordinates of ws.q into x."""
        x[:self.mech.nv] = pin.difference(self.mech.model, self.anchor[0], self.ws.q)
