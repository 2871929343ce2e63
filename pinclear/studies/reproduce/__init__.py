"""The source papers' studies, run end to end, with our results beside the paper's own numbers:
``pinclear reproduce PAPER [--quick] [--bands [--budget CPU_S]] [--out DIR] [--workers N]
[--scheduler ADDRESS]`` writes the figures, report.md, report.html (figures inline) and
report.json. Every compared number gets a class (pinclear.studies.reproduce.verdicts: calibration, not
comparable, contradicted, reproduced, undecided) and the command prints the count of each.

Available: 000 (4UPS-UPU, spherical clearance at S2), 002 (nine-bar, revolute clearances at A
and B), 003 (3-UPRU+UP, prismatic clearance), 004 (4-UPS/UPR screw-theory inverse dynamics).
Each paper's module has ``run(out, quick=False, workers=None, scheduler=None)``; the many runs
of a study go through pinclear.sweep / pinclear.analysis.bifurcation on one executor.
"""
from __future__ import annotations

from pathlib import Path

from pinclear.core.errors import InputError
from pinclear.core.registry import Entry, Registry
from pinclear.studies.reproduce.report import run_record, started_now, write_report
from pinclear.studies.reproduce.verdicts import summary

#: a paper's study: its module's ``run`` (one module and one line here each)
PAPERS = Registry("paper reproduction", {e.name: e for e in (
    Entry("000", "pinclear.studies.reproduce.paper000:run", "4UPS-UPU, spherical clearance at S2"),
    Entry("002", "pinclear.studies.reproduce.paper002:run", "nine-bar, revolute clearances at A and B"),
    Entry("003", "pinclear.studies.reproduce.paper003:run", "3-UPRU+UP, prismatic clearance"),
    Entry("004", "pinclear.studies.reproduce.paper004:run", "4-UPS/UPR screw-theory inverse dynamics"))},
    record=Entry)


def reproduce(paper, out, quick=False, workers=None, scheduler=None, bands=False, budget=None) -> dict:
    """Run ``paper``'s study, write its report into ``out``; return the report (a dict).

    workers: local processes for the study's simulations (default: one per CPU); scheduler: a Dask
    scheduler address (``tcp://HOST:8786``) instead. bands: also measure each row's band over the
    reconstructed inputs (pinclear.studies.reproduce.bands), within ``budget`` CPU seconds if given."""
    if str(paper) not in PAPERS:
        raise InputError(f"reproduce: no study for paper {paper!r}", choices=sorted(PAPERS))
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    extra = {"bands": True, "budget": budget} if bands else {}
    started = started_now()
    report = PAPERS[str(paper)](out, quick=quick, workers=workers, scheduler=scheduler, **extra)
    report["run"] = run_record(paper, started, quick=quick, bands=bands, out=out)
    write_report(report, out)
    return report
