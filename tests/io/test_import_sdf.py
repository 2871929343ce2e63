"""pinclear import from SDF: a hand-written four-bar equals the bundled one, a gearbox coupling
follows its analytic oscillation, the cut choice and its override, malformed files named by
element and line."""
from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

import pinclear
from pinclear.core.errors import ModelFileError
from pinclear.dynamics.simulate import simulate
from pinclear.io.importers import convert, import_file
from pinclear.model import kinematics

DATA = Path(__file__).parents[1] / "data"
ROOT = Path(__file__).resolve().parents[2]
TC, TR = 0.6073259925291628, 1.6127688890867264   # coupler and rocker angles of the fixture (world)


def _bodies(model, data):
    """{link name: (placement, mass, world lever, world rotational inertia)} of the moving bodies."""
    out = {}
    for f in model.frames:
        if f.type == pin.FrameType.BODY and f.parentJoint > 0 and f.placement.isIdentity(1e-15):
            X = data.oMi[f.parentJoint]
            I = model.inertias[f.parentJoint]
            out[f.name] = (X, I.mass, X.act(I.lever), X.rotation @ I.inertia @ X.rotation.T)
    return out


@pytest.mark.parametrize("fixture, cuts", [("import_four_bar.sdf", ["B"]), ("import_four_bar.xml", []),
                                            ("import_four_bar_closing.urdf", [])])
def test_four_bar_fixtures_import_to_the_bundled_four_bar(tmp_path, fixture, cuts):
    """SDF, MJCF and closing-frame URDF, each written by hand: masses, inertias and kinematics of
    the imported tree equal the bundled ones to 1e-12 at every configuration (imported q =
    bundled q - the fixture's pose), and so do the loop's point rows. The SDF's cut joint is B
    (the deepest of four equal revolute joints); MJCF's connect and the URDF's closing frames
    give the loop as a spherical closure B."""
    rep = import_file(DATA / fixture, tmp_path)
    assert [c["joint"] for c in rep["cut"]] == cuts
    assert rep["residual_at_reference"] < 1e-15
    imp = pinclear.load(tmp_path / "four_bar.yaml")
    assert [c.name for c in imp.closures] == ["B"]
    ref = pinclear.load("four_bar_revolute")
    q_star = {"crank_joint": math.pi / 2, "coupler_joint": TC - math.pi / 2, "rocker_joint": TR}
    rng = np.random.default_rng(1)
    di, dr = imp.model.createData(), ref.model.createData()
    for trial in range(5):
        qb = np.zeros(ref.nq)
        qi = np.zeros(imp.nq)
        for name, q0 in q_star.items():
            x = q0 + (0.0 if trial == 0 else rng.uniform(-1, 1))
            qb[ref.model.joints[ref.model.getJointId(name)].idx_q] = x
            qi[imp.model.joints[imp.model.getJointId(name)].idx_q] = x - q0
        pin.forwardKinematics(imp.model, di, qi)
        pin.forwardKinematics(ref.model, dr, qb)
        bi, br = _bodies(imp.model, di), _bodies(ref.model, dr)
        assert set(bi) == set(br) == {"crank", "coupler", "rocker"}
        for name in bi:
            Xi, mi, ci, Ii = bi[name]
            Xr, mr, cr, Ir = br[name]
            assert mi == pytest.approx(mr, abs=1e-15)
            assert np.abs(ci - cr).max() < 1e-12 and np.abs(Ii - Ir).max() < 1e-12
            assert np.abs(Xi.translation - Xr.translation).max() < 1e-12
        # the closure's point rows (world axes) are the same function of the configuration
        pi = kinematics.closure_residual(imp, imp.workspace(), qi)[:3]
        pr = kinematics.closure_residual(ref, ref.workspace(), qb)[:3]
        assert np.abs(pi - pr).max() < 1e-12
        if trial == 0:
            assert np.abs(pr).max() < 1e-12          # the fixture is assembled
    assert kinematics.mobility(imp, imp.q0)["mobility"] == 1


def test_cut_override_keeps_the_rows_of_the_chosen_joint(tmp_path):
    _, sc, rep = convert(DATA / "import_four_bar.sdf", cut=["coupler_joint"])
    assert [c["joint"] for c in rep["cut"]] == ["coupler_joint"]
    assert "as asked (--cut)" in rep["cut"][0]["why"]
    with pytest.raises(ModelFileError, match="--cut: no joint named 'nope'"):
        convert(DATA / "import_four_bar.sdf", cut=["nope"])


GEAR = """<?xml version="1.0"?>
<sdf version="1.6">
  <model name="gears">
    <link name="base"/>
    <link name="wheel1"><inertial><mass>2.0</mass><inertia><ixx>0.3</ixx><iyy>0.3</iyy><izz>0.5</izz></inertia>
      </inertial></link>
    <link name="wheel2"><pose>1 0 0 0 0 0</pose><inertial><mass>1.0</mass>
      <inertia><ixx>0.06</ixx><iyy>0.06</iyy><izz>0.1</izz></inertia></inertial></link>
    <joint name="j1" type="revolute"><parent>base</parent><child>wheel1</child>
      <axis><xyz>0 0 1</xyz><dynamics><spring_stiffness>9.0</spring_stiffness><spring_reference>0</spring_reference>
      </dynamics></axis></joint>
    <joint name="j2" type="revolute"><parent>base</parent><child>wheel2</child><axis><xyz>0 0 -1</xyz></axis></joint>
    <joint name="gear" type="gearbox"><parent>wheel1</parent><child>wheel2</child>
      <gearbox_reference_body>base</gearbox_reference_body><gearbox_ratio>2.0</gearbox_ratio>
      <axis><xyz>0 0 1</xyz></axis><axis2><xyz>0 0 1</xyz></axis2></joint>
  </model>
</sdf>
"""


def test_gearbox_coupling_oscillates_at_the_reflected_inertia(tmp_path):
    """theta2 = -2 theta1 (SDF gearbox), spring k on joint 1: theta1 = A cos(w t) with
    w^2 = k / (I1 + 2^2 I2) (the second wheel's inertia reflected through the gear). Joint 2's
    axis is -z, so q2 = +2 q1."""
    (tmp_path / "gears.sdf").write_text(GEAR)
    rep = import_file(tmp_path / "gears.sdf", tmp_path / "out")
    assert rep["couplings"] == ["gear: q(j2) = 2.0 q(j1) + 0.0"]
    mech = pinclear.load(tmp_path / "out" / "gears.yaml")
    w = math.sqrt(9.0 / (0.5 + 4 * 0.1))
    i1, i2 = (mech.model.joints[mech.model.getJointId(n)].idx_q for n in ("j1", "j2"))
    q0 = np.zeros(mech.nq)
    q0[i1], q0[i2] = 0.1, 0.2
    T = 2 * math.pi / w
    for method in ("lagrange", "proximal"):
        tr = simulate(mech, T, q0=q0, method=method, rtol=1e-11, t_eval=np.linspace(0, T, 9))
        assert tr.status == "success"
        exact = 0.1 * np.cos(w * tr.t)
        assert np.abs(tr.q[:, i1] - exact).max() < 1e-7
        assert np.abs(tr.q[:, i2] - 2 * tr.q[:, i1]).max() < 1e-9


@pytest.mark.parametrize("text, where", [
    ('<sdf version="1.6"><model name="m"><link name="a"><pose>0 0 x 0 0 0</pose></link></model></sdf>',
     "<pose> (line 1): expected 6 number"),
    ('<sdf version="1.6"><model name="m">\n<link name="a"/>\n<joint name="j" type="revolute"><parent>a</parent>'
     "\n<child>b</child></joint></model></sdf>", "<child> (line 4): unknown link 'b'"),
    ('<sdf version="1.6"><model name="m"><link name="a"/><link name="b"/>\n<joint name="j" type="screw">'
     "<parent>a</parent><child>b</child></joint></model></sdf>", "<joint name='j'> (line 2): joint type 'screw'"),
    ('<sdf version="1.5"><model name="m"/></sdf>', "pinclear reads SDF 1.6 and later"),
    ('<!DOCTYPE x [<!ENTITY a "b">]><sdf version="1.6"/>', "DOCTYPE (line 1)"),
    ('<sdf version="1.6"><model name="m"><link name="a"/>', "malformed XML"),
    ('<sdf version="1.6"><model name="m"><link name="a"><pose relative_to="zz">0 0 0 0 0 0</pose></link>'
     "</model></sdf>", "names the frame 'zz'"),
    ('<sdf version="1.6"><model name="../../evil"><link name="a"/></model></sdf>', "is not a plain file name"),
    ('<sdf version="1.6"><model name="m">\n<link name="a&quot;/&gt;&lt;x"/></model></sdf>',
     "line 2: name 'a\"/><x' holds a character"),
])
def test_malformed_sdf_names_element_and_line(tmp_path, text, where):
    (tmp_path / "bad.sdf").write_text(text)
    with pytest.raises(ModelFileError) as exc:
        convert(tmp_path / "bad.sdf")
    msg = str(exc.value)
    assert where in msg and "\n" not in msg and str(tmp_path / "bad.sdf") in msg


@pytest.mark.slow
def test_cli_import_writes_files_and_reports_one_line_errors(tmp_path):
    r = subprocess.run([sys.executable, "-m", "pinclear.cli", "import", str(DATA / "import_four_bar.sdf"),
                        "--out", str(tmp_path)], capture_output=True, text=True, cwd=ROOT, timeout=300,
                       env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "four_bar.yaml").exists() and (tmp_path / "four_bar.import.json").exists()
    (tmp_path / "bad.sdf").write_text('<sdf version="1.6"><model name="m"><link name="a"><pose>1</pose></link>'
                                      "</model></sdf>")
    r = subprocess.run([sys.executable, "-m", "pinclear.cli", "import", str(tmp_path / "bad.sdf"), "--out",
                        str(tmp_path / "o")], capture_output=True, text=True, cwd=ROOT, timeout=300,
                       env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"})
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "<pose> (line 1)" in r.stderr


def test_mjcf_softness_is_kept_and_a_lonely_closing_frame_is_refused(tmp_path):
    rep = convert(DATA / "import_four_bar.xml")[2]
    assert any("solref" in n and "0.02 1" in n and "line 23" in n for n in rep["kept_as_data"])
    text = (DATA / "import_four_bar_closing.urdf").read_text().replace('<link name="closing_B_2"/>', "")
    text = text[:text.index('  <joint name="closing_B_2_frame"')] + "</robot>\n"
    (tmp_path / "bad.urdf").write_text(text)
    with pytest.raises(ModelFileError, match=r"link 'closing_B_1' \(line \d+\): closing frame without its partner "
                       "closing_B_2"):
        convert(tmp_path / "bad.urdf")


def _tree_at(mech, q):
    """The mechanism's tree placed at the assembled q, from Pinocchio's kinematics at q (an
    independent path to the fixture files): per joint (link name, parent joint, world placement,
    inertia, 'revolute'/'prismatic', world axis), and per spherical closure (its two joints and
    the world placements of its two frames)."""
    model, data = mech.model, mech.model.createData()
    J = pin.computeJointJacobians(model, data, q)
    pin.framesForwardKinematics(model, data, q)
    link = {0: "world"}
    for f in model.frames:
        if f.type == pin.FrameType.BODY and f.parentJoint > 0 and f.placement.isIdentity(0.0):
            link.setdefault(f.parentJoint, f.name)
    joints = {}
    for j in range(1, model.njoints):
        jm = model.joints[j]
        prismatic = jm.shortname().startswith("JointModelP")
        axis = J[:3, jm.idx_v] if prismatic else J[3:, jm.idx_v]       # world direction of the joint's motion
        joints[j] = (link[j], model.parents[j], pin.SE3(data.oMi[j]), model.inertias[j],
                     "prismatic" if prismatic else "revolute", axis)
    balls = []
    for c in mech.closures:
        assert c.type == "spherical"
        F1, F2 = model.frames[c.f1], model.frames[c.f2]
        balls.append((c.name, F1.parentJoint, F2.parentJoint, pin.SE3(data.oMf[c.f1]), pin.SE3(data.oMf[c.f2])))
    return link, joints, balls


def _num(x):
    return " ".join(repr(float(v)) for v in np.asarray(x, float).ravel())


def _pose(X):
    return _num(list(X.translation) + list(pin.rpy.matrixToRpy(X.rotation)))


def _inertia_xml(I, attrs=False):
    keys = (("ixx", 0, 0), ("iyy", 1, 1), ("izz", 2, 2), ("ixy", 0, 1), ("ixz", 0, 2), ("iyz", 1, 2))
    if attrs:
        return " ".join(f'{k}="{float(I[a, b])!r}"' for k, a, b in keys)
    return "".join(f"<{k}>{float(I[a, b])!r}</{k}>" for k, a, b in keys)


def _sdf_of(mech, q):
    """An SDF 1.7 text of a mechanism's tree placed at the assembled q, its spherical closures as
    ball joints."""
    link, joints, balls = _tree_at(mech, q)
    out = ['<sdf version="1.7"><model name="leg">']
    for j, (name, parent, X, Y, kind, axis) in joints.items():
        out.append(f'<link name="{name}"><pose>{_pose(X)}</pose><inertial><pose>{_num(Y.lever)} 0 0 0</pose>'
                   f"<mass>{Y.mass!r}</mass><inertia>{_inertia_xml(Y.inertia)}</inertia></inertial></link>")
        out.append(f'<joint name="{mech.model.names[j]}" type="{kind}"><parent>{link[parent]}</parent>'
                   f'<child>{name}</child><pose relative_to="__model__">{_pose(X)}</pose>'
                   f'<axis><xyz expressed_in="__model__">{_num(axis)}</xyz></axis></joint>')
    for name, j1, j2, X1, X2 in balls:
        out.append(f'<joint name="{name}" type="ball"><parent>{link[j1]}</parent><child>{link[j2]}</child>'
                   f'<pose relative_to="__model__">{_pose(X2)}</pose></joint>')
    return "\n".join(out + ["</model></sdf>"])


def _mjcf_of(mech, q):
    """An MJCF text of the same tree: nested bodies placed relative to their parents (pos, quat
    w x y z), one hinge or slide per body with its axis in the body's axes, the spherical closures
    as connect equalities between sites at the two closure frames."""
    link, joints, balls = _tree_at(mech, q)
    X = {0: pin.SE3.Identity(), **{j: v[2] for j, v in joints.items()}}
    sites = {j: [] for j in X}
    for name, j1, j2, X1, X2 in balls:
        for k, (jj, Xs) in enumerate(((j1, X1), (j2, X2)), 1):
            Y = X[jj].actInv(Xs)
            sites[jj].append(f'<site name="{name}_{k}" pos="{_num(Y.translation)}" '
                             f'quat="{_num(pin.Quaternion(Y.rotation).coeffs()[[3, 0, 1, 2]])}"/>')

    def body(j):
        name, parent, Xj, Y, kind, axis = joints[j]
        rel = X[parent].actInv(Xj)
        out = [f'<body name="{name}" pos="{_num(rel.translation)}" '
               f'quat="{_num(pin.Quaternion(rel.rotation).coeffs()[[3, 0, 1, 2]])}">',
               f'<joint name="{mech.model.names[j]}" type="{"slide" if kind == "prismatic" else "hinge"}" '
               f'axis="{_num(Xj.rotation.T @ axis)}"/>',
               f'<inertial pos="{_num(Y.lever)}" mass="{Y.mass!r}" fullinertia="'
               f'{_num([Y.inertia[a, b] for a, b in ((0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2))])}"/>',
               *sites[j]]
        for k in joints:
            if joints[k][1] == j:
                out += body(k)
        return out + ["</body>"]

    world = list(sites[0]) + [line for j in joints if joints[j][1] == 0 for line in body(j)]
    eqs = [f'<connect name="{name}" site1="{name}_1" site2="{name}_2"/>' for name, *_ in balls]
    return "\n".join(['<mujoco model="leg">', '<compiler angle="radian"/>', "<worldbody>", *world, "</worldbody>",
                      "<equality>", *eqs, "</equality>", "</mujoco>"])


def _closing_urdf_of(mech, q):
    """A URDF text of the same tree as a CAD exporter writes it (onshape-to-robot): each joint's
    origin relative to its parent link, its axis in its own frame, and each spherical closure as
    the frames closing_<name>_1 / closing_<name>_2 fixed to its two links."""
    link, joints, balls = _tree_at(mech, q)
    X = {0: pin.SE3.Identity(), **{j: v[2] for j, v in joints.items()}}
    out = ['<robot name="leg">', '<link name="world"/>']
    for j, (name, parent, Xj, Y, kind, axis) in joints.items():
        out.append(f'<link name="{name}"><inertial><origin xyz="{_num(Y.lever)}" rpy="0 0 0"/>'
                   f'<mass value="{Y.mass!r}"/><inertia {_inertia_xml(Y.inertia, attrs=True)}/></inertial></link>')
        rel = X[parent].actInv(Xj)
        out.append(f'<joint name="{mech.model.names[j]}" type="{kind}"><parent link="{link[parent]}"/>'
                   f'<child link="{name}"/><origin xyz="{_num(rel.translation)}" '
                   f'rpy="{_num(pin.rpy.matrixToRpy(rel.rotation))}"/><axis xyz="{_num(Xj.rotation.T @ axis)}"/>'
                   '<limit lower="-10" upper="10" effort="1" velocity="1"/></joint>')
    for name, j1, j2, X1, X2 in balls:
        for k, (jj, Xs) in enumerate(((j1, X1), (j2, X2)), 1):
            rel = X[jj].actInv(Xs)
            out.append(f'<link name="closing_{name}_{k}"/><joint name="closing_{name}_{k}_frame" type="fixed">'
                       f'<parent link="{link[jj]}"/><child link="closing_{name}_{k}"/><origin '
                       f'xyz="{_num(rel.translation)}" rpy="{_num(pin.rpy.matrixToRpy(rel.rotation))}"/></joint>')
    return "\n".join(out + ["</robot>"])


@pytest.mark.parametrize("writer, suffix, cuts", [(_sdf_of, "sdf", ["S2", "S3", "S4", "S5"]), (_mjcf_of, "xml", []),
                                                   (_closing_urdf_of, "urdf", [])])
def test_four_ups_upu_fixtures_equal_the_bundled(tmp_path, writer, suffix, cuts):
    """The 4UPS-UPU of paper 000 as SDF, MJCF and closing-frame URDF (tree at the assembled pose,
    written from Pinocchio's kinematics there; the platform's four S joints as ball joints, connect
    equalities or closing_S*_1/_2 frames): the SDF importer cuts exactly the four ball joints (3
    rows each, the fewest of every loop), the others take the four given closures, and the
    imported tree and closures equal the bundled ones to 1e-12 at other configurations (imported
    q = bundled q - the assembled q)."""
    ref = pinclear.load("four_ups_upu")
    q_star = kinematics.assemble(ref, ref.q0)
    (tmp_path / f"leg.{suffix}").write_text(writer(ref, q_star))
    rep = import_file(tmp_path / f"leg.{suffix}", tmp_path / "out")
    assert sorted(c["joint"] for c in rep["cut"]) == cuts
    assert rep["closure_rows"] == 12 and rep["residual_at_reference"] < 1e-12
    imp = pinclear.load(tmp_path / "out" / "leg.yaml")
    rng = np.random.default_rng(5)
    di, dr = imp.model.createData(), ref.model.createData()
    for _ in range(3):
        qb = q_star + 0.1 * rng.standard_normal(ref.nq)
        qi = np.zeros(imp.nq)
        for j in range(1, ref.model.njoints):
            A, B = ref.model.joints[j], imp.model.joints[imp.model.getJointId(ref.model.names[j])]
            qi[B.idx_q] = qb[A.idx_q] - q_star[A.idx_q]
        pin.forwardKinematics(imp.model, di, qi)
        pin.forwardKinematics(ref.model, dr, qb)
        for j in range(1, ref.model.njoints):
            jb = imp.model.getJointId(ref.model.names[j])
            Xi, Xr = di.oMi[jb], dr.oMi[j]
            assert np.abs(Xi.translation - Xr.translation).max() < 1e-12
            Ii, Ir = imp.model.inertias[jb], ref.model.inertias[j]
            assert abs(Ii.mass - Ir.mass) < 1e-12
            assert np.abs(Xi.act(Ii.lever) - Xr.act(Ir.lever)).max() < 1e-12
            Iwi = Xi.rotation @ Ii.inertia @ Xi.rotation.T
            Iwr = Xr.rotation @ Ir.inertia @ Xr.rotation.T
            assert np.abs(Iwi - Iwr).max() < 1e-12
        pi = kinematics.closure_residual(imp, imp.workspace(), qi)
        pr = kinematics.closure_residual(ref, ref.workspace(), qb)
        for c in ref.closures:                  # each ball's point rows (world axes), matched by name
            k = [x.name for x in imp.closures].index(c.name)
            ri, rr = 3 * k, 3 * ref.closures.index(c)
            assert np.abs(pi[ri:ri + 3] - pr[rr:rr + 3]).max() < 1e-12


MULTI = """<mujoco model="gimbal">
  <compiler angle="radian"/>
  <worldbody>
    <body name="arm" pos="0.1 0.2 0.3" quat="0.9 0.1 -0.3 0.2">
      <joint name="yaw" type="hinge" pos="0.05 0 0" axis="0 0 1"/>
      <joint name="lift" type="slide" axis="0.3 0.4 0"/>
      <joint name="pitch" type="hinge" pos="0 -0.1 0.02" axis="0 1 0"/>
      <inertial pos="0.2 0 0" mass="1.2" diaginertia="0.01 0.02 0.03"/>
      <body name="hand" pos="0.4 0 0"><joint name="roll" type="hinge" axis="1 0 0"/>
        <inertial pos="0.05 0 0" mass="0.3" diaginertia="0.001 0.002 0.002"/></body>
    </body>
  </worldbody>
</mujoco>
"""


def test_mjcf_body_with_several_joints_is_a_chain_of_massless_links(tmp_path):
    """A body with three joints (MuJoCo applies them in order, each at its pos in the body's
    frame as moved by the ones before) imports as a chain of massless links named BODY__JOINT;
    the bodies' world placements equal MuJoCo's own kinematics (mj_kinematics) at random q, to
    1e-12."""
    mujoco = pytest.importorskip("mujoco")
    (tmp_path / "gimbal.xml").write_text(MULTI)
    import_file(tmp_path / "gimbal.xml", tmp_path / "out")
    mech = pinclear.load(tmp_path / "out" / "gimbal.yaml")
    model, data = mech.model, mech.model.createData()
    assert {f.name for f in model.frames} >= {"arm__yaw", "arm__lift", "arm", "hand"}
    m = mujoco.MjModel.from_xml_string(MULTI)
    d = mujoco.MjData(m)
    rng = np.random.default_rng(2)
    for _ in range(3):
        q = rng.uniform(-1, 1, mech.nq)
        for j in range(1, model.njoints):
            d.qpos[m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, model.names[j])]] = \
                q[model.joints[j].idx_q]
        mujoco.mj_kinematics(m, d)
        pin.framesForwardKinematics(model, data, q)
        for name in ("arm", "hand"):
            # the body's own frame: LINK__ref where the URDF link frame moved onto its joint's axis
            X = data.oMf[model.getFrameId(f"{name}__ref" if model.existFrame(f"{name}__ref") else name)]
            b = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)
            assert np.abs(X.translation - d.xpos[b]).max() < 1e-12
            assert np.abs(X.rotation - d.xmat[b].reshape(3, 3)).max() < 1e-12
