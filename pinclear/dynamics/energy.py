"""The energy audit of a run: does the energy balance close?

Every run satisfies, if its models are consistent,

    B(t) = T + V_g + V_el + E_diss - W_drives - W_closures - W_applied = B(0)

T kinetic, V_g gravity potential, V_el the elastic energy of springs and contacts (each force
element's ``potential()``), E_diss the energy dissipated by damping and friction, W_drives the
work of the drive rows (their multipliers are the actuator forces: power lam_d (J_d v) =
lam_d v_j, design.md's sign convention M a + b = tau + J^T lam), W_closures the work of the
closure rows' forces (zero for an exact closure; with Baumgarte stabilisation J_c v = dPhi_c/dt
is not zero while the closure drifts, so they do a little work) and W_applied the work of
applied forces (``joint_force`` elements; any element whose ``power_loss`` is negative).

How each integral is obtained (measured on nine_bar with clearance A, 0.2 s, rtol 1e-8): the
drive forces jump at every impact of a clearance, so their power integrated afterwards over the
output samples is only as good as the samples: with the default 500 samples the balance was off
by 1.77 J on an energy scale of 12.6 J, with 50 000 samples still by 1.6e-3 J; with the work as a
state of the integration, by 1.0e-6 J. So the integrals that impacts make spiky are integrated
with the state, on its steps:

* E_diss of a clearance joint: its own internal state (contact/base.py; ForceElement
  ``dissipation_state``);
* W_drives: a work meter appended to z (``mech.z_work``, present when the mechanism has
  drives) whose rate :func:`meter_rates` (Python loop) or :func:`drive_power` (compiled loop)
  writes after each evaluation of the accelerations, from the multipliers it solved for. The
  meter is a quadrature (nothing depends on it): simulate keeps it out of the error test, as
  CVODES treats quadratures by default, so it rides on the steps the states' error control
  chooses (a Runge-Kutta quadrature of the power along each step, of the method's order). In
  the error test it cost steps for nothing (its start near zero made atol steer them) and, with
  DOP853, accuracy: that method's norm err5^2 / sqrt(err5^2 + 0.01 err3^2) shrinks when one
  component's err3 is large, as the spiky power's is.

The closure rows' work is tiny (Baumgarte drift: 3e-10 J in the run above) and the power of
elements without a dissipation state (springs' viscous damping, joint forces) is a smooth
function of time and state: both are integrated over the output samples (trapezoid), and
:func:`energy_balance` adds their size or quadrature error to the bound. A meter for the closure
rows was tried and dropped: its value stays near zero, so its absolute tolerance alone made the
steps of the four-bar 34 % more numerous for nothing.
"""
from __future__ import annotations

import math

import numpy as np

from pinclear.core.jit import njit

#: safety factor of the integration part of the bound (see :func:`energy_balance`)
SAFETY = 10.0


@njit(cache=True)
def drive_power(lam, by_row, rows, v, iv, mc, zdot, k):
    """zdot[k] = power of the drive rows among the rows ``rows`` solved for: sum lam_d v_j. The
    multiplier of row rows[i] is lam[rows[i]] (by_row) or lam[i] (a solve over the kept rows)."""
    p = 0.0
    for i in range(rows.shape[0]):
        r = rows[i]
        if r >= mc:
            if by_row:
                p += lam[r] * v[iv[r - mc]]
            else:
                p += lam[i] * v[iv[r - mc]]
    zdot[k] = p


def meter_rates(form, v, zdot):
    """Write the work meter's rate into ``zdot`` after ``form.accelerations`` at velocity v
    (the Python loop; the compiled loop calls :func:`drive_power` the same way)."""
    mech = form.mech
    drive_power(form.ws.lam, 1, form.rows, v, mech.driverows.iv, mech.compiled.m, zdot, mech.z_work.start)


def _cumtrapz(y, t):
    out = np.zeros_like(y)
    if len(y) > 1:
        out[1:] = np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(t))
    return out


def _quadrature_error(y, t):
    """Estimate of the trapezoid rule's error on the samples: the difference from Simpson's rule
    over pairs of intervals (the trapezoid's error is h^2/12 f'' per unit time, which the
    second differences of the samples give)."""
    if len(y) < 3:
        return 0.0
    h = np.diff(t)
    d2 = np.abs(np.diff(y, 2))
    # |f''| h^2 ~ |second difference|; the trapezoid error of an interval is h^3/12 |f''|
    return float(np.sum(d2 * 0.5 * (h[1:] + h[:-1])) / 12.0)


def energy_balance(traj) -> dict:
    """The energy balance of a run (see the module doc), a mapping:

    ``error_rel``: max_t |B(t) - B(0)| / scale_J (``error_J``: the same in joules); ``t`` (s): where;
    ``bound_rel``: the error the run's tolerances allow, relative to scale_J (``bound_J`` in
    joules); ``ok``: error <= bound; ``scale_J``: the energy that moved in the run,

        max T + max |V_g - V_g(0)| + max V_el + E_diss(end) + max |W_drives| + max |W_closures|
        + max |W_applied|,

    zero only when nothing moved (then error = 0); each term of B at the run's last sample, the
    time ``terms_t`` (s), in joules, split into ``terms_absolute_J`` (kinetic T and elastic V_el:
    values at that time) and ``terms_change_J`` (gravity V_g - V_g(t0), the dissipated energy
    and the works: changes since t0); ``terms_at_error_absolute_J`` / ``_change_J``: the same at
    ``t``, the time of the largest error; ``bound_terms_rel``: the parts of the bound. The
    names before summary schema 2 (``error``, ``bound``, ``scale``, ``terms``,
    ``terms_at_error``, ``bound_terms``: :data:`ALIASES`) are kept with the same values.

    The bound, written down here and not fitted to any run:

    * integration: an adaptive step is accepted when the RMS over the n states of
      e_i / (atol + rtol |y_i|) is <= 1, so every state's local error is <= sqrt(n) (atol +
      rtol |y_i|). Each energy in B is a function of degree <= 3 in the states it depends on
      (kinetic 2 in v, a Hertz contact 2.5 in the penetration, the dissipation state 1; the
      drive work meter, out of the error test, integrates lam_d v_j, a function of the states
      whose error it inherits at degree 1), so a relative error eps of the states changes it
      by <= 3 eps of itself, and B by
      <= 3 eps scale. A projection method's correction after a step is of the size of that
      step's local error, so it is covered too. Over N accepted steps, with SAFETY = 10 for the
      error estimator being an estimate (of the lower-order solution's error):

          SAFETY * 3 sqrt(n) N (rtol + atol / y_scale),   y_scale = max |q|, |v| over the run.

      Fixed-step runs (RK4) and runs without recorded steps have no such bound: infinite.
    * closure drift: the closure rows' work W_closures is integrated over the samples
      (trapezoid of lam_c . dPhi_c/dt; nonzero only while a Baumgarte-stabilised closure
      drifts); its whole size, the integral of |lam_c . dPhi_c/dt|, is added to the bound.
    * quadrature: the trapezoid's error estimate for the power of elements without a
      dissipation state (springs' damping, joint forces), integrated over the samples.

    The integration term grows with the number of steps: a run whose bound reaches 1 cannot
    be audited at its tolerance (its ``ok`` is then vacuous; tighten rtol).
    """
    S = balance_series(traj)
    if "message" in S:
        return {"error_rel": None, "error_J": None, "t": None, "ok": None, "bound_rel": None, "bound_J": None,
                "scale_J": None, "error": None, "bound": None, "scale": None, "message": S["message"]}
    t, n = S["t"], len(S["t"])
    T, Vg, Vel, D, Wd, Wc, Wa = (S[k] for k in SERIES)
    dev = np.abs(S["balance"])
    k = int(np.argmax(dev))
    scale = float(T.max() + np.abs(Vg).max() + Vel.max() + abs(D[-1]) + np.abs(Wd).max()
                  + np.abs(Wc).max() + np.abs(Wa).max())
    error = float(dev[k] / scale) if scale > 0 else 0.0
    Pa, Pc = S["applied_power"], S["closure_power"]

    rtol, atol = traj.meta.get("rtol"), traj.meta.get("atol")
    steps = int(traj.stats.get("steps") or 0)
    nstate = sum(a.shape[1] for a in (traj.q, traj.v, traj.z) if a.ndim == 2)
    terms = {}
    if rtol is None or not steps:
        terms["integration"] = math.inf
    else:
        y_scale = max(float(np.max(np.abs(traj.q[:n]), initial=0.0)), float(np.max(np.abs(traj.v[:n]), initial=0.0)))
        arel = float(np.max(np.abs(atol))) / y_scale if atol is not None and y_scale > 0 else 0.0
        terms["integration"] = SAFETY * 3.0 * math.sqrt(max(nstate, 1)) * steps * (float(rtol) + arel)
    if scale > 0:
        terms["closure_drift"] = float(_cumtrapz(np.abs(Pc), t)[-1]) / scale
        terms["quadrature"] = _quadrature_error(Pa, t) / scale
    else:
        terms["closure_drift"] = terms["quadrature"] = 0.0
    bound = float(sum(terms.values()))
    res = {"error_rel": error, "error_J": float(dev[k]), "t": float(t[k]), "ok": bool(error <= bound),
           "bound_rel": bound, "bound_J": bound * scale, "scale_J": scale,
           "terms_absolute_J": _split_terms(S, -1, ABSOLUTE), "terms_change_J": _split_terms(S, -1, CHANGES),
           "terms_t": float(t[-1]),
           "terms_at_error_absolute_J": _split_terms(S, k, ABSOLUTE), "terms_at_error_change_J": _split_terms(S, k, CHANGES),
           "bound_terms_rel": terms, "steps": steps, "samples": n}
    # the names before summary schema 2 (ALIASES), kept for readers of older summaries
    res.update({"error": error, "bound": bound, "scale": scale, "terms": {key: float(S[key][-1]) for key in SERIES},
                "terms_at_error": {key: float(S[key][k]) for key in SERIES}, "bound_terms": terms})
    return res


#: the balance's terms that are values at a time (J): kinetic T and elastic V_el, zero at rest
ABSOLUTE = ("kinetic", "elastic")
#: the terms that are changes since the run's start t0 (J): V_g - V_g(t0), the energy dissipated
#: and the work done since t0
CHANGES = ("gravity", "dissipated", "work_drives", "work_closures", "work_applied")
#: energy_balance's keys before summary schema 2 -> the key that now holds the value (the old
#: keys stay, with the same values): relative to ``scale_J``, or joules
ALIASES = {"error": "error_rel", "bound": "bound_rel", "scale": "scale_J", "bound_terms": "bound_terms_rel",
           "terms": "terms_absolute_J + terms_change_J", "terms_at_error": "terms_at_error_absolute_J + "
           "terms_at_error_change_J"}


def _split_terms(S, k, keys) -> dict:
    return {key: float(S[key][k]) for key in keys}


#: the balance's terms: balance_series' series and energy_balance's ``terms``, by the same names
SERIES = ("kinetic", "gravity", "elastic", "dissipated", "work_drives", "work_closures", "work_applied")


def balance_series(traj) -> dict:
    """The terms of the balance B (module doc) at every sample (J): kinetic T, gravity (V_g -
    V_g(0)), elastic V_el, dissipated E_diss, work_drives, work_closures, work_applied, and
    ``balance`` = B - B(0) (zero for an exact run), over the samples ``t`` up to the first with a
    non-finite energy; also the applied forces' power (``applied_power``, W). A mapping with
    ``message`` when the run recorded no energies. The one place B is formed (the audit and the
    energy figure read it)."""
    E = traj.energies
    need = ("kinetic", "potential", "spring", "dissipated", "work_drives", "closure_power", "applied_power")
    if any(k not in E for k in need):
        return {"message": "energy terms not recorded (outputs not evaluated, or a run saved before the energy audit)"}
    t = np.asarray(traj.t, float)
    cols = [np.asarray(E[k], float) for k in need]
    finite = np.all(np.isfinite(np.array(cols).reshape(len(need), -1)), axis=0) if len(t) else np.zeros(0, bool)
    n = int(np.argmin(finite)) if not finite.all() else len(t)
    if n == 0:
        return {"message": "no sample with finite energies"}
    t = t[:n]
    T, Vg, Vel, D, Wd, Pc, Pa = (c[:n] for c in cols)
    Wc = _cumtrapz(Pc, t)
    Wa = 0.0 - _cumtrapz(Pa, t)     # work of applied forces (their power_loss is negative when they inject)
    B = T + Vg + Vel + D - Wd - Wc - Wa
    return {"t": t, "kinetic": T, "gravity": Vg - Vg[0], "elastic": Vel, "dissipated": D, "work_drives": Wd,
            "work_closures": Wc, "work_applied": Wa, "balance": B - B[0], "applied_power": Pa,
            "closure_power": Pc}
