"""report.json, report.md and report.html (figures inline) of a reproduced study.

A report is a dict: title, paper, settings, results (one row per compared number: name, ours,
paper, unit, deviation, tolerance, verdict, why), notes (qualitative findings), figures (file
names in the report folder) and optionally ``sensitivity``: measured tables of how the results
move with the reconstructed quantities, each {"title", "columns", "rows", "note"}."""
from __future__ import annotations

import base64
import html
import json
from pathlib import Path

from ..trajectory import atomic_write_text, jsonable


def compare(name, ours, paper, unit, tolerance, why):
    """One compared number: relative deviation from the paper's value and whether it lies within
    ``tolerance`` (relative), with the reason for the tolerance or the difference."""
    dev = (ours - paper) / abs(paper) if paper else float("nan")
    return {"name": name, "ours": float(ours), "paper": float(paper), "unit": unit, "deviation": float(dev),
            "tolerance": float(tolerance), "verdict": "agrees" if abs(dev) <= tolerance else "differs", "why": why}


def _fmt(x):
    return f"{x:.4g}" if isinstance(x, float) else str(x)


#: every report points to the project's account of what each paper gives and what was reconstructed
SOURCES = ("What the paper gives, what it leaves out and what was reconstructed (and why): docs/papers.md, "
           "section 'Paper {paper}'.")


def sensitivity_markdown(tables):
    lines = []
    for tb in tables:
        lines += ["", f"### {tb['title']}", "", "| " + " | ".join(tb["columns"]) + " |",
                  "|" + "---|" * len(tb["columns"])]
        lines += ["| " + " | ".join(_fmt(c) for c in row) + " |" for row in tb["rows"]]
        if tb.get("note"):
            lines += ["", tb["note"]]
    return lines


def markdown(rep) -> str:
    lines = [f"# {rep['title']}", "", f"Paper {rep['paper']}. Settings: "
             + ", ".join(f"{k} = {_fmt(v)}" for k, v in rep["settings"].items()), "",
             SOURCES.format(paper=rep["paper"]), "",
             "| result | ours | paper | deviation | tolerance | verdict | why |", "|---|---|---|---|---|---|---|"]
    for r in rep["results"]:
        lines.append(f"| {r['name']} | {_fmt(r['ours'])} {r['unit']} | {_fmt(r['paper'])} {r['unit']} | "
                     f"{100 * r['deviation']:+.1f} % | {100 * r['tolerance']:.0f} % | {r['verdict']} | {r['why']} |")
    lines += ["", "## Findings", ""] + [f"- {n}" for n in rep["notes"]]
    if rep.get("sensitivity"):
        lines += ["", "## Sensitivity to the reconstructed quantities (measured)"]
        lines += sensitivity_markdown(rep["sensitivity"])
    for f in rep["figures"]:
        lines += ["", f"![{f}]({f})"]
    return "\n".join(lines) + "\n"


def write_report(rep, out):
    out = Path(out)
    atomic_write_text(out / "report.json", json.dumps(jsonable(rep), indent=1))
    md = markdown(rep)
    atomic_write_text(out / "report.md", md)
    body = [f"<h1>{html.escape(rep['title'])}</h1>", f"<p>{html.escape(SOURCES.format(paper=rep['paper']))}</p>",
            "<table border=1 cellpadding=4>",
            "<tr><th>result</th><th>ours</th><th>paper</th><th>deviation</th><th>tolerance</th><th>verdict</th>"
            "<th>why</th></tr>"]
    for r in rep["results"]:
        body.append("<tr>" + "".join(f"<td>{html.escape(str(c))}</td>" for c in (
            r["name"], f"{_fmt(r['ours'])} {r['unit']}", f"{_fmt(r['paper'])} {r['unit']}",
            f"{100 * r['deviation']:+.1f} %", f"{100 * r['tolerance']:.0f} %", r["verdict"], r["why"])) + "</tr>")
    body.append("</table><h2>Findings</h2><ul>" + "".join(f"<li>{html.escape(n)}</li>" for n in rep["notes"]) + "</ul>")
    if rep.get("sensitivity"):
        body.append("<h2>Sensitivity to the reconstructed quantities (measured)</h2>")
        for tb in rep["sensitivity"]:
            body.append(f"<h3>{html.escape(tb['title'])}</h3><table border=1 cellpadding=4><tr>"
                        + "".join(f"<th>{html.escape(c)}</th>" for c in tb["columns"]) + "</tr>"
                        + "".join("<tr>" + "".join(f"<td>{html.escape(_fmt(c))}</td>" for c in row) + "</tr>"
                                  for row in tb["rows"]) + "</table>"
                        + (f"<p>{html.escape(tb['note'])}</p>" if tb.get("note") else ""))
    for f in rep["figures"]:
        data = base64.b64encode((out / f).read_bytes()).decode()
        body.append(f'<p><img alt="{html.escape(f)}" src="data:image/png;base64,{data}"></p>')
    atomic_write_text(out / "report.html", "<!doctype html><meta charset=utf-8><title>" + html.escape(rep["title"])
                      + "</title>" + "\n".join(body))
