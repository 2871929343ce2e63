"""report.json, report.md and report.html (figures inline) of a reproduced study.

A report is a dict: title, paper, settings, results (one row per compared number, built by
:func:`pinclear.studies.reproduce.verdicts.row`: name, quantity, ours, band, band_from, paper, unit, tau,
verdict, group, why), groups (one paragraph per group of rows: why they differ, said once),
notes (qualitative findings), figures (file names in the report folder) and optionally
``sensitivity``: measured tables of how the results move with the reconstructed quantities, each
{"title", "columns", "rows", "note"}.

Two more parts open the report: ``claims``, the paper's central claims answered one per line
(:func:`claim`: the claim, where the paper shows it, its evidence, ours, the verdict), and ``run``,
how the report was made (:func:`run_record`: CPU of the process and its children, wall time, the
commit, the versions of pinocchio, numpy, scipy and numba, the commands that regenerate it).
``consistency`` rows (built by :func:`verdicts.row` like the results) are checks that cannot fail
by the paper's inputs, e.g. an identity or a fit inside a print-precision box: shown, never counted."""
from __future__ import annotations

import base64
import html
import json
import os
import platform
import subprocess
import sys
import time
from pathlib import Path

from pinclear.core import safeio
from pinclear.core.errors import InputError
from pinclear.dynamics.trajectory import atomic_write_text, jsonable
from pinclear.studies.reproduce.verdicts import CLASSES, TOLERANCES, counts, summary


def _fmt(x):
    return f"{x:.4g}" if isinstance(x, float) else str(x)


#: every report points to the project's account of what each paper gives and what was reconstructed
SOURCES = ("What the paper gives, what it leaves out and what was reconstructed (and why), with each "
           "reconstructed input's plausible range: docs/papers.md, section 'Paper {paper}'.")
LEGEND = ("Classes (pinclear.studies.reproduce.verdicts): calibration = used to choose a reconstruction, does not count; "
          "not comparable = our quantity is not the paper's; contradicted = the paper's value lies further than "
          "tau from our band; reproduced = within tau of a band no wider than 2 tau; undecided = within tau of a "
          "wider band (the lost inputs decide); not measured = no band was measured (one run: it can neither "
          "reproduce nor contradict). Beside each class, the nominal verdict: ours at the nominal inputs against "
          "the paper, in per cent and in tau. tau = max(the paper's reading precision, the quantity's tolerance).")
COLUMNS = ("result", "ours", "band (varied inputs)", "paper", "deviation", "tau", "class", "group / why")


def cells(r):
    """The table cells of one row (as strings)."""
    u = f" {r['unit']}" if r.get("unit") else ""
    if isinstance(r["ours"], float):
        lo, hi = r["band"]
        band = f"{_fmt(lo)}-{_fmt(hi)}{u}" if r["band_from"] else "not measured"
        if r["band_from"]:
            band += f" ({r['band_from']})"
        dev = f"{100 * r['deviation']:+.1f} %" if r.get("deviation") is not None else ""
        tau = f"{_fmt(r['tau'])}{u}"
        ours, paper = f"{_fmt(r['ours'])}{u}", f"{_fmt(r['paper'])}{u}"
    else:
        band = (", ".join(r["band"]) + f" ({r['band_from']})") if r["band_from"] else "not measured"
        dev, tau, ours, paper = "", "categorical", str(r["ours"]), str(r["paper"])
    if not r["band_from"] and r["verdict"] in ("not comparable", "calibration"):
        # neither class is decided by a band: 'not measured' would read as a gap in the report
        band = f"not needed ({r['verdict']})"
    why = " ".join(x for x in (f"[{r['group']}]" if r.get("group") else "", r.get("why") or "") if x)
    verdict = r["verdict"] + (f" ({r['nominal']})" if r.get("nominal") else "")
    return [r["name"], ours, band, paper, dev, tau, verdict, why]


def header(rep):
    """The counts line, and the rows whose band was not measured with the CPU they would need."""
    out = f"**Verdicts: {summary(rep['results'])}.**"
    nm = [r for r in rep["results"] if r["verdict"] == "not measured"]
    if nm:
        # rows share band points, so their needs do not add: the largest bounds what one more run needs
        # for the shared points, and each row states its own
        need = max(r.get("cpu_needed_s") or 0.0 for r in nm)
        out += (f" Not measured: {len(nm)} rows" + (f", the costliest needing about {need / 3600:.2g} CPU h (rows "
                                                    "share band points: their CPU does not add)" if need else "")
                + " (`pinclear reproduce --bands` resumes from the stored points): "
                + "; ".join(r["name"] + (f" ({r['cpu_needed_s']:.0f} CPU s)" if r.get("cpu_needed_s") else "")
                            for r in nm) + ".")
    return out


# ------------------------------------------------------------------------------- claims
#: a claim's verdict: reproduced / contradicted / undecided / not measured as its rows' (the worst
#: counts: one contradicted row contradicts the claim), 'not comparable' when no row of ours is
#: the paper's quantity, 'new finding' for what the paper does not report
CLAIM_VERDICTS = ("reproduced", "contradicted", "undecided", "not measured", "not comparable", "new finding")
CLAIM_COLUMNS = ("claim", "where the paper shows it", "the paper's evidence", "ours", "verdict")


def claim_verdict(rows):
    """The verdict of a claim from the verdicts of the rows that decide it: calibration and
    not-comparable rows do not decide; any contradicted row contradicts; all reproduced reproduce;
    a row whose band was not measured leaves the claim 'not measured'; else undecided."""
    v = [r["verdict"] for r in rows if r["verdict"] not in ("calibration", "not comparable")]
    if not v:
        return "not comparable"
    if "contradicted" in v:
        return "contradicted"
    if all(x == "reproduced" for x in v):
        return "reproduced"
    if "not measured" in v:
        return "not measured"
    return "undecided"


def claim(key, text, where, paper, ours, rows=(), verdict=None):
    """One line of the claims table. key: the claim's id (docs/claims.md lists every id); rows:
    the report rows that decide it (their names are listed, their verdicts give the claim's
    unless ``verdict`` is given, e.g. for a claim checked by a test or a computed fact)."""
    rows = list(rows)
    if verdict is None:
        verdict = claim_verdict(rows)
    if verdict not in CLAIM_VERDICTS:
        raise InputError(f"claim {key!r}: unknown verdict {verdict!r}", choices=list(CLAIM_VERDICTS))
    return {"key": key, "claim": text, "where": where, "paper": paper, "ours": ours, "verdict": verdict,
            "rows": [r["name"] for r in rows]}


def claims_markdown(claims, paper=None, keys=False):
    """The claims table (markdown lines); ``paper``: a first column with the paper's number;
    ``keys``: a first column with each claim's id (docs/claims.md, where other docs cite them)."""
    cols = (("paper",) if paper else ()) + (("key",) if keys else ()) + CLAIM_COLUMNS
    lines = ["| " + " | ".join(cols) + " |", "|" + "---|" * len(cols)]
    for c in claims:
        ours = c["ours"] + (f" (rows: {'; '.join(c['rows'])})" if c.get("rows") else "")
        cells_ = (([paper] if paper else []) + ([f"`{c['key']}`"] if keys else [])
                  + [c["claim"], c["where"], c["paper"], ours, f"**{c['verdict']}**"])
        lines.append("| " + " | ".join(x.replace("|", "/").replace("\n", " ") for x in cells_) + " |")
    return lines


# ------------------------------------------------------------------------------- how it was made
def _commit():
    root = Path(__file__).resolve().parents[3]
    try:
        head = subprocess.run(["git", "-C", str(root), "rev-parse", "--short=12", "HEAD"], capture_output=True,
                              text=True, timeout=10, check=False).stdout.strip()
        dirty = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--untracked-files=no"],
                               capture_output=True, text=True, timeout=10, check=False).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown (no git)"
    return (head + (" + uncommitted changes" if dirty else "")) if head else "unknown (not a git checkout)"


def versions():
    """{package: version} of the libraries a result depends on."""
    from importlib import metadata

    out = {"python": platform.python_version()}
    # pinocchio's distribution is 'pin' on PyPI, 'pinocchio' from conda / robotpkg
    for name, dists in (("pinocchio", ("pin", "pinocchio")), ("numpy", ("numpy",)), ("scipy", ("scipy",)),
                        ("numba", ("numba",))):
        out[name] = "not installed"
        for d in dists:
            try:
                out[name] = metadata.version(d)
                break
            except metadata.PackageNotFoundError:
                continue
    return out


def cpu_now():
    """(CPU s of this process, CPU s of its waited-for children): user + system (os.times; the
    children's part is 0 where the platform does not count it)."""
    t = os.times()
    return t.user + t.system, t.children_user + t.children_system


def started_now():
    """What :func:`run_record` needs from before the study: (wall clock, CPU, the commit then)."""
    return time.perf_counter(), cpu_now(), _commit()


def run_record(paper, started, quick=False, bands=False, out=None):
    """The report's 'how it was made': ``started`` from :func:`started_now` before the study (the
    commit is the one the study began with). Children's CPU counts the worker processes that have
    been waited for (a Dask cluster's workers are not children: their CPU is not in it)."""
    wall0, (self0, child0) = started[:2]
    commit = started[2] if len(started) > 2 else _commit()
    self1, child1 = cpu_now()
    flags = (" --quick" if quick else "") + (" --bands" if bands else "")
    return {"cpu_self_s": self1 - self0, "cpu_children_s": child1 - child0, "wall_s": time.perf_counter() - wall0,
            "cpus": os.cpu_count(), "commit": commit, "versions": versions(),
            "commands": [[f"pinclear reproduce {paper}{flags} --out {out or f'reproduce_{paper}'}", "this report"],
                         [f"pinclear reproduce {paper} --bands --out docs/reproduce/{paper}", "the committed report"]],
            "argv": " ".join(sys.argv)}


#: CPU hours a paper's whole report may take, bands included, on a 2-core developer machine
BUDGET_CPU_H = {"000": 2.0, "002": 4.0, "003": 1.0, "004": 1.0}


def budget_text(paper, run, ledger=None):
    """The header's budget sentence: this run's CPU plus its band points resumed from OUT/bands at
    the CPU they took when run (what the report costs from its stored points) against the paper's
    :data:`BUDGET_CPU_H`; the points not reached are named with their CPU."""
    if not run or str(paper) not in BUDGET_CPU_H:
        return ""
    ledger = ledger or {}
    stored = float(ledger.get("cpu_stored_s") or 0.0)
    total = run["cpu_self_s"] + run["cpu_children_s"] + stored
    cap = 3600.0 * BUDGET_CPU_H[str(paper)]
    t = (f"CPU budget: {total / 3600:.2f} CPU h, bands included (this run's {run['cpu_self_s'] + run['cpu_children_s']:.0f}"
         f" CPU s + {stored:.0f} CPU s of the {ledger.get('resumed', 0)} band points resumed, when they ran), "
         f"against {BUDGET_CPU_H[str(paper)]:g} CPU h for a 2-core developer machine: ")
    t += "within" if total <= cap else f"over by {100 * (total / cap - 1):.0f} %"
    if ledger.get("not_reached"):
        t += (f"; {ledger['not_reached']} band points not reached need about {ledger['needs_cpu_s']:.0f} CPU s more "
              f"({(total + ledger['needs_cpu_s']) / 3600:.2f} CPU h in all)")
    return t + "."


def run_markdown(run, paper=None, ledger=None):
    if not run:
        return []
    v = ", ".join(f"{k} {x}" for k, x in run["versions"].items())
    budget = budget_text(paper, run, ledger)
    return [f"Made by commit {run['commit']} ({v}); CPU {run['cpu_self_s']:.1f} s in this process + "
            f"{run['cpu_children_s']:.1f} s in its worker processes, wall {run['wall_s']:.1f} s on {run['cpus']} CPUs. "
            + (budget + " " if budget else "") + "Regenerate: " + "; ".join(f"`{c}` ({what})" for c, what in run["commands"]) + "."]


def markdown(rep) -> str:
    lines = [f"# {rep['title']}", ""] + run_markdown(rep.get("run"), rep["paper"], rep.get("bands_ledger")) + [
        "", f"Paper {rep['paper']}. Settings: "
             + ", ".join(f"{k} = {_fmt(v)}" for k, v in rep["settings"].items()), ""]
    if rep.get("claims"):
        lines += ["## The paper's claims", ""] + claims_markdown(rep["claims"]) + [""]
    lines += ["## Compared numbers", "", SOURCES.format(paper=rep["paper"]), "", header(rep), "", LEGEND, "",
              "| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    for r in rep["results"]:
        lines.append("| " + " | ".join(c.replace("|", "/") for c in cells(r)) + " |")
    if rep.get("consistency"):
        lines += ["", "### Consistency checks (cannot fail by the lost inputs: shown, not counted)", "",
                  "| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
        lines += ["| " + " | ".join(c.replace("|", "/") for c in cells(r)) + " |" for r in rep["consistency"]]
    lines += _groups_md(rep)
    lines += ["", "## Findings", ""] + [f"- {n}" for n in rep["notes"]]
    if rep.get("sensitivity"):
        lines += ["", "## Sensitivity to the reconstructed quantities (measured)"]
        lines += sensitivity_markdown(rep["sensitivity"])
    for f in rep["figures"]:
        lines += ["", f"![{f}]({f})"]
    return "\n".join(lines) + "\n"


def _used_tolerances(rep):
    used = []
    for r in rep["results"]:
        if r["quantity"] not in used:
            used.append(r["quantity"])
    return used


def _groups_md(rep):
    lines = []
    if rep.get("groups"):
        lines += ["", "### Why, per group of rows", ""]
        lines += [f"- **[{k}]** {v}" for k, v in rep["groups"].items()]
    lines += ["", "### Tolerances used (pinclear.studies.reproduce.verdicts.TOLERANCES)", ""]
    lines += [f"- {q}: {100 * TOLERANCES[q][0]:g} % - {TOLERANCES[q][1]}" for q in _used_tolerances(rep)]
    return lines


def sensitivity_markdown(tables):
    lines = []
    for tb in tables:
        lines += ["", f"### {tb['title']}", "", "| " + " | ".join(tb["columns"]) + " |",
                  "|" + "---|" * len(tb["columns"])]
        lines += ["| " + " | ".join(_fmt(c) for c in row) + " |" for row in tb["rows"]]
        if tb.get("note"):
            lines += ["", tb["note"]]
    return lines


def _html_table(columns, rows):
    return ("<table border=1 cellpadding=4><tr>" + "".join(f"<th>{html.escape(str(c))}</th>" for c in columns)
            + "</tr>" + "".join("<tr>" + "".join(f"<td>{html.escape(_fmt(c))}</td>" for c in row) + "</tr>"
                                for row in rows) + "</table>")


def convergence_table(title, checks, note="", extra=None, extra_label=""):
    """A report table of output-step convergence checks ({run label: StepConvergence}, all on the
    same steps): per run and quantity the value at each output step, coarse to fine, the
    relative change between the two finest and whether that is within the check's rtol.
    ``extra`` {run label: {quantity: value}}: one more column, ``extra_label`` (e.g. the
    integration's own peak over the accepted steps); nan where it has no value."""
    first = next(iter(checks.values()))
    rows = []
    for label, sc in checks.items():
        for name, vals in sc.values.items():
            more = [(extra.get(label) or {}).get(name, float("nan"))] if extra is not None else []
            rows.append([label, name, *vals, *more, sc.changes[name][-1],
                         "converged" if sc.converged[name] else "NOT converged"])
    cols = ["run", "quantity", *(f"output step {1e3 * h:.3g} ms" for h in first.steps),
            *([extra_label] if extra is not None else []), "last change", f"within {first.rtol:.0%}"]
    return {"title": title, "columns": cols, "rows": rows, "note": note}


def bands_figure(rep, out, name="bands.png"):
    """Every row with a measured band. A numeric row as its distance from the paper in units of the
    row's tau, (value - paper) / tau on a symmetric-log axis (so a paper value of 0, as G's worst
    entry, and signed values fit one axis): the band as a bar, ours as a dot, the paper's +- tau
    shaded at [-1, 1]. A categorical row (a kind of motion, an ordering) below them: a square at 0,
    coloured by its class, and its band's kinds against the paper's written beside it. None if no
    row has a band."""
    banded = [r for r in rep["results"] if r["band_from"] and r["verdict"] not in ("calibration", "not comparable")]
    rows = [r for r in banded if isinstance(r["ours"], float) and r["tau"] > 0]
    kinds = [r for r in banded if isinstance(r["ours"], str)]
    if not rows and not kinds:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(rows) + len(kinds)
    fig, ax = plt.subplots(figsize=(12, 0.32 * n + 1.4))
    ax.axvspan(-1.0, 1.0, color="0.85", lw=0)
    colours = {"contradicted": "C3", "reproduced": "C2"}
    for i, r in enumerate(rows):
        p, t, (lo, hi) = r["paper"], r["tau"], r["band"]
        colour = colours.get(r["verdict"], "C0")
        ax.plot([(lo - p) / t, (hi - p) / t], [i, i], color=colour, lw=4, solid_capstyle="butt")
        ax.plot([(r["ours"] - p) / t], [i], "o", ms=4, color=colour, mec="k", mew=0.6)
    for i, r in enumerate(kinds, start=len(rows)):
        ax.plot([0.0], [i], "s", ms=6, color=colours.get(r["verdict"], "C0"), mec="k", mew=0.6)
        ax.annotate(f"{r['verdict']}: band {', '.join(map(str, r['band']))}; paper {r['paper']}", (0.0, i),
                    textcoords="offset points", xytext=(8, -3), fontsize=7)
    ax.axvline(0.0, color="k", lw=0.8)
    ax.set_xscale("symlog", linthresh=1.0)
    ax.set_yticks(range(n))
    ax.set_yticklabels([r["name"][:80] for r in rows + kinds], fontsize=7)
    ax.invert_yaxis()
    fig.subplots_adjust(left=0.42, right=0.98, bottom=1.0 / (0.32 * n + 1.4), top=0.98)
    ax.set_xlabel("(ours - paper) / tau. Bar: our band over the varied inputs (red contradicted, green reproduced, "
                  "blue undecided);\ndot: ours at the nominal inputs; grey: the paper's value +- tau; square: a "
                  "categorical row, its band's kinds beside it", fontsize=8)
    safeio.savefig(fig, Path(out) / name, dpi=90)
    plt.close(fig)
    return name


def write_report(rep, out):
    """Write the report files; adds bands.png to ``rep['figures']`` (in place) when a row's band was measured."""
    out = Path(out)
    fig = bands_figure(rep, out)
    if fig and fig not in rep["figures"]:
        rep["figures"] = list(rep["figures"]) + [fig]
    from pinclear.core.version import provenance

    rep = dict(rep, counts=counts(rep["results"]), versions=provenance())
    atomic_write_text(out / "report.json", json.dumps(jsonable(rep), indent=1))
    atomic_write_text(out / "report.md", markdown(rep))
    body = [f"<h1>{html.escape(rep['title'])}</h1>"] + [f"<p>{html.escape(x)}</p>" for x in run_markdown(
        rep.get("run"), rep["paper"], rep.get("bands_ledger"))]
    if rep.get("claims"):
        body.append("<h2>The paper's claims</h2>" + _html_table(CLAIM_COLUMNS, [
            [c["claim"], c["where"], c["paper"], c["ours"] + (f" (rows: {'; '.join(c['rows'])})" if c["rows"] else ""),
             c["verdict"]] for c in rep["claims"]]))
    body += [f"<h2>Compared numbers</h2><p>{html.escape(SOURCES.format(paper=rep['paper']))}</p>",
             f"<p><b>Verdicts: {html.escape(summary(rep['results']))}.</b></p>", f"<p>{html.escape(LEGEND)}</p>",
             _html_table(COLUMNS, [cells(r) for r in rep["results"]])]
    if rep.get("consistency"):
        body.append("<h3>Consistency checks (shown, not counted)</h3>"
                    + _html_table(COLUMNS, [cells(r) for r in rep["consistency"]]))
    if rep.get("groups"):
        body.append("<h3>Why, per group of rows</h3><ul>" + "".join(
            f"<li><b>[{html.escape(k)}]</b> {html.escape(v)}</li>" for k, v in rep["groups"].items()) + "</ul>")
    body.append("<h3>Tolerances used</h3><ul>" + "".join(
        f"<li>{html.escape(q)}: {100 * TOLERANCES[q][0]:g} % - {html.escape(TOLERANCES[q][1])}</li>"
        for q in _used_tolerances(rep)) + "</ul>")
    body.append("<h2>Findings</h2><ul>" + "".join(f"<li>{html.escape(n)}</li>" for n in rep["notes"]) + "</ul>")
    if rep.get("sensitivity"):
        body.append("<h2>Sensitivity to the reconstructed quantities (measured)</h2>")
        for tb in rep["sensitivity"]:
            body.append(f"<h3>{html.escape(tb['title'])}</h3>" + _html_table(tb["columns"], tb["rows"])
                        + (f"<p>{html.escape(tb['note'])}</p>" if tb.get("note") else ""))
    for f in rep["figures"]:
        data = base64.b64encode((out / f).read_bytes()).decode()
        body.append(f'<p><img alt="{html.escape(f)}" src="data:image/png;base64,{data}"></p>')
    atomic_write_text(out / "report.html", "<!doctype html><meta charset=utf-8><title>" + html.escape(rep["title"])
                      + "</title>" + "\n".join(body))


__all__ = ["CLAIM_VERDICTS", "CLASSES", "claim", "claim_verdict", "claims_markdown", "convergence_table", "header", "markdown", "run_record",
           "sensitivity_markdown", "started_now", "versions", "write_report"]


# ------------------------------------------------------------------------------- the claims page
CLAIMS_INTRO = """# Which of the four papers' claims hold

Each report of `pinclear reproduce PAPER` opens with a table of that paper's central claims: the
claim, where the paper shows it, the paper's evidence, ours and a verdict. This page gathers them
from the committed reports in [docs/reproduce/](reproduce/) (`pinclear reproduce claims` writes it
from their report.json files; a test checks that it matches them). A claim's verdict is that of
the rows that decide it (listed beside "ours"): one contradicted row contradicts it, all
reproduced reproduce it, a row whose band was not measured leaves it **not measured**, a band too
wide to decide leaves it **undecided**; calibration and not-comparable rows never decide. A claim
checked by a test or a computed fact, not by a compared number, names the test; **new finding**
is what the paper does not report. The papers: [docs/papers.md](papers.md); how a row earns its
class and how the bands are measured: [docs/papers.md](papers.md#how-a-row-earns-its-class).
"""


def claims_page(folder) -> str:
    """docs/claims.md's text from the reports under ``folder`` (``NNN/report.json`` for each
    paper with a report there): per paper, its run's commit and CPU, its counts and its claims."""
    import json

    from pinclear.core.bounded import read_text_bounded

    lines = [CLAIMS_INTRO]
    for rep_file in sorted(Path(folder).glob("*/report.json")):
        rep = json.loads(read_text_bounded(rep_file, 64 << 20, "report", "report.json"))
        run = rep.get("run") or {}
        made = (f"made by commit {run['commit']}, {run['cpu_self_s'] + run['cpu_children_s']:.0f} CPU s"
                if run else "made before the reports recorded their run")
        lines += [f"## {rep['title']} ([report](reproduce/{rep_file.parent.name}/report.md))", "",
                  f"Rows: {summary(rep['results'])}; {made}; bands: {rep['settings'].get('bands', 'not recorded')}.", ""]
        lines += (claims_markdown(rep["claims"], keys=True) if rep.get("claims")
                  else ["(no claims table: an older report)"])
        lines.append("")
    return "\n".join(lines)
