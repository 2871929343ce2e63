"""Uncertainty bands of the reproductions: the spread of a row's result over the plausible range
of the reconstructed inputs (pinclear/reproduce/reconstructed.yaml, docs/papers.md).

Screen, then band (:func:`measure_bands`). First a one-at-a-time screen of every input (each at
each end of its range, or each of its other choices, the others nominal) on cheap runs; an input
*matters* for a row when its swing moves the row by more than tau/2 (a categorical row: changes
it). Then each row's band varies the inputs that matter for it: their one-at-a-time ends at the
study's own settings plus a small space-filling sample (a Latin hypercube over the inputs that
matter for any row). A row no input moves by tau/2 gets ours at nominal +- the sum of the
screen's swings (a first-order bound of their joint effect).

Every point is stored as it finishes, one JSON file under the report folder's ``bands/``
(:class:`PointStore`), keyed by its identity: the same command run again resumes, so a report's
bands can be built over several sittings. ``--budget`` (CPU s) stops submitting points once spent;
the rows whose points it did not reach are ``not measured`` with the CPU they would need
(:class:`NotReached`), listed in the report header. The points run on the studies' executor
(local processes or a Dask cluster, :func:`pinclear.analysis.sweeps.make_executor`).
"""
from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np

from pinclear.core.errors import InputError, ModelFileError

FILE = Path(__file__).with_name("reconstructed.yaml")
#: space-filling points asked for when the budget allows
LHS_POINTS = 8


def reconstructed_inputs(paper, file=FILE, keyed=True):
    """The reconstructed inputs of ``paper`` (a list of dicts), checked: each has a name, a
    reason and a range or choices; ``keyed``: only those the bands vary (a key, and not chosen by
    a calibration: ``calibrated`` names the rows that chose it)."""
    import yaml

    data = yaml.safe_load(Path(file).read_text())
    if str(paper) not in data:
        raise ModelFileError(file, str(paper), "no reconstructed inputs for this paper", choices=sorted(data))
    out = []
    for i, e in enumerate(data[str(paper)]):
        where = f"{paper}[{i}]"
        for k in ("name", "reason", "nominal"):
            if k not in e:
                raise ModelFileError(file, f"{where}.{k}", "missing")
        if ("range" in e) == ("choices" in e):
            raise ModelFileError(file, where, "give exactly one of range / choices", choices=["range", "choices"])
        if e.get("key") and "range" in e:
            lo, hi = e["range"]
            if not float(lo) <= float(e["nominal"]) <= float(hi):
                raise ModelFileError(file, f"{where}.range", f"nominal {e['nominal']} outside {e['range']}")
        if (e.get("key") and not e.get("calibrated")) or not keyed:
            out.append(e)
    return out


# ------------------------------------------------------------------ screen, then band (resumable)
#: the version of the stored band points: bump it when a paper's point function changes what it
#: computes, so that points stored before are refused (foreign) and run again
BAND_VERSION = 1
#: bytes of one stored band point read back
MAX_POINT_BYTES = 1 << 20


class NotReached:
    """A row's band the budget did not reach: the CPU its missing points would need."""

    def __init__(self, cpu_s, what=""):
        self.cpu_s, self.what = float(cpu_s), what

    def __repr__(self):
        return f"NotReached({self.cpu_s:.0f} CPU s)"


def band_of(bands, key, ours):
    """(band, band_from, cpu_needed) of a row from the bands' ``{key: (lo, hi, what) | (kinds,
    what) | NotReached}``, ours included: (None, '', None) when nothing was asked, (None, '', CPU
    s) when the budget stopped before it."""
    b = bands.get(key)
    if b is None:
        return None, "", None
    if isinstance(b, NotReached):
        return None, "", b.cpu_s
    if len(b) == 2:                       # categorical: (kinds, what)
        return sorted(set(b[0]) | ({ours} if isinstance(ours, str) else set(ours))), b[1], None
    return (min(b[0], ours), max(b[1], ours)), b[2], None


class PointStore:
    """The band points of one report, one JSON file each under FOLDER/bands/, named by the digest
    of the point's identity (paper, stage, its settings, the input values, :data:`BAND_VERSION`):
    a report is built over several sittings by running the same command again, and a point
    stored by other settings or another version is never taken for this one."""

    def __init__(self, folder, paper, contexts):
        self.dir = None if folder is None else Path(folder) / "bands"
        self.paper, self.contexts = str(paper), contexts
        self.foreign = 0

    def identity(self, stage, values):
        from pinclear.core.jsonsafe import jsonable

        return jsonable({"paper": self.paper, "stage": stage, "settings": self.contexts.get(stage),
                         "values": values, "version": BAND_VERSION})

    def _path(self, ident):
        import hashlib
        import json

        h = hashlib.sha256(json.dumps(ident, sort_keys=True).encode()).hexdigest()[:20]
        return self.dir / f"{ident['stage']}-{h}.json"

    def get(self, stage, values):
        """(result, cpu_s) stored for this point, or None (none stored, or not this point's)."""
        import json

        from pinclear.core.bounded import read_bounded

        if self.dir is None:
            return None
        ident = self.identity(stage, values)
        path = self._path(ident)
        if not path.is_file():
            return None
        try:
            doc = json.loads(read_bounded(path, MAX_POINT_BYTES, "band point", "stored band point"))
            ok = (isinstance(doc, dict) and doc.get("identity") == ident and isinstance(doc.get("result"), dict)
                  and isinstance(doc.get("cpu_s"), (int, float)) and doc["cpu_s"] >= 0)
        except (OSError, ValueError, InputError):
            ok = False
        if not ok:
            self.foreign += 1
            return None
        return doc["result"], float(doc["cpu_s"])

    def put(self, stage, values, result, cpu_s):
        import json

        from pinclear.core import safeio
        from pinclear.core.jsonsafe import jsonable

        if self.dir is None:
            return
        ident = self.identity(stage, values)
        safeio.make_dirs(self.dir)
        safeio.write_text(self._path(ident), json.dumps({"identity": ident, "result": jsonable(result),
                                                         "cpu_s": float(cpu_s)}, indent=1, sort_keys=True))


class _Timed:
    """fn(values) with the CPU its worker spent on it: (result, CPU s); picklable."""

    def __init__(self, fn):
        self.fn = fn

    def __call__(self, values):
        import time

        c0 = time.process_time()
        try:
            res = self.fn(values)
        except Exception as exc:              # a failed point is a result: its message is kept
            res = {"status": f"{type(exc).__name__}: {exc}"}
        return res, time.process_time() - c0


class Ledger:
    """What a budgeted design did: points resumed from the store, run now (with their CPU), not
    reached (with the CPU they would need at the mean cost of the points run)."""

    def __init__(self, cost):
        self.cost, self.resumed, self.ran, self.cpu, self.cpu_stored, self.missing = float(cost), 0, 0, 0.0, 0.0, []

    def mean_cost(self):
        n = self.ran + self.resumed
        return (self.cpu + self.cpu_stored) / n if n else self.cost

    def as_dict(self):
        return {"resumed": self.resumed, "ran": self.ran, "cpu_s": self.cpu, "cpu_stored_s": self.cpu_stored,
                "not_reached": len(self.missing), "needs_cpu_s": self.mean_cost() * len(self.missing)}


def run_design(fn, points, store, stage, executor="serial", budget=None, cost=60.0, ledger=None, known=None):
    """{label: result} of ``fn(values)`` over ``points`` [(label, values)], stored points taken from
    ``store``; each new point stored as it finishes. ``budget`` (CPU s, of all the stages that share
    ``ledger``) stops submitting new points once spent: the points under way finish, the others are
    ``ledger.missing`` (labels) and absent from the result. ``known``: {label: result} already in
    hand (a stage's points shared with the one before), neither run nor counted again."""
    from concurrent.futures import FIRST_COMPLETED, wait

    ledger = ledger or Ledger(cost)
    got, todo = dict(known or {}), []
    for label, values in points:
        if label in got:
            continue
        old = store.get(stage, values)
        if old is None:
            todo.append((label, values))
        else:
            got[label] = old[0]
            ledger.resumed += 1
            ledger.cpu_stored += old[1]
    timed = _Timed(fn) if not isinstance(fn, _Timed) else fn

    def afford():
        return budget is None or ledger.cpu + ledger.mean_cost() <= float(budget)

    def done(label, values, res, cpu):
        ledger.ran += 1
        ledger.cpu += cpu
        got[label] = res
        store.put(stage, values, res, cpu)

    if executor == "serial":
        for i, (label, values) in enumerate(todo):
            if not afford():
                ledger.missing += [lb for lb, _ in todo[i:]]
                break
            done(label, values, *timed(values))
        return got, ledger
    width = max(1, int(getattr(executor, "_max_workers", 2) or 2))
    queue, running = list(todo), {}
    while queue or running:
        while queue and len(running) < width and afford():
            label, values = queue.pop(0)
            running[executor.submit(timed, values)] = (label, values)
        if not running:
            break
        fin, _ = wait(running, return_when=FIRST_COMPLETED)
        for fut in fin:
            label, values = running.pop(fut)
            try:
                res, cpu = fut.result()
            except Exception as exc:          # a lost worker: that point's message, not lost
                res, cpu = {"status": f"{type(exc).__name__}: {exc}"}, 0.0
            done(label, values, res, cpu)
    ledger.missing += [lb for lb, _ in queue]
    return got, ledger


def one_at_a_time(inputs):
    """[(label, input name or None, values)]: the nominal point, then each input at each end of its
    range (or each of its other choices), the others nominal."""
    nominal = {e["key"]: e["nominal"] for e in inputs}
    pts = [("nominal", None, dict(nominal))]
    for e in inputs:
        for v in (e["choices"] if "choices" in e else e["range"]):
            if v != e["nominal"]:
                pts.append((f"{e['name']} = {v}", e["name"], {**nominal, e["key"]: v}))
    return pts


def _differs(a, b, tau):
    if isinstance(a, str) or isinstance(b, str):
        return a != b, (0.0 if a == b else float("inf"))
    d = abs(float(a) - float(b))
    return d > 0.5 * tau, (d / tau if tau > 0 else (0.0 if d == 0 else float("inf")))


def screen(results, oat, keys, taus):
    """(matters, table): ``matters[key]`` the input names whose swing moves ``key`` by more than
    tau/2 (a categorical key: changes it), from the one-at-a-time points ``oat`` (as
    :func:`one_at_a_time`) and their ``results``; the table gives each swing in units of tau
    (the largest over the input's ends), '*' where it matters, 'failed' where a point failed."""
    nominal = results.get("nominal") or {}
    names = list(dict.fromkeys(n for _, n, _ in oat if n))
    matters = {k: [] for k in keys}
    swing = {(n, k): 0.0 for n in names for k in keys}
    failed = set()
    for label, name, _ in oat:
        if name is None:
            continue
        r = results.get(label)
        for k in keys:
            if not isinstance(r, dict) or k not in r or k not in nominal:
                failed.add((name, k))
                continue
            hit, s = _differs(r[k], nominal[k], taus[k])
            swing[(name, k)] = max(swing[(name, k)], s)
            if hit and name not in matters[k]:
                matters[k].append(name)
    def cell(n, k):
        if (n, k) in failed:
            return "failed"
        sw = swing[(n, k)]
        return ("changes" if math.isinf(sw) else f"{sw:.2g}") + (" *" if n in matters[k] else "")

    rows = [[k] + [cell(n, k) for n in names] for k in keys]
    return matters, {"title": "screen: each reconstructed input's swing of each row, in units of the row's tau "
                              "(* = it matters: more than tau/2, or a changed kind)",
                     "columns": ["row"] + names, "rows": rows}


def latin_hypercube(inputs, names, n, seed=0):
    """[(label, values)]: ``n`` points of a Latin hypercube over the numeric inputs ``names``
    (uniform over their ranges; categorical ones among ``names`` in turn), the others nominal."""
    nominal = {e["key"]: e["nominal"] for e in inputs}
    num = [e for e in inputs if e["name"] in names and "range" in e]
    cat = [e for e in inputs if e["name"] in names and "choices" in e]
    if n <= 0 or not (num or cat):
        return []
    rng = np.random.default_rng(seed)
    u = (np.argsort(rng.random((len(num), n)), axis=1) + rng.random((len(num), n))) / n
    pts = []
    for k in range(n):
        p = dict(nominal)
        for i, e in enumerate(num):
            lo, hi = map(float, e["range"])
            p[e["key"]] = lo + u[i, k] * (hi - lo)
        for j, e in enumerate(cat):
            p[e["key"]] = e["choices"][(k + j) % len(e["choices"])]
        pts.append((f"space-filling {k + 1}", p))
    return pts


def _spread_of(vals):
    if any(isinstance(v, str) for v in vals):
        # a point may hold several kinds at once ('below resolution, period-1': two joints)
        return sorted({k for v in vals for k in str(v).split(", ")})
    return min(map(float, vals)), max(map(float, vals))


def _swing_sum(scr, oat, k):
    """The sum over inputs of each one's largest swing of ``k`` in the screen ``scr``."""
    worst = {}
    for lb, n, _ in oat:
        r = scr.get(lb)
        if n and isinstance(r, dict) and k in r:
            worst[n] = max(worst.get(n, 0.0), abs(float(r[k]) - float(scr["nominal"][k])))
    return sum(worst.values())


def measure_bands(fn, inputs, keys, taus, store, executor="serial", budget=None, cost=60.0,
                  screen_fn=None, n_lhs=LHS_POINTS, seed=0, papers=None):
    """Screen, then band (module docstring of this part): the one-at-a-time screen of every input
    on ``screen_fn`` (cheap runs; default ``fn`` itself, whose points are then shared with the
    band), then the band of each key over the inputs that matter for it on ``fn``: their ends
    and ``n_lhs`` space-filling points over the inputs that matter for any key. A key no input
    moves by tau/2 gets as band ours at nominal +- the sum of the screen's swings. ``papers``:
    {key: the paper's value}; a key whose band misses it names its lever in the band's text
    (:func:`lever`) and the ledger's ``levers`` keep each one's tornado. Returns
    (bands {key: (lo, hi, what) | (kinds, what) | NotReached}, screen table, ledger dict)."""
    ledger = Ledger(cost)
    oat = one_at_a_time(inputs)
    same = screen_fn is None
    stage_s = "band" if same else "screen"
    scr, _ = run_design(fn if same else screen_fn, [(lb, v) for lb, _, v in oat], store, stage_s, executor,
                        budget, cost, ledger)
    if "nominal" not in scr or any(lb not in scr for lb, _, _ in oat):
        need = ledger.mean_cost() * (len(ledger.missing) + (0 if same else 1 + 2 * len(inputs) + n_lhs))
        miss = NotReached(need, "the screen did not finish within the budget")
        return {k: miss for k in keys}, None, dict(ledger.as_dict(), stage="screen")
    matters, table = screen(scr, oat, keys, taus)
    if not same:
        # a kind of motion read off the screen's short runs does not screen the long runs' kind:
        # every input is varied for a categorical row
        names = [e["name"] for e in inputs]
        for k in keys:
            if isinstance(scr["nominal"].get(k), str):
                matters[k] = names
        table["note"] = ("the screen ran the quick study's lengths; categorical rows (kinds of motion, orderings) "
                         "are banded over every input, as a short run's kind does not screen a long run's")
    union = [e["name"] for e in inputs if any(e["name"] in m for m in matters.values())]
    pts = [(lb, v) for lb, n, v in oat if n is None or n in union] + latin_hypercube(inputs, union, n_lhs, seed)
    res, _ = run_design(fn, pts, store, "band", executor, budget, cost, ledger, known=scr if same else None)
    bands = {}
    nom = res.get("nominal")
    for k in keys:
        mine = ["nominal"] + [lb for lb, n, _ in oat if n in matters[k]] + ([lb for lb, _ in pts if lb.startswith(
            "space")] if matters[k] else [])
        if any(lb not in res for lb in mine):
            bands[k] = NotReached(ledger.mean_cost() * sum(lb not in res for lb in mine), "budget")
            continue
        vals = [res[lb][k] for lb in mine if isinstance(res[lb], dict) and k in res[lb]]
        if not vals:
            continue
        if not matters[k]:
            nv = nom[k]
            if isinstance(nv, str):
                bands[k] = (_spread_of([nv]), "screen: no input changes it")
            else:
                wide = _swing_sum(scr, oat, k)
                bands[k] = (float(nv) - wide, float(nv) + wide,
                            f"screen: no input moves it by tau/2 (nominal +- the sum of their swings, {wide:.3g})")
            continue
        b = _spread_of(vals)
        what = (f"{len(vals)} of {len(mine)} input sets over {', '.join(matters[k])} "
                f"({sum(lb.startswith('space') for lb in mine)} space-filling)")
        bands[k] = (b, what) if isinstance(b, list) else (b[0], b[1], what)
    failed = sorted(lb for lb, r in res.items() if not (isinstance(r, dict) and r.get("status", "success") == "success"))
    levers = {}
    for k, p in (papers or {}).items():
        b = bands.get(k)
        if not isinstance(b, tuple) or k not in (nom or {}):
            continue
        # a lever only for a row the band misses by more than tau (one that contradicts)
        t = taus.get(k, 0.0)
        missed = (p not in b[0]) if len(b) == 2 else not (b[0] - t <= float(p) <= b[1] + t)
        if missed:
            got = {lb: (res if n in union else scr).get(lb) for lb, n, _ in oat}
            levers[k] = lever(inputs, oat, got, k, p, taus.get(k, 0.0))
            bands[k] = b[:-1] + (f"{b[-1]}; {levers[k]['text']}",)
    return bands, table, dict(ledger.as_dict(), stage="band", foreign=store.foreign, failed=failed, levers=levers,
                              nominal=nom)


def lever(inputs, oat, results, key, paper, tau):
    """What would move row ``key`` to the paper's value: the one-at-a-time tornado (each input's
    value of the row at each end, the others nominal) and its lever, the input with the largest
    swing. Numeric: the value that input would need, by linear interpolation between its sampled
    points when the paper's value lies between them ('interpolated'), else by the nearest
    segment's slope ('extrapolated', beside its plausible range); categorical: the inputs whose
    change gives the paper's kind, or none. {'tornado': [(name, [(value, row)...])], 'text'}."""
    nominal = results.get("nominal") or {}
    by = {e["name"]: e for e in inputs}
    tornado = []
    for name in dict.fromkeys(n for _, n, _ in oat if n):
        e = by[name]
        pts = [(v[e["key"]], results[lb][key]) for lb, n, v in oat
               if n == name and isinstance(results.get(lb), dict) and key in results[lb]]
        tornado.append((name, sorted(pts + [(e["nominal"], nominal[key])], key=lambda t: str(t[0]) if "choices" in e
                                     else float(t[0]))))
    if isinstance(paper, str):
        hits = [f"{n} = {v}" for n, pts in tornado for v, r in pts if paper in str(r).split(", ")]
        text = ("lever: " + ", ".join(hits) + f" gives {paper}" if hits else
                f"no single input reaches {paper} (each one-at-a-time end tried)")
        return {"tornado": tornado, "text": text}
    num = [(n, pts) for n, pts in tornado if "range" in by[n]]
    if not num:
        return {"tornado": tornado, "text": "no numeric input to move"}
    n, pts = max(num, key=lambda t: max(abs(float(r) - float(nominal[key])) for _, r in t[1]))
    e = by[n]
    lo, hi = map(float, e["range"])
    xs, ys = [float(v) for v, _ in pts], [float(r) for _, r in pts]
    p = float(paper)
    need, how = None, "no value of it reaches the paper's"
    for (x0, y0), (x1, y1) in zip(zip(xs, ys), zip(xs[1:], ys[1:])):
        if min(y0, y1) <= p <= max(y0, y1) and y1 != y0:
            need, how = x0 + (p - y0) * (x1 - x0) / (y1 - y0), "interpolated"
            break
    if need is None:
        i = 0 if abs(p - ys[0]) < abs(p - ys[-1]) else len(xs) - 2
        slope = (ys[i + 1] - ys[i]) / (xs[i + 1] - xs[i]) if xs[i + 1] != xs[i] else 0.0
        if slope:
            need, how = xs[i] + (p - ys[i]) / slope, "extrapolated"
    swing = max(abs(y - float(nominal[key])) for y in ys)
    unit = f" {e['unit']}" if e.get("unit") else ""
    text = (f"lever: {n} (swing {swing / tau:.2g} tau over [{lo:g}, {hi:g}]{unit})" if tau > 0 else f"lever: {n}")
    text += (f" would need {need:.3g}{unit} ({how}; plausible [{lo:g}, {hi:g}])" if need is not None else f"; {how}")
    return {"tornado": tornado, "text": text, "lever": n, "needed": need, "how": how}


def tornado_figure(levers, nominal, taus, papers, out, name="tornado.png"):
    """One panel per row that misses the paper: each input's one-at-a-time swing of the row from
    ours at nominal, in units of the row's tau (bars), and where the paper lies (line). Returns
    the file name, or None without numeric levers."""
    keys = [k for k, lv in levers.items() if not isinstance(papers[k], str)][:6]
    if not keys:
        return None
    import matplotlib.pyplot as plt

    from pinclear.core import safeio

    fig, axes = plt.subplots(len(keys), 1, figsize=(7.5, 1.2 + 1.1 * len(keys) + 0.25 * max(
        len(levers[k]["tornado"]) for k in keys) * len(keys)), squeeze=False)
    for ax, k in zip(axes[:, 0], keys):
        nv, tau = float(nominal[k]), taus[k] or 1.0
        rows = [(n, [(float(r) - nv) / tau for _, r in pts]) for n, pts in levers[k]["tornado"]]
        rows.sort(key=lambda t: max(map(abs, t[1])))
        for i, (n, d) in enumerate(rows):
            ax.barh(i, max(d) - min(d), left=min(d), color="C0")
        ax.set_yticks(range(len(rows)), [n for n, _ in rows], fontsize=7)
        ax.axvline(0.0, color="k", lw=0.8)
        ax.axvline((float(papers[k]) - nv) / tau, color="C3", lw=1.5, label="paper")
        ax.set_title(textwrap.fill(f"{k}: {levers[k]['text']}", 120), fontsize=7, loc="left")
        ax.set_xlabel("row - ours at nominal [tau]", fontsize=7)
        ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    safeio.savefig(fig, out / name, dpi=110)
    plt.close(fig)
    return name


def ledger_text(ledger):
    """The header's line on the bands: points resumed, run now and their CPU, what the budget left."""
    if not ledger:
        return "not measured (--bands)"
    t = (f"screened, then banded: {ledger['ran']} points run ({ledger['cpu_s']:.0f} CPU s), "
         f"{ledger['resumed']} resumed from OUT/bands ({ledger['cpu_stored_s']:.0f} CPU s when run)")
    if ledger.get("foreign"):
        t += f", {ledger['foreign']} stored points of other settings ignored"
    if ledger.get("failed"):
        t += f"; {len(ledger['failed'])} points failed (left out of the bands: " + ", ".join(ledger["failed"][:5]) + ")"
    if ledger["not_reached"]:
        t += (f"; {ledger['not_reached']} points not reached within --budget (they need about "
              f"{ledger['needs_cpu_s']:.0f} CPU s)")
    return t


#: a ledger's counts (Ledger.as_dict): what stages add up and reports keep
COUNT_KEYS = ("resumed", "ran", "cpu_s", "cpu_stored_s", "not_reached", "needs_cpu_s")


def ledger_counts(ledger):
    """The numbers of a bands' ledger a report keeps (points resumed, run, not reached, and their
    CPU: the header's budget adds the stored points' CPU when run to this run's), or None."""
    if not ledger:
        return None
    return {k: ledger[k] for k in COUNT_KEYS}


def kinds_band(bands, keys, ours):
    """(kinds, what, cpu_needed) of a categorical row whose band is the union of the motion-kind
    keys ``keys`` (ours included); (None, '', CPU s) when one of them was not reached, (None, '',
    None) when none was measured."""
    got = [bands.get(k) for k in keys]
    need = sum(b.cpu_s for b in got if isinstance(b, NotReached))
    if need:
        return None, "", need
    got = [b for b in got if b is not None]
    if not got:
        return None, "", None
    kinds = set([ours] if isinstance(ours, str) else ours)
    for b in got:
        kinds |= set(b[0])
    return sorted(kinds), "; ".join(dict.fromkeys(f"{k}: {b[1]}" for k, b in zip(keys, [bands[k] for k in keys]))), None
