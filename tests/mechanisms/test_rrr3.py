"""The tutorial's planar 3-RRR (docs/tutorial.md): the builder writes the bundled files, the
mechanism has the mobility Gruebler's count gives, `pinclear info` says so in words, and a clearance
run at P2 starts from the sidecar as written (issue 41: it was refused for a 23 mm penetration)."""
from __future__ import annotations

import importlib.util
import json
import math

import numpy as np
import pytest

import pinclear
from pinclear.cli import commands as cli
from pinclear.model import kinematics
from tests.helpers import ROOT, URDF_DIR
from tests.model_files import assert_same_model_file

RRR3 = URDF_DIR / "rrr3.yaml"


def _build_module():
    spec = importlib.util.spec_from_file_location("rrr3_build", ROOT / "examples" / "rrr3_build.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_bundled_files_are_the_builders_output(tmp_path):
    """urdf/rrr3.* cannot drift from examples/rrr3_build.py: rebuilt and compared by value
    (structure and strings exactly, numbers within the bound of tests/model_files.py: the last bits
    of the builder's trigonometry depend on the build)."""
    mod = _build_module()
    assert mod.main(["--out", str(tmp_path)]) == 0
    for name in ("rrr3.urdf", "rrr3.yaml"):
        assert_same_model_file(tmp_path / name, URDF_DIR / name, name)


def test_home_pose_closes_and_mobility_is_grueblers():
    """Planar Gruebler: 3 (n - 1) - 2 j = 3 (8 - 1) - 2 x 9 = 3 (ground, 6 links, platform; 9
    revolute joints); the builder's home pose (platform centred, trigonometry) closes the loops
    to round-off, and at the drives' t = 0 values the platform points stay on the limbs."""
    mech = pinclear.load(RRR3)
    ws = mech.workspace()
    assert np.abs(kinematics.closure_residual(mech, ws, mech.q0)).max() < 1e-14
    q = kinematics.assemble(mech)
    assert kinematics.mobility(mech, q)["mobility"] == 3
    mod = _build_module()
    for k, phase in enumerate((0.0, 2 * math.pi / 3, 4 * math.pi / 3)):
        jm = mech.model.joints[mech.model.getJointId(f"A{k + 1}")]
        assert q[jm.idx_q] == pytest.approx(mech.q0[jm.idx_q] + mod.AMP * math.sin(phase), abs=1e-12)


def test_info_summary_in_words(capsys):
    assert cli.main(["info", str(RRR3), "--clearance", "P2"]) == 0
    out = capsys.readouterr().out
    assert "3 drives on mobility 5: under-actuated" in out        # P2 freed: two more freedoms
    assert "the ideal mechanism's mobility is 3" in out
    assert "P2: planar_revolute on closure P2, clearance 0.2 mm, active" in out
    assert cli.main(["info", str(RRR3)]) == 0
    out = capsys.readouterr().out
    assert "3 drives on mobility 3: fully actuated" in out
    assert "branch: sign det" in out
    # A2 at t = 0 is its law's value: offset + 0.2 sin(2 pi / 3) (the JSON's q by name agrees)
    mech = pinclear.load(RRR3)
    a2 = mech.q0[mech.model.joints[mech.model.getJointId("A2")].idx_q] + 0.2 * math.sin(2 * math.pi / 3)
    line = next(ln for ln in out.splitlines() if ln.strip().startswith("A2 "))
    assert float(line.split("->")[1].split()[0]) == pytest.approx(a2, abs=1e-8)


def test_clearance_run_from_the_sidecar_as_written(tmp_path, capsys):
    """The command line the issue's user ran, with the sidecar unedited: it runs, and from the
    ideal start the journal is centred at t = 0 (penetration -c)."""
    out = tmp_path / "run"
    assert cli.main(["simulate", str(RRR3), "--clearance", "P2", "--t-end", "0.02", "--out", str(out),
                     "--progress", "off"]) == 0
    tr = pinclear.Trajectory.load(out / "trajectory.npz")
    assert tr.outputs["P2.penetration"][0] == pytest.approx(-2e-4, abs=1e-10)


def test_ideal_start_first_peak_much_smaller_than_least_energy(sim):
    """From the least-energy start P2's journal moves relative to its bearing at t = 0: an
    impact that is not physics (494 N measured at 1 s); from the ideal start the peak comes from
    the motion alone (33 N). 0.1 s holds the first impacts of both."""
    mech = pinclear.load(RRR3, clearances=["P2"])
    peaks = {}
    for start in ("ideal", "least-energy"):
        tr = sim(mech, 0.1, start=start, dt_out=1e-5)
        assert tr.status == "success", tr.message
        peaks[start] = float(np.max(tr.outputs["P2.fn"]))
    assert peaks["ideal"] < 0.25 * peaks["least-energy"]


def test_sweep_writes_a_table_at_simulates_tolerance(tmp_path, capsys):
    """`pinclear sweep` without --rtol runs at simulate's 1e-8 (it was 1e-6, silently) and writes
    table.csv + table.npz: one row per point, the summary's scalars, the same numbers as each
    point's own trajectory file."""
    import csv

    out = tmp_path / "sw"
    rc = cli.main(["sweep", str(RRR3), "--clearance", "P2", "--vary", "P2.clearance=1e-4,2e-4", "--t-end", "0.02",
                   "--out", str(out), "--workers", "1", "--progress", "off"])
    assert rc == 0, capsys.readouterr()
    rows = list(csv.DictReader((out / "table.csv").open()))
    npz = np.load(out / "table.npz")
    assert [float(r["P2.clearance"]) for r in rows] == [1e-4, 2e-4] and list(npz["status"]) == ["success"] * 2
    for i, r in enumerate(rows):
        tr = pinclear.Trajectory.load(out / "points" / f"{i:05d}.npz")
        assert float(r["rtol"]) == 1e-8 == tr.meta["rtol"]
        assert int(r["events"]) == len(tr.stats["events"]) == npz["events"][i]
        assert float(r["energy_balance.error"]) == tr.energy_balance()["error"]
        assert r["energy_balance.ok"] == "True"


def test_poincare_suggests_a_period_aligned_grid_and_labels_units(tmp_path, capsys):
    """With the default grid (t_end / 500 = 4.1e-3 s, not a divisor of the 1 s period) the
    section is interpolated and the command names --dt-out period/n with a short decimal
    (1/250 = 0.004 s, the first n >= 244 with one); on that grid no sample is interpolated. The
    portrait's axes carry the signal's SI unit (m, m/s; rad for a joint)."""
    from pinclear.analysis import signals

    runs = {}
    for name, extra in (("default", []), ("aligned", ["--dt-out", "0.004"])):
        out = tmp_path / name
        assert cli.main(["simulate", str(RRR3), "--t-end", "2.05", "--out", str(out), "--progress", "off",
                         *extra]) == 0
        rep_dir = tmp_path / f"{name}_an"
        assert cli.main(["analyse", "poincare", str(out / "trajectory.npz"), "--period", "1", "--signal", "A1",
                         "--signal", "B1", "--out", str(rep_dir)]) == 0
        runs[name] = json.loads((rep_dir / "poincare.json").read_text())
    capsys.readouterr()
    assert runs["default"]["A1"]["interpolated"] > 0
    assert "--dt-out 0.004 (period 1 s / 250)" in runs["default"]["A1"]["hint"]
    assert runs["aligned"]["A1"]["interpolated"] == 0 and "hint" not in runs["aligned"]["A1"]
    assert signals.axis_label("P2.eccentricity[0]", "m", rate=True) == "d/dt P2.eccentricity[0] [m/s]"
    mech = pinclear.load(RRR3)
    tr = pinclear.Trajectory.load(tmp_path / "aligned" / "trajectory.npz", mech=mech)
    assert signals.series(tr, "A1", mech).unit == "rad"


def test_builder_errors_name_the_choices(tmp_path):
    """Mistakes in a builder script are refused where they are made (joint type, unknown body),
    or by the loader on write() naming the file and the key (a clearance key)."""
    from pinclear.core.errors import InputError, PinclearError
    from pinclear.io.builder import Builder

    b = Builder("pend").body("arm", 1.0, com=(0.5, 0, 0), inertia=(1e-4, 0.1, 0.1))
    with pytest.raises(InputError, match="unknown type 'ball'.*revolute"):
        b.joint("j", "ball", "ground", "arm")
    with pytest.raises(InputError, match="no body 'hand'.*arm"):
        b.joint("j", "revolute", "ground", "hand")
    b.joint("j", "revolute", "ground", "arm", axis=(0, 1, 0), q=0.3)
    b.clearance("nope", clearance=1e-4)
    with pytest.raises(PinclearError, match=r"pend\.yaml.*clearances"):
        b.write(tmp_path)
    # without the bad clearance it writes, loads and assembles: a 1 kg pendulum at its guess
    b.clearances.clear()
    mech = b.write(tmp_path)
    assert mech.nq == 1 and mech.q0[0] == 0.3 and mech.model.inertias[1].mass == 1.0
