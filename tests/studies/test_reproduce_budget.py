"""Issue 55, the last rows: each report's header states its CPU against the paper's budget (the
stored band points counted at the CPU they took when run), a not-comparable row's band is not a
gap, and Fig. 16's threshold row of paper 000 is banded on the clearances that decide it."""
import numpy as np
import pytest

from pinclear.studies.reproduce import paper000, report
from pinclear.studies.reproduce.bands import NotReached
from pinclear.studies.reproduce.verdicts import row

RUN = {"cpu_self_s": 100.0, "cpu_children_s": 3500.0, "wall_s": 1900.0, "cpus": 2, "commit": "abc",
       "versions": {"pinclear": "0"}, "commands": [["pinclear reproduce 000 --bands", "this report"]]}


def test_the_header_adds_the_stored_band_points_cpu_to_this_runs_against_the_budget():
    led = {"resumed": 10, "ran": 0, "cpu_s": 0.0, "cpu_stored_s": 4000.0, "not_reached": 0, "needs_cpu_s": 0.0}
    # 3600 + 4000 CPU s = 2.11 CPU h against 000's 2 CPU h: over by 5.6 %
    t = report.budget_text("000", RUN, led)
    assert "2.11 CPU h" in t and "against 2 CPU h" in t and "over by 6 %" in t
    # the same run without stored points is 1.00 CPU h: within
    assert "within" in report.budget_text("000", RUN, None)
    # 002's budget is 4 CPU h: 7600 s is within, and the points not reached are named with their CPU
    t = report.budget_text("002", RUN, dict(led, not_reached=3, needs_cpu_s=900.0))
    assert "within" in t and "3 band points not reached need about 900 CPU s" in t and "2.36 CPU h in all" in t
    line = report.run_markdown(RUN, "000", led)[0]
    assert line.index("CPU budget") < line.index("Regenerate")
    assert "CPU budget" not in report.run_markdown(RUN, "999")[0]


def test_a_not_comparable_rows_band_is_not_needed_not_missing():
    r = row("platform Z velocity amplitude", "platform deviation", 0.0027, 0.15, "m/s", status="not comparable",
            why="our quantity is not the paper's")
    assert r["verdict"] == "not comparable"
    assert report.cells(r)[2] == "not needed (not comparable)"
    # a comparable row without a band still reads 'not measured'
    assert report.cells(row("y", "load force", 300.0, 100.0, "N"))[2] == "not measured"


def test_fig16_is_decided_on_the_clearances_within_tau_of_the_papers_and_ours():
    s = paper000._settings(False, None)
    # tau = 10 % of 0.67 mm: 0.65, 0.67 and 0.70 mm of the diagram lie within it; 0.60 and 0.75 do not
    assert paper000.vmax_clearances(s, 9e-4) == pytest.approx([6.5e-4, 6.7e-4, 7e-4, 9e-4])
    assert paper000.vmax_clearances(s, 6.7e-4) == pytest.approx([6.5e-4, 6.7e-4, 7e-4, 9e-4])
    assert paper000.vmax_clearances(s, 4.5e-4) == pytest.approx([4.5e-4, 6.5e-4, 6.7e-4, 7e-4, 9e-4])


def _fake(largest_at):
    calls = []

    def fn(values, s, clearances):
        calls.append(values)
        return {paper000.VMAX_KEY: largest_at(values), "status": "success"}
    return fn, calls


def test_fig16_band_over_every_input_but_c2_resumes_and_names_its_lever(tmp_path, monkeypatch):
    s = paper000._settings(True, None)
    n_inputs = [e for e in paper000.reconstructed_inputs("000") if e["key"] != "S2.clearance"]
    # the nominal, each end of each input that differs from its nominal (the impact-speed floor's
    # nominal is its range's end), 8 space-filling
    n_pts = 1 + sum(v != e["nominal"] for e in n_inputs for v in e.get("choices", e.get("range"))) + 8
    # a small ball moves the largest range onto the paper's 0.67 mm: the band covers the paper's
    fn, calls = _fake(lambda v: 0.67 if float(v["S2.radius"]) < 0.0125 else 0.9)
    monkeypatch.setattr(paper000, "_vmax000", fn)
    band, led = paper000.vmax_band(s, "serial", 9e-4, out=tmp_path)
    assert len(calls) == n_pts and all("S2.clearance" not in v for v in calls)
    assert band[:2] == (0.67, 0.9) and "lever" not in band[2] and led.ran == n_pts
    again, led2 = paper000.vmax_band(s, "serial", 9e-4, out=tmp_path)
    assert len(calls) == n_pts and led2.resumed == n_pts and again[:2] == band[:2]
    # everywhere at the diagram's end: the band misses the paper's by more than tau and says no input reaches it
    fn, _ = _fake(lambda v: 0.9)
    monkeypatch.setattr(paper000, "_vmax000", fn)
    band, _ = paper000.vmax_band(s, "serial", 9e-4, out=tmp_path / "other")
    assert band[:2] == (0.9, 0.9) and "no value of it reaches the paper's" in band[2]
    # a budget below one point's cost: not measured with the CPU the design needs
    miss, led = paper000.vmax_band(s, "serial", 9e-4, budget=1.0, out=tmp_path / "third")
    assert isinstance(miss, NotReached) and led.ran == 0 and miss.cpu_s == pytest.approx(n_pts * led.cost)


def test_paper003_levers_interpolate_extrapolate_only_when_monotone_and_go_to_contradicted_rows():
    from pinclear.studies.reproduce import paper003

    # a ratio k = (x / 0.3)^-1 (the deviation's kinematic a / l law) sampled at 0.15 and 0.6
    line = {"slider length": (0.3, (0.15, 0.6), "m", [(0.15, {"dev": 2.0}), (0.6, {"dev": 0.5})])}
    lv = paper003.geometry_lever(line, "dev", 1.5)                 # between the runs: linear between 0.15 and 0.3
    assert lv["needed"] == pytest.approx(0.15 + 0.5 * 0.15 / 1.0) and lv["how"].startswith("interpolated")
    lv = paper003.geometry_lever(line, "dev", 10.0)                # beyond them: the power law, x = 0.3 / 10
    assert lv["needed"] == pytest.approx(0.03, rel=1e-9) and lv["how"].startswith("extrapolated")
    bump = {"guide": (0.45, (0.3, 0.9), "m", [(0.3, {"force": 3.0}), (0.9, {"force": 12.0})])}
    lv = paper003.geometry_lever(bump, "force", 0.6)               # smallest at nominal: no extrapolation
    assert lv["needed"] is None and "not monotone" in lv["text"]
    # the input that swings the ratio most is the lever
    both = dict(line, **{"guide": (0.45, (0.3, 0.9), "m", [(0.3, {"dev": 0.9}), (0.9, {"dev": 1.2})])})
    assert paper003.geometry_lever(both, "dev", 1.5)["lever"] == "slider length"
    rows = [row("platform Z deviation, x", "platform deviation", 0.0015, 0.1, "mm", band=(0.001, 0.002),
                band_from="geometry"),
            row("platform Z deviation, y", "platform deviation", 0.1, 0.1, "mm", band=(0.09, 0.11), band_from="g")]
    assert [r["verdict"] for r in rows] == ["contradicted", "reproduced"]
    paper003.name_levers(rows, line)
    assert "lever: slider length" in rows[0]["why"] and "lever" not in rows[1]


def test_paper000_response_window_is_uniform_enough_for_the_output_step_table():
    from pinclear.analysis.convergence import sampled_convergence

    s = paper000._settings(False, None)
    t_end = s["force_periods"] * paper000.T
    t = paper000.window_times(t_end, s["window_periods"] * paper000.T, s["dt_out"])
    assert t[-1] == t_end and len(t) == round(s["window_periods"] * paper000.T / s["dt_out"]) + 1
    # the full report's window (100-108 s at 0.2 ms): the old arange-and-clip grid failed this check
    c = sampled_convergence(t, lambda i: float(np.sin(t[i]).max()))
    assert all(c.converged.values())
