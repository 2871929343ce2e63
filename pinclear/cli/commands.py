"""Command line: `pinclear simulate|info|bench|view|plot|inverse-dynamics`.

Errors print one line (`pinclear: error: ...`) and exit 2; a failed integration writes what it
computed and exits 1."""
from __future__ import annotations

import argparse
import contextlib
import json
import os
import signal
import sys
import threading
import traceback
import warnings
from pathlib import Path

import numpy as np

from pinclear.cli.args import HelpFormatter, count, number
from pinclear.core.errors import InputError, PinclearError
from pinclear.core.registry import Entry, Registry
from pinclear.io.sidecar import parse_assignments as parse_kv


def _load(args):
    from pinclear.io.sidecar import check_disjoint, load

    options, overrides = parse_kv(getattr(args, "option", None), "--option"), parse_kv(getattr(args, "set", None), "--set")
    check_disjoint(options, overrides, "--option", "--set")
    return load(args.file, options=options, overrides=overrides, clearances=getattr(args, "clearance", None),
                trust=True if getattr(args, "trust", False) else None)


def _add_model_args(p, file_required=True):
    if file_required:
        p.add_argument("file", help="mechanism sidecar (urdf/NAME.yaml) or a bundled mechanism's name")
    p.add_argument("--clearance", action="append", metavar="NAME", help="activate a clearance joint (repeatable)")
    p.add_argument("--set", action="append", metavar="NAME.KEY=VALUE",
                   help="override a clearance key or a scene option (repeatable)")
    p.add_argument("--option", action="append", metavar="KEY=VALUE", help="set a scene option (repeatable)")
    p.add_argument("--trust", action="store_true",
                   help="allow the mechanism file to import Python code outside pinclear (see docs/manual.md, 'Trust')")


#: the simulate options recorded in OUT/run.json (a record for the user: --resume compares the
#: command line with it and takes nothing from it)
RUN_KEYS = ("file", "clearance", "set", "option", "trust", "t_end", "method", "integrator", "rtol", "atol", "h",
            "max_step", "dt_out", "alpha", "beta", "max_cpu", "min_mean_step", "start")
#: the options that define the run a checkpoint continues (--resume refuses a command line that
#: differs in one of them); trust is the user's decision of the moment, never the folder's
RESUME_KEYS = tuple(k for k in RUN_KEYS if k not in ("trust", "max_cpu", "start"))
#: the files a simulate run writes into --out
RUN_FILES = ("run.json", "trajectory.npz", "summary.json", "checkpoint.npz")


def check_out_dir(out: Path, files=()):
    """Fail before the run, not after it, when the results could not be written."""
    if out.exists() and not out.is_dir():
        raise InputError(f"--out {str(out)!r} is an existing file; give a folder")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"--out {str(out)!r}: cannot create the folder ({exc.strerror})") from None
    from pinclear.core.safeio import probe_writable

    try:
        probe_writable(out)
    except OSError as exc:
        raise InputError(f"--out {str(out)!r}: the folder is not writable ({exc.strerror})") from None
    for name in files:
        target = out / name
        if target.is_symlink() or (target.exists() and not target.is_file()):
            raise InputError(f"--out {str(out)!r}: {str(target)!r} exists and is not a regular file (a folder, a "
                             "link or a device); remove it or choose another --out")


class _StopRequest:
    """SIGINT/SIGTERM for the whole of a command: the first signal asks the run to finish its
    current step (samples kept, checkpoint written) and the command to end with the interrupted
    status once everything computed is saved; a second one stops at once, unless the orderly
    stop or the writing of results has begun (``critical``), which always completes."""

    def __init__(self):
        self.requested = False
        self.critical = False
        self._old = {}

    def __enter__(self):
        for sig in (signal.SIGINT, signal.SIGTERM):
            try:
                self._old[sig] = signal.signal(sig, self._handle)
            except ValueError:          # not the main thread: signals stay as they are
                pass
        return self

    def _handle(self, signum, frame):
        if self.requested and not self.critical:     # a second signal: stop at once
            raise KeyboardInterrupt
        self.requested = True

    def __exit__(self, *exc):
        for sig, old in self._old.items():
            # after a stop request the command is ending with 130 with everything saved: a
            # signal arriving now (the second of two quick ones) must not turn that into a
            # death by signal
            signal.signal(sig, signal.SIG_IGN if self.requested else old)
        return False


def _progress_bar(args, t0, t_end):
    """A tqdm bar over simulated time on an interactive terminal (never in CI or when quiet)."""
    show = args.progress == "on" or (args.progress == "auto" and sys.stderr.isatty() and not os.environ.get("CI"))
    if not show:
        return None
    from tqdm import tqdm

    return tqdm(total=t_end - t0, unit="sim s", file=sys.stderr, dynamic_ncols=True,
                bar_format="{l_bar}{bar}| {n:.4g}/{total:.4g} sim s [{elapsed}<{remaining}]")


def _resume_command(recorded: dict, folder) -> str:
    """The command line that continues the run recorded in run.json (shown, never executed)."""
    import shlex

    parts = ["pinclear", "simulate", str(recorded.get("file"))]
    for k in RUN_KEYS:
        v = recorded.get(k)
        if k in ("file", "start") or v is None or v is False or v == []:
            continue
        flag = "--" + k.replace("_", "-")
        if v is True:
            parts.append(flag)
        elif isinstance(v, list):
            for item in v:
                parts += [flag, str(item)]
        else:
            parts += [flag, str(v)]
    parts += ["--resume", str(folder)]
    return " ".join(shlex.quote(p) for p in parts)


def _read_run_json(rdir: Path) -> dict:
    """OUT/run.json of the run to resume, as data: a mapping of the RUN_KEYS with JSON types."""
    path = rdir / "run.json"
    try:
        if path.is_symlink() or not path.is_file():
            raise OSError("not a regular file")
        if path.stat().st_size > 1_000_000:
            raise ValueError("larger than 1 MB")
        recorded = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError) as exc:
        raise InputError(f"--resume {str(rdir)!r}: no readable run.json of an earlier run "
                         f"({type(exc).__name__}: {exc})") from None
    if not isinstance(recorded, dict) or not isinstance(recorded.get("file"), str):
        raise InputError(f"{path}: does not describe a pinclear run (expected a mapping with 'file')")
    scalar = (int, float, str, bool, type(None))
    for k, v in recorded.items():
        if not (isinstance(v, scalar) or (isinstance(v, list) and all(isinstance(x, str) for x in v))):
            raise InputError(f"{path}: {k}: expected a number, text or a list of texts, got {type(v).__name__}")
    return recorded


def _resume_differences(args, recorded: dict) -> list[str]:
    """Where the command line contradicts the recorded run (names the options)."""
    from pinclear.core.models import model_path

    diffs = []
    for k in RESUME_KEYS:
        have, was = getattr(args, k, None), recorded.get(k)
        if k == "file":
            try:
                same = model_path(have).resolve() == model_path(was).resolve()
            except PinclearError:
                same = have == was
            if not same:
                diffs.append(f"mechanism {have!r} (command line) vs {was!r} (the run)")
            continue
        if k in ("clearance", "set", "option"):       # repeatable options: absent == none given
            have, was = have or [], was or []
        if have != was:
            diffs.append(f"--{k.replace('_', '-')} {have!r} (command line) vs {was!r} (the run)")
    return diffs


def cmd_simulate(args):
    """simulate FILE ...: the whole command runs under one lock on --out and one SIGINT/SIGTERM
    handler; the trajectory is written before anything that can raise, and a write that fails
    leaves a copy elsewhere (docs/security.md)."""
    with _StopRequest() as stop:
        rc = _simulate(args, stop)
        if getattr(args, "check", False) and rc == 0 and not stop.requested:
            # the run again at rtol/10 and half the output step, and the table of what moved
            from pinclear.cli.check import check_run

            rc = check_run(args, lambda refined: _simulate(refined, stop))
        return rc


def _simulate(args, stop):
    from pinclear.core.safeio import folder_lock
    from pinclear.dynamics.simulate import simulate
    from pinclear.dynamics.trajectory import Checkpoint, atomic_write_text

    resume = recorded = None
    if args.resume:
        rdir = Path(args.resume)
        if args.out not in (None, "out") and Path(args.out).resolve() != rdir.resolve():
            raise InputError(f"--out {args.out!r} contradicts --resume {str(rdir)!r}: a run is continued in its "
                             "own folder (omit --out)")
        args.out = str(rdir)
        if not rdir.is_dir():
            raise InputError(f"--resume {str(rdir)!r}: no such folder")
    if args.file is None or args.t_end is None:
        hint = ""
        if args.resume:
            with contextlib.suppress(PinclearError):
                hint = f"; the run in it was started as: {_resume_command(_read_run_json(Path(args.resume)), args.resume)}"
        raise InputError("simulate needs a mechanism file and --t-end (with --resume DIR: the same mechanism and "
                         "options as the run being continued; nothing is taken from DIR but its checkpoint)" + hint)
    if getattr(args, "peaks_after", None) is not None and not 0 <= args.peaks_after < args.t_end:
        raise InputError(f"--peaks-after {args.peaks_after:g}: expected a time in [0, --t-end {args.t_end:g}) s")
    out = Path(args.out)
    check_out_dir(out, RUN_FILES)
    with folder_lock(out):
        if args.resume:
            recorded = _read_run_json(out)
            diffs = _resume_differences(args, recorded)
            if diffs:
                raise InputError(f"--resume {str(out)!r}: the command line contradicts the run it continues: "
                                 + "; ".join(diffs) + f" (that run: {_resume_command(recorded, out)})")
            ck_path = out / "checkpoint.npz"
            if not ck_path.exists():
                raise InputError(f"--resume {str(out)!r}: no checkpoint.npz (the run finished, or never wrote one)")
            resume = Checkpoint.load(ck_path)
        mech = _load(args)
        if stop.requested:
            print("pinclear: interrupted before the run started; nothing computed", file=sys.stderr)
            return 130
        kw = {k: getattr(args, k) for k in ("alpha", "beta") if getattr(args, k) is not None}
        if resume is None:
            kw.update(_start_options(args.start, mech))
        max_step = np.inf if args.max_step is None else args.max_step
        atomic_write_text(out / "run.json", json.dumps({k: getattr(args, k) for k in RUN_KEYS}, indent=2))

        def save_checkpoint(ck):
            ck.save(out / "checkpoint.npz")

        bar = _progress_bar(args, resume.t if resume else 0.0, args.t_end)

        def progress(t):
            if bar is not None:
                bar.update(t - bar.n)
            if stop.requested:
                # the run stops in order from here (checkpoint, samples, save): a further
                # signal must not cut that short
                stop.critical = True
            return stop.requested

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            try:
                traj = simulate(mech, args.t_end, method=args.method, integrator=args.integrator, rtol=args.rtol,
                                atol=args.atol, h=args.h, dt_out=args.dt_out, max_step=max_step,
                                max_cpu=args.max_cpu, min_mean_step=args.min_mean_step, progress=progress,
                                **_fixed_step_tol(args),
                                checkpoint=save_checkpoint, checkpoint_every=args.checkpoint_every,
                                resume=resume, **kw)
            finally:
                if bar is not None:
                    bar.close()
        stop.critical = True           # from here on, everything computed is written whatever arrives
        if getattr(args, "peaks_after", None) is not None:     # the summary's peaks after a transient
            traj.meta["peaks_after"] = args.peaks_after
        return _save_run(args, mech, traj, out, stop)


def _fixed_step_tol(args) -> dict:
    """simulate's fixed_step_tol from --fixed-step-tol (0: no check; absent: simulate's default)."""
    tol = getattr(args, "fixed_step_tol", None)
    return {} if tol is None else {"fixed_step_tol": tol or None}


def _start_options(start, mech) -> dict:
    """simulate()'s start, q0, v0 from --start NAME [FILE] (pinclear.model.kinematics.STARTS)."""
    from pinclear.dynamics.simulate import read_state
    from pinclear.model.kinematics import STARTS

    name, rest = (start[0], start[1:]) if start else ("ideal", [])
    if name not in STARTS:
        raise InputError(f"unknown start {name!r}", key="--start", choices=STARTS)
    if name == "state":
        if len(rest) != 1:
            raise InputError("state needs one FILE (.npz with arrays q and v, or .json {\"q\": [...], "
                             "\"v\": [...]})", key="--start")
        q, v = read_state(rest[0], mech)
        return {"start": name, "q0": q, "v0": v}
    if rest:
        raise InputError(f"{name} takes no FILE (only state FILE does)", key="--start")
    return {"start": name}


def _save_run(args, mech, traj, out: Path, stop):
    """Write the trajectory first (nothing that can raise comes before it), then the summary."""
    from pinclear.core.safeio import write_or_fallback
    from pinclear.dynamics.trajectory import atomic_write_text

    problems = []
    written, problem = write_or_fallback(lambda p, root: traj.save(p), out / "trajectory.npz")
    if problem:
        problems.append(problem)
    try:
        summary = traj.summary()
    except Exception as exc:      # e.g. a trusted platform motion raising in the tracking error
        summary = {"status": traj.status, "message": traj.message, "t_end": float(traj.t[-1]) if len(traj.t) else None,
                   "samples": len(traj.t), "summary_error": f"{type(exc).__name__}: {exc}"}
        summary.update(traj.peak_summary())          # reads the run's stats only, never user code
    from pinclear.dynamics.trajectory import SUMMARY_SCHEMA

    summary["mechanism"] = mech.name
    summary["file"] = str(args.file)
    summary.setdefault("schema_version", SUMMARY_SCHEMA)
    _, problem = write_or_fallback(lambda p, root: atomic_write_text(p, json.dumps(summary, indent=2, default=str),
                                                                     root), out / "summary.json")
    if problem:
        problems.append(problem)
    if traj.status == "success" and written == out / "trajectory.npz":
        (out / "checkpoint.npz").unlink(missing_ok=True)
    print(json.dumps({k: summary[k] for k in ("status", "mobility", "redundant_constraints", "max_closure_residual",
                                              "energy_drift_rel", "tracking_error", "rhs_evals", "cpu_s",
                                              "summary_error") if k in summary}, default=str))
    eb = summary.get("energy_balance") or {}
    if eb.get("ok") is False:       # the energy audit (pinclear.dynamics.energy), whatever the status
        print(f"pinclear: warning: energy balance off by {eb['error']:.3g} of the run's energy scale "
              f"{eb['scale']:.3g} J at t = {eb['t']:.6g} s (bound {eb['bound']:.3g} from rtol and steps): "
              "a force element creates or loses energy it does not report", file=sys.stderr)
    for p in problems:
        print(f"pinclear: error: {p}", file=sys.stderr)
    if "summary_error" in summary:
        print(f"pinclear: warning: the summary could not be computed ({summary['summary_error']}); the "
              f"trajectory is saved", file=sys.stderr)
    if traj.status == "interrupted" or stop.requested:
        when = f"at t = {traj.t[-1]:.9g} s" if traj.status == "interrupted" and len(traj.t) else "after the run ended"
        print(f"pinclear: interrupted {when} (SIGINT/SIGTERM); {len(traj.t)} samples saved in {written or out}"
              + (f"; continue with {_resume_command({k: getattr(args, k) for k in RUN_KEYS}, out)}"
                 if traj.status == "interrupted" else ""), file=sys.stderr)
        return 130
    if problems or "summary_error" in summary:
        return 1
    if traj.status != "success":
        print(f"pinclear: integration failed: {traj.message}", file=sys.stderr)
        return 1
    return 0


def cmd_info(args):
    from pinclear.model import kinematics

    mech = _load(args)
    q = kinematics.start_state(mech, "ideal")[0]       # where a run starts: freed joints assembled with the rest
    mob = kinematics.mobility(mech, q)
    info = mech.describe()
    model = mech.model
    info.update({"mobility": mob["mobility"], "closure_rows": mob["rows"], "rank": mob["rank"],
                 "redundant_rows": mob["redundant_rows"], "condition": mob["condition"],
                 "parameters": mech.parameters, "q_assembled": q.tolist(),
                 "q_assembled_by_joint": {model.names[j]: q[model.joints[j].idx_q:model.joints[j].idx_q
                                                            + model.joints[j].nq].tolist()
                                          for j in range(1, model.njoints)}})
    from pinclear.model.joint_chains import lock_margins

    info["lock_margins_deg"] = {k: float(np.degrees(m)) for k, m in lock_margins(model, q).items()}
    from pinclear.analysis.economy import economy_report

    info["economy"] = economy_report(mech, t_end=args.along, threshold=args.threshold)
    info["redundant_rows_named"] = [r["name"] for r in info["economy"]["redundant_rows"]]
    if args.json:
        print(json.dumps(info, indent=2, default=str))
    else:
        print(info_text(mech, q, mob, info["economy"]))
    return 0


def _actuation(n_drives, mobility):
    """'3 drives on mobility 3: fully actuated' and its under- and over-actuated kin."""
    head = f"{n_drives} drive{'s' * (n_drives != 1)} on mobility {mobility}"
    if n_drives == mobility:
        return f"{head}: fully actuated (the drives prescribe every free motion)"
    if n_drives < mobility:
        return f"{head}: under-actuated ({mobility - n_drives} free motion(s) follow the dynamics)"
    return f"{head}: over-actuated ({n_drives - mobility} drive row(s) beyond the mobility: the laws must agree)"


def info_text(mech, q, mob, economy) -> str:
    """pinclear info's readable summary: counts, mobility and actuation, the branch, the
    assembly residual, the clearances declared and the assembled q by joint name."""
    from pinclear.analysis.signals import joint_unit
    from pinclear.model import kinematics

    ws = mech.workspace()
    phi = kinematics.closure_residual(mech, ws, q, with_drives=True)
    J = kinematics.jacobian(mech, ws, q, with_drives=True)
    lines = [f"{mech.name} ({mech.path}): {mech.model.njoints - 1} tree joints, nq {mech.nq}, nv {mech.nv}",
             f"closures: {len(mech.closures)} ({', '.join(c.name + ' ' + c.type for c in mech.closures) or 'none'}): "
             f"{mob['rows']} rows, rank {mob['rank']}, condition {mob['condition']:.3g}; redundant rows: "
             f"{', '.join(mob['redundant_rows']) or 'none'}",
             f"mobility {mob['mobility']}; {_actuation(len(mech.drives), mob['mobility'])}"]
    if mech.replaced_closures:
        ideal = kinematics.mobility(kinematics.ideal_mechanism(mech), q)["mobility"]
        lines.append(f"  with {', '.join(mech.replaced_closures)} freed by clearances; the ideal mechanism's "
                     f"mobility is {ideal}")
    if J.shape[0] == J.shape[1] and J.size:
        sign = np.sign(np.linalg.det(J))
        lines.append(f"branch: sign det [closure rows; drive rows] = {int(sign):+d} (the assembly mode; it changes "
                     "only through a singular configuration)")
    else:
        lines.append(f"branch: not defined by a sign (the Jacobian with drives is {J.shape[0]} x {J.shape[1]})")
    lines.append(f"assembly residual at t = 0: {np.abs(phi).max() if phi.size else 0.0:.3g} (closures and drives, "
                 "m or rad)")
    from pinclear.model.joint_chains import lock_margins

    for label, margin in lock_margins(mech.model, q).items():
        lines.append(f"spherical chain {label} (3 revolute axes at one point): {np.degrees(margin):.3g} deg from its "
                     "lock at t = 0 (90 at best; at 0 its first and last axes align and it loses a freedom)")
    active = {f.name for f in mech.clearances}
    decl = [c for c in (mech.sidecar.get("clearances") or []) if isinstance(c, dict)]
    lines.append(f"clearances declared: {len(decl) or 'none'}")
    for c in decl:
        state = "active" if c.get("name") in active else f"inactive (--clearance {c.get('name')})"
        size = c.get("clearance")
        size = f", clearance {1e3 * float(size):g} mm" if isinstance(size, (int, float)) else ""
        lines.append(f"  {c.get('name')}: {c.get('type')} on closure {c.get('closure')}{size}, {state}")
    lines.append("assembled q by joint (initial guess -> assembled; rad and deg for revolute, m for prismatic):")
    model = mech.model
    for j in range(1, model.njoints):
        jm = model.joints[j]
        sl = slice(jm.idx_q, jm.idx_q + jm.nq)
        a, g = q[sl], mech.q0[sl]
        if jm.nq == 1:
            unit = joint_unit(jm)
            deg = f" ({np.degrees(a[0]):.4g} deg)" if unit == "rad" else ""
            lines.append(f"  {model.names[j]:<14s} {g[0]: .6g} -> {a[0]: .9g} {unit}{deg}")
        else:
            lines.append(f"  {model.names[j]:<14s} {np.round(g, 6).tolist()} -> {np.round(a, 9).tolist()}")
    planar = (economy or {}).get("planarity") or {}
    if "planar" in planar:
        lines.append(f"planar: {'yes' if planar['planar'] else 'no'}")
    lines.append("(--json: every field as JSON, the economy report included)")
    return "\n".join(lines)


def _split_names(text, default):
    """A comma-separated option value as a list of names (the default when not given)."""
    if text is None:
        return [default]
    return [n.strip() for n in text.split(",") if n.strip()]


def cmd_bench(args):
    """bench WHAT: the benchmark's own function (_BENCH) after the checks every benchmark shares."""
    runs_only = [o for o, v in (("--integrators", args.integrators), ("--max-cpu", args.max_cpu)) if v is not None]
    if runs_only and args.what != "runs":
        raise InputError(f"bench {args.what}: {runs_only[0]} applies to bench runs only")
    if args.what in _BENCH:
        return _BENCH[args.what](args)
    if args.rest:
        raise InputError(f"bench {args.what}: unrecognized arguments: {' '.join(args.rest)}")
    if args.file is None:
        raise InputError(f"bench {args.what} needs a mechanism file")
    if args.t_end is None:
        args.t_end = 2.0
    return _bench_one_mechanism(args, _load(args))


def _bench_restitution(args):
    from pinclear.cli.args import OneLineParser
    from pinclear.studies.bench import restitution as cbench

    return cbench.restitution_main(args.rest, parser=OneLineParser)


def _bench_contact_laws(args):
    from pinclear.cli.args import OneLineParser
    from pinclear.studies.bench import restitution as cbench

    return cbench.contact_laws_main(args.rest, parser=OneLineParser)


def _bench_atlas(args):
    from pinclear.studies.bench import atlas

    # the shared --out default names the benchmarks folder: the atlas gets its own sub-folder
    out = Path("benchmarks/atlas" if args.out == "benchmarks" else args.out)
    check_out_dir(out)
    files = [args.file] + list(args.rest or []) if args.file else None
    res = atlas.run_atlas(files, out=out, quick=args.quick, budget=args.budget,
                          methods=args.methods.split(",") if args.methods else None,
                          progress=lambda s: print(f"bench atlas: {s}", file=sys.stderr, flush=True))
    fails = sum(r["status"] != "success" for r in res["rows"])
    print(f"atlas: {len(res['rows'])} cells over {len(res['scenes'])} scenes, {fails} failed; "
          f"{out / 'atlas.json'}, {out / 'atlas.csv'}, heatmap_*.png, work_precision_*.png")
    return 0


def _bench_outputs(args):
    from pinclear.dynamics.trajectory import atomic_write_text
    from pinclear.studies.bench import rhs as bench

    out = Path(args.out)
    check_out_dir(out)
    res = bench.bench_outputs(t_end=2.0 if args.t_end is None else args.t_end,
                              progress=lambda s: print(f"bench outputs: {s}", file=sys.stderr, flush=True))
    atomic_write_text(out / "bench_outputs.json", json.dumps(res, indent=2, default=str))
    print(bench.outputs_table(res))
    return 0


def _bench_runs(args):
    from pinclear.dynamics.trajectory import atomic_write_text
    from pinclear.studies.bench import rhs as bench

    # names first: a typo is refused before the folder is made or anything runs
    methods, integrators = bench.check_run_names(_split_names(args.methods, "lagrange"),
                                                 _split_names(args.integrators, "RK45"),
                                                 keys=("--methods", "--integrators"))
    out = Path(args.out)
    check_out_dir(out)
    files = [args.file] + list(args.rest or []) if args.file else None
    kw = {} if args.max_cpu is None else {"max_cpu": args.max_cpu}
    res = bench.bench_runs(files, t_end=0.5 if args.t_end is None else args.t_end, methods=methods,
                           integrators=integrators,
                           progress=lambda s: print(f"bench runs: {s}", file=sys.stderr, flush=True), **kw)
    atomic_write_text(out / "bench_runs.json", json.dumps(res, indent=2, default=str))
    table = bench.runs_table(res)
    atomic_write_text(out / "bench_runs.md", table + "\n")
    print(table)
    if len(methods) > 1 or len(integrators) > 1:
        matrix = bench.runs_matrix_table(res)
        atomic_write_text(out / "bench_runs_matrix.md", matrix + "\n")
        print()
        print(matrix)
    return 0


def _bench_one_mechanism(args, mech):
    """bench rhs FILE and bench work-precision FILE."""
    from pinclear.dynamics import formulations
    from pinclear.studies.bench import rhs as bench

    if args.what == "rhs":
        methods = args.methods.split(",") if args.methods else None
        for m in methods or []:
            formulations.get(m)         # an unknown name is an error, not skipped
        res = bench.bench_rhs(mech, methods=methods)
        from pinclear.dynamics.trajectory import atomic_write_text

        out = Path(args.out)
        check_out_dir(out)
        atomic_write_text(out / f"bench_rhs_{mech.name}.json", json.dumps(res, indent=2, default=str))
    else:
        res = bench.work_precision(mech, t_end=args.t_end, out_dir=args.out)
        res.pop("rows")
    print(json.dumps(res, indent=2, default=str))
    return 0


#: the benchmarks that take no single mechanism (or several): bench WHAT -> its function
_BENCH = {"restitution": _bench_restitution, "contact-laws": _bench_contact_laws, "atlas": _bench_atlas,
          "outputs": _bench_outputs, "runs": _bench_runs}


def cmd_sweep(args):
    from pinclear.analysis.sweeps import TABLE_CSV, TABLE_NPZ, parse_vary, sweep

    vary = [parse_vary(v) for v in args.vary]       # a list: a key varied twice is refused by the grid
    sim = {"method": args.method, "integrator": args.integrator}
    if args.rtol is not None:
        sim["rtol"] = args.rtol
    if args.dt_out is not None:
        sim["dt_out"] = args.dt_out
    if args.max_cpu is not None:
        sim["max_cpu"] = args.max_cpu
    if args.peaks_after is not None:
        sim["peaks_after"] = args.peaks_after
    load_kw = {"options": parse_kv(args.option, "--option"), "overrides": parse_kv(args.set, "--set"),
               "clearances": args.clearance}
    from pinclear.io.sidecar import check_disjoint

    check_disjoint(load_kw["options"], load_kw["overrides"], "--option", "--set")
    check_disjoint(load_kw["overrides"], {k: "(varied)" for k, _ in vary}, "--set", "--vary")
    if args.trust:
        load_kw["trust"] = True
    show = args.progress == "on" or (args.progress == "auto" and sys.stderr.isatty() and not os.environ.get("CI"))
    res = sweep(args.file, vary, args.t_end, args.out, sim_options=sim,
                load_options={k: v for k, v in load_kw.items() if v}, workers=args.workers,
                scheduler=args.scheduler, progress=True if show else None)
    counts = {}
    for p in res.points:
        counts[p.status] = counts.get(p.status, 0) + 1
    print(json.dumps({"folder": str(res.folder), "points": len(res.points), "computed_now": res.computed,
                      "table": [str(res.folder / TABLE_CSV), str(res.folder / TABLE_NPZ)],
                      "status": counts, "failures": [{"point": p.overrides, "status": p.status, "message": p.message}
                                                     for p in res.failures]}, default=str))
    return 0 if not res.failures else 1


def cmd_warmup(args):
    from pinclear.studies.bench import atlas

    res = atlas.warm_up_all(args.files or None,
                            progress=lambda s: print(f"warmup: {s}", file=sys.stderr, flush=True))
    from pinclear.core.jit import cache_dir

    print(f"pinclear warmup: {res['compilations']} kernels compiled in {res['compile_cpu_s']:.1f} CPU s "
          f"({res['cpu_s']:.1f} s in all); cache {cache_dir()}")
    return 0


def _bare(parser):
    """`pinclear` alone: the command list (exit 2, as for any missing argument)."""
    parser.print_help()
    return 2


#: subcommands that parse their own arguments (a pinclear.cli.args.OneLineParser each): an Entry
#: each, its function called with the arguments after the command's name, its doc the one-line help
COMMANDS = Registry("command", {e.name: e for e in (
    Entry("view", "pinclear.cli.view:view_main", "meshcat viewer / standalone HTML of a mechanism or a run"),
    Entry("plot", "pinclear.cli.view:plot_main", "standard figures of a saved trajectory"),
    Entry("inverse-dynamics", "pinclear.cli.inverse_dynamics:cli_main", "screw-theory inverse dynamics (paper 004)"),
    Entry("analyse", "pinclear.cli.analyse:cli_main", "phase portraits, Poincare maps, bifurcation diagrams"),
    Entry("reproduce", "pinclear.cli.reproduce:cli_main", "a source paper's study with its numbers beside ours"),
    Entry("import", "pinclear.cli.importing:cli_main",
          "a mechanism from SDF, MJCF or a closing-frame URDF as a URDF tree + sidecar"),
    Entry("export", "pinclear.cli.export:cli_main", "a mechanism as MuJoCo MJCF (--mjcf OUT.xml)"),
    Entry("export-run", "pinclear.cli.export_run:cli_main", "a saved run's samples as CSV / MATLAB .mat"),
    Entry("wear", "pinclear.cli.wear:cli_main", "Archard wear of revolute clearances over a service life"),
    Entry("study", "pinclear.cli.study:cli_main", "the wear studies (paper 002's linkage worn at A and B)"))},
    record=Entry)


def _version() -> str:
    """The version, where the package was imported from, and whether its C++ extension is in use
    (and why not): the one check that works from any folder (`python3 -c "import pinclear"` in
    the repository root imports the source folder, which has no built extension)."""
    from pinclear.core.jit import cache_dir
    from pinclear.core.version import __version__
    from pinclear.model import native

    ext = "in use" if native.available() else f"not in use: {native.reason}"
    return (f"pinclear {__version__} from {Path(__file__).resolve().parents[1]}\n"
            f"C++ extension pinclear.model._passes: {ext}\nkernel cache: {cache_dir()}")


class _VersionAction(argparse.Action):
    """--version: printed as is (argparse's own action re-wraps the lines)."""

    def __init__(self, option_strings, dest=argparse.SUPPRESS, default=argparse.SUPPRESS, help=None):
        super().__init__(option_strings=option_strings, dest=dest, default=default, nargs=0, help=help)

    def __call__(self, parser, namespace, values, option_string=None):
        print(_version())
        parser.exit(0)


def _add_run_args(s, rtol):
    """--method/--integrator/--rtol as simulate and sweep take them; the choices are the
    registries' (pinclear.dynamics.formulations.METHODS, pinclear.dynamics.stepping.INTEGRATORS)."""
    from pinclear.dynamics.formulations import METHODS
    from pinclear.dynamics.stepping import INTEGRATORS

    s.add_argument("--method", default="lagrange", choices=list(METHODS),
                   help="forward-dynamics formulation (docs/manual.md, 'Formulations and integrators')")
    s.add_argument("--integrator", default="RK45", choices=list(INTEGRATORS),
                   help="time integrator (RK4: fixed step --h)")
    s.add_argument("--rtol", type=number(), default=rtol, help="relative tolerance of the adaptive integrators"
                   + (" (default: simulate's, 1e-8)" if rtol is None else ""))


def _add_peaks_after(s):
    s.add_argument("--peaks-after", type=number("nonnegative", "s"), default=None, metavar="T",
                   help="also give the peaks from T seconds on (summary 'peaks_after': the steady regime after a "
                        "start-up transient; the whole run's peaks stay)")


def build_parser():
    p = _OneLineParser(prog="pinclear", formatter_class=HelpFormatter,
                       description="Dynamics of parallel mechanisms with joint clearance. `pinclear COMMAND --help` "
                       "describes a command; --debug anywhere shows tracebacks.",
                       epilog="Without a command pinclear prints this help and exits 2.")
    p.add_argument("--version", action=_VersionAction,
                   help="print the version, where pinclear is installed, whether its C++ extension is in use "
                        "(and why not) and the kernel cache folder; exit")
    p.set_defaults(func=lambda args: _bare(p))
    sub = p.add_subparsers(dest="cmd", metavar="COMMAND", parser_class=_OneLineParser)

    _add_simulate_parser(sub)
    _add_sweep_parser(sub)
    _add_info_parser(sub)
    _add_bench_parser(sub)
    _add_warmup_parser(sub)

    for name, entry in COMMANDS.items():
        # everything after the name, --help included, goes to the subcommand's own parser
        s = sub.add_parser(name, help=entry.doc, add_help=False, passthrough=True)
        s.set_defaults(func=lambda args, entry=entry: entry(args.rest))
    return p


def _add_simulate_parser(sub):
    """`pinclear simulate`'s arguments."""
    s = sub.add_parser("simulate", help="forward dynamics; writes OUT/trajectory.npz and OUT/summary.json",
                       formatter_class=HelpFormatter)
    s.add_argument("file", nargs="?", help="mechanism sidecar (urdf/NAME.yaml) or a bundled mechanism's name")
    _add_model_args(s, file_required=False)
    s.add_argument("--t-end", type=number(unit="s"), default=None, help="end time [s] (required unless --resume)")
    _add_run_args(s, rtol=1e-8)
    s.add_argument("--atol", type=number(), default=None, help="absolute tolerance (default: rtol * 1e-2)")
    s.add_argument("--h", type=number(unit="s"), default=None, help="fixed step for RK4 [s]")
    s.add_argument("--max-step", type=number(unit="s"), default=None, help="largest step [s] (default: unbounded)")
    s.add_argument("--dt-out", type=number(unit="s"), default=None,
                   help="output interval [s] (default: 500 intervals over the run)")
    s.add_argument("--alpha", type=number("nonnegative", "1/s"), default=None,
                   help="Baumgarte alpha [1/s] (default: the formulation's)")
    s.add_argument("--beta", type=number("nonnegative", "1/s"), default=None,
                   help="Baumgarte beta [1/s] (default: the formulation's)")
    s.add_argument("--out", default="out", help="output folder (created if missing)")
    s.add_argument("--max-cpu", type=number(unit="s"), default=None,
                   help="CPU budget [s] of the integration (kernel compilation excluded): the run ends as failed, "
                        "samples kept (default: no budget)")
    s.add_argument("--min-mean-step", type=number("nonnegative", "s"), default=None, metavar="SECONDS",
                   help="stall test: the run fails as a step-size collapse when its last 1000 steps average less "
                        "(default 1e-9 of the run's span, at most 1e-8 s; 0: off)")
    s.add_argument("--fixed-step-tol", type=number("nonnegative"), default=None, metavar="TOL",
                   help="RK4 only: the run fails when its step-doubling error estimate, closure residual or "
                        "energy-balance error exceeds TOL (relative; default 1e-2; 0: no check; docs/security.md)")
    s.add_argument("--checkpoint-every", type=number(unit="s"), default=None, metavar="SECONDS",
                   help="write OUT/checkpoint.npz every SECONDS of CPU, so a killed run can be resumed "
                        "(default: only when the run ends early)")
    s.add_argument("--start", nargs="+", default=None, metavar=("NAME", "FILE"),
                   help="the state at t = 0: ideal (default: the ideal mechanism's assembled state and velocity, "
                        "every clearance centred with zero relative velocity, as the papers start), rest, "
                        "least-energy (the clearance mechanism's velocity of least kinetic energy: a start-up "
                        "impact) or state FILE (q and v from a .npz or .json, kept off centre)")
    _add_peaks_after(s)
    s.add_argument("--check", action="store_true",
                   help="then run again at rtol/10 and half the output step (into OUT/check) and print how the "
                        "summary's peaks, events and energy audit moved; exit 1 if any moved by more than --check-tol")
    s.add_argument("--check-tol", type=number(), default=None, metavar="REL",
                   help="relative change that counts as moved for --check (default 0.01)")
    s.add_argument("--resume", default=None, metavar="DIR",
                   help="continue the interrupted or stopped run saved in DIR (same options, same steps)")
    s.add_argument("--progress", choices=["auto", "on", "off"], default="auto",
                   help="progress bar (auto: on an interactive terminal outside CI)")
    s.set_defaults(func=cmd_simulate)


def _add_sweep_parser(sub):
    """`pinclear sweep`'s arguments."""
    s = sub.add_parser("sweep", help="one run per point of a parameter grid, resumable, local or on Dask",
                       formatter_class=HelpFormatter)
    _add_model_args(s)
    s.add_argument("--vary", action="append", required=True, metavar="KEY=a:b:n",
                   help="a load() key (NAME.key, a key path or a scene option) and its values: a:b:n "
                        "(linear), a:b:n:log, or v1,v2,... (repeatable: the grid of all combinations)")
    s.add_argument("--t-end", type=number(unit="s"), required=True, help="simulated time per point [s]")
    s.add_argument("--out", required=True, help="sweep folder (rerun into it to resume)")
    _add_run_args(s, rtol=None)      # None: simulate's own default (pinclear.dynamics.simulate.RTOL_DEFAULT)
    s.add_argument("--dt-out", type=number(unit="s"), default=None,
                   help="output interval [s] (default: 500 intervals per run)")
    s.add_argument("--max-cpu", type=number(unit="s"), default=None,
                   help="CPU budget per point [s] (default: no budget)")
    _add_peaks_after(s)
    s.add_argument("--workers", type=count(1), default=None, help="local worker processes (default: one per CPU)")
    s.add_argument("--scheduler", default=None, metavar="tcp://HOST:PORT",
                   help="run the points on this Dask distributed cluster instead (default: local processes)")
    s.add_argument("--progress", choices=["auto", "on", "off"], default="auto",
                   help="progress bar (auto: on an interactive terminal outside CI)")
    s.set_defaults(func=cmd_sweep)


def _add_info_parser(sub):
    """`pinclear info`'s arguments."""
    s = sub.add_parser("info", help="assemble and print the mechanism: mobility, redundancy, parameters",
                       formatter_class=HelpFormatter)
    _add_model_args(s)
    s.add_argument("--along", type=number(unit="s"), default=None, metavar="T_END",
                   help="also simulate to T_END [s] and test planarity and each body's inertia along the run")
    s.add_argument("--threshold", type=number(), default=0.01,
                   help="relative drive-force change below which a body's inertia is droppable")
    s.add_argument("--json", action="store_true",
                   help="print every field as JSON (the economy report included) instead of the summary")
    s.set_defaults(func=cmd_info)


def _add_bench_parser(sub):
    """`pinclear bench`'s arguments."""
    s = sub.add_parser("bench", help="bench rhs FILE | bench runs [FILES] | bench work-precision FILE | "
                       "bench restitution | bench contact-laws | bench atlas [FILES] [--quick] | bench outputs",
                       formatter_class=HelpFormatter)
    s.add_argument("what", choices=["rhs", "runs", "work-precision", "restitution", "atlas", "contact-laws", "outputs"],
                   help="which benchmark (outputs: the cost of a run's outputs against its samples, docs/outputs.md)")
    s.add_argument("file", nargs="?", help="mechanism sidecar or bundled name (runs, atlas: default all scenes)")
    _add_model_args(s, file_required=False)
    s.add_argument("--methods", default=None, help="comma-separated formulations (default: rhs all; atlas all but "
                   "manifold; runs lagrange)")
    s.add_argument("--integrators", default=None,
                   help="runs: comma-separated adaptive integrators (default RK45); with several methods or "
                        "integrators it also writes OUT/bench_runs_matrix.md, one table per integrator")
    s.add_argument("--max-cpu", type=number(unit="s"), default=None,
                   help="runs: CPU budget [s] of one run, compilation excluded (default 120): a longer run ends "
                        "as failed, its figures kept")
    s.add_argument("--t-end", type=number(unit="s"), default=None,
                   help="simulated time [s] (default: work-precision 2, runs 0.5)")
    s.add_argument("--out", default="benchmarks", help="output folder (atlas: benchmarks/atlas)")
    s.add_argument("--quick", action="store_true", help="atlas: reduced grid (few tolerances/integrators, short runs)")
    s.add_argument("--budget", type=number(unit="s"), default=None,
                   help="atlas: CPU seconds per cell, compilation excluded (default 5 rigid, 4 clearance)")
    s.add_argument("rest", nargs="*", help=argparse.SUPPRESS)
    s.set_defaults(func=cmd_bench)


def _add_warmup_parser(sub):
    """`pinclear warmup`'s arguments."""
    s = sub.add_parser("warmup", help="compile pinclear's kernels now (once per machine, cached), not in a first run",
                       formatter_class=HelpFormatter)
    s.add_argument("files", nargs="*", metavar="FILE",
                   help="mechanism sidecars or bundled names to prepare (default: every bundled mechanism)")
    s.set_defaults(func=cmd_warmup)


class _OneLineParser(argparse.ArgumentParser):
    """argparse prints a usage block on a bad argument; pinclear's errors are one line.
    ``passthrough=True``: a subcommand that parses its own arguments (all of them, --help too)."""

    def __init__(self, *args, passthrough=False, **kwargs):
        kwargs.setdefault("allow_abbrev", False)   # "--h" must not silently mean "--help"
        super().__init__(*args, **kwargs)
        self.passthrough = passthrough

    def parse_known_args(self, args=None, namespace=None):
        if not self.passthrough:
            return super().parse_known_args(args, namespace)
        namespace = namespace if namespace is not None else argparse.Namespace()
        for k, v in self._defaults.items():
            setattr(namespace, k, v)
        namespace.rest = list(sys.argv[1:] if args is None else args)
        return namespace, []

    def error(self, message):
        raise InputError(f"{self.prog}: {message} (see {self.prog} --help)")


def main(argv=None):
    # a SIGINT from here on is a KeyboardInterrupt caught below (one line, exit 130); before
    # this, while pinclear was imported, pinclear/__init__ answered it the same way
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.default_int_handler)
    argv = list(sys.argv[1:] if argv is None else argv)
    debug = "--debug" in argv
    if debug:
        argv.remove("--debug")
    try:
        parser = build_parser()
        args, unknown = parser.parse_known_args(argv)
        if unknown:
            if getattr(args, "what", None) in ("restitution", "contact-laws"):
                args.rest = list(args.rest or []) + unknown     # its own options, parsed there
            else:
                parser.error(f"unrecognized arguments: {' '.join(unknown)}")
        return int(args.func(args) or 0)
    except PinclearError as exc:
        if debug:
            traceback.print_exc()
        print(f"pinclear: error: {' '.join(str(exc).split())}", file=sys.stderr)
        return 2
    except OSError as exc:
        if debug:
            traceback.print_exc()
        where = f"{exc.filename}: " if exc.filename else ""
        print(f"pinclear: error: {where}{exc.strerror or exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("pinclear: interrupted", file=sys.stderr)
        return 130
    except SystemExit:
        raise
    except Exception as exc:  # a bug or an input we did not foresee: one line, the rest on --debug
        if debug:
            traceback.print_exc()
        print(f"pinclear: error: {type(exc).__name__}: {' '.join(str(exc).split())[:500]} "
              "(unexpected; run with --debug for the traceback and please report it)", file=sys.stderr)
        return 3


if __name__ == "__main__":
    sys.exit(main())
