"""Nothing a user has breaks with the layered layout: the old module paths that the README, the
tutorials and the examples used import the same objects, and the files written by pinclear
before the move (commit 50613e9: tests/data/legacy_50613e9) still load, resume and read."""
from __future__ import annotations

import importlib
import shutil
import warnings
from pathlib import Path

import numpy as np
import pytest

import pinclear
import pinclear.core.models

LEGACY = Path(__file__).resolve().parents[1] / "data" / "legacy_50613e9"

#: (old import path, attribute, today's module): the public API as documented before the move
OLD_API = [
    ("pinclear.sidecar", "parse_assignments", "pinclear.io.sidecar"),
    ("pinclear.sidecar", "load", "pinclear.io.sidecar"),
    ("pinclear.kinematics", "frame_motion", "pinclear.model.kinematics"),
    ("pinclear.builder", "Builder", "pinclear.io.builder"),
    ("pinclear.builder", "rod", "pinclear.io.builder"),
    ("pinclear.models", "model_path", "pinclear.core.models"),
    ("pinclear.errors", "InputError", "pinclear.core.errors"),
    ("pinclear.simulate", "read_state", "pinclear.dynamics.simulate"),
    ("pinclear.energy", "energy_balance", "pinclear.dynamics.energy"),
    ("pinclear.validate", "run_identity", "pinclear.dynamics.validate"),
    ("pinclear.trust", "check_recorded_args", "pinclear.core.trust"),
    ("pinclear.sweeps", "write_table", "pinclear.analysis.sweeps"),
    ("pinclear.economy", "economy_report", "pinclear.analysis.economy"),
    ("pinclear.wearing", "read_profile", "pinclear.analysis.wear_life"),
    ("pinclear.wearing", "wear_run", "pinclear.analysis.wear_life"),
    ("pinclear.bench", "pinocchio_floor", "pinclear.studies.bench.rhs"),
    ("pinclear.atlas", "run_atlas", "pinclear.studies.bench.atlas"),
    ("pinclear.stepping.build", "Evaluation", "pinclear.dynamics.stepping.build"),
    ("pinclear.stepping.system", "evaluate", "pinclear.dynamics.stepping.system"),
    ("pinclear.formulations", "get", "pinclear.dynamics.formulations"),
    ("pinclear.screw.virtual", "line_normal", "pinclear.dynamics.screw.virtual"),
    ("pinclear.reproduce.verdicts", "summary", "pinclear.studies.reproduce.verdicts"),
    ("pinclear.reproduce.chaos", None, None),
    ("pinclear._jit", "njit", "pinclear.core.jit"),
    ("pinclear._kernels", "chol_pivoted", "pinclear.core.dense"),
    ("pinclear._kernels", "proximal_inverse", "pinclear.core.regularised"),
    ("pinclear._kernels", "Rows", "pinclear.model.rows"),
    ("pinclear.contact._kernels", "radial_geometry", "pinclear.contact.radial_geometry"),
    ("pinclear.contact._kernels", "G_SPHERICAL", "pinclear.contact.channels"),
]


@pytest.mark.parametrize("old,attr,new", OLD_API, ids=[f"{o}.{a}" for o, a, _ in OLD_API])
def test_old_module_paths_import_todays_objects(old, attr, new):
    mod = importlib.import_module(old)
    if new is None:          # a module whose names moved with it: it only has to import
        assert mod.__name__.startswith("pinclear.studies.reproduce")
        return
    assert getattr(mod, attr) is getattr(importlib.import_module(new), attr)


def test_an_old_module_is_todays_module_object_with_its_own_spec():
    import pinclear.io.sidecar as new
    import pinclear.sidecar as old

    assert old is new and new.__spec__.name == "pinclear.io.sidecar"


def test_the_face_function_survives_importing_the_old_module_of_the_same_name():
    import pinclear.simulate  # noqa: F401  (the old module path)

    assert callable(pinclear.simulate) and pinclear.simulate.__module__ == "pinclear.dynamics.simulate"
    assert pinclear.sidecar is importlib.import_module("pinclear.io.sidecar")
    with pytest.raises(AttributeError):
        pinclear.no_such_module  # noqa: B018


def test_a_split_kernel_file_names_what_it_does_not_have():
    import pinclear._kernels as K

    with pytest.raises(AttributeError, match="moved to"):
        K.no_such_kernel  # noqa: B018


def test_the_trust_gate_accepts_the_old_name_of_an_offered_function():
    from pinclear.core.trust import resolve_function
    from pinclear.dynamics.screw.virtual import line_normal

    assert resolve_function("pinclear.screw.virtual:line_normal", "m.yaml", "screw.virtual") is line_normal
    with pytest.raises(pinclear.ModelFileError):        # an old name of a pinclear function not offered
        resolve_function("pinclear.cli:main", "m.yaml", "law")


def test_a_trajectory_written_before_the_move_loads_and_means_the_same():
    old = pinclear.Trajectory.load(LEGACY / "run_rrr3_P2" / "trajectory.npz")
    mech = pinclear.load("rrr3", clearances=["P2"])
    assert old.status == "success" and old.q.shape == (len(old.t), mech.nq)
    new = pinclear.simulate(mech, 0.02, dt_out=0.005)
    # rtol 1e-8 on both runs: the samples agree to a small multiple of the tolerance, whatever the
    # machine's rounding (the same steps on the same machine give the same bits)
    np.testing.assert_allclose(new.t, old.t, rtol=0, atol=1e-15)
    np.testing.assert_allclose(new.q, old.q, rtol=0, atol=1e-6)
    assert old.summary()["status"] == "success"
    assert old.energy_balance()["ok"]


def test_a_sweep_folder_written_before_the_move_resumes_without_recomputing(tmp_path):
    # A sweep folder records its model file's absolute path and every point its identity (model
    # text, overrides, settings): the legacy folder was made at a fixed path, recreated here.
    place = Path("/tmp/pinclear_legacy_50613e9")
    models = place / "models"
    models.mkdir(parents=True, exist_ok=True)
    for f in ("rrr3.yaml", "rrr3.urdf"):
        shutil.copy(pinclear.core.models.model_path("rrr3").with_name(f), models / f)
    folder = tmp_path / "sweep_rrr3"
    shutil.copytree(LEGACY / "sweep_rrr3", folder)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        res = pinclear.sweep(str(models / "rrr3.yaml"), {"P2.clearance": [1e-4, 2e-4]}, 0.01, folder,
                             sim_options={"method": "lagrange", "integrator": "RK45"},
                             load_options={"clearances": ["P2"]}, workers=1, progress=False)
    assert res.computed == 0 and len(res.points) == 2
    assert all(p.status == "success" for p in res.points)


def test_a_wear_profile_written_before_the_move_reads():
    from pinclear.analysis.wear_life import read_profile

    prof = read_profile(LEGACY / "wear_A" / "profile.csv")
    assert set(prof) == {"A"} and prof["A"].shape == (360,) and np.all(prof["A"] >= 0)
