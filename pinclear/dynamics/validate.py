"""Checks on what pinclear reads back from disk: saved runs, checkpoints, run descriptions.

A results folder is data, never authority (docs/security.md): every NPZ is checked from its
headers before a byte of array data is read (no object arrays, bounded declared sizes), then its
contents are checked against the mechanism they claim to belong to (sizes, finite values,
increasing times, a state on the constraint manifold) before any compiled code touches them.
A checkpoint carries the identity of its run (:func:`run_identity`) so that a stale one from
another run is refused with the differences named.
"""
from __future__ import annotations

import hashlib
import json
import math
import os
import stat
import zipfile
import zlib

import numpy as np

from pinclear.core.errors import InputError
from pinclear.core.failures import Failure, FailureKind
from pinclear.core.jsonsafe import jsonable
from pinclear.dynamics.tolerances import RTOL_DEFAULT, default_atol

#: bound on one array's declared size: a saved run of MAX_SAMPLES samples of a 60-coordinate
#: tree is ~1 GB, so an array declaring more is not one pinclear wrote
MAX_ARRAY_BYTES = 1 << 30
#: bound on the sum of the declared sizes of an archive's arrays
MAX_TOTAL_BYTES = 4 << 30
#: bound on the number of arrays in an archive (multipliers and outputs are a few per element)
MAX_MEMBERS = 20_000
#: array kinds pinclear writes (float data, the JSON metadata string); never objects
_KINDS = "fiub" + "U"


def file_error(path, message):
    return InputError(f"{path}: {message}")


def read_npz(path, what="file") -> dict:
    """Every array of an NPZ archive, after checking each member's header: a regular file, a zip
    of .npy members, no object dtype, declared sizes within MAX_ARRAY_BYTES / MAX_TOTAL_BYTES.
    Errors are InputError naming the file (``what`` says what it should have been)."""
    import numpy.lib.format as fmt

    try:
        st = os.stat(path)
    except OSError as exc:
        raise file_error(path, f"cannot read the {what}: {exc.strerror}") from None
    if not stat.S_ISREG(st.st_mode):
        raise file_error(path, f"not a regular file (a folder or a device), not a pinclear {what}")
    total = 0
    try:
        with zipfile.ZipFile(path) as zf:
            infos = zf.infolist()
            if len(infos) > MAX_MEMBERS:
                raise file_error(path, f"{len(infos)} arrays (at most {MAX_MEMBERS}): not a pinclear {what}")
            for info in infos:
                name = info.filename
                if not name.endswith(".npy"):
                    raise file_error(path, f"member {name!r} is not a .npy array: not a pinclear {what}")
                with zf.open(info) as fh:
                    version = fmt.read_magic(fh)
                    if version == (1, 0):
                        shape, _, dtype = fmt.read_array_header_1_0(fh)
                    elif version == (2, 0):
                        shape, _, dtype = fmt.read_array_header_2_0(fh)
                    else:
                        raise file_error(path, f"array {name[:-4]!r} has .npy format {version}, not 1.0 or 2.0")
                if dtype.hasobject or dtype.kind not in _KINDS:
                    raise file_error(path, f"array {name[:-4]!r} has dtype {dtype} (pinclear writes numbers and text only)")
                nbytes = math.prod(int(s) for s in shape) * dtype.itemsize
                if nbytes > MAX_ARRAY_BYTES:
                    raise file_error(path, f"array {name[:-4]!r} declares shape {tuple(shape)} ({nbytes / 1e9:.3g} GB; at "
                                     f"most {MAX_ARRAY_BYTES / 1e9:.3g} GB): refused before loading")
                total += nbytes
                if total > MAX_TOTAL_BYTES:
                    raise file_error(path, f"the arrays declare more than {MAX_TOTAL_BYTES / 1e9:.3g} GB: refused before "
                                     "loading")
            arrays = {}
            for info in infos:
                with zf.open(info) as fh:
                    arrays[info.filename[:-4]] = fmt.read_array(fh, allow_pickle=False)
    except InputError:
        raise
    except zipfile.BadZipFile as exc:
        raise file_error(path, f"not a readable pinclear {what} (not an NPZ archive, or truncated: {exc})") from None
    except (OSError, EOFError, ValueError, zlib.error, KeyError, NotImplementedError, TypeError,
            zipfile.LargeZipFile, RuntimeError) as exc:
        raise file_error(path, f"not a readable pinclear {what} ({type(exc).__name__}: "
                         f"{' '.join(str(exc).split())[:200]})") from None
    return arrays


def read_meta(arrays, path, what="file") -> dict:
    """The JSON mapping stored as the archive's ``meta`` string."""
    m = arrays.get("meta")
    if m is None or m.shape != () or m.dtype.kind != "U":
        raise file_error(path, f"no metadata string: not a pinclear {what}")
    try:
        meta = json.loads(str(m))
    except (ValueError, RecursionError) as exc:
        raise file_error(path, f"metadata is not JSON ({exc})") from None
    if not isinstance(meta, dict):
        raise file_error(path, f"metadata is a {type(meta).__name__}, not a mapping")
    return meta


def real_array(arrays, key, path, ndim, finite=True, rows=None, cols=None):
    """arrays[key] as float, with ndim dimensions, rows/cols as given, finite when asked."""
    if key not in arrays:
        raise file_error(path, f"array {key!r} is missing")
    a = arrays[key]
    if a.dtype.kind not in "fiub":
        raise file_error(path, f"array {key!r} holds {a.dtype}, not numbers")
    a = np.asarray(a, float)
    if a.ndim != ndim:
        raise file_error(path, f"array {key!r} has shape {a.shape}, expected {ndim} dimension(s)")
    if rows is not None and a.shape[0] != rows:
        raise file_error(path, f"array {key!r} has {a.shape[0]} rows, expected {rows}")
    if cols is not None and a.shape[-1] != cols:
        raise file_error(path, f"array {key!r} has {a.shape[-1]} entries per row, expected {cols}")
    if finite and not np.all(np.isfinite(a)):
        raise file_error(path, f"array {key!r} holds nan or inf")
    return a


def number(x, path, key, positive=False, allow_none=False, integer=False):
    """A JSON number from a metadata field, checked (bool is not a number here)."""
    if x is None and allow_none:
        return None
    from pinclear.core.bounded import shown

    try:            # math.isfinite and float() overflow on an integer beyond the float range
        ok = isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) \
            and (isinstance(x, float) or abs(x) < 2 ** 63)
    except OverflowError:
        ok = False
    if ok and integer:
        ok = float(x).is_integer() and x >= 0
    if ok and positive:
        ok = x > 0
    if not ok:
        kind = "a positive number" if positive else "a non-negative integer" if integer else "a finite number"
        raise file_error(path, f"{key}: expected {kind}, got {shown(x)}")
    return int(x) if integer else float(x)


def increasing(t, path, key, strict=False):
    d = np.diff(t)
    if np.any(d < 0) or (strict and np.any(d == 0)):
        i = int(np.argmax(d <= 0 if strict else d < 0))
        raise file_error(path, f"{key}: times are not increasing (t[{i}] = {t[i]!r}, t[{i + 1}] = {t[i + 1]!r})")


# ------------------------------------------------------------------ the identity of a run
def mechanism_digest(mech) -> str:
    """SHA-256 over what determines a mechanism's dynamics: its description (closures, drives,
    force elements with their parameters, gravity, options) and the tree's inertias and joint
    placements (an edited URDF is another mechanism)."""
    desc = mech.describe()
    desc.pop("path", None)
    h = hashlib.sha256(json.dumps(_plain(desc), sort_keys=True).encode())
    model = mech.model
    for j in range(model.njoints):
        inertia = model.inertias[j]
        h.update(np.ascontiguousarray(np.r_[inertia.mass, np.asarray(inertia.lever).ravel(),
                                            np.asarray(inertia.inertia).ravel()], float).tobytes())
        h.update(np.ascontiguousarray(model.jointPlacements[j].homogeneous, float).tobytes())
    return h.hexdigest()


def _plain(x):
    return jsonable(x)


def run_identity(mech, *, method, method_options, integrator, rtol, atol, t0, t_end, t_eval, h, max_step) -> dict:
    """What a checkpoint must match to continue a run: the mechanism (digest), the method and
    its options, the integrator and its tolerances and step options, the time span and output
    times (digest). JSON-able; compared key by key by :func:`identity_differences`."""
    te = np.ascontiguousarray(np.asarray(t_eval, float))
    return _plain({"mechanism": mechanism_digest(mech), "mechanism_name": mech.name, "method": method,
                   "method_options": dict(method_options or {}), "integrator": integrator, "rtol": rtol,
                   "atol": atol if atol is None or np.isscalar(atol) else list(np.ravel(atol)),
                   "t0": float(t0), "t_end": float(t_end), "h": h,
                   "max_step": None if max_step is None or not math.isfinite(max_step) else float(max_step),
                   "t_eval": f"{len(te)} samples, sha256 {hashlib.sha256(te.tobytes()).hexdigest()[:16]}"})


def identity_differences(recorded, current) -> list[str]:
    """Human-readable differences between a checkpoint's identity and this run's."""
    if not isinstance(recorded, dict):
        return ["the checkpoint records no run identity (written by another program or an older pinclear)"]
    out = []
    for k in current:
        a, b = recorded.get(k, "<missing>"), current[k]
        if a != b:
            if k == "mechanism":
                out.append("mechanism: its description or model differs (closures, drives, forces, gravity, "
                           "options, inertias or joint placements)")
            else:
                out.append(f"{k}: {a!r} (checkpoint) vs {b!r} (this run)")
    return out


# ------------------------------------------------------------------ honest status
def mechanism_length(mech) -> float:
    """A length scale of the mechanism: the sum of the tree's joint offsets (m), at least 1 mm."""
    model = mech.model
    return max(sum(float(np.linalg.norm(model.jointPlacements[j].translation)) for j in range(1, model.njoints)), 1e-3)


#: the closure residual may exceed its tolerance-derived bound by this factor before a run fails
RESIDUAL_SAFETY = 10.0


def residual_bound(mech, rtol, atol, steps, q_scale=1.0, n_state=None) -> float:
    """Bound on the closure residual an adaptive run may reach (m, or rad for rotation rows).

    Each accepted step's local error is at most atol + rtol |x_i| per state component (the RMS
    norm of the embedded error estimate over n components is <= 1); a residual row phi(q) moves
    by at most |J| |dq| with |J| <= L (the tree's lever arm, at least 1 for angle rows). Without
    stabilization the errors add, so after N steps |phi| <= N sqrt(n) L (atol + rtol |q|_inf),
    times RESIDUAL_SAFETY. A run beyond that has left its constraint manifold for a reason the
    tolerances do not explain (a singular start, a wild velocity guess, an ill-conditioned mass
    matrix) and its status cannot be success."""
    n = n_state if n_state is not None else mech.nq + mech.nv
    tol = float(np.max(atol)) + float(rtol) * max(1.0, float(q_scale))
    return RESIDUAL_SAFETY * max(int(steps), 1) * math.sqrt(max(n, 1)) * max(mechanism_length(mech), 1.0) * tol


# ------------------------------------------------------------------ checkpoints
def check_checkpoint(ck, mech, path="<checkpoint>", identity=None, ws=None):
    """Refuse a checkpoint that cannot continue a run of ``mech`` (sizes, finite values,
    increasing times inside [t0, t], a state on the constraint manifold, the run identity)."""
    sizes = {"q": mech.nq, "v": mech.nv, "z": mech.nz, "q_now": mech.nq, "v_now": mech.nv, "z_now": mech.nz}
    for k, n in sizes.items():
        a = np.asarray(getattr(ck, k), float) if getattr(ck, k) is not None else None
        if a is None or a.shape != (n,):
            raise file_error(path, f"{k} has shape {None if a is None else a.shape}, mechanism {mech.name!r} needs ({n},): "
                             "the checkpoint does not belong to this mechanism")
        if not np.all(np.isfinite(a)):
            raise file_error(path, f"{k} holds nan or inf")
        setattr(ck, k, np.ascontiguousarray(a))
    t0 = number(ck.t0, path, "t0")
    t = number(ck.t, path, "t")
    if t < t0:
        raise file_error(path, f"t = {t!r} lies before t0 = {t0!r}")
    number(ck.h_next, path, "h_next", positive=True, allow_none=True)
    if not isinstance(ck.samples, list):
        raise file_error(path, "samples must be a list")
    last = -math.inf
    for i, s in enumerate(ck.samples):
        if not isinstance(s, (list, tuple)) or len(s) != 4:
            raise file_error(path, f"sample {i} is not (t, q, v, z)")
        ts = number(s[0], path, f"samples[{i}].t")
        if ts < last or ts < t0 or ts > t:
            raise file_error(path, f"sample times must increase inside [t0, t] = [{t0!r}, {t!r}]; sample {i} is at {ts!r}")
        last = ts
        for k, (a, n) in zip("qvz", zip(s[1:], (mech.nq, mech.nv, mech.nz))):
            a = np.asarray(a, float)
            if a.shape != (n,) or not np.all(np.isfinite(a)):
                raise file_error(path, f"sample {i}: {k} has shape {a.shape} or non-finite values (needs {n} finite numbers)")
    if not isinstance(ck.stats, dict):
        raise file_error(path, "stats must be a mapping")
    for k in ("rhs_evals", "steps", "restarts"):
        if k in ck.stats:
            number(ck.stats[k], path, f"stats.{k}", integer=True)
    if "cpu_s" in ck.stats:
        number(ck.stats["cpu_s"], path, "stats.cpu_s")
    events = ck.stats.get("events", [])
    if not isinstance(events, list) or not all(isinstance(e, dict) for e in events):
        raise file_error(path, "stats.events must be a list of mappings")
    # a checkpoint built in Python (identity None: e.g. analysis.lyapunov restarting from a state
    # it chose) is the caller's own; one read from a file always carries its run's identity
    if identity is not None and getattr(ck, "identity", None) is not None:
        diffs = identity_differences(ck.identity, identity)
        if diffs:
            raise file_error(path, "the checkpoint belongs to another run: " + "; ".join(diffs))
    _check_on_manifold(ck, mech, path, ws, identity)


def _check_on_manifold(ck, mech, path, ws, identity):
    """Unit quaternions and closure rows satisfied at the initial and the current state, within
    the run's residual bound (stats.steps so far) or 1e-6 of the mechanism's size if larger."""
    import pinocchio as pin

    from pinclear.model import kinematics

    ws = ws if ws is not None else mech.workspace()
    mc = mech.compiled.m
    rtol = (identity or {}).get("rtol") or RTOL_DEFAULT
    atol = default_atol(rtol, (identity or {}).get("atol"))
    steps = int(ck.stats.get("steps", 0) or 0)
    bound = max(residual_bound(mech, rtol, atol, steps, q_scale=float(np.max(np.abs(ck.q_now), initial=1.0))),
                1e-6 * mechanism_length(mech))
    for name, tq, q, v in (("q", ck.t0, ck.q, ck.v), ("q_now", ck.t, ck.q_now, ck.v_now)):
        if not pin.isNormalized(mech.model, q, 1e-6):
            raise file_error(path, f"{name} is not a valid configuration (a quaternion of non-unit norm)")
        if mc:
            kinematics.update(mech, ws, q, v)
            kinematics.constraint_rows(mech, ws, tq, q, v)
            r = float(np.max(np.abs(ws.phi[:mc])))
            if not r <= bound:
                raise file_error(path, f"{name} is off the constraint manifold: closure residual {r:.3g} exceeds "
                                 f"{bound:.3g} (the bound of the run so far)")


def check_residual(traj, mech, rtol, atol):
    """Honest status: a run whose closure residual exceeds the bound its tolerances allow
    (:func:`residual_bound`) ends as failed, samples kept, naming the residual, when it first
    exceeded the bound, and the bound (docs/security.md, 'honest status'). True if so."""
    if not len(traj.t) or not mech.compiled.m:
        return False
    res = np.nan_to_num(traj.residual, nan=0.0)
    bound = residual_bound(mech, rtol, atol, traj.stats.get("steps", 0),
                           q_scale=float(np.max(np.abs(traj.q), initial=1.0)))
    bound += float(res[0])                 # what the assembly left at the start
    if np.all(res <= bound):
        return False
    k = int(np.argmax(res > bound))
    traj.stats["constraint_violation"] = {"t": float(traj.t[k]), "max_residual": float(res.max()), "bound": bound}
    traj.status = "failed"
    traj.message = (f"constraint violated: closure residual {res.max():.3g} exceeds {bound:.3g}, the bound "
                    f"rtol = {rtol:g} allows over {traj.stats.get('steps', 0)} steps (first at t = "
                    f"{traj.t[k]:.9g} s); the motion left its constraint manifold (a singular start, a "
                    "huge initial velocity, an ill-conditioned mass matrix?): try method projection or a "
                    f"smaller rtol (samples kept up to t = {traj.t[-1]:.6g} s)")
    traj.failure = Failure(FailureKind.CONSTRAINT, float(traj.t[k]), traj.message)
    return True


# ------------------------------------------------------------------ fixed-step runs
#: default of simulate(fixed_step_tol=...): a fixed-step run whose step-doubling error estimate,
#: closure residual or energy-balance error exceeds this (relative) fails. It is a sanity bound,
#: not an accuracy request: RK4 at a usable step is orders of magnitude below it (four-bar,
#: h = 1e-2 s: residual 1.8e-5 m), while `--h 10` gave a 0.999 m residual and success.
FIXED_STEP_TOL = 1e-2
#: RK4's order: the error of the run at h is about (x_h - x_2h) / (2**p - 1) (Richardson)
FIXED_STEP_ORDER = 4


def fixed_step_estimate(traj, coarse, mech) -> float:
    """Step-doubling estimate of a fixed-step run's error in its configurations, relative to
    their scale: the largest difference between the run at h and the same run at 2h over the
    common samples (pin.difference), divided by 2**p - 1 and by max(1, |q|). Velocities are left
    out: an impact's velocity jump shifted by a step's fraction makes a velocity difference of
    the contact's acceleration times that shift, which says nothing about the motion's accuracy
    (clr_planar_pendulum at h = 1e-5 s: 1.4e-2 in v, energy balance error 8e-5). Infinite when
    the run at 2h failed or has fewer samples (h is within a factor 2 of instability)."""
    import pinocchio as pin

    n = len(traj.t)
    if coarse.status != "success" or len(coarse.t) < n or not n:
        return math.inf
    dq = max((float(np.max(np.abs(pin.difference(mech.model, qc, qh)), initial=0.0))
              for qc, qh in zip(coarse.q[:n], traj.q)), default=0.0)
    scale = max(1.0, float(np.max(np.abs(traj.q), initial=0.0)))
    est = dq / (2 ** FIXED_STEP_ORDER - 1) / scale
    return est if math.isfinite(est) else math.inf


def check_fixed_step(traj, mech, coarse, h, tol) -> bool:
    """A-posteriori check of a successful fixed-step run (no tolerance bounds its error a
    priori): fails it, samples kept, naming each broken criterion, when the step-doubling
    estimate (:func:`fixed_step_estimate`, ``coarse`` is the run at 2h), the closure residual
    (relative to the mechanism's size, :func:`mechanism_length`) or the energy audit's error
    (beyond its closure-drift and quadrature terms) exceeds ``tol``. True if it failed."""
    from pinclear.dynamics.energy import energy_balance

    if tol is None or traj.status != "success" or not len(traj.t):
        return False
    broken = []
    est = fixed_step_estimate(traj, coarse, mech)
    record = {"tol": tol, "step_doubling": est}
    if not est <= tol:
        broken.append(f"step-doubling error estimate {est:.3g}" + (" (the run at 2h failed)" if math.isinf(est) else ""))
    if mech.compiled.m:
        res = np.nan_to_num(traj.residual, nan=math.inf)
        r = float(res.max() - res[0])
        L = max(mechanism_length(mech), 1.0)
        record["residual"] = r / L
        if not r <= tol * L:
            broken.append(f"closure residual {r:.3g} m (over {tol * L:.3g} = tol x the mechanism's size {L:.3g} m)")
    eb = energy_balance(traj)
    if eb.get("error") is not None:
        terms = eb.get("bound_terms") or {}
        allowed = tol + terms.get("closure_drift", 0.0) + terms.get("quadrature", 0.0)
        record["energy"] = eb["error"]
        if not eb["error"] <= allowed:
            broken.append(f"energy balance off by {eb['error']:.3g} of the run's energy scale (over {allowed:.3g})")
    traj.stats["fixed_step_check"] = record
    if not broken:
        return False
    traj.status = "failed"
    traj.message = (f"fixed step h = {h:g} s is too large: " + "; ".join(broken) + f" (fixed_step_tol = {tol:g}); "
                    f"use a smaller h or an adaptive integrator (samples kept up to t = {traj.t[-1]:.6g} s)")
    traj.failure = Failure(FailureKind.FIXED_STEP, float(traj.t[-1]), traj.message)
    return True
