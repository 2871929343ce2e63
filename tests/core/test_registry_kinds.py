"""One registry style for every plug-in kind (pinclear.core.registry.KINDS): each kind is a
Registry; a toy formulation and a toy paper reproduction join by their module (here, the test)
plus one registry line (an ``add`` call) and are then found by simulate, the command line's
choices and ``pinclear reproduce``."""
from __future__ import annotations

import json

import numpy as np
import pytest

import pinclear
from pinclear.core import registry
from pinclear.core.registry import FORMULATIONS, Entry, Registry
from pinclear.dynamics.formulations.lagrange import Lagrange
from tests.helpers import run_cli

#: every kind and at least the names it must hold (the bundled plug-ins)
EXPECTED = {
    "clearance type": {"spherical", "planar_revolute", "revolute", "prismatic", "lubricated_revolute"},
    "force element type": {"spring_damper", "joint_force", "joint_spring"},
    "integrator": {"RK45", "DOP853", "ROS34PW2", "Radau", "BDF", "LSODA", "RK4"},
    "formulation": {"lagrange", "projection", "pinocchio", "proximal", "manifold"},
    "closure reader": {"coupling"},
    "importer": {".sdf", ".xml", ".mjcf", ".urdf"},
    "paper reproduction": {"000", "002", "003", "004"},
    "study": {"paper000", "paper002"},
    "command": {"view", "plot", "analyse", "reproduce", "import", "export", "wear", "study", "inverse-dynamics"},
}


def test_every_kind_is_a_registry_and_its_entries_resolve():
    kinds = registry.kinds()
    assert set(kinds) == set(EXPECTED)
    for kind, reg in kinds.items():
        assert isinstance(reg, Registry), kind
        assert reg.what == kind
        assert EXPECTED[kind] <= set(reg), (kind, set(reg))
        for name, rec in reg.items():         # every "module:NAME" imports and is its kind's record
            assert rec.name == name
            if isinstance(rec, Entry):
                assert callable(rec.load()), (kind, name)


def test_the_cli_commands_and_readers_come_from_their_registries():
    from pinclear.cli.commands import COMMANDS, build_parser
    from pinclear.io.importers import READERS

    sub = next(a for a in build_parser()._actions if a.dest == "cmd")
    assert set(COMMANDS) <= set(sub.choices)
    with pytest.raises(pinclear.ModelFileError, match=r"\.sdf"):
        from pinclear.io.importers import read_graph

        read_graph("mechanism.step")
    assert READERS[".sdf"].load().__module__ == "pinclear.io.importers.sdf"


# ------------------------------------------------------------------ a toy formulation (its "module")
class ToyLagrange(Lagrange):
    """Lagrange's equations under a name of its own: the same equations, so its run must agree with
    lagrange's to the integration's tolerance while going through every registry lookup by name."""

    name = "toy_lagrange"


@pytest.fixture
def toy_formulation():
    FORMULATIONS.add(ToyLagrange)                 # the one line
    try:
        yield
    finally:
        FORMULATIONS.remove("toy_lagrange")


def test_a_toy_formulation_is_found_by_simulate_and_the_command_line(toy_formulation):
    from pinclear.cli.args import run_choices

    mech = pinclear.load("four_bar")
    ref = pinclear.simulate(mech, 0.05)
    toy = pinclear.simulate(mech, 0.05, method="toy_lagrange")
    assert toy.status == "success" and toy.meta["method"]["method"] == "toy_lagrange"
    # rtol 1e-8 on O(1) angles: the two runs take the same steps; 1e-9 is far inside the tolerance
    assert np.allclose(toy.q, ref.q, rtol=0, atol=1e-9)
    assert "toy_lagrange" in run_choices()[0]
    with pytest.raises(TypeError, match="Formulation"):
        FORMULATIONS.add(Entry("not_a_formulation", print))


# ------------------------------------------------------------------ a toy paper (its "module")
def toy_paper_run(out, quick=False, workers=None, scheduler=None):
    """A toy 'paper' claims the free four-bar keeps its mechanical energy (no dissipation, no
    drive): our number is the energy after 0.05 s, the paper's the energy at the start."""
    from pinclear.studies.reproduce.verdicts import row

    tr = pinclear.simulate(pinclear.load("four_bar"), 0.05)
    e = tr.energy()["total"]
    return {"title": "Toy paper: energy of the free four-bar", "paper": "toy", "settings": {"t_end [s]": 0.05},
            "results": [row("energy after 0.05 s", "kinematic peak", float(e[-1]), float(e[0]), "J")],
            "groups": {}, "notes": [], "figures": []}


@pytest.fixture
def toy_paper():
    from pinclear.studies.reproduce import PAPERS

    PAPERS.add(Entry("toy", toy_paper_run, "energy of the free four-bar"))   # the one line
    try:
        yield
    finally:
        PAPERS.remove("toy")


def test_a_toy_paper_is_reproduced_by_the_command(toy_paper, tmp_path, capsys):
    code, out, err = run_cli(["reproduce", "toy", "--out", str(tmp_path / "rep")], capsys)
    assert code == 0, err
    assert "Toy paper" in out and (tmp_path / "rep" / "report.md").is_file()
    rep = json.loads((tmp_path / "rep" / "report.json").read_text())
    (r,) = rep["results"]
    # conservation: the relative drift of a rtol = 1e-8 run over 0.05 s stays below 1e-6
    assert abs(r["ours"] - r["paper"]) <= 1e-6 * max(abs(r["paper"]), 1e-3)
    # no band was measured: the row is "not measured", and at nominal it holds
    assert r["verdict"] == "not measured" and r["nominal_verdict"] == "reproduced", r
