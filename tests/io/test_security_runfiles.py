"""Hostile round 4 (issue 42), run files: a saved run's recorded arguments never become code
(with --trust and PINCLEAR_TRUST=1 neither), and a path recorded in a results file is never
opened: errors never quote a file the user did not name. The run files are real four-bar runs
whose JSON metadata is rewritten as an attacker would."""
from __future__ import annotations

import json

import pytest

import pinclear
from pinclear.core.errors import ModelFileError
from pinclear.core.trust import check_recorded_args
from pinclear.dynamics import validate
from tests.core.test_trust import _tampered as tampered_npz
from tests.helpers import run_cli

SECRET = "AKIA-SECRET-KEY-4242"


@pytest.fixture(scope="module")
def four_bar_run(tmp_path_factory):
    d = tmp_path_factory.mktemp("run")
    tr = pinclear.simulate(pinclear.load("four_bar"), 0.4, dt_out=0.01)
    return tr.save(d / "run.npz")


def _tampered(src, dst, load_args=None, **meta_changes):
    """A copy of a saved run with metadata fields replaced (load_args: entries merged in)."""
    if load_args is not None:
        meta = json.loads(str(validate.read_npz(src)["meta"]))
        meta_changes["load_args"] = dict(meta["load_args"], **load_args)
    return tampered_npz(src, dst, **meta_changes)


def _spawn_force(marker):
    """The audit's override: a joint force whose python law is os.spawnv (forks a shell)."""
    return [{"name": "evil", "type": "joint_force", "joint": "crank_joint",
             "law": {"type": "python", "function": "os:spawnv",
                     "args": {"file": "/bin/sh", "args": ["sh", "-c", f"echo pwned > {marker}"]}}}]


@pytest.mark.parametrize("overrides", [
    "forces", "drives[0].law.function", "urdf", "hook", "nested"])
def test_recorded_overrides_never_add_code_even_trusted(four_bar_run, tmp_path, capsys, monkeypatch, overrides):
    marker = tmp_path / "PWNED"
    ov = {"forces": {"forces": _spawn_force(marker)},
          "drives[0].law.function": {"drives[0].law.function": "os:spawnv"},
          "urdf": {"urdf": "/etc/passwd"},
          "hook": {"hook": "pinclear.cli:main"},
          "nested": {"S1.mu": {"deep": [{"x": "os.path:join"}]}}}[overrides]
    run = _tampered(four_bar_run, tmp_path / "run.npz", load_args={"overrides": ov})
    four = str(pinclear.core.models.model_path("four_bar"))
    for argv in (["view", str(run), "--trust", "--html", str(tmp_path / "x.html")],
                 ["plot", str(run), "--trust", "--out", str(tmp_path / "f")],
                 ["plot", str(run), "--mech", four, "--trust", "--out", str(tmp_path / "f")]):
        code, _, err = run_cli(argv, capsys)
        assert code == 2 and "load_args.overrides" in err and "never adds code" in err, (argv, err)
        assert len(err.strip().splitlines()) == 1
    monkeypatch.setenv("PINCLEAR_TRUST", "1")
    code, _, err = run_cli(["plot", str(run), "--out", str(tmp_path / "f")], capsys)
    assert code == 2 and "load_args.overrides" in err
    with pytest.raises(ModelFileError, match="never adds code"):
        pinclear.Trajectory.load(run).load_mechanism(four, trust=True)
    assert not marker.exists() and not (tmp_path / "f").exists() and not (tmp_path / "x.html").exists()


def test_recorded_data_overrides_still_apply(four_bar_run, tmp_path):
    """What a run may record: numbers and words for options and clearance keys, offered names."""
    assert check_recorded_args({"overrides": {"S1.mu": 0.2, "S1.friction_law": "coulomb"},
                                "options": {"limbs": False}, "clearances": ["S1"]}, "r") == {
        "overrides": {"S1.mu": 0.2, "S1.friction_law": "coulomb"}, "options": {"limbs": False}, "clearances": ["S1"]}
    ok = {"x": "pinclear.mechanisms.four_ups_upu:limb_lengths"}
    assert check_recorded_args({"overrides": ok}, "r")["overrides"] == ok
    assert pinclear.Trajectory.load(four_bar_run).load_mechanism().name == "four_bar"


def test_a_recorded_path_is_never_opened(four_bar_run, tmp_path, capsys, monkeypatch):
    """The audit's case: the run names a fake credentials file as its mechanism; plot, view and
    analyse printed its key in the YAML error. Now nothing is read from it and nothing quoted."""
    creds = tmp_path / "credentials.yaml"
    creds.write_text(f"[default]\naws_secret_access_key = {SECRET}\n: {{ [\n")
    opened = []
    import pinclear.io.sidecar as sidecar
    real = sidecar.read_yaml
    monkeypatch.setattr(sidecar, "read_yaml", lambda p, *a, **k: (opened.append(str(p)), real(p, *a, **k))[1])
    run = _tampered(four_bar_run, tmp_path / "run.npz", mech_path=str(creds),
                    load_args={"path": str(creds)})
    for argv in (["view", str(run), "--html", str(tmp_path / "x.html")],
                 ["plot", str(run), "--out", str(tmp_path / "f")],
                 ["plot", str(run), "--trust", "--out", str(tmp_path / "f")],
                 ["analyse", "poincare", str(run), "--period", "0.1", "--signal", "crank_joint", "--out", str(tmp_path / "a")]):
        code, out, err = run_cli(argv, capsys)
        assert code == 2 and "not a bundled mechanism" in err and "--mech" in err, (argv, err)
        assert SECRET not in err + out
    assert not any("credentials" in p for p in opened)
    # a planted file named like a bundled mechanism: the bundled one is loaded by its name
    planted = tmp_path / "evil" / "four_bar.yaml"
    planted.parent.mkdir()
    planted.write_text(f"key: {SECRET}\n: [\n")
    run2 = _tampered(four_bar_run, tmp_path / "run2.npz", mech_path=str(planted), load_args={"path": str(planted)})
    code, out, err = run_cli(["plot", str(run2), "--out", str(tmp_path / "f2")], capsys)
    assert code == 0 and SECRET not in err + out and (tmp_path / "f2").is_dir()
    assert not any("evil" in p for p in opened)


@pytest.mark.parametrize("meta", [{"mechanism": None}, {"mechanism": {"forces": [1, "x", None]}}])
def test_analyse_on_tampered_metadata_is_a_clear_error_or_a_result(four_bar_run, tmp_path, capsys, meta):
    run = _tampered(four_bar_run, tmp_path / "run.npz", **meta)
    code, _, err = run_cli(["analyse", "poincare", str(run), "--period", "0.1", "--signal", "crank_joint", "--out", str(tmp_path / "a")], capsys)
    assert code in (0, 2), err
    assert "unexpected" not in err and len(err.strip().splitlines()) <= 1
