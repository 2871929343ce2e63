"""Long-horizon Archard wear of a revolute clearance (``pinclear wear``; docs/wear_lubrication.md).

The standard iterative scheme of the worn-joint literature (Flores 2009, Mech. Mach. Theory 44,
1211, sec. 4; Mukras et al. 2010, Wear 268, 643, sec. 3): simulate ``block_periods`` periods of the
mechanism with the bearing's current profile, integrate the Archard depth over the block's samples
(pinclear.contact.wear.block_increment), scale it by the update factor (cycles each simulated cycle
stands for), reshape the bearing, continue from the block's last state. Two ways to choose the
factor (``scheme``):

- ``factor``: the same factor for every update, cycles / (updates x block_periods);
  :func:`converged` doubles the updates until halving the factor changes every worn joint's final
  maximum depth by <= ``tol`` (5 %).
- ``depth`` (depth-limited update): each update's factor is chosen from the block just simulated so
  that the largest nodal depth increment of any worn joint is ``step`` x that joint's radial
  clearance c (never below one cycle per simulated cycle; the last update takes what is left of
  the life). The wear step is limited in depth, not in cycles, as in the FE wear literature
  (Podra & Andersson 1999, Tribol. Int. 32, 71: the wear step sized by the largest nodal wear
  increment; Mukras et al. 2009, Wear 266, 822: the extrapolation step adapted to the change of the
  contact pressure): where the worn profile changes the motion (the rate grows with the depth),
  the updates are as fine in depth at the end of the life as at its start. The scheme is explicit
  Euler in the cycles with the depth as its step control: its error is first order in ``step``.
  :func:`converged` halves ``step`` until halving it changes every joint's final maximum depth by
  <= ``tol``, counting only a halving that made more updates (two trials both held at one update
  by the life's end are not a test).

Mesh: either scheme's converged trial is then repeated with the wear cells halved (a bearing's
nodes, a socket's rows doubled: :func:`refined`); halving the cell must change the largest depth
and the profile's L2 norm (RMS depth, :func:`profile_norm`) by <= ``tol`` of the largest depth
(:func:`mesh_change`), else the test has not converged (``mesh`` in its result). The explicit update
is stable only while one update wears less than the contact patch's approach (about the new
bearing's Hertz approach b^2 / (2 R*), docs/wear_lubrication.md sec. 8).

Energy: each block is audited on its own (pinclear.dynamics.energy.energy_balance, between reshapes); a
reshape changes the contact's elastic energy at a fixed state by a jump that is neither work nor
dissipation, reported apart (``jump``: the total energy at the next block's first sample less the
block's last).

Files (all through pinclear.core.safeio, written after every update, so an interrupt loses at most the
block under way, and a second call with the same folder resumes): OUT/checkpoint.npz (profile,
state, history, the run's identity), OUT/history.csv, OUT/profile.csv (depth vs angle, degrees
labelled).

A checkpoint is data, never authority (docs/security.md): it carries the identity of its run
(:func:`wear_identity`: the contact models' version, the mechanism's digest with every active
clearance's parameters and wear mapping, the load's overrides, the settings, the start), is read
through pinclear.dynamics.validate.read_npz, and every field is checked for type, shape, sign and
bound against this run before it is used (:func:`_load_checkpoint`); a mismatch is refused naming
the field. A depth beyond ``max_depth_fraction`` of a bearing's (socket's) radius ends the trial as
failed, naming the joint (its last checkpoint is the update before).
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from pinclear.core import safeio
from pinclear.core.errors import ContactSetupError, InputError

#: history columns every run has; each worn joint NAME adds NAME.max_depth (m) and NAME.worn_volume (m^3)
HISTORY = ("cycles", "audit_error", "audit_bound", "jump", "cpu_sim", "cpu_update", "factor")
SCHEMES = ("factor", "depth")


@dataclass(frozen=True)
class WearSettings:
    """cycles: service life (mechanism periods); period (s); block_periods: periods simulated per
    update; updates: number of reshapes over the life (the update factor is cycles / updates /
    block_periods); transient_periods: simulated first, without wear (start-up landings);
    rtol, dt_out: of each block's integration (the wear quadrature uses its samples);
    scheme: ``factor`` (``updates`` fixed factors) or ``depth`` (each update's largest nodal
    increment ``step`` x the joint's clearance; at most ``max_updates`` updates); max_depth_fraction:
    a trial whose depth exceeds this fraction of a bearing's (socket's) radius ends as failed."""
    cycles: float
    period: float
    updates: int = 4
    block_periods: int = 1
    transient_periods: int = 1
    rtol: float = 1e-6
    dt_out: float = 1e-4
    scheme: str = "factor"
    step: float = 0.01
    max_updates: int = 2000
    max_depth_fraction: float = 0.05

    def check(self):
        for key in ("cycles", "period", "rtol", "dt_out"):
            v = getattr(self, key)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InputError(f"{key} must be a number > 0, got {v!r}", key=key)
        for key in ("updates", "block_periods"):
            v = getattr(self, key)
            if not (isinstance(v, int) and v >= 1):
                raise InputError(f"{key} must be an integer >= 1, got {v!r}", key=key)
        if self.scheme not in SCHEMES:
            raise InputError(f"scheme must be one of {', '.join(SCHEMES)}, got {self.scheme!r}", key="scheme",
                             choices=SCHEMES)
        if not (isinstance(self.step, (int, float)) and 0 < self.step <= 1):
            raise InputError(f"step must be a fraction of the clearance in (0, 1], got {self.step!r}", key="step")
        f = self.max_depth_fraction
        if not (isinstance(f, (int, float)) and not isinstance(f, bool) and 0 < f <= 0.5):
            raise InputError(f"max_depth_fraction must be a fraction of the radius in (0, 0.5], got {f!r}",
                             key="max_depth_fraction")
        if not (isinstance(self.max_updates, int) and self.max_updates >= 1):
            raise InputError(f"max_updates must be an integer >= 1, got {self.max_updates!r}", key="max_updates")
        if not (isinstance(self.transient_periods, int) and self.transient_periods >= 0):
            raise InputError(f"transient_periods must be an integer >= 0, got {self.transient_periods!r}",
                             key="transient_periods")
        if self.scheme == "factor" and self.cycles < self.updates * self.block_periods:
            raise InputError(f"cycles ({self.cycles:g}) must be at least updates x block_periods "
                             f"({self.updates * self.block_periods}): an update factor below 1", key="cycles")

    @property
    def factor(self) -> float:
        """Cycles each simulated cycle stands for (the update factor)."""
        return self.cycles / (self.updates * self.block_periods)


def worn_joint(mech, name):
    """(index in mech.forces, joint) of the worn clearance ``name``; a clear error otherwise."""
    from pinclear.contact.wear import WornJoint

    names = [f.name for f in mech.clearances]
    for i, f in enumerate(mech.forces):
        if f.name == name:
            if not isinstance(f, WornJoint):
                raise ContactSetupError(f"clearance {name!r} has no 'wear:' key (a planar_revolute or spherical "
                                        "clearance with wear: {model: archard, k, hardness})", file=str(mech.path),
                                        key=f"clearances.{name}.wear", choices=["wear"])
            return i, f
    raise InputError(f"no active clearance named {name!r}", key="--clearance", choices=names)


def _simulate(mech, t0, t_end, q, v, s):
    from pinclear.dynamics.simulate import simulate

    kw = dict(rtol=s.rtol, dt_out=s.dt_out, t0=t0)
    if q is not None:
        kw.update(q0=q, v0=v, assemble=False, start="state")
    tr = simulate(mech, t_end, **kw)
    if tr.status != "success":
        raise RuntimeError(f"wear block [{t0:.6g}, {t_end:.6g}] s: {tr.message}")
    return tr


def _with_depth(mech, idx, depth):
    forces = list(mech.forces)
    for name, i in idx.items():
        forces[i] = forces[i].with_depth(depth[name], continuing=True)
    return mech.replace(forces=forces)


#: the layout of OUT/checkpoint.npz; a checkpoint of another layout (or none) is refused
CHECKPOINT_FORMAT = 2


def wear_identity(mech, names, s, start=None) -> dict:
    """What a checkpoint must match to continue a wear run (JSON-able, compared key by key by
    pinclear.dynamics.validate.identity_differences): the contact models' version, the mechanism
    (digest of its description: every active clearance with its parameters and wear mapping,
    drives, inertias), its active clearances and wear mappings spelled out, the load's overrides,
    the settings, the worn joints and the start state."""
    import hashlib

    from pinclear.contact import MODEL_VERSION
    from pinclear.core.jsonsafe import jsonable
    from pinclear.dynamics.validate import mechanism_digest

    wear = {}
    for n in sorted(names):
        wm = worn_joint(mech, n)[1].wear
        wear[n] = {k: getattr(wm, k) for k in ("k", "hardness", "distribution") if hasattr(wm, k)}
        wear[n]["nodes"] = int(wm.nodes)
    if start is None:
        st = None
    else:
        st = hashlib.sha256(np.ascontiguousarray(np.r_[np.ravel(start[0]), np.ravel(start[1])], float).tobytes())
        st = st.hexdigest()[:32]
    return jsonable({"contact_model": MODEL_VERSION, "mechanism": mechanism_digest(mech), "mechanism_name": mech.name,
                     "clearances": sorted(f.name for f in mech.clearances), "wear": wear,
                     "overrides": dict((mech.load_args or {}).get("overrides") or {}),
                     **{f"settings.{k}": v for k, v in asdict(s).items()},
                     "joints": sorted(names), "start": st})


def _load_checkpoint(folder, s, wms, mech=None, identity=None, joints=None):
    """OUT/checkpoint.npz as {field: array} after checking it belongs to this run and holds what
    pinclear writes (module doc); None when there is none."""
    from pinclear.dynamics import validate

    path = Path(folder) / "checkpoint.npz"
    if not path.exists():
        return None
    z = validate.read_npz(path, "wear checkpoint")
    fmt = z.get("format")
    if fmt is None or fmt.shape != () or fmt.dtype.kind not in "iu" or int(fmt) != CHECKPOINT_FORMAT:
        raise InputError(f"{path}: a wear checkpoint of another layout (format {None if fmt is None else fmt!r}, "
                         f"this pinclear writes {CHECKPOINT_FORMAT}: written before the run identity and the contact "
                         "models' version were stored); choose another --out or delete it", key="--out")
    meta = validate.read_meta({"meta": z.get("identity")}, path, "wear checkpoint")
    if identity is not None:
        diffs = validate.identity_differences(meta, identity)
        if diffs:
            raise InputError(f"{path}: a checkpoint of another run: " + "; ".join(diffs) + "; choose another --out "
                             "or the same mechanism and settings", key="--out")
    ck = _checked_fields(z, path, s, wms, mech)
    if mech is not None and joints is not None:
        _check_state(path, mech, joints, ck)
    return ck


def _checked_fields(z, path, s, wms, mech):
    """The checkpoint's arrays, each checked for type, shape, sign and bound (module doc)."""
    from pinclear.dynamics import validate

    def bad(key, why):
        return InputError(f"{path}: {key} {why}: not a checkpoint this run wrote", key="--out")

    ck = {}
    done = z.get("done")
    if done is None or done.shape != () or done.dtype.kind not in "iu":
        raise bad("done", "is not an integer")
    done = int(done)
    most = s.updates if s.scheme == "factor" else s.max_updates
    if not 1 <= done <= most:
        raise bad("done", f"= {done} lies outside [1, {most}]")
    ck["done"] = done
    if mech is not None:
        ck["q"] = validate.real_array(z, "q", path, 1, rows=mech.nq)
        ck["v"] = validate.real_array(z, "v", path, 1, rows=mech.nv)
    else:
        ck["q"], ck["v"] = (validate.real_array(z, k, path, 1) for k in "qv")
    ck["t"] = validate.real_array(z, "t", path, 0)
    if not ck["t"] >= 0.0:
        raise bad("t", f"= {float(ck['t'])!r} is negative")
    ck["last_E"] = validate.real_array(z, "last_E", path, 0, finite=False)
    if np.isinf(ck["last_E"]):
        raise bad("last_E", "is infinite")
    for k in _history_keys(sorted(wms)):
        a = validate.real_array(z, k, path, 1, rows=done)
        if k in ("cycles", "factor", "cpu_sim", "cpu_update", "audit_bound") or k.endswith(("max_depth", "worn_volume")):
            if np.any(a < 0.0) or (k in ("cycles", "factor") and np.any(a <= 0.0)):
                raise bad(k, "holds a negative value (or zero)")
        ck[k] = a
    cyc = ck["cycles"]
    if np.any(np.diff(cyc) <= 0.0) or cyc[-1] > s.cycles * (1.0 + 1e-9):
        raise bad("cycles", f"do not increase to at most the life {s.cycles:g}")
    if s.scheme == "factor" and not np.allclose(cyc, np.arange(1, done + 1) * s.cycles / s.updates, rtol=1e-9, atol=0):
        raise bad("cycles", f"are not the factor scheme's (k + 1) x {s.cycles:g} / {s.updates}")
    for n, wm in wms.items():
        d = validate.real_array(z, f"depth.{n}", path, 1, rows=wm.nodes)
        bound = s.max_depth_fraction * _radius(wm)
        if np.any(d < 0.0) or np.any(d > bound):
            raise bad(f"depth.{n}", f"lies outside [0, {bound:.4g}] m (max_depth_fraction x the radius)")
        hd, hv = ck[f"{n}.max_depth"], ck[f"{n}.worn_volume"]
        if np.any(np.diff(hd) < 0.0) or np.any(np.diff(hv) < 0.0):
            raise bad(f"{n}.max_depth", "decreases (wear only removes material)")
        if not math.isclose(hd[-1], float(d.max()), rel_tol=1e-9, abs_tol=1e-300) or \
                not math.isclose(hv[-1], wm.volume(d), rel_tol=1e-6, abs_tol=1e-30):
            raise bad(f"depth.{n}", "differs from its history's last max_depth or worn_volume")
        ck[f"depth.{n}"] = d
    return ck


def _radius(wm):
    """The worn surface's radius: the bearing's or the socket's (R1)."""
    return float(wm.R1)


def _check_state(path, mech, joints, ck):
    """The checkpoint's state in the worn mechanism: a configuration (unit quaternions, closure rows
    within 1e-3 of the mechanism's size) and no clearance penetrating by more than its clearance."""
    import pinocchio as pin

    from pinclear.dynamics.validate import mechanism_length
    from pinclear.model import kinematics

    q, v = ck["q"], ck["v"]
    if not pin.isNormalized(mech.model, q, 1e-6):
        raise InputError(f"{path}: q is not a valid configuration (a quaternion of non-unit norm)", key="--out")
    worn = _with_depth(mech, joints, {n: ck[f"depth.{n}"] for n in joints})
    ws = worn.workspace()
    kinematics.update(worn, ws, q, v)
    mc = worn.compiled.m
    if mc:
        kinematics.constraint_rows(worn, ws, float(ck["t"]), q, v)
        r = float(np.max(np.abs(ws.phi[:mc])))
        if not r <= 1e-3 * mechanism_length(worn):
            raise InputError(f"{path}: q is off the constraint manifold (closure residual {r:.3g})", key="--out")
    for i, f in enumerate(worn.forces):
        if getattr(f, "is_clearance", False):
            pen = float(np.max(f.event_values(worn, ws, ws.force_data[i], float(ck["t"]), q, v, np.zeros(f.nz))))
            if not pen <= f.c:
                raise InputError(f"{path}: the state puts clearance {f.name!r} {pen:.3g} m inside its bearing (more "
                                 f"than its clearance {f.c:.3g} m)", key="--out")


def _history_keys(names):
    return HISTORY + tuple(f"{n}.{k}" for n in names for k in ("max_depth", "worn_volume"))


def _save(folder, s, wms, depth, state, done, hist, identity):
    folder = Path(folder)
    q, v, t, last_E = state
    keys = _history_keys(sorted(wms))
    safeio.savez(folder / "checkpoint.npz", {
        "q": q, "v": v, "t": np.array(t), "last_E": np.array(np.nan if last_E is None else last_E),
        "done": np.array(done, dtype=np.int64), "format": np.array(CHECKPOINT_FORMAT, dtype=np.int64),
        "identity": np.array(json.dumps(identity, sort_keys=True)),
        **{f"depth.{n}": d for n, d in depth.items()}, **{k: np.array(hist[k]) for k in keys}})
    _tables(folder, wms, depth, hist)


def _tables(folder, wms, depth, hist):
    """OUT/history.csv and OUT/profile.csv (depth vs angle, degrees labelled)."""
    keys = _history_keys(sorted(wms))
    units = {"cycles": "", "audit_error": " [-]", "audit_bound": " [-]", "jump": " (reshape) [J]", "cpu_sim": " [s]",
             "cpu_update": " [s]"}
    head = [k + units.get(k, " [m^3]" if k.endswith("volume") else " [m]") for k in keys]
    rows = ["# " + ", ".join(head)] + [", ".join(f"{hist[k][i]:.9g}" for k in keys) for i in range(len(hist["cycles"]))]
    safeio.write_text(folder / "history.csv", "\n".join(rows) + "\n")
    names = sorted(wms)
    # node coordinates: the bearing angle, or a socket's (theta, phi) (contact.wear_spherical)
    cols = wms[names[0]].profile_columns()
    prof = ["# " + ", ".join(cols) + ", " + ", ".join(f"{n} depth [m]" for n in names)]
    ang = np.array(list(cols.values())).T
    if all(wms[n].nodes == len(ang) and type(wms[n]) is type(wms[names[0]]) for n in names):
        prof += [", ".join(f"{x:.6f}" for x in a) + ", " + ", ".join(f"{depth[n][k]:.9g}" for n in names)
                 for k, a in enumerate(ang)]
    else:
        prof = [f"# {n}: " + " ".join(f"{x:.9g}" for x in depth[n]) for n in names]
    safeio.write_text(folder / "profile.csv", "\n".join(prof) + "\n")


def update_factor(s: WearSettings, inc, clearance, left):
    """Cycles each simulated cycle of this block stands for: the fixed factor, or (depth scheme) the
    one that makes the largest nodal increment of any joint ``step`` x its clearance, at least 1 and
    at most what is ``left`` of the life (cycles) over the block's periods. inc: {name: block's
    depth increment}; clearance: {name: c}."""
    if s.scheme == "factor":
        return s.factor
    ratio = max(float(np.max(inc[n])) / clearance[n] for n in inc)
    cap = left / s.block_periods
    return cap if ratio <= 0.0 else min(cap, max(1.0, s.step / ratio))


def _start(mech, s, out, wms, found, start, identity):
    """(depth, q, v, t, done, cycles done, last_E, history) from OUT's checkpoint or a new start (the
    start-up periods simulated without wear)."""
    joints = {n: f[0] for n, f in found.items()}
    ck = _load_checkpoint(out, s, wms, mech, identity, joints) if out is not None else None
    if ck is not None:
        hist = {k: list(ck[k]) for k in _history_keys(sorted(wms))}
        return ({n: ck[f"depth.{n}"] for n in wms}, ck["q"], ck["v"], float(ck["t"]), int(ck["done"]),
                float(hist["cycles"][-1]) if hist["cycles"] else 0.0,
                None if np.isnan(ck["last_E"]) else float(ck["last_E"]), hist)
    depth = {n: np.array(f[1].depth) for n, f in found.items()}
    q, v, t = settled_start(mech, s, start)
    return depth, q, v, t, 0, 0.0, None, {k: [] for k in _history_keys(sorted(wms))}


def settled_start(mech, s, start):
    """(q, v, t) where the wear starts: ``start`` (None: simulate's ideal start) after the start-up
    periods (landings from the sidecar's start) on the new bearing, without wear."""
    q, v, t = (None, None, 0.0) if start is None else (np.asarray(start[0], float), np.asarray(start[1], float), 0.0)
    if s.transient_periods:
        tr = _simulate(mech, 0.0, s.transient_periods * s.period, q, v, s)
        q, v, t = tr.q[-1], tr.v[-1], float(tr.t[-1])
    return q, v, t


def _finished(s, done, cyc):
    if s.scheme == "factor":
        return done >= s.updates
    # the depth scheme's last update takes the rest of the life: round-off never leaves a sliver
    return cyc >= s.cycles * (1.0 - 1e-12) or done >= s.max_updates


def read_profile(path) -> dict:
    """{name: node depths (m)} from a wear run's profile.csv (OUT/profile.csv of ``pinclear wear`` or
    ``pinclear study``; ``path`` the file or its folder), as :func:`_tables` writes it."""
    from pinclear.core.bounded import check_regular
    from pinclear.core.errors import ModelFileError

    path = Path(path)
    path = path / "profile.csv" if path.is_dir() else path
    if not path.exists():
        raise ModelFileError(str(path), "path", "no such file (a wear run's OUT/profile.csv)")
    check_regular(path, "path", "wear profile")
    from pinclear.core.bounded import read_text_bounded

    # a 5 GiB profile was read whole: at most 64 MB (a million nodes of a dozen joints)
    lines = read_text_bounded(path, 64 << 20, "path", "wear profile").splitlines()
    from pinclear.contact.wear import MAX_NODES

    if len(lines) > MAX_NODES + 1:
        raise ModelFileError(str(path), "profile", f"{len(lines) - 1} rows: at most {MAX_NODES} wear nodes a joint")
    try:
        head = lines[0].lstrip("# ").split(", ")
        # node coordinates first: a bearing's angle, or a socket's (theta, phi) (contact.wear_spherical)
        nc = 2 if head[:2] == ["theta from the pole [deg]", "phi [deg]"] else 1
        if head[0] in ("angle [deg]", "theta from the pole [deg]") and len(head) > nc \
                and all(h.endswith(" depth [m]") for h in head[nc:]):
            table = np.loadtxt(lines[1:], delimiter=",", ndmin=2)
            return {h[: -len(" depth [m]")]: table[:, k + nc].copy() for k, h in enumerate(head[nc:])}
        # joints of other node counts: '# NAME: d0 d1 ...' a line
        return {name: np.array(vals.split(), float) for name, _, vals in (ln.lstrip("# ").partition(": ")
                                                                         for ln in lines) if vals}
    except (IndexError, ValueError) as exc:
        raise ModelFileError(str(path), "profile", f"not a wear profile ({exc}); expected the header "
                             "'# angle [deg], NAME depth [m], ...'") from None


def with_profile(mech, profile, file="profile.csv", max_depth_fraction=WearSettings.max_depth_fraction):
    """``mech`` with each worn clearance of ``profile`` ({name: depths}, :func:`read_profile`) worn to
    its depths; the joints must be active with the same ``wear:`` node count as the run's, every depth
    within [0, max_depth_fraction x the bearing's radius] (what a wear run can write)."""
    from pinclear.core.errors import ModelFileError

    idx, depth = {}, {}
    for name, d in profile.items():
        i, joint = worn_joint(mech, name)
        if d.shape != (joint.wear.nodes,) or not np.all(np.isfinite(d)):
            raise ModelFileError(str(file), name, f"{d.size} depths for a {joint.wear.nodes}-node bearing "
                                 "(load the mechanism with the wear run's --clearance and --set)")
        bound = max_depth_fraction * _radius(joint.wear)
        if np.any(d < 0.0) or np.any(d > bound):
            raise ModelFileError(str(file), name, f"depths {d.min():.4g} to {d.max():.4g} m: a wear run writes depths "
                                 f"in [0, {bound:.4g}] m ({max_depth_fraction:g} x the radius {_radius(joint.wear):.4g} m)")
        idx[name], depth[name] = i, d
    forces = list(mech.forces)
    for name, i in idx.items():
        forces[i] = forces[i].with_depth(depth[name])
    return mech.replace(forces=forces)


def wear_run(mech, names, s: WearSettings, out=None, progress=None, start=None) -> dict:
    """The iterative scheme (module doc) on the worn clearances ``names`` (one name or several)
    of ``mech``; resumes from OUT/checkpoint.npz. start: (q0, v0) of the run (default: simulate's
    ideal start). Returns {depth: {name: (nodes,)}, angles: {name: (nodes,)}, history (lists),
    settings, mech (worn), complete (False when the depth scheme stopped at max_updates before the
    life's end)}."""
    s.check()
    names = [names] if isinstance(names, str) else list(names)
    found = {n: worn_joint(mech, n) for n in names}
    idx, wms = {n: f[0] for n, f in found.items()}, {n: f[1].wear for n, f in found.items()}
    clearance = {n: f[1].c for n, f in found.items()}
    identity = wear_identity(mech, names, s, start)
    depth, q, v, t, done, cyc, last_E, hist = _start(mech, s, out, wms, found, start, identity)
    worn = _with_depth(mech, idx, depth)
    failed = None
    while not _finished(s, done, cyc):
        c0 = time.process_time()
        tr = _simulate(worn, t, t + s.block_periods * s.period, q, v, s)
        c1 = time.process_time()
        E = tr.energy()["total"]
        jump = 0.0 if last_E is None else float(E[0] - last_E)
        bal = tr.energy_balance()
        inc = {n: wms[n].increment(n, tr, depth[n]) for n in names}
        factor = update_factor(s, inc, clearance, s.cycles - cyc)
        new = {n: depth[n] + factor * inc[n] for n in names}
        failed = _too_deep(s, wms, new, done + 1)
        if failed:
            break
        depth = new
        worn = _with_depth(worn, idx, depth)
        c2 = time.process_time()
        # the next block starts from this one's last state: its energy there is the elastic
        # energy against the new profile (the reshape jump)
        q, v, t, last_E = tr.q[-1], tr.v[-1], float(tr.t[-1]), float(E[-1])
        done += 1
        # the factor scheme's cycles as a product (bit-identical to its earlier releases)
        cyc = done * s.cycles / s.updates if s.scheme == "factor" else cyc + factor * s.block_periods
        row = {"cycles": cyc, "audit_error": bal.get("error", math.nan), "audit_bound": bal.get("bound", math.nan),
               "jump": jump, "cpu_sim": c1 - c0, "cpu_update": c2 - c1, "factor": factor}
        for n, wm in wms.items():
            row[f"{n}.max_depth"] = depth[n].max()
            row[f"{n}.worn_volume"] = wm.volume(depth[n])
        for k, val in row.items():
            hist[k].append(float(val))
        if out is not None:
            _save(out, s, wms, depth, (q, v, t, last_E), done, hist, identity)
        if progress:
            progress(done, f"of {s.updates}" if s.scheme == "factor" else f"{cyc:.4g}/{s.cycles:.4g} cycles",
                     max(d.max() for d in depth.values()))
    return {"depth": depth, "angles": {n: wm.angles() for n, wm in wms.items()}, "history": hist, "settings": s,
            "mech": worn, "failed": failed,
            "complete": failed is None and _finished(s, done, cyc) and cyc >= s.cycles * (1.0 - 1e-12)}


def _too_deep(s, wms, depth, update):
    """The failure of a trial whose depth passes max_depth_fraction of a radius (None: within)."""
    for n, wm in wms.items():
        dmax, bound = float(np.max(depth[n])), s.max_depth_fraction * _radius(wm)
        if not dmax <= bound:
            return (f"{n}: update {update} wears {dmax:.4g} m deep, beyond max_depth_fraction {s.max_depth_fraction:g} x "
                    f"the radius {_radius(wm):.4g} m = {bound:.4g} m; the trial failed (its last checkpoint is the "
                    "update before)")
    return None


def block_length(mech, names, s: WearSettings, tol=0.025, max_periods=32, start=None):
    """Periods per block whose mean wear rate is a converged average (for irregular motion, where
    one period's increment is a noisy sample): from the run's start (after s.transient_periods),
    blocks of n = 1, 2, 4, ... consecutive periods, n doubled until the mean increment over 2n
    periods changes every joint's largest nodal mean increment by <= tol from the first n periods'.
    Returns (n, converged, table [(n, {name: largest nodal increment per period of the n-period
    mean, m})]); at max_periods unconverged: (max_periods, False, table). On the new bearing only:
    a worn one's motion may differ (docs/wear_lubrication.md)."""
    s.check()
    names = [names] if isinstance(names, str) else list(names)
    found = {n: worn_joint(mech, n) for n in names}
    wms = {n: f[1].wear for n, f in found.items()}
    q, v, t = settled_start(mech, s, start)
    # the blocks continue the start-up's state, which may be in an impact deeper than the start-pose
    # check allows (its limit is for a pose from the sidecar, not a state mid-run)
    mech = _with_depth(mech, {n: f[0] for n, f in found.items()}, {n: f[1].depth for n, f in found.items()})
    tr = _simulate(mech, t, t + s.period, q, v, s)
    total = {m: wms[m].increment(m, tr) for m in names}
    count, table = 1, [(1, {m: float(total[m].max()) for m in names})]
    while True:
        # double the periods summed: count more, continuing from the last state
        tr = _simulate(mech, float(tr.t[-1]), float(tr.t[-1]) + count * s.period, tr.q[-1], tr.v[-1], s)
        total = {m: total[m] + wms[m].increment(m, tr) for m in names}
        count *= 2
        mean = {m: float(total[m].max()) / count for m in names}
        table.append((count, mean))
        if all(abs(mean[m] - table[-2][1][m]) <= tol * mean[m] for m in names):
            return count // 2, True, table
        if count >= max_periods:
            return count, False, table


def _trial(s, k):
    """The settings of trial k (0 first) of the convergence test: the updates doubled (factor
    scheme) or the depth step halved (depth scheme) k times."""
    if s.scheme == "factor":
        return WearSettings(**{**asdict(s), "updates": s.updates * 2 ** k})
    return WearSettings(**{**asdict(s), "step": s.step / 2 ** k})


def refined(mech, names):
    """The mechanism with the worn joints ``names``' wear cells halved (a bearing's nodes doubled, a
    socket's rows doubled: 4x its nodes), new (unworn), for the mesh half of the convergence test."""
    import dataclasses

    forces = list(mech.forces)
    for name in _names(names):
        i, joint = worn_joint(mech, name)
        wm = joint.wear
        wm2 = (dataclasses.replace(wm, rows=2 * wm.rows) if hasattr(wm, "rows")
               else dataclasses.replace(wm, nodes=2 * wm.nodes))
        args, kw = joint._ctor
        forces[i] = type(joint)(*args, wear=wm2, depth=None, **kw)
    return mech.replace(forces=forces)


def _names(names):
    return [names] if isinstance(names, str) else list(names)


def profile_norm(wm, depth) -> float:
    """The profile's L2 norm over the worn surface per unit measure (RMS depth, m): the nodes'
    mean square, a socket's weighted by its cells' areas, so that meshes of any size compare."""
    depth = np.asarray(depth, float)
    if hasattr(wm, "cell_areas"):
        a = wm.cell_areas()
        return float(np.sqrt(np.sum(a * depth ** 2) / np.sum(a)))
    return float(np.sqrt(np.mean(depth ** 2)))


def mesh_change(mech, names, s, res, out=None, start=None, tol=0.05) -> dict:
    """The mesh half of the convergence test: the run ``res`` (settings s) repeated with the cells
    halved (refined); per joint the changes of the largest depth and of the profile's L2 norm
    (profile_norm), both relative to the finer run's largest depth; ``ok`` when all are <= tol.
    A single joint's numbers are also at the top level (nodes, max_depth, l2, d_max, d_l2)."""
    fine_mech = refined(mech, names)
    fine = wear_run(fine_mech, names, s, None if out is None else safeio.make_dirs(Path(out) / "mesh_halved"),
                    None, start)
    joints = {}
    for name in _names(names):
        wm1, wm2 = worn_joint(mech, name)[1].wear, worn_joint(fine_mech, name)[1].wear
        d1, d2 = res["depth"][name], fine["depth"][name]
        top = max(float(d2.max()), 1e-300)
        joints[name] = {"nodes": (wm1.nodes, wm2.nodes), "max_depth": (float(d1.max()), float(d2.max())),
                        "l2": (profile_norm(wm1, d1), profile_norm(wm2, d2)),
                        "d_max": abs(float(d2.max()) - float(d1.max())) / top,
                        "d_l2": abs(profile_norm(wm2, d2) - profile_norm(wm1, d1)) / top}
    ok = bool(fine["complete"]) and all(j["d_max"] <= tol and j["d_l2"] <= tol for j in joints.values())
    result = {"joints": joints, "complete": fine["complete"], "ok": ok}
    if len(joints) == 1:
        result.update(next(iter(joints.values())))
    return result


def at_wear_ratio(hist, name, life, ratio):
    """(largest depth, worn volume) of joint ``name`` after ``life`` cycles with Archard's k/H
    scaled by ``ratio``, read off a run's history at ``ratio`` x ``life`` cycles; None beyond the
    run. Exact for both schemes up to their discretisation: the wear rate is k/H times a function of
    the profile, so scaling k/H scales the cycles each update stands for and leaves the sequence of
    profiles unchanged (Archard 1953, eq. of the worn volume k F s / H). Before the first update
    the new surface's rate holds and the growth is linear from zero."""
    cyc = np.concatenate([[0.0], np.asarray(hist["cycles"], float)])
    n = ratio * life
    if n > cyc[-1] * (1 + 1e-9):
        return None
    return (float(np.interp(n, cyc, np.concatenate([[0.0], hist[f"{name}.max_depth"]]))),
            float(np.interp(n, cyc, np.concatenate([[0.0], hist[f"{name}.worn_volume"]]))))


def converged(mech, name, s: WearSettings, tol=0.05, max_rounds=5, out=None, progress=None, start=None,
              mesh=True) -> dict:
    """The convergence test of the scheme (module doc): trials with the factor halved (``factor``:
    updates doubled) or the depth step halved (``depth``) until every joint's final maximum depth
    changes by <= tol; then (mesh) the converged trial repeated with the wear cells halved: the
    largest depth and the profile's L2 norm (relative to the largest depth) must change by <= tol
    too (mesh_change, returned as ``mesh``). Returns the finest run's result plus ``rounds`` (one
    dict a trial: updates, factor or step, complete, max_depth {name: m}, worn_volume {name: m^3},
    cpu_s), ``mesh`` and ``converged`` (False after max_rounds, when a trial stopped at
    max_updates, or when the mesh changed the result by more than tol: every trial's numbers are
    in rounds and mesh)."""
    rounds, prev = [], None
    if s.scheme == "factor" and s.cycles < s.updates * s.block_periods:
        raise InputError(f"{s.cycles:g} cycles are fewer than updates x block periods = {s.updates} x "
                         f"{s.block_periods}: give more cycles or fewer updates", key="cycles")
    for k in range(max_rounds):
        si = _trial(s, k)
        if si.scheme == "factor" and si.cycles < si.updates * si.block_periods:
            break
        sub = f"updates_{si.updates}" if si.scheme == "factor" else f"step_{si.step:.6g}"
        res = wear_run(mech, name, si, None if out is None else safeio.make_dirs(Path(out) / sub), progress, start)
        d = {n: float(x.max()) for n, x in res["depth"].items()}
        n_upd = len(res["history"]["cycles"])
        rounds.append({"updates": n_upd, **({"factor": si.factor} if si.scheme == "factor" else {"step": si.step}),
                       "complete": res["complete"], "max_depth": d,
                       "worn_volume": {n: (res["history"][f"{n}.worn_volume"] or [0.0])[-1] for n in d},
                       # the trial's blocks and updates, resumed parts included (from its history)
                       "cpu_s": float(sum(res["history"]["cpu_sim"]) + sum(res["history"]["cpu_update"]))})
        rounds[-1]["failed"] = res["failed"]
        if not res["complete"]:
            res.update(rounds=rounds, mesh=None, converged=False)
            return res
        # a halving that made no more updates (the life's end held both at the same count) tests
        # nothing, unless nothing wore at all (no step to resolve)
        if (prev is not None and (n_upd > rounds[-2]["updates"] or not any(d.values()))
                and all(abs(d[n] - prev["depth"][n].max()) <= tol * d[n] for n in d)):
            m = mesh_change(mech, name, si, res, out, start, tol) if mesh else None
            res.update(rounds=rounds, mesh=m, converged=m is None or m["ok"])
            return res
        prev = res
    prev.update(rounds=rounds, mesh=None, converged=False)
    return prev


def plot(res, out):
    """OUT/depth_vs_angle.png and OUT/growth.png (matplotlib, through safeio)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    h = res["history"]
    for n in res["depth"]:
        if np.ndim(res["angles"][n]) == 2:
            _socket_map(res, n, out)
    bearings = {n: d for n, d in res["depth"].items() if np.ndim(res["angles"][n]) == 1}
    if bearings:
        fig, ax = plt.subplots(figsize=(6, 3.5))
        for n, d in bearings.items():
            ax.plot(np.degrees(res["angles"][n]), 1e6 * d, label=n)
        ax.set(xlabel="bearing angle [deg] (frame1 x towards y)", ylabel="wear depth [um]",
               title=f"worn profile after {h['cycles'][-1]:.3g} cycles")
        ax.legend()
        ax.grid(alpha=0.3)
        fig.tight_layout()
        safeio.savefig(fig, Path(out) / "depth_vs_angle.png", dpi=120)
        plt.close(fig)
    fig, ax = plt.subplots(figsize=(6, 3.5))
    for n in res["depth"]:
        ax.plot([0.0] + h["cycles"], [0.0] + [1e6 * x for x in h[f"{n}.max_depth"]], "o-", label=n)
    ax.set(xlabel="cycles", ylabel="clearance growth (max depth) [um]", title="clearance growth")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    safeio.savefig(fig, Path(out) / "growth.png", dpi=120)
    plt.close(fig)


def _socket_map(res, name, out):
    """OUT/depth_map_NAME.png: a worn socket's depth on its (theta, phi) map."""
    import matplotlib.pyplot as plt

    from pinclear.contact.wear_spherical import plot_depth_map

    wm = worn_joint(res["mech"], name)[1].wear
    fig, ax = plt.subplots(figsize=(7, 3.8))
    plot_depth_map(ax, wm, res["depth"][name], f"{name}: worn socket after {res['history']['cycles'][-1]:.3g} cycles")
    fig.tight_layout()
    safeio.savefig(fig, Path(out) / f"depth_map_{name}.png", dpi=120)
    plt.close(fig)
