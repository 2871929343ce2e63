"""The compiled integration loop: RK45 steps whose every stage runs in one compiled function.

Why: on the Python path each right-hand side crosses from Python into Pinocchio four times and
into numba three to five times, and every step runs the simulator's bookkeeping in Python (events,
samples, stall test): 10-16 us per evaluation on trees whose Pinocchio work costs 2-4 us
(``pinclear bench runs``). Here the whole step loop is one numba function. A stage calls
Pinocchio's passes through the C function of pinclear._passes (pinclear.native), on the very
pin.Data whose arrays the kernels read, then the same bound kernels the Python path calls
(placements, force elements, drive laws, the Lagrange KKT solve), in the same order, on the same
buffers. The step is SciPy's RK45 as pinclear.integrators.CompiledRK45 takes it (same tableau,
same stage sums, same step-size control), so a run takes the same steps and reaches the same
states as on the Python path (tests/test_fastloop.py compares them).

The loop returns to Python every CHUNK steps (progress, checkpoints, the CPU budget), and for any
step that needs the simulator's own handling: an event crossing, a pivot dip, a non-finite state.
The search a pivot dip starts (simulate's singular-passage location) evaluates compiled too
(:meth:`FastLoop.locate`).
A stage it cannot take (a non-finite or rank-deficient evaluation, constraint rows to choose
again, a step below SciPy's minimum) is handed back before it changes anything, and Python takes
that step through the solver.

Eligible runs: method 'lagrange', integrator 'RK45', Euclidean
configurations, trees of 1-dof joints, every force element with a compiled right-hand side and
compiled events, every drive law compiled. Anything else runs on the Python path;
``Trajectory.stats['loop']`` says which path a run took and why.
"""
from __future__ import annotations

import math

import numpy as np
from . import native
from ._bind import DYN, bind, load_generated
from ._jit import njit
from ._kernels import BRENT_STATE
from .contact._kernels import channel_penetrations
from .energy import drive_power
from .formulations.base import SINGULAR_DIP
from .formulations.lagrange import RESELECT_DIP
from .stepping.call import call_passes  # noqa: F401  (the generated loop imports it from here)
from .stepping.checks import monitor  # the pivot monitor, once for both loops
from .timelaws import eval_laws

#: accepted steps per compiled call; between calls Python looks at progress, checkpoints and
#: the CPU budget (a chunk of a clearance run takes well under a millisecond)
CHUNK = 128

#: most evaluations of the search for a singular passage inside one step (simulate)
LOCATE_MAXITER = 500

#: what a chunk ended with
QUIET, FINISHED, HANDLE, PYSTEP, STALLED = 0, 1, 2, 3, 4


@njit(cache=True)
def dense_into(K, P, y_old, t_old, h, t, out):
    """SciPy's RK45 dense output of the last step at t: y_old + h Q p(x), Q = K^T P,
    p = (x, x^2, x^3, x^4), x = (t - t_old) / h."""
    x = (t - t_old) / h
    n, nk, order = y_old.shape[0], K.shape[0], P.shape[1]
    for i in range(n):
        acc, p = 0.0, 1.0
        for k in range(order):
            p *= x
            qik = 0.0
            for j in range(nk):
                qik += K[j, i] * P[j, k]
            acc += qik * p
        out[i] = h * acc + y_old[i]


# The loop, shared by every mechanism; the generated module supplies rhs() and events().
_LOOP = '''
@njit(cache=True)
def loop(T, PS, tau, zdot, abuf, fdrv, t, t_bound, h_abs, y, f, K, y_old, ys, y_new, A, B, C, E, P,
         atol, rtol, expo, t_eval, samples, out_i, g_prev, g_new, dirs, mon, ring, n_acc, h_stall, state):
    """Up to CHUNK accepted RK45 steps from (t, y, f, h_abs); see pinclear.fastloop. Returns
    (code, t, t_old, h_abs, h_previous, out_i, n_acc, steps, evaluations, good evaluations)."""
    nfev = 0
    ngood = 0
    steps = 0
    t_old = t
    h_prev = 0.0
    ns = A.shape[0]
    n = y.shape[0]
    while True:
        h_start = h_abs      # a step handed back to Python starts from here, as if never tried
        min_step = 10.0 * abs(np.nextafter(t, np.inf) - t)
        if h_abs > state[0]:
            h_abs = state[0]
        elif h_abs < min_step:
            h_abs = min_step
        accepted = False
        rejected = False
        while not accepted:
            if h_abs < min_step:
                return PYSTEP, t, t_old, h_start, h_prev, out_i, n_acc, steps, nfev, ngood
            t_new = t + h_abs
            if t_new - t_bound > 0:
                t_new = t_bound
            h = t_new - t
            h_abs = abs(h)
            for i in range(n):
                K[0, i] = f[i]
            for s in range(1, ns + 1):
                if s < ns:
                    _rk_stage(y, K, A[s], s, h, ys)
                    r = rhs(T, PS, tau, zdot, abuf, fdrv, t + C[s] * h, ys, K[s])
                else:
                    _rk_stage(y, K, B, ns, h, y_new)
                    r = rhs(T, PS, tau, zdot, abuf, fdrv, t + h, y_new, K[ns])
                nfev += 1
                if not monitor(r, mon):
                    return PYSTEP, t, t_old, h_start, h_prev, out_i, n_acc, steps, nfev, ngood
                ngood += 1
            err = _rk_error_norm(y, y_new, K, E, h, atol, rtol)
            if err < 1:
                if err == 0:
                    factor = 10.0
                else:
                    factor = 0.9 * err ** expo
                    if not factor < 10.0:
                        factor = 10.0
                if rejected and not factor < 1.0:
                    factor = 1.0
                h_abs *= factor
                accepted = True
            else:
                factor = 0.9 * err ** expo
                if not factor > 0.2:
                    factor = 0.2
                h_abs *= factor
                rejected = True
        # accepted: the solver's state moves on (as OdeSolver.step)
        h_prev = h
        t_old = t
        t = t_new
        fin = 0.0
        for i in range(n):
            y_old[i] = y[i]
            y[i] = y_new[i]
            f[i] = K[ns, i]
            fin += y[i]
        steps += 1
        # the simulator's per-step checks, in its order; a step that needs its own handling
        # goes back unprocessed
        if mon[1] == mon[1] and mon[0] < state[1] * mon[1]:
            return HANDLE, t, t_old, h_abs, h_prev, out_i, n_acc, steps, nfev, ngood
        mon[0] = np.inf
        if not math.isfinite(fin):
            return HANDLE, t, t_old, h_abs, h_prev, out_i, n_acc, steps, nfev, ngood
        if g_prev.shape[0]:
            events(T, PS, y, g_new)
            for k in range(g_prev.shape[0]):
                a0, b0, d = g_prev[k], g_new[k], dirs[k]
                if (a0 < 0 <= b0 and d >= 0) or (a0 > 0 >= b0 and d <= 0):
                    return HANDLE, t, t_old, h_abs, h_prev, out_i, n_acc, steps, nfev, ngood
            for k in range(g_prev.shape[0]):
                g_prev[k] = g_new[k]
        while out_i < t_eval.shape[0] and t_eval[out_i] <= t:
            dense_into(K, P, y_old, t_old, h_prev, t_eval[out_i], samples[out_i])
            out_i += 1
        finished = t - t_bound >= 0
        k = n_acc % ring.shape[0]
        if n_acc >= ring.shape[0] and t - ring[k] < ring.shape[0] * h_stall and not finished:
            return STALLED, t, t_old, h_abs, h_prev, out_i, n_acc, steps, nfev, ngood
        ring[k] = t
        n_acc += 1
        if finished:
            return FINISHED, t, t_old, h_abs, h_prev, out_i, n_acc, steps, nfev, ngood
        if steps >= CHUNK:
            return QUIET, t, t_old, h_abs, h_prev, out_i, n_acc, steps, nfev, ngood


@njit(cache=True)
def locate(T, PS, tau, zdot, abuf, fdrv, K, P, y_old, t_old, h, x, dx, mon, a, b, xatol, st):
    """Brent's search (brent_start/brent_next) for the smallest pivot ratio along the last
    step's dense output on [a, b]. Returns (s, evaluations, python): python when the evaluation
    at s (its state left in x) is Python's to take, as monitor() decides."""
    s = brent_start(a, b, xatol, st)
    n = 0
    while True:
        dense_into(K, P, y_old, t_old, h, s, x)
        r = rhs(T, PS, tau, zdot, abuf, fdrv, s, x, dx)
        n += 1
        if not monitor(r, mon):
            return s, n, True
        s, done = brent_next(st, r, LOCATE_MAXITER)
        if done:
            return s, n, False
'''


def _parts(fn):
    """(wrapper, P, F, I) of a bound kernel (pinclear._bind); None when it runs unbound."""
    b = getattr(fn, "bound", None)
    return None if b is None else (b.call, b.P, b.F, b.I)


class FastLoop:
    """The compiled loop of one run, over the formulation's buffers (see :func:`build`)."""

    def __init__(self, form, sysf, module, tables, flags, events, t_eval, h_stall):
        ws, mech = form.ws, form.mech
        self.form, self.sysf, self.module, self.T = form, sysf, module, tables
        self.rows = form._bound_rows
        model_addr, data_addr = native.addresses(mech.model, ws.data)
        self.PS = np.array([native.passes_address(), model_addr, data_addr, flags], dtype=np.int64)
        self.keep = (mech.model, ws.data)        # the addresses are valid while these live
        self.nq, self.nv = mech.nq, mech.nv
        self.dirs = np.concatenate([d for _, _, d in events]).astype(float) if events else np.zeros(0)
        ng = len(self.dirs)
        self.g_prev, self.g_new = np.zeros(ng), np.zeros(ng)
        self.t_eval = np.ascontiguousarray(t_eval, float)
        # samples are written once each: the simulator keeps views of these rows
        self.samples = np.zeros((len(t_eval), mech.nq + mech.nv + mech.nz))
        self.h_stall = float(h_stall)
        self.mon = np.array([np.inf, np.nan, form._ratio_floor, RESELECT_DIP if form._dropped else -np.inf])
        self.args = (self.T, self.PS, ws.tau, ws.zdot, form._a, form._drive_data.f)
        self.evals = 0
        self.ys = self.y_new = self.state = None

    def stale(self) -> bool:
        """True once the formulation chose other rows (a Python step did): build again."""
        return self.form._bound_rows is not self.rows

    def _load_monitor(self):
        form, mon = self.form, self.mon
        mon[0] = form.ratio_min
        mon[1] = np.nan if form.ratio_ref is None else form.ratio_ref

    def _store_monitor(self, ngood):
        form, mon = self.form, self.mon
        form.ratio_min = float(mon[0])
        if mon[1] == mon[1]:
            form.ratio_ref = float(mon[1])
        self._forget_caches()
        if ngood:                              # as OdeSystem after a finite evaluation
            self.sysf.bad, self.sysf.rank_loss = 0, None

    def _forget_caches(self):
        """The compiled calls overwrote what the Python path caches by state or by time."""
        form = self.form
        for d in form.ws.force_data:
            if hasattr(d, "key"):
                d.key = d.q_key = None
        tg = form._drive_data.t_group
        tg[:] = [None] * len(tg)

    def locate(self, solver, xatol):
        """Brent's search for the smallest pivot ratio inside the solver's last step, every
        evaluation compiled (see pinclear.simulate._locate_singular_passage). Returns (s, x,
        python): python is True when the evaluation at s (state x) is Python's to take."""
        if self.stale():
            return solver.t_old, None, True
        x = np.empty(solver.n)
        self._load_monitor()
        mon = self.mon.copy()      # the search's evaluations leave the step's monitor as it was
        s, n, python = self.module.locate(*self.args, solver.K, solver.P, solver.y_old, float(solver.t_old),
                                          float(solver.h_previous), x, np.empty(solver.n), mon, float(solver.t_old),
                                          float(solver.t), float(xatol), np.empty(BRENT_STATE))
        self.evals += n
        self._forget_caches()
        return s, x, python

    def fun(self, t, x):
        """The right-hand side for the solver's own (Python) steps and start: one compiled call;
        an evaluation the compiled checks refuse goes through the Python path (OdeSystem),
        which rejects the stage, raises or chooses rows again exactly as without this loop."""
        if self.stale():
            return self.sysf(t, x)
        self._load_monitor()
        x = np.ascontiguousarray(x, float)
        dx = np.empty(len(x))
        r = self.module.rhs(*self.args, float(t), x, dx)
        if not monitor(r, self.mon):
            return self.sysf(t, x)
        self.evals += 1
        self._store_monitor(1)
        return dx

    def advance(self, solver, out_i, ev_prev, ring, n_acc):
        """Run one chunk from the solver's state and put the state it reached back into the
        solver. Returns (code, out_i, n_acc, steps); rows old out_i:out_i of ``samples`` are new."""
        n = solver.n
        if self.ys is None:
            self.ys, self.y_new = np.empty(n), np.empty(n)
            self.state = np.array([solver.max_step, SINGULAR_DIP])
        y = np.array(solver.y, float)
        f = np.array(solver.f, float)
        y_old = np.empty(n)
        self._load_monitor()
        if len(self.dirs):
            np.concatenate(ev_prev, out=self.g_prev)
        code, t, t_old, h_abs, h_prev, out_i, n_acc, steps, nfev, ngood = self.module.loop(
            *self.args, float(solver.t), float(solver.t_bound), float(solver.h_abs), y, f, solver.K, y_old, self.ys,
            self.y_new, solver._A, solver.B, solver.C, solver.E, solver.P, solver._atol, float(solver.rtol),
            float(solver.error_exponent), self.t_eval, self.samples, out_i, self.g_prev, self.g_new, self.dirs,
            self.mon, ring, n_acc, self.h_stall, self.state)
        self.evals += nfev
        self._store_monitor(ngood)
        if len(self.dirs):
            k = 0
            for g in ev_prev:
                g[:] = self.g_prev[k:k + len(g)]
                k += len(g)
        solver.h_abs = h_abs
        if steps:
            solver.t_old, solver.t = t_old, t
            solver.y, solver.y_old, solver.f = y, y_old, f
            solver.h_previous = h_prev
            if t - solver.t_bound >= 0:
                solver.status = "finished"
        return code, out_i, n_acc, steps

    def sample_rows(self, i, j):
        """(t, q, v, z) of samples i..j-1, as views of their rows."""
        X, nq, nv = self.samples[i:j], self.nq, self.nv
        return zip(self.t_eval[i:j].tolist(), X[:, :nq], X[:, nq:nq + nv], X[:, nq + nv:])


def eligible(form, integrator) -> str:
    """Why a run cannot take the compiled loop ("" when it can)."""
    mech = form.mech
    if not native.available():
        return native.reason
    if integrator != "RK45":
        return f"integrator {integrator!r} (the compiled loop is RK45's)"
    if form.name != "lagrange":
        return f"method {form.name!r} (the compiled loop solves method 'lagrange')"
    if not mech.euclidean:
        return "configurations on a Lie group other than R^n (free-flyer, spherical or planar joints)"
    if form.ws.fk.chain is None:
        return "a joint with more than one degree of freedom in the tree"
    dr = mech.driverows
    if dr.single or any(g[3] is None or g[0].compiled_filler() is None for g in dr.groups):
        return "a drive law without a compiled form (a Python function)"
    for f in mech.forces:
        if f.rhs_kernel() is None:
            return f"force element {f.name!r} has no compiled right-hand side"
        if f.events and getattr(f, "_geom", None) is None:
            return f"force element {f.name!r} has no compiled event values"
    return ""


def build(form, sysf, events, t_eval, h_stall):
    """The FastLoop of this run (the formulation's kernels are bound: call after an evaluation)."""
    mech, ws = form.mech, form.ws
    comps = []       # (wrapper, P, F, I) of every bound kernel the generated code calls

    def call(fn, *dyn):
        """The generated line calling bound kernel ``fn`` with the dynamic arguments ``dyn``."""
        p = _parts(fn)
        if p is None:
            raise RuntimeError("a kernel runs unbound")
        comps.append(p)
        i = len(comps) - 1
        return f"    k{i}(T[{3 * i}], T[{3 * i + 1}], T[{3 * i + 2}]{''.join(', ' + a for a in dyn)})"

    nq, nv = mech.nq, mech.nv
    lines_rhs = ["    q = x[:NQ]", "    v = x[NQ:NQ + NV]", "    z = x[NQ + NV:]",
                 "    # Pinocchio: computeJointJacobiansTimeVariation, updateFramePlacements, crba, nle",
                 "    call_passes(PS[0], PS[1], PS[2], x.ctypes.data, x.ctypes.data + 8 * NQ, PS[3])"]
    placements = call(ws.fk._placements, "q")
    lines_rhs.append(placements)
    if mech.forces:
        lines_rhs.append("    tau[:] = 0.0")
    for f, d, sl in zip(mech.forces, ws.force_data, mech.z_slices):
        kernel, args = f.rhs_kernel()
        lines_rhs.append(call(bind(kernel, args(ws, d, DYN, DYN, ws.tau, ws.zdot[sl])), "v", f"z[{sl.start}:{sl.stop}]"))
    dr, fdrv = mech.driverows, form._drive_data.f
    for law, _, _, _ in dr.groups:
        kernel, args = law.compiled_filler()
        lines_rhs.append(call(bind(kernel, (DYN,) + tuple(args) + (fdrv,)), "t"))
    if dr.law_table is not None:
        lt = dr.law_table
        lines_rhs.append(call(bind(eval_laws, (lt[0], lt[1], lt[2], DYN, lt[3], fdrv)), "t"))
    if form._bound_rows is not form.rows:
        form._bind()
    lines_rhs.append("    r = " + call(form._kernel, "q", "v", "fdrv").strip())
    if mech.n_work:
        # the work meter of the energy audit, from the multipliers the solve just left
        lam = ws.lam if form._all_rows else form._buf["lam"]
        rows = np.ascontiguousarray(form.rows, dtype=np.int64)
        lines_rhs.append(call(bind(drive_power, (lam, int(form._all_rows), rows, DYN, mech.driverows.iv,
                                                 mech.compiled.m, ws.zdot, mech.z_work.start)), "v"))
    lines_rhs += ["    for i in range(NQ):", "        dx[i] = v[i]",
                  "    for i in range(NV):", "        dx[NQ + i] = abuf[i]",
                  "    for i in range(zdot.shape[0]):", "        dx[NQ + NV + i] = zdot[i]",
                  "    return r"]
    lines_ev = ["    q = y[:NQ]", placements]
    g0, fk = 0, ws.fk
    for fi, f, _ in events:
        d, g = ws.force_data[fi], f._geom
        lines_ev.append(call(bind(channel_penetrations, (g[0], g[1], fk.Hj, fk.jidx, fk.jMf, d.slot, d.M, d.scratch,
                                                         d.delta, d.n, d.p1, d.p2, f.event_snap))))
        lines_ev.append(call(bind(_copy_into, (d.delta, DYN, g0)), "g"))
        g0 += len(d.delta)
    src = ["# generated by pinclear.fastloop: one mechanism's compiled loop (do not edit)",
           "import math", "import numpy as np", "from pinclear._jit import njit",
           "from pinclear.fastloop import call_passes, dense_into, monitor, QUIET, FINISHED, HANDLE, PYSTEP, STALLED, CHUNK",
           "from pinclear.fastloop import LOCATE_MAXITER",
           "from pinclear._kernels import brent_next, brent_start",
           "from pinclear.integrators import _rk_stage, _rk_error_norm"]
    for k, p in enumerate(comps):
        src.append(f"from {p[0].__module__} import {p[0].__name__} as k{k}")
    src += ["", f"NQ = {nq}", f"NV = {nv}", "", "",
            "@njit(cache=True)", "def rhs(T, PS, tau, zdot, abuf, fdrv, t, x, dx):"] + lines_rhs
    src += ["", "", "@njit(cache=True)", "def events(T, PS, y, g):"] + lines_ev + ["    return"]
    src.append(_LOOP)
    module = load_generated("\n".join(src) + "\n", "loop")
    tables = tuple(x for p in comps for x in p[1:])
    flags = (native.FRAMES if mech.forces else 0) | native.MASS   # frames as kinematics.update
    return FastLoop(form, sysf, module, tables, flags, events, t_eval, h_stall)


@njit(cache=True)
def _copy_into(src, dst, start):
    for i in range(src.shape[0]):
        dst[start + i] = src[i]

