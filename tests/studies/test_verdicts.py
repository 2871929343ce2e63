"""The classes of a reproduction's rows (pinclear.studies.reproduce.verdicts), on hand-made cases of each."""
from __future__ import annotations

import pytest

from pinclear.core.errors import InputError
from pinclear.studies.reproduce import verdicts as v


def test_each_class_on_a_hand_made_case():
    # tau = max(reading precision, 5 % of 100) = 5 for a load force of 100
    kw = dict(quantity="load force", paper=100.0, unit="N", band_from="ranges of reconstructed.yaml")
    assert v.row("a", ours=101.0, band=(98.0, 104.0), **kw)["verdict"] == "reproduced"       # width 6 <= 10
    assert v.row("b", ours=101.0, band=(80.0, 130.0), **kw)["verdict"] == "undecided"        # width 50 > 10
    assert v.row("c", ours=120.0, band=(110.0, 130.0), **kw)["verdict"] == "contradicted"    # gap 10 > 5
    assert v.row("d", ours=120.0, band=(104.0, 130.0), **kw)["verdict"] == "undecided"       # gap 4 <= 5, wide
    assert v.row("e", ours=106.0, band=(105.0, 106.0), **kw)["verdict"] == "reproduced"      # gap 5 = tau
    assert v.row("f", ours=101.0, band=(98.0, 104.0), status="calibration", **kw)["verdict"] == "calibration"
    assert v.row("g", ours=1.0, status="not comparable", **kw)["verdict"] == "not comparable"


def test_an_unmeasured_band_neither_reproduces_nor_contradicts():
    r = v.row("x", "load force", 100.0, 100.0, "N")              # exact agreement, nothing varied
    assert r["verdict"] == "not measured" and "band not measured" in r["why"]
    assert v.row("y", "load force", 300.0, 100.0, "N")["verdict"] == "not measured"


def test_reading_precision_widens_tau():
    # 'about 85 N' read to 2.5 N: tau = max(2.5, 5 % of 85 = 4.25) = 4.25; a printed '85' alone: 0.5
    r = v.row("p", "drive force peak", 90.0, 85.0, "N", band_from="exact", reading=2.5)
    assert r["tau"] == pytest.approx(4.25) and r["verdict"] == "contradicted"
    r = v.row("q", "force ratio", 25.0, 24.47, band_from="exact", reading=0.72)
    assert r["tau"] == pytest.approx(0.72) and r["verdict"] == "reproduced"
    assert v.half_digit("122.5") == 0.05 and v.half_digit("2 080") == 0.5 and v.half_digit("0.616") == 0.0005


def test_categorical_rows():
    kw = dict(quantity="motion kind", band_from="8 variants")
    assert v.row("k1", ours="period-1", band=["period-1"], paper="chaotic", **kw)["verdict"] == "contradicted"
    assert v.row("k2", ours="chaotic", band=["chaotic"], paper="chaotic", **kw)["verdict"] == "reproduced"
    assert v.row("k3", ours="chaotic", band=["chaotic", "period-1"], paper="chaotic", **kw)["verdict"] == "undecided"
    # 'irregular' (0-1 test without a confirmed Lyapunov exponent) can neither reproduce nor contradict chaos
    assert v.row("k4", ours="irregular", band=["irregular"], paper="chaotic", **kw)["verdict"] == "undecided"
    assert v.row("k5", ours="irregular", band=["irregular", "period-1"], paper="quasi-periodic",
                 **kw)["verdict"] == "contradicted"


def test_counts_list_every_class_and_the_table_is_checked():
    rows = [v.row("a", "load force", 100.0, 100.0, band=(99, 101), band_from="x"),
            v.row("b", "load force", 100.0, 100.0, status="calibration")]
    assert v.counts(rows) == {"calibration": 1, "not comparable": 0, "contradicted": 0, "reproduced": 1,
                              "undecided": 0, "not measured": 0}
    assert v.summary(rows).startswith("1 calibration, 1 reproduced")
    with pytest.raises(InputError, match="load force"):
        v.row("z", "load forces", 1.0, 1.0)
    with pytest.raises(InputError):
        v.row("z", "load force", 1.0, 1.0, status="reproduced")
    # every tolerance states its reason
    assert all(len(why) > 20 and 0 <= tol < 1 for tol, why in v.TOLERANCES.values())


def test_an_unmeasured_band_is_not_measured_and_states_its_cost():
    """Issue 51: 'not measured' is a class of its own, apart from 'undecided' (a measured band too
    wide to decide); it says what measuring would cost."""
    r = v.row("x", "load force", 100.0, 100.0, "N", cpu_s=5400.0)
    assert r["verdict"] == "not measured" and r["cpu_needed_s"] == 5400.0
    assert r["why"].startswith("band not measured (about 90 min CPU, pinclear reproduce --bands)")
    k = v.row("k", "motion kind", "period-1", "chaotic")
    assert k["verdict"] == "not measured" and k["nominal_verdict"] == "contradicted"
    assert v.classify_numeric((1.0, 1.0), 1.0, 0.1, False) == "not measured"
    assert v.classify_kind(["chaotic"], "chaotic", False) == "not measured"
    # a measured band too wide stays undecided
    assert v.row("w", "load force", 100.0, 100.0, band=(50.0, 150.0), band_from="x")["verdict"] == "undecided"
    assert v.counts([r, k])["not measured"] == 2 and v.CLASSES[-1] == "not measured"


def test_every_row_prints_its_nominal_verdict():
    # ours 313 vs 100: +213 %; tau = 10 % of 100 = 10 -> 21 tau
    r = v.row("p", "impact peak", 313.0, 100.0, "N")
    assert r["nominal"] == "+213 %, 21 τ at nominal" and r["nominal_verdict"] == "contradicted"
    # within tau at nominal, whatever the (wide) band says: 102 vs 100 with tau 5
    r = v.row("q", "load force", 102.0, 100.0, "N", band=(60.0, 140.0), band_from="x")
    assert r["nominal"] == "+2.0 %, 0.4 τ at nominal" and r["nominal_verdict"] == "reproduced"
    assert r["verdict"] == "undecided"
    # calibration rows carry it too (it is never counted)
    r = v.row("c", "load force", 90.0, 100.0, "N", status="calibration")
    assert r["nominal"] == "-10 %, 2.0 τ at nominal" and r["verdict"] == "calibration"
    # a zero paper value: the difference in the row's unit
    r = v.row("z", "platform deviation", 3.2, 0.0, "mm", reading=2.0)
    assert r["nominal"] == "Δ = 3.2 mm, 1.6 τ at nominal"
    assert v.row("k", "motion kind", ["chaotic", "period-1"], "chaotic", band_from="v")["nominal"] == \
        "chaotic, period-1 at nominal"
