"""Cassie from example-robot-data's five SDF variants (pinclear.mechanisms.cassie): the bundled
files are what the importer writes, the loops close, the legs sit where the SDF puts them, and a
passive swing conserves energy within the audit's bound."""
from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.core.errors import InputError
from pinclear.core.models import example_robot_data_dir, models_dir
from pinclear.dynamics.simulate import simulate
from pinclear.mechanisms import cassie
from pinclear.model import kinematics
from pinclear.model.joint_spring import JointSpring
from tests.model_files import assert_same_model_file

pytestmark = pytest.mark.skipif(example_robot_data_dir() is None, reason="example-robot-data is not installed")


@pytest.mark.parametrize("variant", cassie.VARIANTS)
def test_variant_imports_to_the_bundled_files_and_its_loops_close(variant, tmp_path):
    from pinclear.io.importers import import_file

    rep = import_file(cassie.sdf_path(variant), tmp_path, fix="pelvis", name=variant)
    # by value, not byte for byte: the frames' rpy come from atan2 of composed placements, whose
    # last bit differs between builds (AMD EPYC: cassie_v2's pitch 0.07225343999506346 came out
    # ...345); structure, names and strings exactly, numbers within 64 ulp of the transform
    # chain's magnitude (the bound's derivation: tests/model_files.py)
    for ext in ("urdf", "yaml"):
        assert_same_model_file(tmp_path / f"{variant}.{ext}", models_dir() / f"{variant}.{ext}")
    # four ball joints cut in every variant (3 rows each); cassie.sdf adds its two shin-spring
    # prismatic joints (5 rows) and ten gearbox couplings (1 row)
    balls = [c["joint"] for c in rep["cut"] if c["type"] == "ball"]
    assert sorted(balls) == sorted(f"{s}-{j}" for s in ("left", "right") for j in ("pitch-rod-joint",
                                                                                    "plantar-foot-joint"))
    assert rep["closure_rows"] == (12 + 10 + 10 if variant == "cassie" else 12)
    mech = pinclear.load(variant)
    q = kinematics.assemble(mech, mech.q0 + 0.01)            # from a guess off the reference
    assert np.abs(kinematics.closure_residual(mech, mech.workspace(), q)).max() < 1e-12
    mob = kinematics.mobility(mech, mech.q0)
    # a plantar loop (crank, plantar rod, foot: three revolute joints and the ball) whose three
    # axes are parallel is planar, and one row of its ball is then redundant; the variants differ
    # (cassie_reduced and cassie_simple tilt the plantar rod's axis by 0.1 rad; cassie_v2's right
    # leg has its axes 7e-8 rad apart, the SDF writing pi/2 as 1.5708: parallel within 1e-6 rad,
    # far below what the rank test resolves, about 1e-11 of the rows' scale)
    data = mech.model.createData()
    Jw = pin.computeJointJacobians(mech.model, data, mech.q0)[3:]     # world angular columns: the axes

    def axis(name):
        return Jw[:, mech.model.joints[mech.model.getJointId(name)].idx_v]

    planar = 0
    for s in ("left", "right"):
        a = [axis(f"{s}-{j}") for j in ("tarsus-crank-joint", "crank-rod-joint", "foot-op")]
        planar += all(np.linalg.norm(np.cross(a[0], b)) < 1e-6 for b in a[1:])
    assert sum("plantar-foot-joint" in r for r in mob["redundant_rows"]) == planar
    assert mob["mobility"] == mech.nv - mob["rank"] and mob["rank"] == mob["rows"] - len(mob["redundant_rows"])


def _rpy(r, p, y):
    """SDF's fixed-axis roll-pitch-yaw, built from the three elementary rotations."""
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    Rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    Ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    Rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


@pytest.mark.parametrize("variant", cassie.VARIANTS)
def test_legs_sit_at_the_sdf_poses_at_the_reference(variant):
    """Every link's frame (its ``__ref`` frame where the URDF frame had to move onto a joint axis)
    is at the SDF's own <pose> (model frame, SDF 1.6) at q = 0, to 1e-12."""
    mech = pinclear.load(variant)
    data = mech.model.createData()
    pin.framesForwardKinematics(mech.model, data, mech.q0)
    root = ET.parse(cassie.sdf_path(variant)).getroot()
    links = root.find("model").findall("link")
    assert len(links) >= 23
    for link in links:
        name = link.get("name")
        x = [float(s) for s in link.find("pose").text.split()]
        fname = f"{name}__ref" if mech.model.existFrame(f"{name}__ref") else name
        X = data.oMf[mech.model.getFrameId(fname, pin.FrameType.BODY)]
        assert np.abs(X.translation - x[:3]).max() < 1e-12, name
        assert np.abs(X.rotation - _rpy(*x[3:])).max() < 1e-12, name


def test_passive_swing_without_dampers_conserves_energy():
    """Springs kept, dampers removed (c = 0): a conservative system; the energy balance of a
    lagrange run stays within its error bound (pinclear.dynamics.energy), with no dissipated work."""
    mech = pinclear.load("cassie_v2")
    springs = [JointSpring(f.name, f.idx_q, f.idx_v, f.k, 0.0, f.reference) for f in mech.forces]
    mech = mech.replace(forces=springs)
    assert mech.conservative
    tr = simulate(mech, 0.2, rtol=1e-9)
    eb = tr.energy_balance()
    assert tr.status == "success" and eb["ok"], eb
    assert eb["error"] <= eb["bound"]
    assert eb["terms"]["work_applied"] == 0.0
    assert eb["terms"]["kinetic"] > 0.1                      # the legs did swing
    # (a run whose closure residual passes the bound its tolerances allow ends as failed:
    # pinclear.dynamics.validate.check_residual, so "success" covers the loops)


def _hip_drives(variant):
    return pinclear.load(variant, overrides={"drives": [
        {"name": f"{s}-hip", "joint": f"{s}-pitch-op",
         "law": {"type": "sines", "offset": 0.0, "terms": [{"amp": 0.2, "omega": 6.0, "kind": "sin"}]}}
        for s in ("left", "right")]})


def test_prescribed_hip_motion_every_formulation_agrees():
    """cassie_v2, both hip-pitch joints driven by 0.2 sin(6 t): lagrange, projection, proximal and
    manifold reach the same state (to their tolerance) with the energy balance closed. Pinocchio's
    own solver (method 'pinocchio') is refused before the run, naming the redundant plantar rows
    (its rigid constraints take a ball closure whole, and its proximal solver does not converge on
    them: it stopped at t = 0 with a residual of 7)."""
    mech = _hip_drives("cassie_v2")
    ends = {}
    for method in ("lagrange", "projection", "proximal", "manifold"):
        tr = simulate(mech, 0.1, method=method, rtol=1e-9)
        assert tr.status == "success", (method, tr.message)
        assert tr.energy_balance()["ok"], method
        m = mech.model
        op = m.joints[m.getJointId("left-pitch-op")].idx_q
        assert abs(tr.q[-1, op] - 0.2 * np.sin(0.6)) < 1e-6
        ends[method] = tr.q[-1]
    for method, q in ends.items():
        assert np.abs(q - ends["lagrange"]).max() < 1e-5, method
    with pytest.raises(InputError, match=r"closure rows right-plantar-foot-joint.y, left-plantar-foot-joint.y are "
                       r"redundant .*\(rank 10 of 12\).* use lagrange, projection, proximal or manifold"):
        simulate(mech, 0.1, method="pinocchio")


def test_pinocchio_method_runs_where_no_row_is_redundant():
    """cassie_reduced tilts the plantar rod's axis (no redundant row): method 'pinocchio' runs
    and ends where lagrange does (both at rtol 1e-9: the difference is the integration error)."""
    mech = _hip_drives("cassie_reduced")
    assert kinematics.mobility(mech, mech.q0)["redundant_rows"] == []
    ends = {m: simulate(mech, 0.05, method=m, rtol=1e-9) for m in ("lagrange", "pinocchio")}
    assert all(tr.status == "success" for tr in ends.values())
    assert np.abs(ends["pinocchio"].q[-1] - ends["lagrange"].q[-1]).max() < 1e-6


def test_gearbox_couplings_hold_in_a_passive_swing(method="manifold"):
    """cassie.sdf (rotors, ten gearbox couplings): q_op = -ratio q_ip along a passive swing, with
    the energy balance closed. lagrange and projection stop at t = 0 naming the cause: the right
    shin-spring closure (a prismatic cut joint, 5 rows) keeps two rows, x and ry, whose combination
    is independent of the others by 2e-7 of the rows' scale only (the SDF's rounded poses), which
    passes the rank test on J (7e-12) but squares to a Schur complement J M^-1 J^T of condition
    1.2e14 (> 1e12; the rotors' small inertias add only a factor 2.5). Proximal is refused
    (test below)."""
    mech = pinclear.load("cassie")
    tr = simulate(mech, 0.1, method=method, rtol=1e-8)
    assert tr.status == "success", tr.message
    assert tr.energy_balance()["ok"]
    m = mech.model
    for joint, ratio in (("pitch", 0.0625), ("knee", 0.0625), ("foot", 0.02), ("roll", 0.04)):
        ip, op = (m.joints[m.getJointId(f"left-{joint}-{x}")].idx_q for x in ("ip", "op"))
        assert np.abs(tr.q[:, op] + ratio * tr.q[:, ip]).max() < 1e-8
    assert np.abs(tr.q[-1]).max() > 1e-3                       # it moved


def test_gearbox_variant_shin_triangles_stay_rigid_with_manifold():
    """In cassie.sdf the shin-spring prismatic joint closes a planar triangle (knee, knee spring,
    shin: planar Grubler count 3 (3 - 1) - 2 x 3 = 0), so the knee-shin spring joint cannot move.
    The manifold method, which keeps every closure row on the constraint manifold, keeps it at
    rest on both legs while the legs swing, and every row closed to 1e-12. (The right triangle's
    lock rests on a row independent by 2e-7 only: dropping that row lets lagrange run but frees
    the right knee-shin joint, 7e-4 rad in 0.1 s; proximal's regularisation frees both: residual
    2e-8, knee rotors 1.2e-2 rad off; docs/import_export.md.)"""
    mech = pinclear.load("cassie")
    tr = simulate(mech, 0.1, method="manifold", rtol=1e-8, dt_out=0.01)
    assert tr.status == "success", tr.message
    ws, m = mech.workspace(), mech.model
    assert max(np.abs(kinematics.closure_residual(mech, ws, q)).max() for q in tr.q) < 1e-12
    for side in ("left", "right"):
        iq = m.joints[m.getJointId(f"{side}-knee-shin-joint")].idx_q
        assert np.abs(tr.q[:, iq]).max() < 1e-9
        assert abs(tr.q[-1, m.joints[m.getJointId(f"{side}-knee-ip")].idx_q]) > 1e-2     # the knee swung


@pytest.mark.parametrize("method", ["lagrange", "projection"])
def test_gearbox_variant_stops_naming_the_nearly_dependent_rows(method):
    """The failure of lagrange and projection on cassie.sdf names the two shin-spring rows the
    Schur complement cannot separate (docstring above) and the method that works."""
    mech = pinclear.load("cassie")
    with pytest.warns(RuntimeWarning, match="nearly dependent rows: right-shin-spring-joint.x, "
                      f"right-shin-spring-joint.ry\\); method '{method}'.*use method='manifold'"):
        tr = simulate(mech, 0.1, method=method)
    assert tr.status == "failed" and tr.t.size == 0


def test_proximal_refuses_the_gearbox_variant_naming_both_shin_triangles():
    """Both shin triangles of cassie.sdf rest on row combinations whose eigenvalue of J M^-1 J^T
    is ~1e-9 of the proximal regularisation rho: its iterations would leave all their force
    unapplied (it used to report success while both triangles flexed and the knee rotors ended
    1.2e-2 rad from manifold's result), and no iteration count within MAX_ITER_AUTO can resolve
    them. The run is refused before it starts, naming the shin-spring rows and manifold."""
    mech = pinclear.load("cassie")
    with pytest.raises(InputError, match=r"left-shin-spring-joint\.y.*right-shin-spring-joint\.ry.*more than 2000: "
                       r"this method does not hold these rows; use method='manifold'"):
        simulate(mech, 0.1, method="proximal", rtol=1e-8)


def test_view_reads_the_package_meshes():
    """The visuals' package://example-robot-data/... meshes resolve to example-robot-data's STL
    files (the meshcat view, pinclear.viz.geometry), one per link of cassie_v2."""
    from pinclear.io.sidecar import allowed_roots
    from pinclear.viz.geometry import confined_visual_model

    mech = pinclear.load("cassie_v2")
    vm = confined_visual_model(mech.model, models_dir() / "cassie_v2.urdf", allowed_roots(models_dir() / "x.yaml"))
    meshes = [g.meshPath for g in vm.geometryObjects]
    assert len(meshes) == 23 and all(p.endswith(".stl") and "cassie_description/meshes" in p for p in meshes)
