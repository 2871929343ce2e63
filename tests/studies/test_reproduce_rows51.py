"""The reports' rows that say one thing each (issue 51): each rule on hand-made inputs whose class
is known, so a rule that drifts fails here before it reaches a report."""
from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

from pinclear.studies.reproduce import paper000, paper002, paper003


# ------------------------------------------------------------------------------------ 002
def test_spread_ordering_is_decided_only_beyond_the_sampling_error():
    # the committed 1 mm spreads: 0.0204 vs 0.0195 m/s over 100 points, 4.6 % apart; the standard error of
    # ln(s) is 1/sqrt(2 x 99) = 7.1 % each, 10 % for the difference: the statistic cannot tell them apart
    assert paper002.spread_order(0.0204, 0.0195, 100) == ["A", "B"]
    # 30 % apart is 2.6 standard errors of the difference: decided, either way round
    assert paper002.spread_order(0.026, 0.020, 100) == "A"
    assert paper002.spread_order(0.020, 0.026, 100) == "B"
    # the threshold is 2 standard errors: just inside and just outside
    se = math.sqrt(2.0) / math.sqrt(2.0 * 99)
    assert paper002.spread_order(math.exp(1.99 * se), 1.0, 100) == ["A", "B"]
    assert paper002.spread_order(math.exp(2.01 * se), 1.0, 100) == "A"
    # more points resolve a smaller difference
    assert paper002.spread_order(0.0204, 0.0195, 10_000) == "A"


def test_a_decided_ordering_is_stored_as_its_label_not_its_letters():
    """A decided spread_order is a label string; sorting it (the bug the sixth sitting found) stored
    'wider at 3 pi' as its 13 sorted characters, which then matches no nominal answer."""
    labels = ("wider at 3 pi", "not wider at 3 pi")
    assert paper002._order_text(paper002.spread_order(0.026, 0.020, 100, labels=labels)) == "wider at 3 pi"
    assert paper002._order_text(paper002.spread_order(0.020, 0.026, 100, labels=labels)) == "not wider at 3 pi"
    assert paper002._order_text(paper002.spread_order(0.0204, 0.0195, 100, labels=labels)) == \
        "not wider at 3 pi, wider at 3 pi"
    assert paper002._order_text(paper002.spread_order(0.026, 0.020, 100)) == "A"


_ORDER_ANSWERS = {"stronger": {"A", "B", "A, B"},
                  "wider at 3 pi": {"wider at 3 pi", "not wider at 3 pi", "not wider at 3 pi, wider at 3 pi"}}


def test_the_stored_band_points_hold_readable_orderings():
    """Every stored paper-002 point (docs/reproduce/002/bands) answers each ordering row with one of its
    answers: a garbled field would count as a band point that disagrees with the nominal."""
    import json
    from pathlib import Path
    files = sorted((Path(__file__).resolve().parents[2] / "docs/reproduce/002/bands").glob("*.json"))
    assert files
    for f in files:
        res = json.loads(f.read_text())["result"]
        for key, answers in _ORDER_ANSWERS.items():
            if key in res:
                assert res[key] in answers, (f.name, key, res[key])


@pytest.mark.parametrize("quick", [True, False])
def test_the_papers_named_values_are_in_the_committed_settings(quick):
    """Sec. 4 names 0.01 / 0.8 mm and 2 pi / 3 pi rad/s: both run and each always gets a Lyapunov estimate."""
    s = paper002._settings(quick)
    assert 3.0 in s["lyapunov at speeds [pi rad/s]"] and 2.0 in s["lyapunov at speeds [pi rad/s]"]
    assert s["lyapunov at clearances [mm]"] == [0.01, 0.8]
    assert any(abs(v - 3.0) < 1e-9 for v in s["speeds [pi rad/s]"])
    assert any(abs(v - 2.0) < 1e-9 for v in s["speeds [pi rad/s]"])


def _claim_rows(b, ab):
    return paper002._claim_rows({"B 0.5": {"B impact force peak [N]": b}, "AB 0.5": {"B impact force peak [N]": ab}})


def test_one_vs_two_clearances_row_says_which_way_ours_goes():
    (r,) = _claim_rows(988.1, 1298.0)
    assert r["ours"] == "stronger with A and B" and r["paper"] == "weaker with A and B"
    assert r["nominal_verdict"] == "contradicted" and "988.1 -> 1298 N" in r["why"]
    (r,) = _claim_rows(581.0, 330.0)
    assert r["nominal_verdict"] == "reproduced"


def test_002_claims_list_every_claim_once():
    rows = _claim_rows(988.1, 1298.0)
    got = paper002.claims(rows)
    assert [c["key"] for c in got] == list(paper002.CLAIMS)
    number = next(c for c in got if c["key"] == "002-number")
    assert number["rows"] == [rows[0]["name"]] and number["verdict"] == "not measured"
    # a claim none of whose rows ran says so, it is not silently reproduced
    assert next(c for c in got if c["key"] == "002-trend")["verdict"] == "not comparable"


# ------------------------------------------------------------------------------------ 003
def test_trend_counts_steps_within_the_tolerance_as_flat():
    assert paper003.trend([2.2, 3.3, 5.4], 0.10) == "rises"
    assert paper003.trend([0.01538, 0.01536, 0.01533], 0.10) == "flat"
    assert paper003.trend([0.0028, 0.0025, 0.0021], 0.10) == "falls"
    assert paper003.trend([1.0, 1.5, 1.2], 0.10) == "mixed"       # up beyond, then down beyond the tolerance
    assert paper003.trend([1.0, 1.05, 1.3], 0.10) == "rises"      # a flat step does not break a rise
    assert paper003.trend([1.0, 1.3, 1.05], 0.10) == "mixed"      # ends within, a step beyond


def _resp(z_dev, vz=0.003, az=0.4, f=600.0):
    return {"z_dev": z_dev, "vz_amp": vz, "az_amp": az, "F_max": 10 * f, "F_max_settled": f}


def _settings003():
    return {"clearances": (1e-4, 2e-4, 3e-4), "mus": (0.02, 0.05, 0.08), "models": ("energy", "paper003"),
            "fig8_clearance": 0.0, "settle": 0.05}


def test_fig9_rows_compare_deviation_per_clearance_times_any_plausible_gap():
    """Deviation / clearance 0.15 (and 0.45 at the geometry band's end) reaches at most 0.45 mm at a 1 mm gap:
    the paper's 1.6 / 3.3 / 5.4 mm are contradicted, each with the gap it would need."""
    s = _settings003()
    rc = {(str([c, c]), m): _resp(0.15 * c) for c in s["clearances"] for m in s["models"]}
    factors = {"dev": (0.5, 3.0), "vel": (1.0, 1.0), "acc": (1.0, 1.0), "what": "test geometry"}
    rows = paper003.fig9_rows(rc, s, factors, list(s["models"]), "energy")
    dev = [r for r in rows if r["name"].startswith("platform Z deviation, Fig. 9")]
    assert len(dev) == 3
    for r, paper in zip(dev, (1.6, 3.3, 5.4)):
        assert r["band"][1] == pytest.approx(0.45 * 1e3 * paper003.GAP_MAX)        # mm
        assert r["verdict"] == "contradicted" and r["paper"] == paper
        assert f"needs a gap of at least {paper / 0.45:.3g} mm" in r["why"]
    # a gap that reaches the paper is not contradicted: deviation / clearance 5 -> 5 mm at 1 mm
    rc5 = {k: _resp(5.0 * float(k[0].strip("[]").split(",")[0])) for k in rc}
    first = paper003.fig9_rows(rc5, s, None, list(s["models"]), "energy")[0]
    assert first["verdict"] != "contradicted"
    assert {r["verdict"] for r in rows if "velocity" in r["name"] or "acceleration" in r["name"]} == {"not comparable"}
    assert [r["paper"] for r in rows if "acceleration" in r["name"]] == list(paper003.PAPER_CLEARANCE_ACC)


def test_mu_trend_rows_contradict_a_flat_and_a_falling_ours():
    s = _settings003()
    law = {mu: paper003.friction_law(mu) for mu in s["mus"]}
    vals = {0.02: (0.01538, 0.0028, 700.0), 0.05: (0.01536, 0.0025, 650.0), 0.08: (0.01533, 0.0021, 560.0)}
    rf = {(str(law[mu]), m): _resp(1e-3 * z, v, 0.4, f) for mu, (z, v, f) in vals.items() for m in s["models"]}
    rows = paper003.trend_rows({"friction": rf}, s)
    ours = {r["name"].split(" against")[0]: r for r in rows}
    assert ours["Z deviation"]["ours"] == "flat" and ours["Z vibration (velocity amplitude)"]["ours"] == "falls"
    assert ours["contact force after the first landing"]["ours"] == "falls"
    assert all(r["paper"] == "rises" and r["verdict"] == "contradicted" for r in rows)   # both models agree


# ------------------------------------------------------------------------------------ 000
def _kind(k):
    return SimpleNamespace(kind=k, K=None, note="")


def test_000_platform_rows_say_what_the_paper_says_and_the_window_is_one_row():
    Y, Z = "S2.eccentricity[1]", "platform.z"
    kinds = {"mu": {0.01: {Y: _kind("period-1"), Z: _kind("period-1")},
                    0.02: {Y: _kind("below resolution"), Z: _kind("period-1")},
                    0.05: {Y: _kind("quasi-periodic"), Z: _kind("period-1")}},
             "clearance": {5e-4: {Y: _kind("quasi-periodic"), Z: _kind("period-1")}},
             "sens": {"v": {Y: _kind("period-1")}}}
    bif = {"clearance": SimpleNamespace(runs=[])}
    rows = {r["name"]: r for r in paper000.chaos_rows(bif, kinds, {}, None, load=(91.0, 13.0))}
    (window,) = [r for n, r in rows.items() if "chaos window" in n]
    assert window["ours"] == "below resolution, period-1" and window["verdict"] == "contradicted"
    assert "stays above 91 N (response windows) against +-13 N" in window["why"] and "mu 0.01, 0.02" in window["why"]
    (small,) = [r for n, r in rows.items() if n.startswith("platform Z motion at mu 0.01")]
    assert small["paper"] == "quasi-periodic" and small["nominal_verdict"] == "contradicted"
    (rest,) = [r for n, r in rows.items() if n.startswith("platform Z motion, mu above")]
    assert rest["paper"] == "period-1" and rest["nominal_verdict"] == "reproduced"
    claims = {c["key"]: c for c in paper000.claims(list(rows.values()))}
    assert set(claims) == set(paper000.CLAIMS)
    assert claims["000-clearance-chaos"]["verdict"] == "contradicted"


def test_needed_value_follows_the_power_law_and_says_when_it_extrapolates():
    # k = 0.045 / l (deviation / clearance against the slider length, the kinematic bound's form)
    ls = [0.15, 0.3, 0.6]
    ks = [0.045 / x for x in ls]
    x, how = paper003.needed_value(ls, ks, 0.2)
    assert x == pytest.approx(0.225) and how == "interpolated"
    x, how = paper003.needed_value(ls, ks, 10.0)
    assert x == pytest.approx(0.0045) and how == "extrapolated"
    assert paper003.needed_value(ls, [0.15, 0.15, 0.15], 10.0) is None      # an input that moves nothing


def test_lever_form_draws_the_tornado_and_names_the_needed_values(tmp_path):
    zg = paper003.mod.GUIDE_Z0 + paper003.mod.GUIDE_LEN / 2
    length = {"title": "slider length (reconstructed; sidecar 0.3 m) ...", "columns": [
        "slider length [m]", "Z deviation [um]", "deviation / clearance", "v", "F"],
        "rows": [[L, 15.0 * 0.3 / L, 0.15 * 0.3 / L, 0.0, 0.0] for L in (0.15, 0.3, 0.6)]}
    lever = {"title": "lever arm: ...", "columns": ["guide", "Z deviation [um]", "deviation / clearance", "v"],
             "rows": [[zg + sh, 0.0, 0.15 * (zg + sh) / zg, 0.0] for sh in (-0.15, 0.0, 0.45)]}
    models = {"columns": ["run", "model", "Z deviation [um]", "deviation / clearance"],
              "rows": [["clearance 0.1 mm, mu_d 0.16", m, 0.0, k] for m, k in (("energy", 0.15), ("paper003", 0.12))]}
    got = paper003.lever_form([length, lever], models, tmp_path)
    assert (tmp_path / "levers.png").stat().st_size > 5_000
    by = {(r[0], r[3]): r for r in got["levers"]}
    # Fig. 8's 10 clearances need a slider 0.045 / 10 = 4.5 mm long: far outside 0.15-0.6 m
    r = by[("slider length [m]", "Fig. 8")]
    assert r[5] == "0.0045 (extrapolated)" and r[6] == "0.15-0.6"
    # and a lever arm 10 / 0.15 = 67 times the reconstructed one
    r = by[("guide centre above the base U joint [m]", "Fig. 8")]
    assert float(r[5].split()[0]) == pytest.approx(zg * 10.0 / 0.15, rel=1e-6) and "extrapolated" in r[5]


def test_000_x_offset_is_undecided_when_the_papers_reading_decides():
    from pinclear.studies.reproduce.verdicts import row

    base = row("x", "platform deviation", 0.086, 0.1, "mm", printed="0.1")
    # mean -14 % (0.3 tau) but max +70 % (1.4 tau): the unstated reading decides
    r = paper000.offset_reading(base, 0.17)
    assert r["verdict"] == "undecided" and "decides" in r["why"] and "+70 %, 1.4 tau" in r["why"]
    # both readings within tau: the row keeps its class (not measured without a band)
    r = paper000.offset_reading(base, 0.12)
    assert r["verdict"] == "not measured" and "decides" not in r["why"]


def test_transient_notes_check_every_finished_run_of_both_signals():
    """Each finished run's clearance Y and platform Z sections are classified again with half the
    recorded cycles (at most 20) more transient left out; failed runs and sections too short for
    that are not counted. A start-up the classifier already recognises keeps its class."""
    import numpy as np

    from pinclear.analysis.poincare import PoincareSection

    def section(x):
        x = np.asarray(x, float)
        k = np.arange(len(x))
        return PoincareSection(k=k, t=2.0 * k, x=x, xdot=np.zeros_like(x), period=2.0, phase=0.0, label="y",
                               interpolated=np.zeros(len(x), bool))

    n = 10
    clean = 1e-3 + np.zeros(n)
    start = 1e-3 + np.r_[np.array([4e-5, -3e-5, 2e-5, -1e-5, 5e-6]), np.zeros(n - 5)]
    runs = [SimpleNamespace(ok=True, value=v, stats={}, sections={"S2.eccentricity[1]": section(x),
                                                                  "platform.z": section(clean)})
            for v, x in ((0.01, clean), (0.05, start))]
    runs.append(SimpleNamespace(ok=False, value=0.1, stats={}, sections={}))
    runs.append(SimpleNamespace(ok=True, value=0.2, stats={}, sections={"platform.z": section(clean[:4])}))
    bif = {"mu": SimpleNamespace(runs=runs), "clearance": SimpleNamespace(runs=[])}
    s = {"cycles": n, "transient": 3, "clearance": 5e-4}
    mu_note, c_note = paper000.transient_notes(bif, s)
    assert mu_note.startswith("mu diagram, 3 vs 8 transient periods: transient check (+5 periods)")
    assert mu_note.endswith("4 of 4 keep their class")
    assert c_note.endswith("no transient check")
