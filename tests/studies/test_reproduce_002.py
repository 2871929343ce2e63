"""pinclear reproduce 002 (nine-bar, revolute clearances at A and B): a much reduced study (0.3 s of
response, two turns per bifurcation value) checked for its report and against two independent
references: the closed-form position analysis of the ideal linkage (nine_bar.positions, eq. 15
alone, no Pinocchio) and the Hertz bound on the journal's excursion beyond the clearance."""
from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

import pinclear.studies.reproduce.paper002 as p002
from pinclear.mechanisms import nine_bar
from pinclear.studies.reproduce import reproduce

T_RESP = 0.3
TINY = {"response t_end [s]": T_RESP, "clearances [mm]": [0.01, 0.8], "speeds [pi rad/s]": [2.0, 3.0],
        "cycles": 1, "transient cycles": 0, "long cycles": 1}


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    import pinclear.studies.reproduce.paper002 as p002

    out = tmp_path_factory.mktemp("r002")
    orig = p002._settings
    p002._settings = lambda quick: {**orig(quick), **TINY}
    try:
        rep = reproduce("002", out, quick=True, workers=1)
    finally:
        p002._settings = orig
    return out, rep


@pytest.mark.slow
def test_report_files_and_keys(report):
    out, rep = report
    doc = json.loads((out / "report.json").read_text())
    assert {"title", "paper", "settings", "results", "notes", "figures", "tables"} <= set(doc)
    assert doc["paper"] == "002" and doc["settings"]["cycles"] == 1
    assert set(doc["tables"]) == {"response", "clearance", "speed"}
    # every printed number of sec. 3 has a row with the paper's value beside ours and a reason (its group's)
    papers = {r["paper"] for r in doc["results"]}
    assert {0.115, 0.616, 0.653, 0.512, 289.0, 581.0, 124.0, 330.0, 76.2, 90.7} <= papers
    assert all(r["group"] in doc["groups"] for r in doc["results"])
    # the reconstructed linkage's own kinematics and the start-up landings are not the paper's quantities
    by = {r["name"]: r for r in doc["results"]}
    assert all(r["verdict"] == "not comparable" for r in doc["results"] if r["group"] in ("linkage", "startup"))
    assert by["A 0.5 mm impact force peak (paper at 0.018 s), ours over the run"]["band_from"]   # sensitivity runs
    assert by["the joint with the stronger chaos (larger Poincaré velocity spread at 0.8 mm)"]["paper"] == "A"
    # the bifurcation tables carry the paper's named values (0.01 and 0.8 mm; 2 pi and 3 pi)
    assert [round(r["clearance [mm]"], 6) for r in doc["tables"]["clearance"]] == [0.01, 0.8]
    assert [round(r["speed [pi rad/s]"], 6) for r in doc["tables"]["speed"]] == [2.0, 3.0]
    assert all(r["status"] == "success" for t in ("clearance", "speed") for r in doc["tables"][t])
    assert any("0.01 mm, mu 0.3: paper quasi-periodic" in n for n in doc["notes"])
    for f in doc["figures"]:
        assert (out / f).stat().st_size > 10_000
    md = (out / "report.md").read_text()
    assert "| AB impact force peak at B (paper at 0.034 s), ours over the run |" in md
    assert "![bifurcation_clearance.png]" in md
    assert (out / "report.html").read_text().count("data:image/png;base64,") == len(doc["figures"])
    # the measured sensitivity: journal radius x K form (3 x 2 runs) and the longer 0.01 mm run
    radius, start, long = doc["sensitivity"]
    # the start-eccentricity table: the centred run, then one run per direction whose assembled
    # start lies START_E off centre (assembly error ~ second order in 0.25 mm over ~0.1 m links)
    assert start["rows"][0][0].startswith("centred") and len(start["rows"]) == 1 + len(p002.START_ANGLES)
    for r, a in zip(start["rows"][1:], p002.START_ANGLES):
        assert abs(r[1] - 1e3 * p002.START_E) < 0.01 * 1e3 * p002.START_E
        assert abs((r[2] - math.degrees(a) + 180) % 360 - 180) < 1.0
        assert r[3] == "success" and r[4] > 0
    assert sorted((r[0], r[1]) for r in radius["rows"]) == sorted(
        (1e3 * a, k) for a in p002.SENS_RADII for k in p002.SENS_K)
    assert all(r[2] == "success" and r[3] > 0 for r in radius["rows"])
    assert [r[0] for r in long["rows"]] == ["A", "B"] and "## Sensitivity" in md and "docs/papers.md" in md
    # the claims table opens the report, one line per claim of paper002.CLAIMS; the one-vs-two claim is
    # decided by its ordering row
    assert [c["key"] for c in doc["claims"]] == list(p002.CLAIMS) and md.index("## The paper's claims") < md.index(
        "## Compared numbers")
    number = next(c for c in doc["claims"] if c["key"] == "002-number")
    assert number["rows"] == ["impact at B, one (B) vs two clearances (paper: 581 -> 330 N)"]


def test_ideal_slider_matches_the_closed_form_position_analysis(report):
    """Our ideal run's slider stroke against eq. 15 solved in closed form at the same instants.
    Error bound: the run's global error, at most (steps ~ 50/s) x rtol 1e-6 x |q| (~ 2 pi) per
    second times levers below 1 m, about 1e-4 m over 0.3 s; the output grid (2e-5 s) is the
    same on both sides."""
    _, rep = report
    t = np.arange(0.0, T_RESP + 1e-12, rep["settings"]["output step [s]"])
    x = np.array([nine_bar.positions(nine_bar.THETA1_0 + nine_bar.OMEGA1 * ti,
                                     nine_bar.THETA4_0 + nine_bar.OMEGA4 * ti)["points"]["F"][0] for ti in t])
    d = x - x[0]
    i = int(np.argmax(np.abs(d)))
    row = rep["tables"]["response"]["ideal"]
    assert abs(row["displacement peak [m]"] - abs(d[i])) < 1e-4
    assert abs(row["at [s]"] - t[i]) <= 2 * rep["settings"]["output step [s]"] + 1e-12
    assert abs(d[i]) > 0.03                       # a real stroke, not a run that did not move


def test_journal_stays_within_clearance_plus_hertz_penetration(report):
    """At the deepest point of an impact the penetration rate is zero, so the contact force
    there is the elastic part K delta^1.5 alone: delta_max <= (F_peak / K)^(2/3), with K of
    eq. 8 as printed (R_eff = R1 R2 / (R1 + R2)) for steel (E = 207 GPa, nu = 0.3), journal
    10 mm in a 10.5 mm bearing. The eccentricity must stay within c + delta_max (5 % slack on
    delta for the sampled force peak) and must reach the clearance (the journal does hit)."""
    _, rep = report
    E, nu, Rj = 207e9, 0.3, 0.010
    for key, row in rep["tables"]["response"].items():
        if key == "ideal":
            continue
        c = float(key.split()[1]) * 1e-3
        Rb = Rj + c
        K = 4.0 / 3.0 * E / (2 * (1 - nu ** 2)) * math.sqrt(Rj * Rb / (Rj + Rb))
        for j in ("A", "B"):
            if f"{j} impact force peak [N]" not in row:
                continue
            dmax = (row[f"{j} impact force peak [N]"] / K) ** (2 / 3)
            ecc = row[f"{j} max eccentricity [m]"]
            assert c < ecc <= c + 1.05 * dmax, (key, j, ecc, c, dmax)
        assert row["max |x - x_ideal| [m]"] > 0            # the play does change the slider's motion


def test_cli_takes_workers_and_scheduler(tmp_path, capsys):
    from pinclear.cli.reproduce import cli_main

    r = subprocess.run([sys.executable, "-m", "pinclear.cli", "reproduce", "002", "--workers", "0", "--out",
                        str(tmp_path)], capture_output=True, text=True, timeout=120)
    assert r.returncode == 2 and "--workers must be a positive number" in r.stderr
    with pytest.raises(SystemExit) as exc:
        cli_main(["--help"])
    assert exc.value.code == 0
    usage = capsys.readouterr().out
    assert "--scheduler ADDRESS" in usage and "--workers" in usage and "002" in usage


def test_bands_screen_store_and_follow_hertz_scaling(tmp_path):
    """--bands for sec. 3 (0.6 s runs here, no sec. 4 kinds): the screen runs every input one at a
    time (1 + 2 per numeric input whose nominal is not an end + 1 per other end or choice = 13),
    each point stored under OUT/bands; every band holds the nominal point's value; the journal
    radius moves the first impact the way K ~ sqrt(R_eff) says (a larger journal, a stiffer
    contact, a larger peak), and heavier links hit harder (F ~ m^0.6)."""
    import json

    s = {**p002._settings(True), "response t_end [s]": 0.6, "output step [s]": 1e-3, "cycles": 0}
    got, tables, ledger = p002.paper002_bands(tmp_path, s, "serial")
    pts = [json.loads(f.read_text()) for f in (tmp_path / "bands").glob("band-*.json")]
    assert ledger["ran"] >= 13 and ledger["not_reached"] == 0 and len(pts) == ledger["ran"]
    nominal = {e["key"]: e["nominal"] for e in p002.reconstructed_inputs("002")}

    def at(key, value):
        want = {**nominal, key: value}
        return next(p["result"] for p in pts if p["identity"]["values"] == want)

    pk = "A 0.5 mm impact force peak"
    lo, hi, what = got[pk]
    assert lo <= at("{j}.radius", 0.01)[pk] <= hi
    assert at("{j}.radius", 0.005)[pk] < at("{j}.radius", 0.01)[pk] < at("{j}.radius", 0.02)[pk]
    assert at("mass:links", 0.67)[pk] < at("mass:links", 1.5)[pk]
    assert tables and tables[0]["columns"][0] == "row"
    # the same call again resumes every point
    _, _, again = p002.paper002_bands(tmp_path, s, "serial")
    assert again["ran"] == 0 and again["resumed"] == ledger["ran"]
