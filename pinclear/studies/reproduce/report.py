"""report.json, report.md and report.html (figures inline) of a reproduced study.

A report is a dict: title, paper, settings, results (one row per compared number, built by
:func:`pinclear.studies.reproduce.verdicts.row`: name, quantity, ours, band, band_from, paper, unit, tau,
verdict, group, why), groups (one paragraph per group of rows: why they differ, said once),
notes (qualitative findings), figures (file names in the report folder) and optionally
``sensitivity``: measured tables of how the results move with the reconstructed quantities, each
{"title", "columns", "rows", "note"}."""
from __future__ import annotations

import base64
import html
import json
from pathlib import Path

from pinclear.core import safeio
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
          "wider band (the lost inputs decide), or the band was not measured. tau = max(the paper's reading "
          "precision, the quantity's tolerance).")
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
    why = " ".join(x for x in (f"[{r['group']}]" if r.get("group") else "", r.get("why") or "") if x)
    return [r["name"], ours, band, paper, dev, tau, r["verdict"], why]


def header(rep):
    return f"**Verdicts: {summary(rep['results'])}.**"


def markdown(rep) -> str:
    lines = [f"# {rep['title']}", "", f"Paper {rep['paper']}. Settings: "
             + ", ".join(f"{k} = {_fmt(v)}" for k, v in rep["settings"].items()), "",
             SOURCES.format(paper=rep["paper"]), "", header(rep), "", LEGEND, "",
             "| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    for r in rep["results"]:
        lines.append("| " + " | ".join(c.replace("|", "/") for c in cells(r)) + " |")
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


def bands_figure(rep, out, name="bands.png"):
    """Each numeric row with a measured band, as a ratio to the paper's value (log scale): the band
    as a bar, ours as a dot, the paper at 1 with its tolerance tau shaded; None if there is none."""
    rows = [r for r in rep["results"] if isinstance(r["ours"], float) and r["band_from"] and r.get("paper")
            and r["verdict"] not in ("calibration", "not comparable") and min(r["band"]) * r["paper"] > 0]
    if not rows:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(12, 0.32 * len(rows) + 1.4))
    for i, r in enumerate(rows):
        p, (lo, hi) = r["paper"], r["band"]
        colour = {"contradicted": "C3", "reproduced": "C2"}.get(r["verdict"], "C0")
        ax.fill_betweenx([i - 0.4, i + 0.4], 1 - r["tau"] / abs(p), 1 + r["tau"] / abs(p), color="0.85", lw=0)
        ax.plot([lo / p, hi / p], [i, i], color=colour, lw=4, solid_capstyle="butt")
        ax.plot([r["ours"] / p], [i], "o", ms=4, color=colour, mec="k", mew=0.6)
    ax.axvline(1.0, color="k", lw=0.8)
    ax.set_xscale("log")
    ax.set_yticks(range(len(rows)))
    ax.set_yticklabels([r["name"][:80] for r in rows], fontsize=7)
    ax.invert_yaxis()
    fig.subplots_adjust(left=0.42, right=0.98, bottom=1.0 / (0.32 * len(rows) + 1.4), top=0.98)
    ax.set_xlabel("ours / paper. Bar: our band over the varied inputs (red contradicted, green reproduced, blue "
                  "undecided);\ndot: ours at the nominal inputs; grey: the paper's value +- tau", fontsize=8)
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
    body = [f"<h1>{html.escape(rep['title'])}</h1>", f"<p>{html.escape(SOURCES.format(paper=rep['paper']))}</p>",
            f"<p><b>Verdicts: {html.escape(summary(rep['results']))}.</b></p>", f"<p>{html.escape(LEGEND)}</p>",
            _html_table(COLUMNS, [cells(r) for r in rep["results"]])]
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


__all__ = ["CLASSES", "markdown", "write_report", "sensitivity_markdown", "header"]
