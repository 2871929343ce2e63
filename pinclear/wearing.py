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

#: history columns every run has; each worn joint NAME adds NAME.max_depth (m) and NAME.worn_volume (m^3)
HISTORY = ("cycles", "audit_error", "audit_bound", "jump", "cpu_sim", "cpu_update")


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
    from .contact.wear_spherical import WornSphericalClearance

    names = [f.name for f in mech.clearances]
    for i, f in enumerate(mech.forces):
        if f.name == name:
            if not isinstance(f, (WornRevoluteClearance, WornSphericalClearance)):
                raise ContactSetupError(f"clearance {name!r} has no 'wear:' key (a planar_revolute or spherical "
                                        "clearance with wear: {model: archard, k, hardness})", file=str(mech.path),
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


def _with_depth(mech, idx, depth):
    forces = list(mech.forces)
    for name, i in idx.items():
        forces[i] = forces[i].with_depth(depth[name], continuing=True)
    return mech.replace(forces=forces)


def _load_checkpoint(folder, s, wms):
    path = Path(folder) / "checkpoint.npz"
    if not path.exists():
        return None
    with np.load(path, allow_pickle=False) as z:
        saved = json.loads(str(z["settings"]))
        if saved != {**asdict(s), "joints": sorted(wms)}:
            raise InputError(f"{path}: a checkpoint of other settings ({saved}); choose another --out or the same "
                             "settings", key="--out")
        ck = {k: np.array(z[k]) for k in z.files if k != "settings"}
    for name, wm in wms.items():
        if ck.get(f"depth.{name}", np.zeros(0)).shape != (wm.nodes,):
            raise InputError(f"{path}: no {wm.nodes}-node depth of {name}", key="--out")
    return ck


def _history_keys(names):
    return HISTORY + tuple(f"{n}.{k}" for n in names for k in ("max_depth", "worn_volume"))


def _save(folder, s, wms, depth, state, done, hist):
    folder = Path(folder)
    q, v, t, last_E = state
    keys = _history_keys(sorted(wms))
    safeio.savez(folder / "checkpoint.npz", {
        "q": q, "v": v, "t": np.array(t), "last_E": np.array(np.nan if last_E is None else last_E),
        "done": np.array(done), "settings": np.array(json.dumps({**asdict(s), "joints": sorted(wms)})),
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


def wear_run(mech, names, s: WearSettings, out=None, progress=None, start=None) -> dict:
    """The iterative scheme (module doc) on the worn clearances ``names`` (one name or several)
    of ``mech``; resumes from OUT/checkpoint.npz. start: (q0, v0) of the run (default: simulate's
    ideal start). Returns {depth: {name: (nodes,)}, angles: {name: (nodes,)}, history (lists),
    settings, mech (worn)}."""
    s.check()
    names = [names] if isinstance(names, str) else list(names)
    found = {n: worn_joint(mech, n) for n in names}
    idx, wms = {n: f[0] for n, f in found.items()}, {n: f[1].wear for n, f in found.items()}
    T, blockT = s.period, s.block_periods * s.period
    ck = _load_checkpoint(out, s, wms) if out is not None else None
    if ck is None:
        depth = {n: np.array(f[1].depth) for n, f in found.items()}
        hist = {k: [] for k in _history_keys(sorted(wms))}
        done, t, last_E = 0, 0.0, None
        q, v = (None, None) if start is None else (np.asarray(start[0], float), np.asarray(start[1], float))
        if s.transient_periods:
            # the start-up (landings from the sidecar's start) on the new bearing, without wear
            tr = _simulate(mech, 0.0, s.transient_periods * T, q, v, s)
            q, v, t = tr.q[-1], tr.v[-1], float(tr.t[-1])
    else:
        depth = {n: ck[f"depth.{n}"] for n in names}
        q, v, t, done = ck["q"], ck["v"], float(ck["t"]), int(ck["done"])
        last_E = None if np.isnan(ck["last_E"]) else float(ck["last_E"])
        hist = {k: list(ck[k]) for k in _history_keys(sorted(wms))}
    worn = _with_depth(mech, idx, depth)
    while done < s.updates:
        c0 = time.process_time()
        tr = _simulate(worn, t, t + blockT, q, v, s)
        c1 = time.process_time()
        E = tr.energy()["total"]
        jump = 0.0 if last_E is None else float(E[0] - last_E)
        bal = tr.energy_balance()
        depth = {n: depth[n] + s.factor * wms[n].increment(n, tr) for n in names}
        worn = _with_depth(worn, idx, depth)
        c2 = time.process_time()
        # the next block starts from this one's last state: its energy there is the elastic
        # energy against the new profile (the reshape jump)
        q, v, t, last_E = tr.q[-1], tr.v[-1], float(tr.t[-1]), float(E[-1])
        done += 1
        row = {"cycles": done * s.cycles / s.updates, "audit_error": bal.get("error", math.nan),
               "audit_bound": bal.get("bound", math.nan), "jump": jump, "cpu_sim": c1 - c0, "cpu_update": c2 - c1}
        for n, wm in wms.items():
            row[f"{n}.max_depth"] = depth[n].max()
            row[f"{n}.worn_volume"] = wm.volume(depth[n])
        for k, val in row.items():
            hist[k].append(float(val))
        if out is not None:
            _save(out, s, wms, depth, (q, v, t, last_E), done, hist)
        if progress:
            progress(done, s.updates, max(d.max() for d in depth.values()))
    return {"depth": depth, "angles": {n: wm.angles() for n, wm in wms.items()}, "history": hist, "settings": s,
            "mech": worn}


def converged(mech, name, s: WearSettings, tol=0.05, max_rounds=5, out=None, progress=None, start=None) -> dict:
    """Double ``s.updates`` (halve the update factor) until every joint's final maximum depth
    changes by <= tol; returns the finer run's result plus ``rounds`` [(updates, factor,
    {name: max depth})] and
    ``converged`` (False after max_rounds: the last two runs' change is then reported)."""
    rounds, prev = [], None
    u = s.updates
    for _ in range(max_rounds):
        si = WearSettings(**{**asdict(s), "updates": u})
        if si.cycles < si.updates * si.block_periods:
            break
        res = wear_run(mech, name, si, None if out is None else safeio.make_dirs(Path(out) / f"updates_{u}"), progress,
                       start)
        d = {n: float(x.max()) for n, x in res["depth"].items()}
        rounds.append((u, si.factor, d))
        if prev is not None and all(abs(d[n] - prev["depth"][n].max()) <= tol * d[n] for n in d):
            res.update(rounds=rounds, converged=True)
            return res
        prev = res
        u *= 2
    prev.update(rounds=rounds, converged=False)
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

    from .contact.wear_spherical import plot_depth_map

    wm = worn_joint(res["mech"], name)[1].wear
    fig, ax = plt.subplots(figsize=(7, 3.8))
    plot_depth_map(ax, wm, res["depth"][name], f"{name}: worn socket after {res['history']['cycles'][-1]:.3g} cycles")
    fig.tight_layout()
    safeio.savefig(fig, Path(out) / f"depth_map_{name}.png", dpi=120)
    plt.close(fig)


def build_parser():
    import argparse

    from ._argtypes import count, number
    from .cli import _add_model_args

    p = argparse.ArgumentParser(prog="pinclear wear", description="Archard wear of revolute clearances over a "
                                "service life: the iterative scheme with the update factor chosen by a convergence "
                                "test (docs/wear_lubrication.md). Writes OUT/history.csv, OUT/profile.csv, "
                                "OUT/depth_vs_angle.png, OUT/growth.png, OUT/summary.json; rerun to resume.")
    _add_model_args(p)
    p.add_argument("--cycles", type=number(), required=True, help="service life in mechanism periods (e.g. 1e6)")
    p.add_argument("--period", type=number(unit="s"), required=True, help="the mechanism's period [s]")
    p.add_argument("--updates", type=count(1), default=4, help="reshapes of the first trial (doubled until "
                   "converged; default 4)")
    p.add_argument("--block-periods", type=count(1), default=1, help="periods simulated per reshape (default 1)")
    p.add_argument("--transient-periods", type=count(0), default=1, help="periods simulated first without wear "
                   "(default 1)")
    p.add_argument("--tol", type=number(), default=0.05, help="convergence: halving the update factor changes the "
                   "final depth by at most this (default 0.05)")
    p.add_argument("--max-rounds", type=count(1), default=5, help="most trials of the update factor (default 5)")
    p.add_argument("--rtol", type=number(), default=1e-6, help="relative tolerance of each block (default 1e-6)")
    p.add_argument("--dt-out", type=number(unit="s"), default=1e-4, help="sample interval of the wear quadrature "
                   "[s] (default 1e-4)")
    p.add_argument("--out", required=True, help="output folder (rerun into it to resume)")
    return p


def cli_main(argv=None) -> int:
    from .cli import _load

    args = build_parser().parse_args(argv)
    if not args.clearance:
        raise InputError("name the worn clearance(s) with --clearance NAME", key="--clearance")
    mech = _load(args)
    s = WearSettings(cycles=float(args.cycles), period=float(args.period), updates=args.updates,
                     block_periods=args.block_periods, transient_periods=args.transient_periods, rtol=args.rtol,
                     dt_out=args.dt_out)
    out = safeio.make_dirs(Path(args.out))
    with safeio.folder_lock(out):
        res = converged(mech, args.clearance, s, tol=args.tol, max_rounds=args.max_rounds, out=out,
                        progress=lambda k, n, d: print(f"wear: update {k}/{n}: max depth {d:.4g} m", flush=True))
        _tables(out, {n: worn_joint(res["mech"], n)[1].wear for n in res["depth"]}, res["depth"], res["history"])
        plot(res, out)
        summary = {"converged": res["converged"], "rounds": res["rounds"], "update_factor": res["settings"].factor,
                   "max_depth_m": {n: float(d.max()) for n, d in res["depth"].items()},
                   "cpu_sim_s": float(sum(res["history"]["cpu_sim"])),
                   "cpu_update_s": float(sum(res["history"]["cpu_update"]))}
        safeio.write_text(out / "summary.json", json.dumps(summary, indent=1) + "\n")
    print(json.dumps(summary))
    return 0 if res["converged"] else 1
