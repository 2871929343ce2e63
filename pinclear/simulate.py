"""Forward simulation: SciPy's OdeSolver classes stepped one step at a time, so that events
(contact onset/separation) are located, projection can act after accepted steps, a failure
keeps everything computed so far, and configurations stay on Pinocchio's Lie group.

State x = [qc, v, z]: qc is q itself when the tree is Euclidean (revolute/prismatic joints
only); otherwise a chart dq around an anchor, q = pin.integrate(anchor, dq), re-anchored when
|dq| grows, with d(dq)/dt = (d integrate / d dq)^-1 v.
"""
from __future__ import annotations

import time
import warnings

import numpy as np
import pinocchio as pin
from scipy import integrate as spi
from scipy.optimize import brentq

from . import formulations, kinematics
from .errors import InputError, PinclearError, RankLossError
from .trajectory import Trajectory

INTEGRATORS = ("RK45", "DOP853", "Radau", "BDF", "LSODA", "RK4")
_SCIPY = {"RK45": spi.RK45, "DOP853": spi.DOP853, "Radau": spi.Radau, "BDF": spi.BDF, "LSODA": spi.LSODA}


class _HermiteDense(spi.DenseOutput):
    """Cubic Hermite interpolant over one step (for the fixed-step RK4)."""

    def __init__(self, t0, t1, y0, y1, f0, f1):
        super().__init__(t0, t1)
        self.h, self.y0, self.y1, self.f0, self.f1 = t1 - t0, y0, y1, f0, f1

    def _call_impl(self, t):
        s = (np.asarray(t) - self.t_old) / self.h
        h00, h10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
        h01, h11 = -2 * s**3 + 3 * s**2, s**3 - s**2
        y = (np.multiply.outer(self.y0, h00) + np.multiply.outer(self.f0 * self.h, h10)
             + np.multiply.outer(self.y1, h01) + np.multiply.outer(self.f1 * self.h, h11))
        return y


class RK4(spi.OdeSolver):
    """Classical fixed-step Runge-Kutta 4 in SciPy's OdeSolver interface."""

    def __init__(self, fun, t0, y0, t_bound, h=1e-3, vectorized=False, **_):
        super().__init__(fun, t0, y0, t_bound, vectorized)
        if not h or h <= 0:
            raise InputError(f"RK4 needs a positive step h, got {h!r}")
        self.h_fixed = float(h)
        self.f = self.fun(self.t, self.y)
        self._prev = None

    def _step_impl(self):
        t, y, h = self.t, self.y, min(self.h_fixed, abs(self.t_bound - self.t))
        k1 = self.f
        k2 = self.fun(t + h / 2, y + h / 2 * k1)
        k3 = self.fun(t + h / 2, y + h / 2 * k2)
        k4 = self.fun(t + h, y + h * k3)
        y1 = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        f1 = self.fun(t + h, y1)
        self._prev = (t, t + h, y, y1, k1, f1)
        self.t, self.y, self.f = t + h, y1, f1
        return True, None

    def _dense_output_impl(self):
        return _HermiteDense(*self._prev)


class _System:
    """The ODE right-hand side over the state x = [qc, v, z] for a formulation."""

    def __init__(self, form):
        self.form = form
        mech = form.mech
        self.mech = mech
        self.nq_state = mech.nq if mech.euclidean else mech.nv
        self.nv, self.nz = mech.nv, mech.nz
        self.anchor = None
        self.nfev = 0
        self.bad = 0            # consecutive non-finite evaluations
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
        if self.mech.euclidean:
            q, dq = x[:n], v
        else:
            q = pin.integrate(self.mech.model, self.anchor, x[:n])
            dq = np.linalg.solve(pin.dIntegrate(self.mech.model, self.anchor, x[:n], pin.ARG1), v)
        form = self.form
        a = form.accelerations(t, q, v, x[n + nv:])
        if form.nonfinite if form.checks_finite else not np.isfinite(a.sum()):
            # a too-long trial step into a stiff contact overflows; SciPy's RK solvers reject it
            # and shrink the step. At a solver's first evaluation, or when it keeps happening, stop
            # (SciPy's initial-step selection would loop forever on NaN).
            self.bad += 1
            if self.strict or self.bad > MAX_NONFINITE:
                raise FloatingPointError(f"at t = {t:.9g} s: non-finite accelerations (check parameters, "
                                         "stiffness, and that the mass matrix is positive definite)")
        else:
            self.bad = 0
        out = np.empty_like(x)
        out[:n] = dq
        out[n:n + nv] = a
        out[n + nv:] = form.ws.zdot
        return out


def _check_inputs(t_end, t0, rtol, atol, integrator, h, max_step, t_eval, dt_out):
    if integrator not in INTEGRATORS:
        raise InputError(f"unknown integrator {integrator!r} (valid: {', '.join(INTEGRATORS)})")
    if not np.isfinite(t_end) or t_end <= t0:
        raise InputError(f"t_end must be a finite time after t0 = {t0}, got {t_end!r}")
    if rtol is None or not rtol > 0:
        raise InputError(f"rtol must be positive, got {rtol!r}")
    if atol is not None and not np.all(np.asarray(atol) > 0):
        raise InputError(f"atol must be positive, got {atol!r}")
    if h is not None and not h > 0:
        raise InputError(f"step h must be positive, got {h!r}")
    if integrator == "RK4" and h is None:
        raise InputError("integrator 'RK4' is fixed-step: give h (seconds)")
    if max_step is not None and not max_step > 0:
        raise InputError(f"max_step must be positive, got {max_step!r}")
    if dt_out is not None and not dt_out > 0:
        raise InputError(f"dt_out must be positive, got {dt_out!r}")
    if t_eval is not None:
        te = np.asarray(t_eval, float)
        slack = 1e-12 * max(1.0, abs(t_end))
        if te.ndim != 1 or np.any(np.diff(te) < 0) or te[0] < t0 - slack or te[-1] > t_end + slack:
            raise InputError("t_eval must be increasing and inside [t0, t_end]")


def simulate(mech, t_end, method="lagrange", integrator="RK45", rtol=1e-8, atol=None, t_eval=None,
             dt_out=None, q0=None, v0=None, t0=0.0, max_step=np.inf, h=None, first_step=None,
             assemble=True, strict=False, max_cpu=None, **method_options) -> Trajectory:
    """Integrate the forward dynamics of ``mech`` from t0 to t_end; return a Trajectory.

    method: lagrange | projection | pinocchio | proximal (see pinclear.formulations).
    integrator: RK45 | DOP853 | Radau | BDF | LSODA | RK4 (fixed step h).
    Output at t_eval, or every dt_out (default 500 intervals). A failure (step-size collapse,
    rank loss, non-finite state, max_cpu exceeded) ends the run with status 'failed', a message
    saying when and why, and every sample computed so far; strict=True raises IntegrationError.
    """
    _check_inputs(t_end, t0, rtol, atol, integrator, h, max_step, t_eval, dt_out)
    Form = formulations.get(method)
    form = Form(mech, **method_options)
    if integrator == "LSODA" and form.supports_projection:
        raise InputError("method 'projection' corrects the state after each step, which LSODA's internal "
                         "history cannot absorb: use RK45, DOP853, Radau, BDF or RK4")
    if atol is None:
        atol = rtol * 1e-2
    cpu0 = time.process_time()
    ws = form.ws
    # ---------------- consistent initial state
    q = np.array(mech.q0 if q0 is None else q0, float)
    if assemble:
        q = kinematics.assemble(mech, q, t=t0, ws=ws)
        v = kinematics.consistent_velocity(mech, q, mech.v0 if v0 is None else v0, t=t0, ws=ws)
    else:
        v = np.array(mech.v0 if v0 is None else v0, float)
    # redundant rows: found once at the start, dropped by formulations that need a full-rank S
    J = kinematics.jacobian(mech, ws, q, t0, with_drives=True)
    rank, indep, redundant = kinematics.rank_analysis(J, mech.row_names())
    if form.opts.get("drop_redundant", False):
        form.rows = np.array(indep, dtype=int)
    kinematics.update(mech, ws, q, v)
    z = np.concatenate([f.z0(mech, ws, q, v) for f in mech.forces]) if mech.nz else np.zeros(0)

    sysf = _System(form)
    x = sysf.pack(q, v, z)
    if t_eval is None:
        dt = dt_out or (t_end - t0) / 500
        t_eval = np.append(np.arange(t0, t_end, dt), t_end)
        if len(t_eval) > 1 and t_eval[-1] - t_eval[-2] < 1e-9 * dt:
            t_eval = np.delete(t_eval, -2)
    t_eval = np.asarray(t_eval, float)

    traj = Trajectory.empty(mech, form, integrator, rtol, atol, t_eval)
    mob = kinematics.mobility(mech, q, ws)
    traj.stats.update(mobility=mob["mobility"], redundant_constraints=len(mob["redundant_rows"]),
                      redundant_rows=mob["redundant_rows"], redundant_rows_with_drives=redundant,
                      closure_condition=mob["condition"])
    stats = traj.stats
    # event channels per force element, evaluated together (one kinematics pass per element)
    events = [(fi, f, np.array([e[1] if isinstance(e, tuple) else 0 for e in f.events]))
              for fi, f in enumerate(mech.forces) if getattr(f, "events", None)]

    def event_vals(fi, f, t, x):
        q_, v_, z_ = sysf.split(x)
        ws.q_cur = q_
        kinematics.update(mech, ws, q_, v_)
        zf = z_[mech.z_slices[fi]]
        if hasattr(f, "event_values"):
            return np.array(f.event_values(mech, ws, t, q_, v_, zf), float)
        return np.array([f.event_value(k, mech, ws, t, q_, v_, zf) for k in range(len(f.events))], float)

    def all_events(t, x):
        return [event_vals(fi, f, t, x) for fi, f, _ in events]
    out_i = 0
    samples = []            # (t, x, chart anchor) recorded at output times

    def _sample(ts, xs):
        """An output sample; projection formulations put it on the manifold like the steps."""
        if form.supports_projection:
            qs, vs, zs = sysf.split(xs)
            qs, vs = form.project(ts, qs, vs)
            xs = np.concatenate([qs if mech.euclidean else pin.difference(mech.model, sysf.anchor, qs), vs, zs])
        return ts, xs, None if mech.euclidean else sysf.anchor.copy()

    def make_solver(t_start, x_start, step_hint=None):
        kw = {}
        if integrator == "RK4":
            return RK4(sysf, t_start, x_start, t_end, h=h)
        if integrator != "LSODA" or np.isfinite(max_step):
            kw["max_step"] = max_step
        fs = first_step if step_hint is None else step_hint
        if fs is not None:
            kw["first_step"] = min(fs, t_end - t_start)
        sysf.strict = True          # a non-finite first evaluation would hang SciPy's step selection
        try:
            return _SCIPY[integrator](sysf, t_start, x_start, t_end, rtol=rtol, atol=atol, **kw)
        finally:
            sysf.strict = False

    status, message = "success", "reached t_end"
    try:
        solver = make_solver(t0, x)
        while out_i < len(t_eval) and t_eval[out_i] <= t0 + 1e-15:
            samples.append(_sample(t_eval[out_i], x.copy()))
            out_i += 1
        ev_prev = all_events(t0, x)
        while solver.status == "running":
            t_old = solver.t
            msg = solver.step()
            if solver.status == "failed":
                status = "failed"
                h_last = solver.step_size if solver.step_size is not None else float("nan")
                message = (f"integrator {integrator} failed at t = {solver.t:.9g} s: {msg} "
                           f"(step-size collapse, last step {h_last:.3g} s; the problem may be stiff: "
                           "try Radau/BDF, or the contact stiffness/tolerance)")
                break
            stats["steps"] += 1
            t_new = solver.t
            if getattr(form, "ratio_ref", None) and form.ratio_min < SINGULAR_DIP * form.ratio_ref:
                dense_s = solver.dense_output()
                try:
                    _locate_singular_passage(form, sysf, dense_s, t_old, t_new)
                except RankLossError as exc:       # keep the samples before the singular time
                    while out_i < len(t_eval) and t_eval[out_i] < exc.t:
                        samples.append(_sample(t_eval[out_i], dense_s(t_eval[out_i])))
                        out_i += 1
                    raise
            if hasattr(form, "ratio_min"):
                form.ratio_min = np.inf
            if not np.all(np.isfinite(solver.y)):
                status, message = "failed", f"non-finite state at t = {t_new:.9g} s"
                break
            dense = solver.dense_output() if (out_i < len(t_eval) or events) else None
            # ---- events: earliest sign change in this step
            hit = None
            if events:
                g_new = all_events(t_new, solver.y)
                for (fi, f, dirs), g0, g1 in zip(events, ev_prev, g_new):
                    crossed = (((g0 < 0) & (g1 >= 0) & (dirs >= 0)) | ((g0 > 0) & (g1 <= 0) & (dirs <= 0)))
                    for k in np.flatnonzero(crossed):
                        te = brentq(lambda s, fi=fi, f=f, k=k: event_vals(fi, f, s, dense(s))[k], t_old, t_new,
                                    xtol=1e-14, rtol=4 * np.finfo(float).eps)
                        if hit is None or te < hit[0]:
                            hit = (te, fi, int(k), f)
                ev_prev = g_new
            t_stop = hit[0] if hit else t_new
            while out_i < len(t_eval) and t_eval[out_i] <= t_stop:
                samples.append(_sample(t_eval[out_i], dense(t_eval[out_i])))
                out_i += 1
            restart, step_hint = False, solver.step_size
            if hit:
                te, fi, k, f = hit
                xe = dense(te)
                qe, ve, ze = sysf.split(xe)
                ze = ze.copy()
                kinematics.update(mech, ws, qe, ve)
                sl = mech.z_slices[fi]
                ze[sl] = f.handle_event(k, mech, ws, te, qe, ve, ze[sl])
                stats["events"].append({"t": float(te), "element": f.name, "event": _event_name(f, k)})
                x_restart, t_restart, restart = sysf.pack(qe, ve, ze), te, True
                # an impact changes the time scale: let the integrator choose its first step again
                step_hint = None
                ev_prev = all_events(te, x_restart)
                # the handled channel sits at zero right after its event: step off it in its sense
                ev_prev[[e[0] for e in events].index(fi)][k] = 0.0
            elif form.supports_projection:
                q1, v1, z1 = sysf.split(solver.y)
                q1, v1 = form.project(t_new, q1, v1)
                x_restart, t_restart = sysf.pack(q1, v1, z1), t_new
                _reset_state(solver, integrator, sysf, x_restart, t_new)
            elif not mech.euclidean and np.linalg.norm(solver.y[: sysf.nq_state], np.inf) > 0.5:
                q1, v1, z1 = sysf.split(solver.y)
                x_restart, t_restart, restart = sysf.pack(q1, v1, z1), t_new, True
            if restart:
                stats["restarts"] += 1
                if t_restart < t_end:
                    solver = make_solver(t_restart, x_restart, step_hint)
            if max_cpu is not None and time.process_time() - cpu0 > max_cpu:
                status = "failed"
                message = f"stopped at t = {solver.t:.9g} s: CPU budget max_cpu = {max_cpu} s exhausted"
                break
    except RankLossError as exc:
        status, message = "failed", str(exc)
        stats["rank_loss"] = {"t": exc.t, "rank": exc.rank, "rows": exc.rows, "cond": exc.cond}
    except FloatingPointError as exc:
        status, message = "failed", f"integrator {integrator} failed {exc}"
    except np.linalg.LinAlgError as exc:
        status, message = "failed", f"linear algebra failure after t = {_last_t(samples, t0):.9g} s: {exc}"
    except PinclearError:
        raise
    stats["rhs_evals"] = sysf.nfev
    stats["cpu_s"] = time.process_time() - cpu0
    traj.status, traj.message = status, message
    traj.fill(samples, sysf)
    stats["cpu_s_total"] = time.process_time() - cpu0
    if len(traj.t) > 1:
        stats["cpu_per_sim_s"] = stats["cpu_s"] / (traj.t[-1] - t0)
    if status != "success":
        if strict:
            from .errors import IntegrationError

            raise IntegrationError(message, trajectory=traj)
        warnings.warn(f"pinclear.simulate: {message} ({len(samples)} of {len(t_eval)} samples kept)",
                      RuntimeWarning, stacklevel=2)
    return traj


#: consecutive non-finite right-hand sides tolerated (rejected trial steps) before failing
MAX_NONFINITE = 50

#: a step whose Schur-complement pivot ratio dips below this fraction of its initial value may
#: have stepped over a singular configuration: the minimum inside the step is then located
SINGULAR_DIP = 1e-3


def _locate_singular_passage(form, sysf, dense, t_old, t_new):
    """Minimise the pivot ratio along the step's dense output; a rank loss there raises
    RankLossError at its time, instead of letting the step jump branches silently."""
    from scipy.optimize import minimize_scalar

    def ratio(s):
        q, v, z = sysf.split(dense(s))
        form.ratio_min = np.inf
        form.accelerations(s, q, v, z)         # raises RankLossError below the rank threshold
        return form.ratio_min

    minimize_scalar(ratio, bounds=(t_old, t_new), method="bounded", options={"xatol": 1e-13 * max(1.0, t_new)})


def _last_t(samples, t0):
    return samples[-1][0] if samples else t0


def _event_name(f, k):
    ev = f.events[k]
    return ev[0] if isinstance(ev, tuple) else str(ev)


def _reset_state(solver, integrator, sysf, x, t):
    """Put a corrected state into a running solver without restarting it."""
    solver.y = x
    if integrator in ("RK45", "DOP853", "RK4", "Radau"):
        solver.f = sysf(t, x)
    elif integrator == "BDF":
        solver.D[0] = x
