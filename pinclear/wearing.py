"""Long-horizon Archard wear of a revolute clearance (``pinclear wear``; docs/wear_lubrication.md).

The standard iterative scheme of the worn-joint literature (Flores 2009, Mech. Mach. Theory 44,
1211, sec. 4; Mukras et al. 2010, Wear 268, 643, sec. 3): simulate ``block_periods`` periods of the
mechanism with the bearing's current profile, integrate the Archard depth over the block's samples
(pinclear.contact.wear.block_increment), scale it by the update factor (cycles per update / cycles
per block), reshape the bearing, continue from the block's last state. The factor is not fixed by
hand: :func:`converged` doubles the number of updates until halving the factor changes the final
wear depth by <= ``tol`` (5 %).

Energy: each block is audited on its own (pinclear.energy.energy_balance, between reshapes); a
reshape changes the contact's elastic energy at a fixed state by a jump that is neither work nor
dissipation, reported apart (``jump``: the total energy at the next block's first sample less the
block's last).

Files (all through pinclear.safeio, written after every update, so an interrupt loses at most the
block under way, and a second call with the same folder resumes): OUT/checkpoint.npz (profile,
state, history), OUT/history.csv, OUT/profile.csv (depth vs angle, degrees labelled).
"""
from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from . import safeio
from .errors import ContactSetupError, InputError

HISTORY = ("cycles", "max_depth", "worn_volume", "audit_error", "audit_bound", "jump", "cpu_sim", "cpu_update")


@dataclass(frozen=True)
class WearSettings:
    """cycles: service life (mechanism periods); period (s); block_periods: periods simulated per
    update; updates: number of reshapes over the life (the update factor is cycles / updates /
    block_periods); transient_periods: simulated first, without wear (start-up landings);
    rtol, dt_out: of each block's integration (the wear quadrature uses its samples)."""
    cycles: float
    period: float
    updates: int = 4
    block_periods: int = 1
    transient_periods: int = 1
    rtol: float = 1e-6
    dt_out: float = 1e-4

    def check(self):
        for key in ("cycles", "period", "rtol", "dt_out"):
            v = getattr(self, key)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise InputError(f"{key} must be a number > 0, got {v!r}", key=key)
        for key in ("updates", "block_periods"):
            v = getattr(self, key)
            if not (isinstance(v, int) and v >= 1):
                raise InputError(f"{key} must be an integer >= 1, got {v!r}", key=key)
        if not (isinstance(self.transient_periods, int) and self.transient_periods >= 0):
            raise InputError(f"transient_periods must be an integer >= 0, got {self.transient_periods!r}",
                             key="transient_periods")
        if self.cycles < self.updates * self.block_periods:
            raise InputError(f"cycles ({self.cycles:g}) must be at least updates x block_periods "
                             f"({self.updates * self.block_periods}): an update factor below 1", key="cycles")

    @property
    def factor(self) -> float:
        """Cycles each simulated cycle stands for (the update factor)."""
        return self.cycles / (self.updates * self.block_periods)


def worn_joint(mech, name):
    """(index in mech.forces, joint) of the worn clearance ``name``; a clear error otherwise."""
    from .contact.wear import WornRevoluteClearance

    names = [f.name for f in mech.clearances]
    for i, f in enumerate(mech.forces):
        if f.name == name:
            if not isinstance(f, WornRevoluteClearance):
                raise ContactSetupError(f"clearance {name!r} has no 'wear:' key (a planar_revolute clearance "
                                        "with wear: {model: archard, k, hardness})", file=str(mech.path),
                                        key=f"clearances.{name}.wear", choices=["wear"])
            return i, f
    raise InputError(f"no active clearance named {name!r}", key="--clearance", choices=names)


def _simulate(mech, t0, t_end, q, v, s):
    import pinclear

    kw = dict(rtol=s.rtol, dt_out=s.dt_out, t0=t0)
    if q is not None:
        kw.update(q0=q, v0=v, assemble=False, start="state")
    tr = pinclear.simulate(mech, t_end, **kw)
    if tr.status != "success":
        raise RuntimeError(f"wear block [{t0:.6g}, {t_end:.6g}] s: {tr.message}")
    return tr


def _with_depth(mech, i, depth):
    forces = list(mech.forces)
    forces[i] = forces[i].with_depth(depth, continuing=True)
    return mech.replace(forces=forces)


def _load_checkpoint(folder, s, nodes):
    path = Path(folder) / "checkpoint.npz"
    if not path.exists():
        return None
    with np.load(path, allow_pickle=False) as z:
        saved = json.loads(str(z["settings"]))
        if saved != asdict(s):
            raise InputError(f"{path}: a checkpoint of other settings ({saved}); choose another --out or the same "
                             "settings", file=str(path))
        ck = {k: np.array(z[k]) for k in z.files if k != "settings"}
    if ck["depth"].shape != (nodes,):
        raise InputError(f"{path}: depth has {ck['depth'].shape} values, the joint {nodes} nodes", file=str(path))
    return ck


def _save(folder, s, wm, depth, q, v, t, done, hist, last_E):
    folder = Path(folder)
    safeio.savez(folder / "checkpoint.npz", {"depth": depth, "q": q, "v": v, "t": np.array(t), "last_E": np.array(last_E),
                                               "done": np.array(done), "settings": np.array(json.dumps(asdict(s))),
                                               **{k: np.array(hist[k]) for k in HISTORY}})
    rows = ["# cycles, max_depth [m], worn_volume [m^3], audit_error [-], audit_bound [-], reshape_jump [J], "
            "cpu_sim [s], cpu_update [s]"]
    rows += [", ".join(f"{hist[k][i]:.9g}" for k in HISTORY) for i in range(len(hist["cycles"]))]
    safeio.write_text(folder / "history.csv", "\n".join(rows) + "\n")
    prof = ["# angle [deg], depth [m]"] + [f"{a:.6f}, {d:.9g}" for a, d in zip(np.degrees(wm.angles()), depth)]
    safeio.write_text(folder / "profile.csv", "\n".join(prof) + "\n")


def wear_run(mech, name, s: WearSettings, out=None, progress=None, start=None) -> dict:
    """The iterative scheme (module doc) on clearance ``name`` of ``mech``; resumes from
    OUT/checkpoint.npz. start: (q0, v0) of the run (default: simulate's ideal start). Returns
    {depth, angles, history (lists), settings, mech (worn)}."""
    from .contact.wear import block_increment

    s.check()
    i, joint = worn_joint(mech, name)
    wm = joint.wear
    T, blockT = s.period, s.block_periods * s.period
    ck = _load_checkpoint(out, s, wm.nodes) if out is not None else None
    if ck is None:
        depth = np.array(joint.depth)
        hist = {k: [] for k in HISTORY}
        done, t, last_E = 0, 0.0, None
        q, v = (None, None) if start is None else (np.asarray(start[0], float), np.asarray(start[1], float))
        if s.transient_periods:
            # the start-up (landings from the sidecar's start) on the new bearing, without wear
            tr = _simulate(mech, 0.0, s.transient_periods * T, q, v, s)
            q, v, t = tr.q[-1], tr.v[-1], float(tr.t[-1])
    else:
        depth, q, v, t, done = ck["depth"], ck["q"], ck["v"], float(ck["t"]), int(ck["done"])
        last_E = float(ck["last_E"])
        hist = {k: list(ck[k]) for k in HISTORY}
    worn = _with_depth(mech, i, depth)
    while done < s.updates:
        c0 = time.process_time()
        tr = _simulate(worn, t, t + blockT, q, v, s)
        c1 = time.process_time()
        E = tr.energy()["total"]
        jump = 0.0 if last_E is None else float(E[0] - last_E)
        bal = tr.energy_balance()
        inc = s.factor * block_increment(wm, name, tr)
        depth = depth + inc
        worn = _with_depth(worn, i, depth)
        c2 = time.process_time()
        # the next block starts from this one's last state: its energy there is the elastic
        # energy against the new profile (the reshape jump)
        q, v, t, last_E = tr.q[-1], tr.v[-1], float(tr.t[-1]), float(E[-1])
        done += 1
        for k, val in zip(HISTORY, (done * s.cycles / s.updates, depth.max(), float(depth.sum()) * wm.R1 *
                                    wm.spacing * wm.L, bal.get("error", math.nan), bal.get("bound", math.nan),
                                    jump, c1 - c0, c2 - c1)):
            hist[k].append(float(val))
        if out is not None:
            _save(out, s, wm, depth, q, v, t, done, hist, last_E)
        if progress:
            progress(done, s.updates, depth.max())
    return {"depth": depth, "angles": wm.angles(), "history": hist, "settings": s, "mech": worn}


def converged(mech, name, s: WearSettings, tol=0.05, max_rounds=5, out=None, progress=None, start=None) -> dict:
    """Double ``s.updates`` (halve the update factor) until the final maximum depth changes by
    <= tol; returns the finer run's result plus ``rounds`` [(updates, factor, max depth)] and
    ``converged`` (False after max_rounds: the last two runs' change is then reported)."""
    rounds, prev = [], None
    u = s.updates
    for _ in range(max_rounds):
        si = WearSettings(**{**asdict(s), "updates": u})
        if si.cycles < si.updates * si.block_periods:
            break
        res = wear_run(mech, name, si, None if out is None else safeio.make_dirs(Path(out) / f"updates_{u}"), progress,
                       start)
        d = float(res["depth"].max())
        rounds.append((u, si.factor, d))
        if prev is not None and abs(d - prev["depth"].max()) <= tol * d:
            res.update(rounds=rounds, converged=True)
            return res
        prev = res
        u *= 2
    prev.update(rounds=rounds, converged=False)
    return prev


def plot(res, name, out):
    """OUT/depth_vs_angle.png and OUT/growth.png (matplotlib, through safeio)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot(np.degrees(res["angles"]), 1e6 * res["depth"])
    ax.set(xlabel="bearing angle [deg] (frame1 x towards y)", ylabel="wear depth [um]",
           title=f"{name}: worn profile after {res['history']['cycles'][-1]:.3g} cycles")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    safeio.savefig(fig, Path(out) / "depth_vs_angle.png", dpi=120)
    plt.close(fig)
    h = res["history"]
    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.plot([0.0] + h["cycles"], [0.0] + [1e6 * x for x in h["max_depth"]], "o-")
    ax.set(xlabel="cycles", ylabel="clearance growth (max depth) [um]", title=f"{name}: clearance growth")
    ax.grid(alpha=0.3)
    fig.tight_layout()
    safeio.savefig(fig, Path(out) / "growth.png", dpi=120)
    plt.close(fig)
