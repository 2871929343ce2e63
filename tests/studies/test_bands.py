"""The bands' machinery (pinclear.studies.reproduce.bands): the one-at-a-time points and the Latin
hypercube, the screen's rule (an input matters past tau/2), the store that lets a report's bands
be built over several sittings, and the budget that stops cleanly and says what it left."""
import json

import numpy as np
import pytest

from pinclear.studies.reproduce import bands
from pinclear.studies.reproduce.verdicts import row

INPUTS = [{"name": "x", "key": "x", "nominal": 0.5, "range": [0.0, 1.0], "reason": "r"},
          {"name": "y", "key": "y", "nominal": 0.0, "range": [-1.0, 1.0], "reason": "r"},
          {"name": "form", "key": "form", "nominal": "a", "choices": ["a", "b"], "reason": "r"}]
TAUS = {"f": 0.2, "kind": 0.0}


def model(values):
    """f moves by 1.0 over x's range (5 tau), by 0.06 over y's (0.3 tau: does not matter); the
    kind changes with x past 0.9 and never with y or form; form moves f by 0.08 (0.4 tau)."""
    x, y = float(values.get("x", 0.5)), float(values["y"])
    return {"f": x + 0.03 * y + (0.08 if values["form"] == "b" else 0.0),
            "kind": "qp" if x > 0.9 else "p1", "status": "success"}


class Fixed(bands._Timed):
    """The point function at a fixed cost of 10 CPU s a point (a deterministic budget)."""

    calls = 0

    def __call__(self, values):
        Fixed.calls += 1
        return self.fn(values), 10.0


def test_one_at_a_time_and_latin_hypercube():
    pts = bands.one_at_a_time(INPUTS)
    assert pts[0][:2] == ("nominal", None) and len(pts) == 1 + 2 + 2 + 1
    for label, name, v in pts[1:]:
        moved = [k for k in v if v[k] != {e["key"]: e["nominal"] for e in INPUTS}[k]]
        assert moved == [name]
    lhs = bands.latin_hypercube(INPUTS, ["x", "y"], 8, seed=3)
    for e in INPUTS[:2]:
        lo, hi = e["range"]
        u = np.sort([(p[e["key"]] - lo) / (hi - lo) for _, p in lhs])
        assert np.all(np.floor(u * 8) == np.arange(8))        # one point in each 1/8 slice
    assert all(p["form"] == "a" for _, p in lhs)               # not among the names: nominal


def test_screen_marks_the_inputs_that_move_a_row_past_half_tau():
    oat = bands.one_at_a_time(INPUTS)
    res = {lb: model(v) for lb, _, v in oat}
    matters, table = bands.screen(res, oat, ["f", "kind"], TAUS)
    assert matters["f"] == ["x"]                      # 2.5 tau either end; y 0.15 tau, form 0.4 tau
    assert matters["kind"] == ["x"]                   # x = 1 gives 'qp'
    cells = dict(zip(table["columns"], table["rows"][0]))
    assert cells["x"] == "2.5 *" and cells["y"] == "0.15" and cells["form"] == "0.4"


def test_bands_cover_the_model_and_resume_without_rerunning(tmp_path, monkeypatch):
    monkeypatch.setattr(bands, "_Timed", Fixed)
    Fixed.calls = 0
    store = bands.PointStore(tmp_path, "T", {"band": {"n": 1}})
    got, table, ledger = bands.measure_bands(model, INPUTS, ["f", "kind"], TAUS, store, n_lhs=4)
    # f's band over x's ends and the space-filling points: 0 .. 1 plus y's and form's small parts
    lo, hi, what = got["f"]
    assert lo == pytest.approx(0.0, abs=0.03 + 0.08) and hi == pytest.approx(1.0, abs=0.03 + 0.08)
    assert lo <= model({"x": 0.0, "y": 0.0, "form": "a"})["f"] and hi >= model({"x": 1.0, "y": 0.0, "form": "a"})["f"]
    assert "over x" in what
    assert got["kind"][0] == ["p1", "qp"]
    n_run = Fixed.calls
    assert ledger["ran"] == n_run == 1 + 2 + 2 + 1 + 4 and ledger["cpu_s"] == 10.0 * n_run
    assert len(list((tmp_path / "bands").glob("*.json"))) == n_run
    # the same command again: every point from the store, nothing run, the same bands
    Fixed.calls = 0
    again, _, led2 = bands.measure_bands(model, INPUTS, ["f", "kind"], TAUS, bands.PointStore(tmp_path, "T", {"band": {"n": 1}}),
                                         n_lhs=4)
    assert Fixed.calls == 0 and led2["resumed"] == n_run and again["f"][:2] == got["f"][:2]
    # other settings: none of the stored points is taken
    Fixed.calls = 0
    bands.measure_bands(model, INPUTS, ["f"], TAUS, bands.PointStore(tmp_path, "T", {"band": {"n": 2}}), n_lhs=0)
    assert Fixed.calls == 1 + 2 + 2 + 1


def test_a_row_no_input_moves_gets_the_sum_of_the_swings(tmp_path):
    inputs = INPUTS[1:]                                # y and form: 0.15 and 0.4 tau
    got, _, _ = bands.measure_bands(model, inputs, ["f"], TAUS, bands.PointStore(None, "T", {}))
    lo, hi, what = got["f"]
    nominal = model({"x": 0.5, "y": 0.0, "form": "a"})["f"]
    assert (lo, hi) == pytest.approx((nominal - 0.03 - 0.08, nominal + 0.03 + 0.08))
    assert "no input moves it" in what


def test_budget_stops_cleanly_and_the_rows_say_what_it_left(tmp_path, monkeypatch):
    monkeypatch.setattr(bands, "_Timed", Fixed)
    store = bands.PointStore(tmp_path, "T", {"band": {}})
    # 6 screen points at 10 CPU s fit in 60; the band's space-filling points do not
    got, table, ledger = bands.measure_bands(model, INPUTS, ["f", "kind"], TAUS, store, budget=65.0, n_lhs=4)
    assert ledger["ran"] == 6 and ledger["not_reached"] == 4 and ledger["needs_cpu_s"] == pytest.approx(40.0)
    assert table is not None                          # the screen finished
    miss = got["f"]
    assert isinstance(miss, bands.NotReached) and miss.cpu_s == pytest.approx(40.0)
    band, frm, need = bands.band_of(got, "f", 0.5)
    r = row("f", "force span", 0.5, 0.5, "N", band=band, band_from=frm, cpu_s=need)
    assert r["verdict"] == "not measured" and r["cpu_needed_s"] == pytest.approx(40.0) and "40 s" in r["why"]
    assert "4 points not reached" in bands.ledger_text(ledger)
    # a budget too small for the screen: every row not measured, nothing lost
    got2, table2, _ = bands.measure_bands(model, INPUTS, ["f"], TAUS, bands.PointStore(tmp_path / "b", "T", {}),
                                          budget=15.0)
    assert table2 is None and isinstance(got2["f"], bands.NotReached)
    # the next sitting resumes the first run's points and runs only what was left
    Fixed.calls = 0
    done, _, led = bands.measure_bands(model, INPUTS, ["f", "kind"], TAUS, store, n_lhs=4)
    assert Fixed.calls == 4 and led["resumed"] == 6 and isinstance(done["f"], tuple)


@pytest.mark.parametrize("tamper", ["identity", "result", "cpu", "garbage"])
def test_a_stored_point_that_is_not_this_one_is_never_taken(tmp_path, tamper):
    store = bands.PointStore(tmp_path, "T", {"band": {"n": 1}})
    values = {"x": 0.5}
    store.put("band", values, {"f": 1.0}, 3.0)
    assert store.get("band", values) == ({"f": 1.0}, 3.0)
    path = next((tmp_path / "bands").glob("*.json"))
    doc = json.loads(path.read_text())
    if tamper == "identity":
        doc["identity"]["values"]["x"] = 0.7              # another point's result under this name
    elif tamper == "result":
        doc["result"] = [1, 2]
    elif tamper == "cpu":
        doc["cpu_s"] = -1.0
    path.write_text("not json {" if tamper == "garbage" else json.dumps(doc))
    assert store.get("band", values) is None and store.foreign == 1


def test_a_row_the_band_misses_names_its_lever_and_the_value_it_needs(tmp_path):
    """f = x + 0.03 y (+0.08 for form b): a paper value of 1.4 lies 1.5 tau above the band (x at most
    1): the lever is x, and it would need x = 1.4 (extrapolated beyond [0, 1]); 0.25 lies inside x's
    sampled points: interpolated; a kind no input gives is said to be out of reach; a value within tau
    of the band gets no lever."""
    papers = {"f": 1.4, "kind": "chaos"}
    got, _, led = bands.measure_bands(model, INPUTS, ["f", "kind"], TAUS, bands.PointStore(None, "T", {}), n_lhs=0,
                                      papers=papers)
    lv = led["levers"]["f"]
    assert lv["lever"] == "x" and lv["how"] == "extrapolated" and lv["needed"] == pytest.approx(1.4)
    assert "lever: x" in got["f"][2] and "would need 1.4" in got["f"][2]
    assert "no single input reaches chaos" in led["levers"]["kind"]["text"]
    oat = bands.one_at_a_time(INPUTS)
    res = {lb: model(v) for lb, _, v in oat}
    inside = bands.lever(INPUTS, oat, res, "f", 0.25, 0.2)
    assert inside["how"] == "interpolated" and inside["needed"] == pytest.approx(0.25)
    _, _, led2 = bands.measure_bands(model, INPUTS, ["f"], TAUS, bands.PointStore(None, "T", {}), n_lhs=0,
                                     papers={"f": 1.15})
    assert led2["levers"] == {}
    fig = bands.tornado_figure(led["levers"], led["nominal"], TAUS, papers, tmp_path)
    assert fig == "tornado.png" and (tmp_path / fig).stat().st_size > 1000


def test_a_short_screen_does_not_screen_a_kind_of_motion():
    """The screen's short runs see period-1 everywhere; the study's runs change kind with x: the
    kind's band must still vary every input (and so find 'qp'), while f keeps the screen's rule."""
    def short(values):
        return dict(model(values), kind="p1")

    got, table, _ = bands.measure_bands(model, INPUTS, ["f", "kind"], TAUS, bands.PointStore(None, "T", {}), n_lhs=0,
                                        screen_fn=short)
    assert got["kind"][0] == ["p1", "qp"] and "over x, y, form" in got["kind"][1]
    assert "over x " in got["f"][2] and "short run" in table["note"]
