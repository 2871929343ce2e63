"""Inverse dynamics along a prescribed platform motion by the screw method (paper 004, eq. 26),
the condition-number monitor of a motion or a simulated run, and Pinocchio's Lagrangian drive
forces as the independent reference."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from pinclear.core.errors import InputError, ModelFileError, PinclearError
from pinclear.dynamics.screw.algebra import from_motion
from pinclear.dynamics.screw.section import read_section
from pinclear.dynamics.screw.system import cond_sign, screw_system
from pinclear.model import kinematics


@dataclass
class InverseDynamicsResult:
    t: np.ndarray
    tau: np.ndarray                  # (N, n_act) drive forces
    virtual: np.ndarray              # (N, 6 - n_act) virtual-joint generalized forces
    constraint_wrench: np.ndarray    # (N, 6) wrench (m_o; f) the constraint limbs exert on the platform
    cond: np.ndarray                 # (N,) condition number of G_p^q (normalised)
    drive_names: list
    threshold: float
    intervals: list                  # [(t_start, t_end, max cond)] where cond > threshold
    limbs: bool
    gravity: bool
    q: np.ndarray | None = None
    crossings: list = field(default_factory=list)   # [(t, cond)] singular crossings (det sign change)

    def peaks(self) -> dict:
        k = np.argmax(np.abs(self.tau), axis=0)
        return {n: {"peak_abs": float(abs(self.tau[k[i], i])), "t": float(self.t[k[i]]),
                    "max": float(self.tau[:, i].max()), "min": float(self.tau[:, i].min())}
                for i, n in enumerate(self.drive_names)}

    def outside_intervals(self) -> np.ndarray:
        """Mask of the samples outside every reported ill-conditioned interval."""
        ok = np.ones(len(self.t), dtype=bool)
        for a, b, _ in self.intervals:
            ok &= (self.t < a) | (self.t > b)
        return ok

    def summary(self) -> dict:
        ok = self.outside_intervals()
        return {"drive_names": self.drive_names, "peaks": self.peaks(),
                "peak_abs_all": float(np.abs(self.tau).max()),
                "peak_abs_outside_intervals": float(np.abs(self.tau[ok]).max()) if ok.any() else None,
                "limbs": self.limbs, "gravity": self.gravity,
                "cond_max": float(self.cond.max()), "cond_min": float(self.cond.min()),
                "cond_threshold": self.threshold,
                "ill_conditioned_intervals": [{"t_start": a, "t_end": b, "cond_max": c}
                                              for a, b, c in self.intervals],
                "singular_crossings": [{"t": tc, "cond": c} for tc, c in self.crossings]}


def threshold_intervals(t, x, threshold):
    """Maximal intervals of t where x > threshold: [(t_start, t_end, max x)]."""
    above = np.asarray(x) > threshold
    out = []
    i, n = 0, len(t)
    while i < n:
        if above[i]:
            j = i
            while j + 1 < n and above[j + 1]:
                j += 1
            out.append((float(t[i]), float(t[j]), float(np.max(x[i:j + 1]))))
            i = j + 1
        else:
            i += 1
    return out


def motion_function(mech, motion=None, section=None):
    """The platform motion as a callable t -> (SE3, V, A) (paper order) or t -> SE3.

    motion: a callable, a name of the sidecar's ``screw: motions:``, or None for the sidecar's
    ``platform.motion``."""
    if isinstance(motion, str):
        section = section if section is not None else read_section(mech)
        if motion not in section.motions:
            raise ModelFileError(section.file, "screw.motions", f"unknown platform motion {motion!r}",
                                 choices=list(section.motions))
        return section.motions[motion]
    if motion is None:
        motion = mech.platform_motion
        if motion is None:
            raise ModelFileError(mech.path or mech.name, "platform.motion",
                                 "no platform motion given and none in the sidecar")
    if not callable(motion):
        raise InputError(f"motion: expected a callable, a motion name or None, got {motion!r}")
    return motion


def pose_derivatives(f, t, h=1e-3):
    """(SE3, V, A) of a pose function by 4th-order central differences of pin.log6 (world twist);
    used only when a motion gives poses without derivatives (truncation error ~ h^4)."""
    M0 = f(t)

    def tw(s):
        return from_motion(pin.log6(f(t + s) * M0.inverse()))

    d1, d2 = tw(h), tw(2 * h)
    m1, m2 = tw(-h), tw(-2 * h)
    V = (8 * (d1 - m1) - (d2 - m2)) / (12 * h)
    # twist at t +- h from the same stencil is costly; the spatial acceleration is dV/dt
    Vp = _twist_at(f, t + h, h)
    Vm = _twist_at(f, t - h, h)
    return M0, V, (Vp - Vm) / (2 * h)


def _twist_at(f, t, h):
    M0 = f(t)
    d1 = from_motion(pin.log6(f(t + h) * M0.inverse()))
    m1 = from_motion(pin.log6(f(t - h) * M0.inverse()))
    return (d1 - m1) / (2 * h)


def ik_solver(mech, section=None):
    """Tree configuration for a platform pose, ``solve(M, q_prev) -> q``: the sidecar's
    ``screw: ik:`` when declared, else :func:`numerical_ik`."""
    section = section if section is not None else read_section(mech)
    if section.ik is not None:
        f = section.ik
        return lambda M, q_prev: f(mech, M, q_prev)
    return numerical_ik(mech)


def numerical_ik(mech, tol=1e-13, max_iter=50):
    """Newton on the closures plus the platform frame's pose error (warm-started from the
    previous configuration, else from ``mech.q0``)."""
    model = mech.model
    ws = mech.workspace()
    data = model.createData()
    fid = mech.platform_frame
    m = mech.m_closures

    def solve(M, q_prev):
        q = np.array(mech.q0 if q_prev is None else q_prev, float)
        for _ in range(max_iter):
            kinematics.update_positions(mech, ws, q)
            kinematics.constraint_rows(mech, ws, 0.0, q, ws.zero_v)
            pin.framesForwardKinematics(model, data, q)
            err = pin.log6(M.actInv(data.oMf[fid])).np
            Jf = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL)
            r = np.concatenate([ws.phi[:m], err])
            if np.max(np.abs(r)) < tol:
                return q
            Jr = np.vstack([ws.J[:m], pin.Jlog6(M.actInv(data.oMf[fid])) @ Jf])
            q = pin.integrate(model, q, np.linalg.lstsq(Jr, -r, rcond=None)[0])
        if np.max(np.abs(r)) > 1e-9:
            raise PinclearError(f"{mech.path or mech.name}: cannot place the platform at the commanded pose "
                                f"(residual {np.max(np.abs(r)):.2e})")
        return q

    return solve


def inverse_dynamics(mech, motion=None, t=None, limbs=True, gravity=None, wrench=None, threshold=1e3,
                     system=None, keep_q=False) -> InverseDynamicsResult:
    """Drive forces along a prescribed platform motion by the screw method (paper 004, eq. 26).

    mech: a loaded Mechanism (pinclear.load); motion: callable t -> (SE3, V, A) in the paper's
    order, or t -> SE3 (differentiated numerically), or a name of the sidecar's ``screw:
    motions:``; default the sidecar's platform motion; t: sample times; limbs: include limb
    inertia; gravity: None (the model's), False/True or a 3-vector; wrench: constant external
    wrench (m_o; f) on the platform; threshold: condition number above which an interval is
    reported; system: a :class:`ScrewSystem` of ``mech`` to reuse."""
    sys_ = system or screw_system(mech)
    f = motion_function(mech, motion, sys_.section)
    t = np.atleast_1d(np.asarray(t if t is not None else [0.0], float))
    if gravity is None or gravity is True:
        g = np.array(mech.model.gravity.linear)
        if gravity is True and not np.any(g):
            g = np.array([0.0, 0.0, -9.81])
    elif gravity is False:
        g = np.zeros(3)
    else:
        g = np.asarray(gravity, float)
    ik = ik_solver(mech, sys_.section)
    N, na = len(t), sys_.n_act
    tau = np.zeros((N, 6))
    cw = np.zeros((N, 6))
    cond = np.zeros(N)
    sign = np.zeros(N)
    qs = np.zeros((N, mech.model.nq)) if keep_q else None
    q = None
    for i, ti in enumerate(t):
        out = f(ti)
        M, V, A = out if isinstance(out, tuple) else pose_derivatives(f, ti)
        q = ik(M, q)
        tau[i], info = sys_.inverse_dynamics(q, V, A, limbs=limbs, gravity=g, wrench=wrench)
        Gpq = info["Gpq"]
        # input r balances W with the wrench tau_r * (row r of G_p^q); the virtual rows are the
        # constraint limbs' reactions
        cw[i] = Gpq[na:].T @ tau[i, na:]
        cond[i], sign[i] = cond_sign(Gpq, sys_.length_scale)
        if keep_q:
            qs[i] = q

    def cond_sign_at(s):
        out = f(s)
        return sys_.cond_sign(ik(out[0] if isinstance(out, tuple) else out, None))

    crossings = _crossings(t, sign, cond_sign_at)
    intervals = _merge(threshold_intervals(t, cond, threshold)
                       + [(a, b, c) for a, b, _, c in crossings])
    return InverseDynamicsResult(t=t, tau=tau[:, :na], virtual=tau[:, na:], constraint_wrench=cw, cond=cond,
                                 drive_names=sys_.drive_names, threshold=threshold, intervals=intervals,
                                 limbs=limbs, gravity=bool(np.any(g)), q=qs,
                                 crossings=[(tc, c) for _, _, tc, c in crossings])


def _crossings(t, sign, at):
    """[(t_i, t_i+1, t_crossing, cond at it)] for each sign change of det between samples, the
    crossing located by bisection on the sign (to 1e-10 s)."""
    out = []
    for i in np.nonzero(sign[:-1] * sign[1:] < 0)[0]:
        a, b = float(t[i]), float(t[i + 1])
        sa = sign[i]
        while b - a > 1e-10:
            c = 0.5 * (a + b)
            if at(c)[1] == sa:
                a = c
            else:
                b = c
        tc = 0.5 * (a + b)
        out.append((float(t[i]), float(t[i + 1]), tc, float(at(tc)[0])))
    return out


def _merge(intervals):
    out = []
    for a, b, c in sorted(intervals):
        if out and a <= out[-1][1]:
            pa, pb, pc = out[-1]
            out[-1] = (pa, max(pb, b), max(pc, c))
        else:
            out.append((a, b, c))
    return out



def influence_coefficients(mech, q, system=None):
    """(G, H) at q: first- and second-order influence coefficients of the platform (paper 004,
    eqs. 8, 14), inputs = drives then virtual joints (``screw_system(mech).labels``)."""
    return (system or screw_system(mech)).influence_coefficients(q)


def singularity(mech, q, system=None, tol=1e-9):
    """Rank, condition number and lost motion/wrench of the actuation + constraint wrench system at q."""
    return (system or screw_system(mech)).singularity(q, tol=tol)


def condition_along(mech, q_traj, system=None):
    """Condition number of the actuation map and sign of its determinant at each row of q_traj
    (e.g. a simulated Trajectory.q)."""
    sys_ = system or screw_system(mech)
    out = np.zeros(len(q_traj))
    sign = np.zeros(len(q_traj))
    for i, q in enumerate(q_traj):
        out[i], sign[i] = sys_.cond_sign(q)
    return out, sign


def monitor(mech, traj, threshold=1e3, system=None) -> dict:
    """Condition-number monitor of a simulated trajectory (``traj.t``, ``traj.q``): the series, the
    intervals above threshold and the sample pairs between which det changes sign (a crossing)."""
    cond, sign = condition_along(mech, traj.q, system)
    t = np.asarray(traj.t)
    flips = [(float(t[i]), float(t[i + 1]), max(cond[i], cond[i + 1]))
             for i in np.nonzero(sign[:-1] * sign[1:] < 0)[0]]
    return {"t": t, "cond": cond, "threshold": threshold,
            "intervals": _merge(threshold_intervals(t, cond, threshold) + flips)}


# --------------------------------------------------------------------------- Lagrangian reference
def lagrange_inverse_dynamics(mech, q, v, a, ws=None):
    """Drive forces from Pinocchio: tau = rnea(q, v, a), then J^T lam = tau with J the closure and
    drive rows (sign convention M a + b = tau + J^T lam); returns lam for the drives."""
    ws = ws or mech.workspace()
    kinematics.update_positions(mech, ws, q)
    kinematics.constraint_rows(mech, ws, 0.0, q, ws.zero_v)
    J = ws.J[:mech.m]
    tau = pin.rnea(mech.model, ws.data, q, v, a)
    lam = np.linalg.lstsq(J.T, tau, rcond=None)[0]
    return lam[mech.m_closures:]
