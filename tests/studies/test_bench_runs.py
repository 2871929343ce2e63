"""`pinclear bench runs` over methods x integrators: one cell per (scene, method, integrator),
refusals recorded as skipped, names checked against the registries, and the matrix tables.

Two small planar scenes, 0.05 simulated seconds, two repeats: the figures are not benchmarks
here, only their bookkeeping is under test.
"""
from __future__ import annotations

import re

import pytest

from pinclear.cli.commands import main
from pinclear.core.errors import InputError
from pinclear.dynamics import formulations
from pinclear.dynamics import stepping as integrators
from pinclear.studies.bench import rhs as bench

SCENES = ["four_bar", "a02_nfourbar_1"]
# pinocchio's rigid constraints cannot express a planar_point closure: both scenes refuse it
METHODS = ("lagrange", "pinocchio")
INTEGS = ("RK45", "DOP853")


@pytest.fixture(scope="module")
def res():
    return bench.bench_runs(SCENES, t_end=0.05, methods=METHODS, integrators=INTEGS, repeat=2)


def test_one_cell_per_scene_method_and_integrator(res):
    keys = [(r["scene"], r["method"], r["integrator"]) for r in res["scenes"]]
    assert sorted(keys) == sorted((s, m, i) for s in SCENES for m in METHODS for i in INTEGS)
    assert res["methods"] == list(METHODS) and res["integrators"] == list(INTEGS)


def test_measured_cells_carry_their_figures_and_the_ratio_is_theirs(res):
    for r in res["scenes"]:
        if r["method"] != "lagrange":
            continue
        assert r["status"] == "success" and r["t_reached"] == pytest.approx(0.05, abs=1e-12)
        assert r["rhs_evals"] > 0 and r["steps"] > 0 and r["events"] == 0 and r["loop"]
        assert r["floor_us"] > 0 and r["us_per_eval"] > 0
        assert r["ratio_over_floor"] == pytest.approx(r["us_per_eval"] / r["floor_us"], rel=1e-12)


def test_a_refused_method_is_a_skipped_cell_with_its_reason(res):
    skipped = [r for r in res["scenes"] if r["method"] == "pinocchio"]
    assert len(skipped) == len(SCENES) * len(INTEGS)
    for r in skipped:
        assert r["status"] == "skipped" and "planar_point" in r["reason"] and "InputError" in r["reason"]
        assert "ratio_over_floor" not in r


def test_matrix_table_has_a_table_per_integrator_and_the_worst_cell(res):
    text = bench.runs_matrix_table(res)
    blocks = text.split("### ")[1:]
    assert [b.split(" ")[0] for b in blocks] == list(INTEGS)
    cells = {(r["scene"], r["method"], r["integrator"]): r for r in res["scenes"]}
    for integ, block in zip(INTEGS, blocks):
        lines = [ln for ln in block.splitlines() if ln.startswith("| ")]
        assert lines[0] == "| scene | " + " | ".join(METHODS) + " |"
        rows = {ln.split(" | ")[0][2:]: [c.strip(" |") for c in ln.split(" | ")[1:]] for ln in lines[1:]}
        assert sorted(rows) == sorted(SCENES)
        for scene, row in rows.items():
            for m, cell in zip(METHODS, row):
                r = cells[(scene, m, integ)]
                if r["status"] == "skipped":
                    assert cell == "skipped"
                else:
                    assert cell == f"{r['ratio_over_floor']:.1f} ({r['us_per_eval']:.0f})"
    measured = [r for r in res["scenes"] if "ratio_over_floor" in r]
    worst = max(measured, key=lambda r: r["ratio_over_floor"])
    summary = text.splitlines()[-1]
    assert f"worst cell {worst['scene']} / {worst['method']} + {worst['integrator']}" in summary
    over = sum(r["ratio_over_floor"] > 3.0 for r in measured)
    assert f"{over} of {len(measured)} measured cells exceed 3x" in summary
    assert f"{len(SCENES) * len(INTEGS)} skipped" in summary


def test_failed_cells_are_marked_in_the_matrix():
    res = {"t_end": 1.0, "rtol": 1e-6, "methods": ["lagrange"], "integrators": ["RK45"], "scenes": [
        {"scene": "a", "method": "lagrange", "integrator": "RK45", "status": "failed", "us_per_eval": 10.0,
         "floor_us": 2.0, "ratio_over_floor": 5.0},
        {"scene": "b", "method": "lagrange", "integrator": "RK45", "status": "success", "us_per_eval": 4.0,
         "floor_us": 2.0, "ratio_over_floor": 2.0}]}
    text = bench.runs_matrix_table(res)
    assert "| a | failed: 5.0 (10) |" in text and "| b | 2.0 (4) |" in text
    assert "worst cell a / lagrange + RK45 at 5.0x" in text and "1 of 2 measured cells exceed 3x; 1 failed" in text


def test_default_arguments_keep_the_single_table():
    res = bench.bench_runs(["four_bar"], t_end=0.02, repeat=1)
    assert [(r["method"], r["integrator"]) for r in res["scenes"]] == [("lagrange", "RK45")]
    lines = bench.runs_table(res).splitlines()
    assert lines[0] == ("| scene | status | CPU s / sim s | set-up ms | rhs evals | steps | us / eval | floor us | "
                        "ratio |")
    assert lines[2].startswith("| four_bar | success | ")


def test_bad_names_are_input_errors_naming_the_valid_choices():
    with pytest.raises(InputError, match="unknown method 'nope'") as e:
        bench.bench_runs(["four_bar"], methods=("lagrange", "nope"))
    assert all(m in str(e.value) for m in formulations.METHODS)
    with pytest.raises(InputError, match="unknown integrator 'RK99'") as e:
        bench.bench_runs(["four_bar"], integrators=("RK99",))
    assert all(i in str(e.value) for i in integrators.INTEGRATORS)
    # a fixed-step integrator has no rtol to run at: refused, the adaptive ones named
    fixed = [k for k, v in integrators.INTEGRATORS.items() if not v.adaptive]
    for k in fixed:
        with pytest.raises(InputError, match="fixed-step") as e:
            bench.bench_runs(["four_bar"], integrators=(k,))
        valid = re.search(r"\(valid: (.*)\)", str(e.value)).group(1).split(", ")
        assert sorted(valid) == sorted(n for n, v in integrators.INTEGRATORS.items() if v.adaptive)


@pytest.mark.parametrize("option, value, names", [
    ("--methods", "lagrange,nope", list(formulations.METHODS)),
    ("--integrators", "RK45,RK99", list(integrators.INTEGRATORS)),
])
def test_cli_refuses_bad_names_before_anything_runs(option, value, names, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["bench", "runs", "four_bar", option, value, "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith(f"pinclear: error: {option}: unknown ")
    assert all(n in err for n in names), err
    assert not (tmp_path / "o").exists()


def test_cli_writes_the_matrix(tmp_path, capsys):
    out = tmp_path / "o"
    assert main(["bench", "runs", "four_bar", "--t-end", "0.02", "--methods", "lagrange,pinocchio",
                 "--integrators", "RK45", "--out", str(out)]) == 0
    for name in ("bench_runs.json", "bench_runs.md", "bench_runs_matrix.md"):
        assert (out / name).is_file()
    matrix = (out / "bench_runs_matrix.md").read_text()
    assert "| four_bar | " in matrix and "| skipped |" in matrix
    assert main(["bench", "rhs", "four_bar", "--integrators", "RK45"]) == 2
    assert "--integrators applies to bench runs only" in capsys.readouterr().err
