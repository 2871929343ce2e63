"""Model/data split (issue 9): a Mechanism and its elements are immutable descriptions; every
buffer, cache and mode lives in a workspace, so mechanisms and threads never share state."""
from __future__ import annotations

import subprocess
import sys
import threading
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest

import pinclear
from pinclear.model import kinematics
from pinclear.model.drives import DriveRows

ROOT = Path(__file__).resolve().parents[2]

#: a shared vector drive law that counts its calls per (process-wide) thread
CALLS: list = []


def limb_law(t, scale=1.0):
    CALLS.append((threading.get_ident(), t))
    return (scale * np.array([np.sin(t), 0.1 * t]), scale * np.array([np.cos(t), 0.1]),
            scale * np.array([-np.sin(t), 0.0]))


def _shared_law_mech(path):
    """The four-bar with two (dummy) drives on one shared python law, trusted (test module)."""
    from pinclear.model.drives import Drive
    from pinclear.model.timelaws import build_law

    mech = pinclear.load(path)
    spec = {"type": "python", "function": "tests.model.test_architecture:limb_law"}
    laws = [build_law(dict(spec, index=k), str(path), f"law{k}", trust=True) for k in range(2)]
    return mech, laws, Drive


def test_two_loads_do_not_share_drive_law_state():
    """Two mechanisms from one file, each with a shared IK-style law: each evaluates its own law
    into its own workspace's values, once per call for all the drives sharing it (an old
    process-wide registry returned the first one's value to the second). No value is kept by
    time: a run's compiled stages write the same buffer, so a time-keyed value would go stale."""
    mech, laws, Drive = _shared_law_mech("four_bar")
    rows_a = DriveRows([Drive(f"d{k}", "j", 0, 0, law) for k, law in enumerate(laws)], mech.nv)
    _, laws_b, _ = _shared_law_mech("four_bar")
    rows_b = DriveRows([Drive(f"d{k}", "j", 0, 0, law) for k, law in enumerate(laws_b)], mech.nv)
    da, db = rows_a.create_data(), rows_b.create_data()
    CALLS.clear()
    fa = rows_a.values(0.3, da).copy()
    fb = rows_b.values(0.3, db).copy()
    assert len(CALLS) == 2                      # each mechanism evaluated its own law once
    np.testing.assert_array_equal(fa, fb)
    rows_a.values(0.3, da)
    assert len(CALLS) == 3                      # evaluated again: nothing answers from a cache


def test_loaded_mechanisms_are_independent_objects():
    a = pinclear.load("four_ups_upu", clearances=["S2"])
    b = pinclear.load("four_ups_upu", clearances=["S2"])
    assert a.model is not b.model
    assert a.forces[0] is not b.forces[0]
    # elements are immutable: writing to one raises instead of leaking into runs
    with pytest.raises(AttributeError, match="immutable"):
        a.forces[0].nc = 3


def test_replace_shares_no_element_data():
    mech = pinclear.load("four_ups_upu", clearances=["S2"])
    other = mech.replace(q0=mech.q0.copy())
    assert other.forces[0] is mech.forces[0]            # the immutable description may be shared ...
    wa, wb = mech.workspace(), other.workspace()
    assert wa.force_data[0] is not wb.force_data[0]    # ... its data never is
    assert wa.drive_data is not wb.drive_data
    # evaluating one workspace leaves the other's data untouched
    q = kinematics.assemble(mech)
    v = np.zeros(mech.nv)
    kinematics.update(mech, wa, q, v)
    el = mech.forces[0]
    before = {k: np.array(val, copy=True) for k, val in vars(wb.force_data[0]).items()
              if isinstance(val, np.ndarray)}
    el.add_force(mech, wa, wa.force_data[0], 0.0, q, v, np.zeros(el.nz), np.zeros(mech.nv), np.zeros(el.nz))
    for k, val in before.items():
        np.testing.assert_array_equal(getattr(wb.force_data[0], k), val)


@pytest.mark.parametrize("name, kw", [("four_bar", {}),
                                      ("clr_ball", {"clearances": ["S"]})])
def test_two_threads_give_bit_identical_trajectories(name, kw):
    """One mechanism, two runs in two threads at once: each run owns its workspace, so the
    results are bit-identical to each other and to a serial run."""
    mech = pinclear.load(name, **kw)
    t_end = 0.3
    start = {}
    if kw:        # the ball thrown around its socket, so the runs contain impacts
        start = dict(q0=np.zeros(mech.nq), v0=np.array([0.5, 0.3, -0.2, 3, -2, 1]), assemble=False,
                     max_step=2e-5, rtol=1e-6)
        t_end = 0.03

    def run(_):
        return pinclear.simulate(mech, t_end, **{"rtol": 1e-8, **start})
    serial = run(0)
    with ThreadPoolExecutor(2) as ex:
        a, b = ex.map(run, range(2))
    if kw:
        assert len(serial.stats["events"]) >= 3
    for tr in (a, b):
        assert tr.status == "success"
        np.testing.assert_array_equal(tr.q, serial.q)
        np.testing.assert_array_equal(tr.v, serial.v)
        np.testing.assert_array_equal(tr.a, serial.a)
        for k in serial.outputs:
            np.testing.assert_array_equal(tr.outputs[k], serial.outputs[k])


def test_trajectory_load_then_summary(tmp_path):
    mech = pinclear.load("four_ups_upu")
    tr = pinclear.simulate(mech, 0.2, rtol=1e-8)
    tr.save(tmp_path / "run.npz")
    back = pinclear.Trajectory.load(tmp_path / "run.npz", mech=mech)
    s = back.summary()
    assert s["status"] == "success" and s["samples"] == len(tr.t)
    # the drive tracking error survives the round trip (it was set only when filling a run)
    assert s["tracking_error"]["drives"] == pytest.approx(tr.summary()["tracking_error"]["drives"], rel=0, abs=0)
    assert s["tracking_error"]["drives"] < 1e-6


@pytest.mark.slow
def test_models_load_by_name_from_another_directory(tmp_path):
    """The bundled models are found through pinclear.core.models, not the working directory."""
    code = ("import pinclear, pinclear.core.models as m; names = m.available(); "
            "[pinclear.load(n) for n in names]; print(len(names))")
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert int(out.stdout.strip()) == len(list((ROOT / "urdf").glob("*.yaml")))


@pytest.mark.slow
def test_models_found_in_a_non_editable_install_layout(tmp_path):
    """``pip install .`` puts urdf/ at site-packages/pinclear/urdf without __init__.py (a
    namespace package, see setup.py). Laid out so here, with the repository out of reach, the
    bundled models load by name (importlib.resources once handed back a MultiplexedPath here,
    and no model was found)."""
    import shutil

    site = tmp_path / "site"
    shutil.copytree(ROOT / "pinclear", site / "pinclear", ignore=shutil.ignore_patterns("__pycache__"))
    shutil.copytree(ROOT / "urdf", site / "pinclear" / "urdf")
    code = ("import pinclear, pinclear.core.models as m; assert m.models_dir().parent == "
            "__import__('pathlib').Path(pinclear.__file__).parent, m.models_dir(); "
            "print(len(m.available())); pinclear.load('four_ups_upu', clearances=['S2'])")
    env = {**__import__("os").environ, "PYTHONPATH": str(site)}
    work = tmp_path / "work"
    work.mkdir()
    out = subprocess.run([sys.executable, "-c", code], cwd=work, env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert int(out.stdout.strip()) == len(list((ROOT / "urdf").glob("*.yaml")))


@pytest.mark.slow
def test_numba_cache_is_outside_the_package(tmp_path):
    """Compiled caches go to the user cache folder (PINCLEAR_CACHE_DIR here), never next to the
    installed sources: a leftover __pycache__ there once shadowed a later install."""
    code = ("import numba, pinclear, pinclear.simulate; "
            "m = pinclear.load('four_bar'); pinclear.simulate(m, 0.01); print(numba.config.CACHE_DIR)")
    env = {**__import__("os").environ, "PINCLEAR_CACHE_DIR": str(tmp_path / "cache")}
    env.pop("NUMBA_CACHE_DIR", None)
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env, capture_output=True, text=True,
                         timeout=600)
    assert out.returncode == 0, out.stderr
    from pinclear.core.jit import KERNEL_OPTIONS, KERNELS_DIGEST

    # named by the digest of every compiled source (a change in any file a kernel inlines
    # must not load stale code: numba's index watches a function's own file only)
    folder = tmp_path / "cache" / f"numba-{KERNEL_OPTIONS}-{KERNELS_DIGEST.hex()[:12]}"
    assert out.stdout.strip() == str(folder)
    assert list(folder.rglob("*.nbi")), "no compiled kernel was cached"
    pkg = Path(pinclear.__file__).parent
    assert not [p for p in pkg.rglob("*.nbi") if tmp_path not in p.parents]


def test_one_parameter_language_reaches_any_sidecar_value(tmp_path, capsys):
    """load()'s overrides take sidecar key paths too, so sweeps, the CLI's --set and Python all
    speak one language (no rewritten copies of the file)."""
    osc = ROOT / "tests" / "data" / "analysis_oscillator.yaml"
    mech = pinclear.load(osc, overrides={"forces[spring].k": 7.5})
    assert {f.name: getattr(f, "k", None) for f in mech.forces}["spring"] == 7.5
    assert mech.path == str(osc) and mech.load_args["overrides"] == {"forces[spring].k": 7.5}
    with pytest.raises(pinclear.ModelFileError, match=r"forces\[sprung\].*valid: push, spring"):
        pinclear.load(osc, overrides={"forces[sprung].k": 1.0})
    from pinclear.cli import commands as cli

    assert cli.main(["info", str(osc), "--set", "forces[spring].k=2.5", "--json"]) == 0
    assert '"k": 2.5' in capsys.readouterr().out


def test_a_folder_named_after_a_mechanism_does_not_hide_it(tmp_path, monkeypatch):
    """`pinclear simulate squeezer --out squeezer` then `pinclear warmup` from the same folder: the
    bare name still means the bundled mechanism, not the output folder of that name (it did, and
    the loader refused it as 'a folder'); an existing file of that name is still taken as given."""
    from pinclear.core.models import model_path, models_dir

    monkeypatch.chdir(tmp_path)
    (tmp_path / "four_bar").mkdir()
    assert model_path("four_bar") == models_dir() / "four_bar.yaml"
    assert pinclear.load("four_bar").name == "four_bar"
    (tmp_path / "mine").write_text("not a sidecar")
    assert model_path("mine").resolve() == tmp_path / "mine"
