"""The reports' claims tables and headers, and docs/claims.md: every paper's claims answered."""
from __future__ import annotations

import re
from pathlib import Path

import pytest

from pinclear.core.errors import InputError
from pinclear.studies.reproduce import PAPERS
from pinclear.studies.reproduce.report import claim, claim_verdict, claims_markdown, markdown, run_record
from pinclear.studies.reproduce.verdicts import row

ROOT = Path(__file__).resolve().parents[2]


def _r(verdict, band_from="x"):
    return {"name": verdict, "verdict": verdict, "band_from": band_from}


def test_a_claims_verdict_is_its_worst_deciding_row():
    assert claim_verdict([_r("reproduced"), _r("contradicted"), _r("not measured", "")]) == "contradicted"
    assert claim_verdict([_r("reproduced"), _r("reproduced")]) == "reproduced"
    assert claim_verdict([_r("reproduced"), _r("not measured", "")]) == "not measured"
    assert claim_verdict([_r("reproduced"), _r("undecided")]) == "undecided"
    # a row undecided by something other than its band (000's offset: the paper's reading) stays undecided
    assert claim_verdict([_r("undecided", ""), _r("undecided", "")]) == "undecided"
    # calibration and not-comparable rows never decide a claim
    assert claim_verdict([_r("calibration"), _r("reproduced")]) == "reproduced"
    assert claim_verdict([_r("calibration"), _r("not comparable")]) == "not comparable"
    with pytest.raises(InputError, match="unknown verdict"):
        claim("k", "text", "sec. 1", "p", "o", verdict="holds")


def test_claims_table_and_header_come_first_in_the_report():
    r1 = row("a peak", "impact peak", 120.0, 100.0, "N", band=(118.0, 125.0), band_from="inputs")
    c = claim("x-1", "the peak is 100 N", "Fig. 3", "100 N", "120 N", [r1])
    assert c["verdict"] == "contradicted" and c["rows"] == ["a peak"]
    rep = {"title": "T", "paper": "999", "settings": {"a": 1}, "results": [r1], "claims": [c], "notes": [],
           "figures": [], "run": run_record("999", (0.0, (0.0, 0.0)), quick=True, out="o")}
    md = markdown(rep)
    assert md.index("Made by commit") < md.index("## The paper's claims") < md.index("## Compared numbers")
    assert "| the peak is 100 N | Fig. 3 | 100 N | 120 N (rows: a peak) | **contradicted** |" in md
    assert "`pinclear reproduce 999 --quick --out o`" in md and "numba" in md
    assert claims_markdown([c], paper="999")[2].startswith("| 999 | the peak is 100 N")


def test_docs_claims_lists_every_papers_claims_with_a_verdict_and_the_readme_links_it():
    text = (ROOT / "docs" / "claims.md").read_text()
    import importlib

    for name in PAPERS:
        mod = importlib.import_module(PAPERS.get(name).target.split(":")[0])
        for key in mod.CLAIMS:
            line = [ln for ln in text.splitlines() if f"`{key}`" in ln]
            assert len(line) == 1, key
            verdict = re.search(r"\*\*([a-z ]+)\*\*", line[0])
            assert verdict and verdict.group(1) in ("reproduced", "contradicted", "undecided", "not measured",
                                                    "not comparable", "new finding"), key
    assert "(docs/claims.md)" in (ROOT / "README.md").read_text()


def test_bands_figure_draws_every_banded_row_even_a_paper_value_of_zero(tmp_path):
    from pinclear.studies.reproduce.report import bands_figure

    rows = [row("G worst entry", "influence coefficient", 1.1, 0.0, "tau", band=(0.02, 22.8), band_from="box",
                reading=1.0),
            row("a peak", "impact peak", 120.0, 100.0, "N", band=(118.0, 125.0), band_from="inputs"),
            row("unbanded", "impact peak", 120.0, 100.0, "N"),
            row("calib", "impact peak", 120.0, 100.0, "N", band=(1.0, 2.0), band_from="x", status="calibration")]
    assert bands_figure({"results": rows}, tmp_path) == "bands.png"
    assert (tmp_path / "bands.png").stat().st_size > 5_000
    assert bands_figure({"results": rows[2:]}, tmp_path, name="none.png") is None
    # a categorical row with a measured band (the kinds over the varied inputs) is drawn too, alone if need be
    kind = row("motion at 0.8 mm", "motion kind", "chaotic", "chaotic", band=["chaotic", "period-1"],
               band_from="inputs")
    assert kind["verdict"] == "undecided"
    assert bands_figure({"results": rows[2:] + [kind]}, tmp_path, name="kinds.png") == "kinds.png"
    assert (tmp_path / "kinds.png").stat().st_size > 5_000


def test_run_record_counts_the_worker_processes_cpu():
    """CPU of the process and of its children apart: a child that burns CPU shows in the children's part."""
    import subprocess
    import sys

    from pinclear.studies.reproduce.report import started_now

    st = started_now()
    subprocess.run([sys.executable, "-c", "sum(i * i for i in range(4_000_000))"], check=True)
    run = run_record("004", st, quick=True, out="o")
    assert run["cpu_children_s"] > 0.05 and run["cpu_self_s"] >= 0.0 and run["wall_s"] >= run["cpu_children_s"] * 0.5
    assert run["commit"] and run["commands"][0] == ["pinclear reproduce 004 --quick --out o", "this report"]
