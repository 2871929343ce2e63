"""Signals of a run: a scalar coordinate and its exact rate (joints, frame coordinates, outputs, multipliers)."""
from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np
import pinocchio as pin
from scipy.interpolate import CubicSpline

from pinclear.core.errors import InputError
from pinclear.model.kinematics import frame_motion

LWA = pin.LOCAL_WORLD_ALIGNED
_AXES = {"x": 0, "y": 1, "z": 2}
_INDEX = re.compile(r"^(.*)\[(-?\d+)\]$")


@dataclass
class Series:
    """A scalar signal of a run: x(t), its rate xdot(t) and, where known, its second derivative."""

    t: np.ndarray
    x: np.ndarray
    xdot: np.ndarray
    xddot: np.ndarray | None
    label: str
    exact_rate: bool = True
    unit: str | None = None         # SI unit of x (None: not known); the rate's is unit/s


#: units of the force elements' outputs (pinclear.contact.channels.RECORD, pinclear.model.forces)
OUTPUT_UNITS = {"penetration": "m", "normal_force": "N", "friction_force": "N", "fn": "N", "contact": "-",
                "dissipated": "J", "eccentricity": "m", "length": "m", "force": "N"}


def joint_unit(jm) -> str:
    """'m' for a prismatic joint's coordinate, 'rad' for the others' (revolute, spherical...)."""
    name = jm.shortname()
    return "m" if "Prismatic" in name or name[:-1].endswith("JointModelP") else "rad"


def axis_label(label, unit, rate=False) -> str:
    """An axis label with its unit: 'A.eccentricity[0] [m]', 'd/dt A.eccentricity[0] [m/s]'."""
    text = f"d/dt {label}" if rate else label
    if unit is None:
        return text
    return f"{text} [{'1/s' if rate and unit == '-' else unit + '/s' if rate else unit}]"


def _split_index(spec: str):
    m = _INDEX.match(spec)
    return (m.group(1), int(m.group(2))) if m else (spec, None)


def _spline_rate(t, x):
    if len(t) < 2:
        return np.zeros_like(x)
    if len(t) < 4:
        return np.gradient(x, t)
    return CubicSpline(t, x)(t, 1)


def _remembered(memo, key, compute):
    """compute() once per key of ``memo`` (a dict kept for one trajectory: the signals of one
    run, e.g. platform.x, .y and .z, share one pass over its samples); no memo: compute()."""
    if memo is None:
        return compute()
    if key not in memo:
        memo[key] = compute()
    return memo[key]


def _frame_series(model, fid, traj, memo=None):
    """World position, LWA linear velocity and classical acceleration of a frame origin."""
    def compute():
        acc = traj.a if traj.a.shape == traj.v.shape and np.all(np.isfinite(traj.a)) else None
        fm = frame_motion(model, [fid], traj.q, traj.v, acc)
        return fm.p[:, 0], fm.v[:, 0], fm.a[:, 0]

    return _remembered(memo, ("frame", int(fid)), compute)


def relative_rate(model, f1, f2, traj, memo=None):
    """d/dt of e = R1^T (p2 - p1) (the eccentricity in body 1's frame):
    R1^T (v2 - v1 - w1 x (p2 - p1)), with origin velocities and w1 in world axes. ``memo``: a
    dict kept for this trajectory (the three components of one eccentricity share the pass)."""
    def compute():
        fm = frame_motion(model, [f1, f2], traj.q, traj.v)
        d = fm.p[:, 1] - fm.p[:, 0]
        rel = fm.v[:, 1] - fm.v[:, 0] - np.cross(fm.w[:, 0], d)
        return np.einsum("nji,nj->ni", fm.R[:, 0], rel)

    return _remembered(memo, ("relative", int(f1), int(f2)), compute)


def _signal_choices(traj, mech):
    model = mech.model if mech is not None else None
    ch = []
    if model is not None:
        ch += [f"joint {n}" for n in list(model.names)[1:]]
        ch += [f"{f.name}.x|y|z" for f in model.frames if f.type in (pin.FrameType.BODY, pin.FrameType.OP_FRAME)]
        if mech.platform_frame is not None:
            ch.append("platform.x|y|z")
    ch += [f"output {k}" for k in traj.outputs]
    ch += [f"multiplier {k}" for k in traj.lam]
    return ch


def series(traj, signal, mech=None, memo=None) -> Series:
    """Resolve ``signal`` (see the module docstring) on the samples of ``traj``. ``memo``: a dict
    the caller keeps for this one trajectory, so that several signals of it share the frame
    kinematics (the same numbers as without it: each pass is computed once and reused)."""
    mech = mech if mech is not None else getattr(traj, "mech", None)
    t = np.asarray(traj.t, float)
    if callable(signal):
        out = signal(traj)
        label = getattr(signal, "__name__", "signal")
        if isinstance(out, tuple) and len(out) == 2:
            return Series(t, np.asarray(out[0], float), np.asarray(out[1], float), None, label)
        x = np.asarray(out, float)
        return Series(t, x, _spline_rate(t, x), None, label, exact_rate=False)
    if isinstance(signal, (tuple, list)):
        if len(signal) != 2:
            raise InputError(f"a signal pair is (x_spec, xdot_spec), got {signal!r}")
        sx, sv = series(traj, signal[0], mech, memo), series(traj, signal[1], mech, memo)
        return Series(t, sx.x, sv.x, sv.xdot, f"{sx.label} / {sv.label}", exact_rate=True)
    if not isinstance(signal, str):
        raise InputError(f"signal must be a name, a (x, xdot) pair of names or a callable, got {signal!r}")
    base, idx = _split_index(signal)
    model = mech.model if mech is not None else None
    # ---- joint coordinate
    if model is not None and base != "universe" and model.existJointName(base):
        jm = model.joints[model.getJointId(base)]
        if jm.nq != jm.nv:
            raise InputError(f"signal {signal!r}: joint {base!r} ({jm.shortname()}) has nq != nv, its "
                             "coordinates are not plain numbers: use a frame coordinate '<frame>.x|y|z'")
        k = 0 if idx is None else idx
        if not 0 <= k < jm.nv:
            raise InputError(f"signal {signal!r}: joint {base!r} has {jm.nv} coordinate(s), index {k} is out of range")
        a = traj.a[:, jm.idx_v + k] if traj.a.shape == traj.v.shape else None
        return Series(t, traj.q[:, jm.idx_q + k].copy(), traj.v[:, jm.idx_v + k].copy(), a, signal,
                      unit=joint_unit(jm))
    # ---- force-element output
    if base in traj.outputs:
        arr = np.asarray(traj.outputs[base], float)
        if arr.ndim == 2:
            if idx is None:
                if arr.shape[1] != 1:
                    raise InputError(f"signal {signal!r}: output {base!r} has {arr.shape[1]} components: "
                                     f"add an index, e.g. '{base}[1]'")
                idx = 0
            if not -arr.shape[1] <= idx < arr.shape[1]:
                raise InputError(f"signal {signal!r}: output {base!r} has {arr.shape[1]} components")
            x = arr[:, idx].copy()
        else:
            x = arr.reshape(len(t)).copy()
        elem_name, _, what = base.rpartition(".")
        unit = OUTPUT_UNITS.get(what)
        elem = None
        if mech is not None:
            elem = next((f for f in mech.forces if f.name == elem_name), None)
        if what == "eccentricity" and elem is not None and elem.is_clearance \
                and arr.ndim == 2 and arr.shape[1] == 3:
            rate = relative_rate(model, elem.f1, elem.f2, traj, memo)[:, idx]
            return Series(t, x, rate, None, signal, unit=unit)
        return Series(t, x, _spline_rate(t, x), None, signal, exact_rate=False, unit=unit)
    # ---- constraint multiplier (drive force, closure row)
    if signal in traj.lam:
        x = np.asarray(traj.lam[signal], float).copy()
        return Series(t, x, _spline_rate(t, x), None, signal, exact_rate=False)
    # ---- frame coordinate
    fname, _, comp = signal.rpartition(".")
    if model is not None and comp in _AXES and fname:
        fid = None
        if fname == "platform" and mech.platform_frame is not None and not model.existFrame("platform"):
            fid = mech.platform_frame
        elif model.existFrame(fname):
            fid = model.getFrameId(fname)
        if fid is not None:
            P, V, A = _frame_series(model, fid, traj, memo)
            c = _AXES[comp]
            return Series(t, P[:, c], V[:, c], A[:, c], signal, unit="m")
    if mech is None:
        raise InputError(f"signal {signal!r}: not an output of the run ({', '.join(traj.outputs) or 'none'}) and "
                         "the trajectory carries no mechanism: pass mech= to resolve joints and frames")
    ch = _signal_choices(traj, mech)
    shown = ", ".join(ch[:30]) + (f", ... ({len(ch) - 30} more)" if len(ch) > 30 else "")
    raise InputError(f"unknown signal {signal!r} (valid: {shown})")


def phase_portrait(traj, signal, mech=None, t_min=None):
    """(x, xdot) arrays of ``signal`` over the samples of ``traj`` (from ``t_min`` on)."""
    s = series(traj, signal, mech)
    keep = slice(None) if t_min is None else s.t >= t_min
    return s.x[keep], s.xdot[keep]
