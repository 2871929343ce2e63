"""summary.json's keys say their units and references (issue 52, item 8): the energy audit in
relative and joule keys whose values agree, the balance terms split into values at a time and
changes since the start (adding up to the balance), the old keys kept as aliases with the same
values, a schema version, and the versions a result was made with."""
import json
import subprocess
import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy

import pinclear
from pinclear.dynamics.energy import ABSOLUTE, ALIASES, CHANGES, SERIES, balance_series


@pytest.fixture(scope="module")
def run():
    mech = pinclear.load("clr_planar_pendulum", clearances=["A"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tr = pinclear.simulate(mech, 0.05, dt_out=1e-3, rtol=1e-6)
    assert tr.status == "success"
    return tr


def test_energy_keys_name_their_units(run):
    s = run.summary()
    assert s["schema_version"] == 2
    eb = s["energy_balance"]
    S = balance_series(run)
    # the relative error is the joule error over the scale, the joule error the balance's largest |B - B(0)|
    assert eb["error_J"] == pytest.approx(np.max(np.abs(S["balance"])), rel=1e-12)
    assert eb["error_rel"] == pytest.approx(eb["error_J"] / eb["scale_J"], rel=1e-12)
    assert eb["bound_J"] == pytest.approx(eb["bound_rel"] * eb["scale_J"], rel=1e-12)
    assert eb["error_J"] <= eb["bound_J"] and eb["ok"]
    # values at a time vs changes since t0, one set of the balance's terms, their signed sum B(end) - B(0)
    assert set(eb["terms_absolute_J"]) == set(ABSOLUTE) and set(eb["terms_change_J"]) == set(CHANGES)
    assert set(ABSOLUTE) | set(CHANGES) == set(SERIES)
    terms = {**eb["terms_absolute_J"], **eb["terms_change_J"]}
    B = (terms["kinetic"] + terms["gravity"] + terms["elastic"] + terms["dissipated"] - terms["work_drives"]
         - terms["work_closures"] - terms["work_applied"])
    B0 = S["kinetic"][0] + S["elastic"][0]           # the changes are zero at t0
    assert B - B0 == pytest.approx(S["balance"][-1], abs=1e-12 * eb["scale_J"])
    # the names before schema 2 hold the same values, and the summary says which is which
    assert eb["error"] == eb["error_rel"] and eb["bound"] == eb["bound_rel"] and eb["scale"] == eb["scale_J"]
    assert eb["terms"] == terms
    assert s["aliases"]["energy_balance.error"] == "energy_balance.error_rel"
    assert set(s["aliases"]) == {f"energy_balance.{k}" for k in ALIASES}
    assert s["units"]["contact_force_peaks"] == "N"


def test_results_record_versions_and_commit(run, tmp_path):
    path = run.save(tmp_path / "run.npz")
    v = pinclear.Trajectory.load(path).meta["summary"]["versions"]
    import numba
    import pinocchio

    assert v["pinclear"] == pinclear.__version__ and v["pinocchio"] == pinocchio.__version__
    assert v["numpy"] == np.__version__ and v["scipy"] == scipy.__version__ and v["numba"] == numba.__version__
    root = Path(pinclear.__file__).resolve().parents[1]
    try:
        sha = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True,
                             check=True, timeout=10).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        sha = None
    assert v["commit"] == sha
    assert json.loads(json.dumps(v)) == v


def test_sweep_table_writes_the_decimals_of_the_range(tmp_path):
    from pinclear.analysis.sweeps import parse_vary, write_table

    key, values = parse_vary("A.clearance=1e-4:5e-4:5")
    assert values == [1e-4, 2e-4, 3e-4, 4e-4, 5e-4]          # not 0.00030000000000000003
    assert np.max(np.abs(np.array(values) - np.linspace(1e-4, 5e-4, 5))) <= 1e-16 * 5e-4 * 5
    _, geo = parse_vary("k=1:1000:4:log")
    assert geo == [1.0, 10.0, 100.0, 1000.0]

    from pinclear.analysis.sweeps import SweepPoint

    write_table(tmp_path, [key], [SweepPoint(i, {key: v}, "pending", "", None) for i, v in enumerate(values)])
    text = (tmp_path / "table.csv").read_text()
    assert "0.0003," in text and "0.00030000000000000003" not in text
