"""Parameter sweeps: one simulation per point of a grid of load() overrides, on a local process
pool or a Dask cluster, each finished point written to disk at once so a killed sweep resumes.

A sweep folder holds
  sweep.json          what was asked (model, the varied keys and values, t_end, options) and,
                      per point, its overrides, status and message (rewritten as points finish);
  points/NNNNN.npz    the point's trajectory (``Trajectory.load``), also for failed runs (the
                      samples computed before the failure are kept);
  points/NNNNN.json   a point that could not run at all (bad value, assembly error): its reason.
Rerunning the same sweep into the same folder computes only the points without a file; a
different sweep (other keys, values, t_end or options) is refused rather than mixed in.

Workers return the saved file's bytes and the parent writes them, so a Dask cluster needs no
shared file system. Each point's computation does not depend on where it runs: results are
bit-identical whatever the executor and whatever was interrupted.
"""
from __future__ import annotations

import hashlib
import itertools
import json
import math
import os
import signal
import sys
import tempfile
import threading
import time
import warnings
import zipfile
from concurrent.futures import Executor, ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from pinclear.core import safeio
from pinclear.core.errors import InputError
from pinclear.dynamics.trajectory import Trajectory, jsonable

FORMAT = "pinclear-sweep/1"
#: points of one sweep grid: every finished point rewrites the index (sweep.json, about 100 bytes
#: per point), so a grid is refused before anything is built above this (split it into sweeps)
MAX_SWEEP_POINTS = 10_000
#: bytes of the sweep index and of a point's error file / recorded metadata read back on resume
MAX_INDEX_BYTES = 64_000_000
MAX_POINT_META_BYTES = 16_000_000


# ------------------------------------------------------------------------------- executors
def make_executor(workers=None, scheduler=None, jobs=None):
    """(executor, close) for ``workers`` local processes, or the Dask cluster at ``scheduler``
    (``tcp://HOST:PORT``; dask.distributed is then required). Local processes are never more
    than the CPUs nor than ``jobs`` when it is given (:func:`worker_count`): every command's
    ``--workers`` ends here, and ``--workers 100000`` once forked a process per number."""
    if scheduler is not None:
        try:
            from distributed import Client
        except ImportError:
            raise InputError("--scheduler needs dask.distributed: pip install 'pinclear[cluster]'") from None
        client = _dask_client(Client, scheduler)
        return client.get_executor(), lambda abort=False: client.close()
    if workers is not None and int(workers) < 1:
        raise InputError(f"workers must be a positive number of processes, got {workers!r}")
    ex = ProcessPoolExecutor(max_workers=worker_count(workers, jobs),
                             initializer=_die_with_parent, initargs=(os.getpid(),))

    def close(abort=False):
        # on an error or an interrupt the running points are not waited for: the workers end now
        ex.shutdown(wait=not abort, cancel_futures=True)
        if abort:
            for proc in list((getattr(ex, "_processes", None) or {}).values()):
                if proc.is_alive():
                    proc.kill()
    return ex, close


#: seconds to wait for a Dask scheduler's answer when connecting
SCHEDULER_TIMEOUT_S = 20.0


def _dask_client(Client, scheduler):
    """A dask.distributed Client of ``scheduler``, or one InputError line within
    SCHEDULER_TIMEOUT_S (+5 s): distributed's own timeout covers the TCP connection, not a server
    that accepts and never answers (it blocked past it), and a server answering garbage made it
    allocate a declared length ("MemoryError 6.09 EiB"). The connecting thread is a daemon: a
    hung one does not keep the process alive."""
    import threading

    box = {}

    def connect():
        try:
            box["client"] = Client(scheduler, timeout=f"{SCHEDULER_TIMEOUT_S:g}s")
        except BaseException as exc:             # MemoryError from a garbage length included
            box["error"] = exc
    th = threading.Thread(target=connect, name="pinclear-dask-connect", daemon=True)
    th.start()
    th.join(SCHEDULER_TIMEOUT_S + 5.0)
    if "client" in box:
        return box["client"]
    why = (f"no answer within {SCHEDULER_TIMEOUT_S + 5:g} s" if th.is_alive() else
           f"{type(box['error']).__name__}: {' '.join(str(box['error']).split())[:200]}")
    raise InputError(f"cannot reach a Dask scheduler at {scheduler!r} ({why}); check --scheduler tcp://HOST:PORT")


def _die_with_parent(parent):
    """Worker initializer: the worker ends when the process that started the sweep ends, however
    it ends (SIGKILL included). Workers otherwise wait forever for jobs from a dead parent,
    holding its caller's pipes open. Linux: the kernel sends SIGKILL to the worker when its
    parent exits (prctl PR_SET_PDEATHSIG); elsewhere, or when the worker's parent is a fork
    server rather than the sweep's process, a daemon thread polls the sweep's process."""
    armed = False
    if sys.platform.startswith("linux") and os.getppid() == parent:
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            armed = libc.prctl(1, int(signal.SIGKILL), 0, 0, 0) == 0      # 1 = PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            armed = False
    if not _alive(parent):              # the parent died before the signal was armed
        os._exit(1)
    if not armed:
        threading.Thread(target=_watch_parent, args=(parent,), name="pinclear-parent-watch", daemon=True).start()


def _alive(pid) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:             # exists, owned by someone else (a reused pid): not ours
        return pid == os.getppid()
    return True


def _watch_parent(parent, every=1.0):
    while _alive(parent):
        time.sleep(every)
    os._exit(1)


def run_jobs(fn, jobs, executor, on_result, on_error):
    """fn(job) for every job on ``executor`` ('serial': in this process), calling on_result(job,
    result) as each finishes; a job whose worker died is on_error(job, exc), never lost."""
    if executor == "serial":
        for job in jobs:
            on_result(job, fn(job))
        return
    if not isinstance(executor, Executor):
        raise InputError(f"executor must be 'serial' or a concurrent.futures.Executor, got {executor!r}")
    futs = {executor.submit(fn, job): job for job in jobs}
    for fut in as_completed(futs):
        job = futs[fut]
        try:
            res = fut.result()
        except Exception as exc:                  # BrokenProcessPool, a lost Dask worker...
            on_error(job, exc)
            continue
        on_result(job, res)


# ------------------------------------------------------------------------------- the grid
def parse_vary(spec):
    """``KEY=a:b:n`` (n values from a to b, linear), ``KEY=a:b:n:log`` (geometric) or
    ``KEY=v1,v2,...`` -> (key, values)."""
    if not isinstance(spec, str) or "=" not in spec:
        raise InputError(f"--vary expects KEY=a:b:n or KEY=v1,v2,..., got {spec!r}")
    key, _, rhs = spec.partition("=")
    key = key.strip()
    try:
        if ":" in rhs:
            parts = rhs.split(":")
            if len(parts) not in (3, 4) or (len(parts) == 4 and parts[3] != "log"):
                raise ValueError
            a, b, n = float(parts[0]), float(parts[1]), int(parts[2])
            if n < 1 or not (math.isfinite(a) and math.isfinite(b)):
                raise ValueError
            if n > MAX_SWEEP_POINTS:
                raise InputError(f"--vary {spec!r}: {n} values, more than a sweep may have (at most "
                                 f"{MAX_SWEEP_POINTS} points)")
            if len(parts) == 4:
                if a <= 0 or b <= 0:
                    raise InputError(f"--vary {spec!r}: a geometric range needs positive ends")
                return key, _decimal(np.geomspace(a, b, n))
            return key, _decimal(np.linspace(a, b, n))
        return key, [_number(x) for x in rhs.split(",")]
    except ValueError as exc:
        if isinstance(exc, InputError):         # already says what is wrong
            raise
        raise InputError(f"--vary {spec!r}: expected KEY=a:b:n[:log] (n >= 1) or KEY=v1,v2,...") from None


def _decimal(values) -> list:
    """A range's values rounded to 15 significant digits: the decimals the user's ends imply
    (linspace(1e-4, 5e-4, 5)[2] is 0.00030000000000000003, one rounding of 1e-4 + 2e-4 away from
    0.0003), so the run, its point's name and the table all hold 0.0003 (15 digits: below the 15.95
    digits a double holds exactly, a change of at most 5e-16 relative)."""
    return [float(f"{v:.15g}") for v in values]


def _number(text):
    text = text.strip()
    try:
        v = float(text)
    except ValueError:
        return text                              # option values may be words (a law's name)
    return int(v) if v.is_integer() and "." not in text and "e" not in text.lower() else v


def grid(vary):
    """Every combination of the varied keys' values, the last key fastest: a list of dicts."""
    items = list(vary.items()) if isinstance(vary, dict) else [tuple(kv) for kv in vary]
    if not items:
        raise InputError("sweep: nothing to vary (give at least one KEY and its values)")
    keys = [k for k, _ in items]
    if len(set(keys)) != len(keys):
        raise InputError(f"sweep: a key is varied twice: {keys}")
    for k, vals in items:
        if len(vals) == 0:
            raise InputError(f"sweep: no values for {k!r}")
    count = math.prod(len(v) for _, v in items)
    if count > MAX_SWEEP_POINTS:
        sizes = " x ".join(f"{len(v)} ({k})" for k, v in items)
        raise InputError(f"sweep: the grid of --vary {', '.join(keys)} has {sizes} = {count} points, more than a "
                         f"sweep may have (at most {MAX_SWEEP_POINTS}); split it into several sweeps")
    return [dict(zip(keys, combo)) for combo in itertools.product(*[list(v) for _, v in items])]


def describe_point(overrides):
    """The point in the user's terms: ``S2.mu = 0.1, S2.clearance = 0.0005``."""
    return ", ".join(f"{k} = {v:.6g}" if isinstance(v, float) else f"{k} = {v}" for k, v in overrides.items())


# ------------------------------------------------------------------------------- one point
def _run_point(job):
    """Worker: load the variant, simulate, return the saved trajectory's bytes and its summary
    (or the reason the point could not run)."""
    from pinclear.dynamics.simulate import simulate
    from pinclear.io.sidecar import load

    t0 = time.perf_counter()
    try:
        for k, v in job["overrides"].items():
            if isinstance(v, float) and not math.isfinite(v):
                raise InputError(f"{k} = {v!r} is not a finite number")
        mech = load(job["path"], **{**job["load_kw"], "overrides": {**job["fixed"], **job["overrides"]}})
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)      # a failed run is a result here
            sim_kw = dict(job["sim_kw"])
            peaks_after = sim_kw.pop("peaks_after", None)     # the summary's, not simulate()'s
            tr = simulate(mech, job["t_end"], **sim_kw)
        tr.meta["sweep_point"] = job.get("point_id")
        if peaks_after is not None:
            tr.meta["peaks_after"] = peaks_after
        with tempfile.TemporaryDirectory() as tmp:
            p = tr.save(Path(tmp) / "point.npz")
            blob = Path(p).read_bytes()
        return {"status": tr.status, "message": tr.message, "npz": blob,
                "stats": {"cpu_s": tr.stats.get("cpu_s"), "rhs_evals": tr.stats.get("rhs_evals"),
                          "steps": tr.stats.get("steps"), "events": len(tr.stats.get("events", [])),
                          "wall_s": time.perf_counter() - t0}}
    except Exception as exc:                     # the point's own fault: a result, not a crash
        return {"status": "error", "message": f"{type(exc).__name__}: {exc}", "npz": None, "point_id": job.get("point_id"),
                "stats": {"wall_s": time.perf_counter() - t0}}


@dataclass
class SweepPoint:
    index: int
    overrides: dict
    status: str              # success | failed | error | pending
    message: str
    file: Path | None

    @property
    def ok(self):
        return self.status == "success"

    def trajectory(self) -> Trajectory:
        if self.file is None or self.file.suffix != ".npz":
            raise InputError(f"sweep point {self.index} ({describe_point(self.overrides)}) has no trajectory: "
                             f"{self.status}: {self.message}")
        return Trajectory.load(self.file)


@dataclass
class SweepResult:
    folder: Path
    keys: list
    points: list
    computed: int            # points computed by this call (the others were on disk already)

    def table(self):
        return [{"index": p.index, **p.overrides, "status": p.status, "message": p.message} for p in self.points]

    @property
    def failures(self):
        return [p for p in self.points if not p.ok]


def _point_files(folder, i):
    return folder / "points" / f"{i:05d}.npz", folder / "points" / f"{i:05d}.json"


def _status_from_file(npz, err, expected=None):
    """(status, message, file) of a point from its file on disk; ("pending", ...) when it has
    none. A file that cannot be read back (truncated, not a point file, a FIFO, a link...) is
    moved aside as ``NAME.corrupt``, one that belongs to another sweep or point (``expected``:
    the point's identity, :func:`point_identity`) as ``NAME.foreign``; either is reported on
    stderr by name, and the point is computed again."""
    for f, read in ((npz, _npz_status), (err, _json_status)):
        if not (f.exists() or f.is_symlink()):
            continue
        try:
            if f.is_symlink():
                raise InputError("is a link (pinclear never follows a link inside a results folder)")
            meta = read(f)
            status, message = _checked_status(meta)
            if expected is not None:
                _check_point_identity(meta, expected, f.suffix == ".json")
            return status, message, f
        except (InputError, OSError, ValueError, KeyError, TypeError, EOFError, zipfile.BadZipFile) as exc:
            why = " ".join(str(exc).split())[:200] or type(exc).__name__
            aside = f.with_name(f.name + (".foreign" if isinstance(exc, ForeignPoint) else ".corrupt"))
            try:
                aside = safeio.move_aside(f, aside.name)        # never over an earlier one
                where = f"moved to {aside.name}"
            except OSError as mv:
                where = f"could not be moved aside ({mv.strerror}); it is replaced"
            print(f"pinclear: warning: {f}: unreadable sweep point file ({why}); {where}, the point is computed "
                  "again", file=sys.stderr)
    return "pending", "", None


def _npz_status(npz):
    from pinclear.core.bounded import check_regular

    check_regular(npz, "point", "sweep point")
    with zipfile.ZipFile(npz) as z:
        size = z.getinfo("meta.npy").file_size
    if size > MAX_POINT_META_BYTES:
        raise InputError(f"its metadata declares {size} bytes (at most {MAX_POINT_META_BYTES})")
    # the whole file checked as a saved run (pinclear.dynamics.validate): a planted or truncated point
    # is refused before its status is believed
    return Trajectory.load(npz).meta


def _json_status(err):
    from pinclear.core.bounded import read_text_bounded

    return json.loads(read_text_bounded(err, MAX_POINT_META_BYTES, "point", "sweep point"))


class ForeignPoint(InputError):
    """A point file of another sweep, another point, or no sweep at all."""


def point_identity(spec: dict, model_bytes: bytes, index: int) -> dict:
    """What a point file must carry to be accepted as point ``index`` of the sweep ``spec``: a
    digest of the sweep's description and of its mechanism file's bytes, the index and the
    point's parameter values (an edited sidecar makes every old point foreign)."""
    h = hashlib.sha256(json.dumps(jsonable(spec), sort_keys=True).encode() + b"\0" + model_bytes).hexdigest()
    return {"sweep": h, "index": int(index), "overrides": jsonable(spec["points"][index])}


def _check_point_identity(meta, expected, is_error_file):
    """Refuse (ForeignPoint) a point whose recorded identity is not ``expected``; an error file
    may only record an error (a point that ran has a trajectory)."""
    got = meta.get("sweep_point") if isinstance(meta, dict) else None
    if got != expected:
        what = ("records no sweep point (not written by this sweep)" if got is None else
                "belongs to another sweep or point (its identity or parameter values differ)")
        raise ForeignPoint(what)
    if is_error_file and meta.get("status") != "error":
        raise ForeignPoint(f"an error file recording status {str(meta.get('status'))[:20]!r} with no trajectory")


def _checked_status(meta):
    if not (isinstance(meta, dict) and isinstance(meta.get("status"), str) and isinstance(meta.get("message"), str)):
        raise ValueError("no status and message recorded")
    return meta["status"], meta["message"]


# ------------------------------------------------------------------------------- the sweep
def _point_identities(spec, path):
    """point_identity of every point of the sweep ``spec`` of the mechanism file ``path``."""
    from pinclear.core.bounded import read_bounded
    from pinclear.io.sidecar import MAX_SIDECAR_BYTES

    model_bytes = read_bounded(path, MAX_SIDECAR_BYTES, "model", "sidecar")
    return [point_identity(spec, model_bytes, i) for i in range(len(spec["points"]))]


def worker_count(workers=None, jobs=None):
    """Local processes for ``jobs`` jobs: what was asked (default: one per CPU), never more than
    the CPUs or the jobs (``--workers 40`` for 2 sweep points forked 40 processes)."""
    cpus = os.cpu_count() or 1
    return max(1, min(int(workers) if workers else cpus, cpus, jobs if jobs else cpus))


def _write_index(index_path, doc):
    """Rewrite sweep.json (link-safe); a failure (full disk) is a warning: the points' files,
    not the index, hold the results, and the next run rebuilds the index from them."""
    try:
        safeio.write_text(index_path, json.dumps(doc, indent=1))
    except OSError as exc:
        print(f"pinclear: warning: could not write {index_path} ({exc.strerror or exc}); the point files are kept "
              "and a rerun rebuilds it", file=sys.stderr)


def _write_point(folder, job, res):
    """The point's trajectory (or its error file) into ``folder/points``, link-safe; when that
    fails (full disk), a copy beside it or in the user cache, both paths named on stderr (the
    point stays pending on disk and a rerun computes it again). Returns the file written."""
    npz, err = _point_files(folder, job["index"])
    if res["npz"] is not None:
        target, blob = npz, res["npz"]
    else:
        target = err
        blob = json.dumps({"status": res["status"], "message": res["message"],
                           "overrides": jsonable(job["overrides"]), "sweep_point": job.get("point_id")}).encode()
    written, problem = safeio.write_or_fallback(lambda p, root: safeio.write_bytes(p, blob, root), target, folder)
    if problem:
        print(f"pinclear: error: sweep point {job['index']} ({describe_point(job['overrides'])}): {problem}",
              file=sys.stderr)
    return written


def sweep(model, vary, t_end, out, *, sim_options=None, load_options=None, workers=None, scheduler=None,
          executor=None, progress=True) -> SweepResult:
    """Simulate ``model`` at every point of the grid of ``vary``, for ``t_end`` seconds each,
    writing each point into ``out`` as it finishes. Points already in ``out`` from an earlier,
    interrupted call of the same sweep are not computed again. The folder is held locked
    (``OUT/.lock``, as a simulate run's folder) for the whole call: a second sweep into it is
    refused at once, naming the process holding it.

    Parameters
    ----------
    model : str or Path
        A sidecar path or a bundled mechanism's name.
    vary : dict
        ``{key: values}``: load()'s override keys such as ``"S2.mu"``, ``"forces[spring].k"``,
        or a scene option; the grid is every combination.
    t_end : float
        Simulated time per point [s].
    out : str or Path
        The sweep folder (``sweep.json``, ``points/``, ``table.csv``).
    sim_options : dict, optional
        Keyword arguments of :func:`pinclear.simulate` (method, integrator, rtol, dt_out,
        max_cpu...), and ``peaks_after`` [s]: each point's summary also gives its peaks from
        then on (Trajectory.window_peaks), table columns ``peaks_after.*``.
    load_options : dict, optional
        Keyword arguments of :func:`pinclear.load` (clearances, options, overrides for keys
        that stay fixed, trust).
    workers : int, optional
        Local processes (default: one per CPU).
    scheduler : str, optional
        A Dask scheduler address, used instead of local processes.
    executor : concurrent.futures.Executor or "serial", optional
        Any executor (e.g. a Dask client's ``get_executor()``), or "serial": in this process.
    progress : bool, None or callable
        True: a progress bar with ETA on stderr; None: silent; or ``f(done, total, point)``.

    Returns
    -------
    SweepResult
        The folder, the keys, every point's status and the number computed by this call.
    """
    folder = Path(out)
    if folder.exists() and not folder.is_dir():
        raise InputError(f"--out {str(folder)!r} is an existing file; give a folder")
    for name, kind in (("points", Path.is_dir), ("sweep.json", Path.is_file)):
        p = folder / name
        if p.is_symlink() or (p.exists() and not kind(p)):
            raise InputError(f"--out {str(folder)!r}: {str(p)!r} is a link or not a {'folder' if name == 'points' else 'file'}"
                             "; pinclear never follows a link inside a results folder (remove it or choose another "
                             "--out)")
    with safeio.folder_lock(folder):
        return _sweep_in_folder(model, vary, t_end, out, sim_options=sim_options, load_options=load_options,
                                workers=workers, scheduler=scheduler, executor=executor, progress=progress)


def _sweep_in_folder(model, vary, t_end, out, *, sim_options=None, load_options=None, workers=None, scheduler=None,
                     executor=None, progress=True) -> SweepResult:
    """:func:`sweep` inside its locked folder (the arguments as there)."""
    path, sim_kw, load_kw, fixed, points, keys = _checked(model, vary, t_end, sim_options, load_options)
    folder = Path(out)
    spec = jsonable({"format": FORMAT, "model": str(path.resolve()), "keys": keys, "points": points,
                     "t_end": float(t_end), "sim_options": sim_kw, "load_options": load_kw, "fixed": fixed})
    index_path = folder / "sweep.json"
    _check_folder(folder, index_path, spec)
    safeio.make_dirs(folder / "points", folder)
    ids = _point_identities(spec, path)

    state = []
    for i, ov in enumerate(points):
        st, msg, f = _status_from_file(*_point_files(folder, i), ids[i])
        state.append(SweepPoint(i, ov, st, msg, f))

    from pinclear.core.version import provenance

    # who wrote the index last (each point's trajectory records its own versions); not part of the
    # sweep's identity: a sweep continued after an upgrade is the same sweep
    versions = provenance()

    def write_index():
        doc = dict(spec, status=[{"index": p.index, "status": p.status, "message": p.message} for p in state],
                   versions=versions)
        _write_index(index_path, doc)

    write_index()
    todo = [p for p in state if p.status == "pending"]
    jobs = [{"index": p.index, "overrides": p.overrides, "path": str(path), "load_kw": load_kw, "fixed": fixed,
             "t_end": float(t_end), "sim_kw": sim_kw, "point_id": ids[p.index]} for p in todo]

    bar = None
    if progress is True and todo:
        from tqdm import tqdm
        bar = tqdm(total=len(state), initial=len(state) - len(todo), desc="sweep", unit="point",
                   file=sys.stderr, dynamic_ncols=True)

    def on_result(job, res):
        i = job["index"]
        file = _write_point(folder, job, res)
        p = state[i]
        p.status, p.message, p.file = res["status"], res["message"], file
        write_index()
        if bar is not None:
            bar.set_postfix_str(f"{describe_point(p.overrides)}: {p.status}", refresh=False)
            bar.update(1)
        elif callable(progress):
            progress(sum(q.status != "pending" for q in state), len(state), p)

    def on_error(job, exc):
        # the worker, not the point, failed: reported, and left without a file so a rerun retries it
        p = state[job["index"]]
        p.status, p.message = "error", f"worker lost: {type(exc).__name__}: {exc}"
        write_index()
        if bar is not None:
            bar.update(1)

    try:
        _run_points(jobs, executor, workers, scheduler, on_result, on_error)
    finally:
        if bar is not None:
            bar.close()
    write_table(folder, keys, state)
    return SweepResult(folder, keys, state, len(jobs))


def _checked(model, vary, t_end, sim_options, load_options):
    """The sweep's arguments checked, every key once at the first point before any work (an
    unknown key names the valid ones): (path, sim_kw, load_kw, fixed overrides, points, keys)."""
    from pinclear.core.models import model_path

    path = model_path(model)
    if not path.exists():
        raise InputError(f"sweep: no such mechanism file {str(path)!r}")
    if not (isinstance(t_end, (int, float)) and math.isfinite(t_end) and t_end > 0):
        raise InputError(f"sweep: t_end must be a positive number of seconds, got {t_end!r}")
    sim_kw = dict(sim_options or {})
    for k in ("t_end", "t0", "strict", "resume", "checkpoint", "progress"):
        if k in sim_kw:
            raise InputError(f"sweep: sim_options may not set {k!r}")
    pa = sim_kw.get("peaks_after")
    if pa is not None and not (isinstance(pa, (int, float)) and not isinstance(pa, bool) and 0 <= pa < t_end):
        raise InputError(f"sweep: peaks_after = {pa!r}: expected a time in [0, t_end = {t_end:g}) s")
    load_kw = dict(load_options or {})
    bad = set(load_kw) - {"options", "overrides", "clearances", "trust"}
    if bad:
        raise InputError(f"sweep: unknown load option {sorted(bad)[0]!r} (valid: clearances, options, overrides, trust)")
    fixed = dict(load_kw.pop("overrides", None) or {})
    points = grid(vary)
    keys = list(points[0])
    # check every key once, at the first point, before any work: an unknown key names the valid ones
    from pinclear.io.sidecar import load
    load(path, **{**load_kw, "overrides": {**fixed, **points[0]}})
    return path, sim_kw, load_kw, fixed, points, keys


def _check_folder(folder, index_path, spec):
    """A folder that holds another sweep (or is a file) is refused; the same sweep's is resumed."""
    if index_path.exists():
        from pinclear.core.bounded import read_text_bounded

        try:
            old = json.loads(read_text_bounded(index_path, MAX_INDEX_BYTES, "sweep.json", "sweep index"))
        except json.JSONDecodeError as exc:
            raise InputError(f"{index_path}: not a readable sweep index ({exc})") from None
        if not isinstance(old, dict):
            raise InputError(f"{index_path}: not a sweep index (a JSON object)")
        diff = [k for k in spec if old.get(k) != spec[k]]
        if diff:
            raise InputError(f"{folder} holds a different sweep (it differs in {', '.join(diff)}); "
                             "give another --out folder or delete this one")
    elif folder.exists() and not folder.is_dir():
        raise InputError(f"--out {str(folder)!r} is an existing file; give a folder")


def _run_points(jobs, executor, workers, scheduler, on_result, on_error):
    """The jobs through _run_point on ``executor`` (None: local processes or the Dask scheduler,
    made and shut down here; an interrupt ends the workers at once)."""
    close = None
    try:
        if jobs:
            ex = executor
            if ex is None:
                ex, close = make_executor(workers if scheduler is None else None, scheduler, jobs=len(jobs))
            run_jobs(_run_point, jobs, ex, on_result, on_error)
    except BaseException:
        if close is not None:
            close(abort=True)
            close = None
        raise
    finally:
        if close is not None:
            close()


# ------------------------------------------------------------------------------- the table
#: the per-point table a sweep writes beside its points (one row per point)
TABLE_CSV, TABLE_NPZ = "table.csv", "table.npz"


def summary_scalars(summary, prefix="") -> dict:
    """The scalars of a run's summary (Trajectory.summary()) as flat columns: nested mappings
    joined by '.', e.g. ``energy_balance.error``, ``drive_force_peaks.A1_drive``; numbers, flags
    and texts kept, lists dropped (they are not one number per point)."""
    out = {}
    for k, v in (summary or {}).items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(summary_scalars(v, key + "."))
        elif v is None or isinstance(v, (bool, int, float, str)):
            out[key] = v
    return out


def point_summary(point) -> dict:
    """The summary a point's trajectory file recorded (its metadata only, bounded as the status
    read is), {} for a point without one (an error or a pending point)."""
    if point.file is None or point.file.suffix != ".npz":
        return {}
    with zipfile.ZipFile(point.file) as z:
        if z.getinfo("meta.npy").file_size > MAX_POINT_META_BYTES:
            return {}
    with np.load(point.file, allow_pickle=False) as d:
        meta = json.loads(str(d["meta"]))
    return (meta.get("summary") or {}) if isinstance(meta, dict) else {}


def write_table(folder, keys, points):
    """FOLDER/table.csv and FOLDER/table.npz: one row per point with the varied values, status,
    message and every scalar of the point's summary (peaks, events, energy error...), columns in
    order of first appearance; numbers as float64 (nan where a point has none), the rest as text.
    Rewritten whole after every sweep call (points computed earlier included)."""
    import csv
    import io

    rows = []
    for p in points:
        try:
            scalars = summary_scalars(point_summary(p))
        except (OSError, ValueError, KeyError, zipfile.BadZipFile) as exc:
            scalars = {"table_error": f"{type(exc).__name__}: {exc}"}
        for k in [k for k in scalars if k in ("status", "message") or k.startswith(("units.", "aliases."))]:
            del scalars[k]                # the same texts for every point: the summary's, not the table's
        rows.append({"index": p.index, **p.overrides, "status": p.status, "message": p.message, **scalars})
    cols = list(dict.fromkeys(["index", *keys, "status", "message"] + [c for r in rows for c in r]))
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=cols, restval="", lineterminator="\n")
    w.writeheader()
    w.writerows(rows)
    safeio.write_text(Path(folder) / TABLE_CSV, buf.getvalue(), root=folder)
    arrays = {}
    for c in cols:
        vals = [r.get(c) for r in rows]
        numeric = all(v is None or (isinstance(v, (int, float)) and not isinstance(v, bool)) for v in vals)
        arrays[c] = (np.array([np.nan if v is None else float(v) for v in vals]) if numeric
                     else np.array(["" if v is None else str(v) for v in vals]))
    safeio.write_atomic(Path(folder) / TABLE_NPZ, lambda fh: np.savez(fh, **arrays), root=folder)
