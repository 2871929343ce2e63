"""A run exported for other programs (issue 52, item 8): CSV and MATLAB .mat round trips. Read
back with an independent reader (the csv module and float(); scipy.io.loadmat), every channel is
the run's array exactly (shortest round-trip decimals, doubles in the .mat), NaN included, named
as documented (pinclear.dynamics.export_run)."""
import csv
import json
import warnings

import numpy as np
import pytest
import scipy.io

import pinclear


@pytest.fixture(scope="module")
def run():
    mech = pinclear.load("clr_planar_pendulum", clearances=["A"])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tr = pinclear.simulate(mech, 0.02, dt_out=1e-3, rtol=1e-6)
    assert tr.status == "success"
    tr.a[3, 0] = np.nan                     # a sample whose evaluation failed keeps NaN through the export
    return mech, tr


def _expected(tr):
    want = {"t": tr.t}
    for kind in ("q", "v", "a"):
        for i, name in enumerate(("px", "py", "rz")):
            want[f"{kind}.{name}"] = getattr(tr, kind)[:, i]
    for k, v in tr.lam.items():
        want[f"lam.{k}"] = v
    E = tr.outputs["A.eccentricity"]
    for k in range(E.shape[1]):
        want[f"out.A.eccentricity[{k}]"] = E[:, k]
    want["out.A.fn"] = np.ravel(tr.outputs["A.fn"])
    want["energy.kinetic"] = tr.energies["kinetic"]
    want["residual"] = tr.residual
    return want


def test_csv_round_trip(run, tmp_path):
    _, tr = run
    path = tr.to_csv(tmp_path / "run.csv")
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    header, body = rows[0], rows[1:]
    assert len(body) == len(tr.t) and len(set(header)) == len(header)
    cols = {h: np.array([float(r[i]) for r in body]) for i, h in enumerate(header)}
    for name, want in _expected(tr).items():
        np.testing.assert_array_equal(cols[name], want, err_msg=name)      # exact, NaN where NaN
    assert np.isnan(cols["a.px"][3])
    # shortest round-trip decimals: 0.001 is written as 0.001, not 0.0010000000000000002
    assert body[1][0] == repr(float(tr.t[1])) == "0.001"


def test_mat_round_trip(run, tmp_path):
    _, tr = run
    path = tr.to_mat(tmp_path / "run.mat")
    m = scipy.io.loadmat(path)
    np.testing.assert_array_equal(m["t"].ravel(), tr.t)
    np.testing.assert_array_equal(m["q"], tr.q)
    np.testing.assert_array_equal(m["a"], tr.a)
    names = [str(x[0]) for x in m["lam_names"].ravel()]
    assert names == [f"lam.{k}" for k in tr.lam]
    for j, k in enumerate(tr.lam):
        np.testing.assert_array_equal(m["lam"][:, j], tr.lam[k])
    onames = [str(x[0]) for x in m["outputs_names"].ravel()]
    j = onames.index("out.A.fn")
    np.testing.assert_array_equal(m["outputs"][:, j], np.ravel(tr.outputs["A.fn"]))
    assert [str(x[0]) for x in m["q_names"].ravel()] == ["q.px", "q.py", "q.rz"]
    meta = json.loads(str(m["meta_json"][0]))
    assert meta["versions"]["pinclear"] == pinclear.__version__ and meta["status"] == "success"


def test_export_run_cli(run, tmp_path, capsys):
    from pinclear.cli.commands import main

    _, tr = run
    folder = tmp_path / "o"
    folder.mkdir()
    tr.save(folder / "trajectory.npz")
    assert main(["export-run", str(folder), "--csv", str(tmp_path / "r.csv"), "--mat", str(tmp_path / "r.mat")]) == 0
    back = scipy.io.loadmat(tmp_path / "r.mat")
    np.testing.assert_array_equal(back["v"], tr.v)
    assert (tmp_path / "r.csv").read_text().splitlines()[0].startswith("t,q.px,q.py,q.rz,")
    capsys.readouterr()
    assert main(["export-run", str(folder)]) == 2
    assert "--csv" in capsys.readouterr().err
    assert main(["export-run", str(tmp_path / "none.npz"), "--csv", str(tmp_path / "x.csv")]) == 2
    err = capsys.readouterr().err
    assert "none.npz" in err and err.count("\n") == 1
