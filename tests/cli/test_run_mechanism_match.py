"""A run of one's own mechanism in plot, view and analyse poincare (issue 52, item 3, the rest):
`--set` repeats a recorded override a results file may not apply itself, `view SIDECAR --mech
OTHER` is refused rather than ignored, and a mechanism file that is not the run's (same joints and
elements, other parameters: the recorded mechanism digest differs) is refused with one line."""
import json
import warnings
from pathlib import Path

import numpy as np
import pytest

import pinclear
from pinclear.cli.view import plot_main, view_main

URDF = Path(__file__).resolve().parents[2] / "urdf"


@pytest.fixture(scope="module")
def own(tmp_path_factory):
    """The journal-bearing pendulum as the user's own sidecar (not a bundled name), run with a
    recorded override of its clearance."""
    d = tmp_path_factory.mktemp("own")
    text = (URDF / "clr_planar_pendulum.yaml").read_text()
    text = text.replace("urdf: clr_planar_pendulum.urdf", f"urdf: {URDF / 'clr_planar_pendulum.urdf'}")
    side = d / "mine.yaml"
    side.write_text(text + "\nplatform: {frame: journal}\n")
    other = d / "other.yaml"          # the same mechanism with another clearance written in the file
    other.write_text(side.read_text().replace("clearance: 1.0e-4", "clearance: 3.0e-4"))
    mech = pinclear.load(side, clearances=["A"], overrides={"A.clearance": 2e-4})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        tr = pinclear.simulate(mech, 0.04, dt_out=1e-3, rtol=1e-6)
    npz = tr.save(d / "run.npz")
    return d, side, other, npz


def _err(capsys):
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0, err
    return err


@pytest.mark.slow
def test_the_runs_digest_refuses_another_version_of_the_mechanism(own, capsys):
    d, side, other, npz = own
    assert plot_main([str(npz), "--mech", str(side), "--out", str(d / "figs")]) == 0
    assert plot_main([str(npz), "--mech", str(other), "--out", str(d / "figs")]) == 0
    capsys.readouterr()
    # the recorded override A.clearance = 2e-4 wins over either file's value: both files give the
    # run's mechanism; a file with another mass does not
    heavy = d / "heavy.urdf"
    heavy.write_text((URDF / "clr_planar_pendulum.urdf").read_text().replace('<mass value="1.0"', '<mass value="2.0"'))
    assert heavy.read_text() != (URDF / "clr_planar_pendulum.urdf").read_text()
    mod = d / "heavy.yaml"
    mod.write_text(side.read_text().replace(str(URDF / "clr_planar_pendulum.urdf"), str(heavy)))
    for rc in (lambda: plot_main([str(npz), "--mech", str(mod), "--out", str(d / "f2")]),
               lambda: _analyse(["poincare", str(npz), "--mech", str(mod), "--period", "0.01", "--signal", "rz",
                                 "--out", str(d / "p2")])):
        assert rc() == 2
        err = _err(capsys)
        assert "digest" in err and "run.npz" in err


def _analyse(argv):
    from pinclear.cli.commands import main

    return main(["analyse", *argv])


def test_analyse_poincare_uses_the_runs_recorded_overrides(own, capsys):
    d, side, _, npz = own
    out = d / "poinc"
    assert _analyse(["poincare", str(npz), "--mech", str(side), "--period", "0.01", "--signal", "rz",
                     "--out", str(out)]) == 0
    assert (out / "poincare.json").exists()
    prov = json.loads((out / "provenance.json").read_text())
    assert prov["versions"]["pinclear"] == pinclear.__version__ and prov["run"] == str(npz)


@pytest.mark.slow
def test_set_repeats_only_the_runs_own_overrides(own, capsys):
    d, side, _, npz = own
    base = [str(npz), "--mech", str(side), "--out", str(d / "f3")]
    assert plot_main(base + ["--set", "A.clearance=2e-4"]) == 0
    capsys.readouterr()
    assert plot_main(base + ["--set", "A.clearance=3e-4"]) == 2
    assert "made with A.clearance = 0.0002" in _err(capsys)
    assert plot_main(base + ["--set", "A.ce=0.5"]) == 2
    assert "made without it" in _err(capsys)


def test_a_recorded_code_override_can_be_repeated_by_the_user(own, tmp_path, capsys):
    """A run whose recorded overrides name a file: refused on its own (the message says how to
    give it), accepted as far as the results file goes when the user repeats it with --set."""
    _, side, _, npz = own
    with np.load(npz) as z:
        arrays = {k: z[k] for k in z.files}
    meta = json.loads(str(arrays["meta"]))
    meta["load_args"]["overrides"]["A.file"] = "extra.yaml"
    arrays["meta"] = np.array(json.dumps(meta))
    bad = tmp_path / "coded.npz"
    np.savez(bad, **arrays)
    assert plot_main([str(bad), "--mech", str(side), "--out", str(tmp_path / "f")]) == 2
    err = _err(capsys)
    assert "may not set 'file'" in err and "--set KEY=VALUE" in err and "plot" in err
    # repeated by the user, the results file's refusal is gone (the mechanism's own check of the key remains)
    assert plot_main([str(bad), "--mech", str(side), "--out", str(tmp_path / "f"), "--set", "A.file=extra.yaml"]) == 2
    assert "may not set" not in _err(capsys)


def test_view_sidecar_with_another_mech_is_refused(own, capsys):
    d, side, other, _ = own
    assert view_main([str(side), "--mech", str(other), "--html", str(d / "v.html")]) == 2
    err = _err(capsys)
    assert "--mech" in err and str(other) in err
