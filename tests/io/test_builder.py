"""pinclear.io.builder: names checked before anything is written, escaped XML, files only inside
the named folder, rods along any axis, spherical and universal joints as revolute chains with
massless links, and a spherical chain turned so that its start lies 90 deg from its lock
(issue 52, item 1)."""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest

from pinclear.core.errors import InputError
from pinclear.io.builder import NAME_PATTERN, Builder, rod
from pinclear.io.urdf_write import thin_rod, urdf_joint, urdf_link
from pinclear.model.joint_chains import lock_margins, spherical_chains

EVIL = 'a"/><link name="evil'
BOB = {"mass": 2.0, "com": (0.0, 0.0, -0.5), "inertia": (0.01, 0.02, 0.03)}


def _files(folder):
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*"))


@pytest.mark.parametrize("name", ["../escaped", "a/b", "", "1st", EVIL, "x" * 101, "a.b", "a b"])
def test_a_mechanism_name_that_is_not_a_name_is_one_error_naming_it_and_the_pattern(tmp_path, name):
    with pytest.raises(InputError) as err:
        Builder(name).write(tmp_path / "inside")
    msg = str(err.value)
    assert len(msg.splitlines()) == 1 and repr(name) in msg and NAME_PATTERN in msg, msg
    assert _files(tmp_path) == []                      # nothing written, inside or outside


@pytest.mark.parametrize("where", ["body", "joint", "closure", "drive", "clearance", "frame"])
def test_every_name_the_builder_writes_is_checked(where):
    b = Builder("m").body("arm", 1.0)
    call = {"body": lambda: b.body(EVIL, 1.0),
            "joint": lambda: b.joint(EVIL, "revolute", "ground", "arm"),
            "closure": lambda: b.closure(EVIL, "spherical", ("ground", (0, 0, 0)), ("arm", (0, 0, 0))),
            "drive": lambda: b.drive("j", {"type": "constant", "value": 0.0}, name=EVIL),
            "clearance": lambda: b.clearance(EVIL, type="spherical"),
            "frame": lambda: b.platform("arm", xyz=(0, 0, 0), name=EVIL)}[where]
    with pytest.raises(InputError, match=r"name 'a\"/><link name=\"evil' is not a name"):
        call()


def test_the_files_land_in_the_named_folder_only(tmp_path):
    """A valid name is a file name: NAME.urdf and NAME.yaml inside the folder; a link planted
    at the target is replaced, never followed (what it pointed to stays as it was)."""
    inside = tmp_path / "inside"
    inside.mkdir()
    victim = tmp_path / "victim.txt"
    victim.write_text("keep")
    (inside / "pend.urdf").symlink_to(victim)
    b = Builder("pend").body("arm", **BOB)
    b.joint("j", "revolute", "ground", "arm", axis=(0, 1, 0), q=0.3)
    mech = b.write(inside)
    assert _files(tmp_path) == ["inside", "inside/pend.urdf", "inside/pend.yaml", "victim.txt"]
    assert victim.read_text() == "keep" and not (inside / "pend.urdf").is_symlink()
    assert mech.nq == 1


@pytest.mark.parametrize("name", [EVIL, "a<b>&c'd", 'q"'])
def test_the_urdf_writer_escapes_what_it_writes(name):
    """The writer shared with the bundled generators: whatever the name, the XML parses and
    carries it as the attribute's value (never as markup)."""
    text = (f"<robot name='r'>{urdf_link(name)}{urdf_link('b', (1.0, (0, 0, 0), np.eye(3)))}"
            f"{urdf_joint(name, 'revolute', name, 'b', axis=(0, 0, 1))}</robot>")
    root = ET.fromstring(text)
    assert [ln.get("name") for ln in root.findall("link")] == [name, "b"]
    assert root.find("joint").get("name") == name and root.find("joint/parent").get("link") == name


def test_a_rod_along_any_axis():
    """Thin rod: m L^2/12 sin^2(phi) about an axis at angle phi to the rod (closed form), the
    token axial moment along the rod; "x" is the writer's thin_rod."""
    m, L = 0.6, 0.4
    i = m * L * L / 12
    assert np.array_equal(rod(m, L), thin_rod(m, L))
    assert np.allclose(rod(m, L, "z"), np.diag([i, i, 1e-7]), rtol=0, atol=1e-15)
    d = np.array([1.0, 2.0, 2.0]) / 3.0
    I = rod(m, L, d)
    for u in (d, np.array([0.0, 1.0, -1.0]) / math.sqrt(2), np.array([1.0, 0.0, 0.0])):
        phi = math.acos(abs(d @ u))
        expected = i * math.sin(phi) ** 2 + 1e-7 * math.cos(phi) ** 2
        assert u @ I @ u == pytest.approx(expected, rel=1e-12)
    with pytest.raises(InputError, match="not a direction"):
        rod(m, L, (0, 0, 0))
    with pytest.raises(InputError, match="axis 'w'"):
        rod(m, L, "w")


def _spherical_pendulum(tmp_path, rpy=(0.0, 0.0, 0.0), q=None):
    b = Builder("sph").body("bob", **BOB)
    b.joint("S", "spherical", "ground", "bob", xyz=(0.1, 0.2, 1.0), rpy=rpy, q=q)
    return b, b.write(tmp_path)


def test_a_spherical_joint_is_three_concurrent_revolutes_with_massless_links(tmp_path):
    """The chain S_1..3 about x, y, z with two massless links: at q = 0 its mass matrix is the
    bob's inertia about the pivot (parallel axes: I_c + m (|c|^2 1 - c c^T)), nothing of the links."""
    _, mech = _spherical_pendulum(tmp_path)
    model = mech.model
    assert [model.names[j] for j in range(1, model.njoints)] == ["S_1", "S_2", "S_3"]
    assert [model.inertias[j].mass for j in (1, 2)] == [0.0, 0.0] and model.inertias[3].mass == 2.0
    assert spherical_chains(model) == [(1, 2, 3)]
    c = np.array(BOB["com"])
    expected = np.diag(BOB["inertia"]) + BOB["mass"] * (c @ c * np.eye(3) - np.outer(c, c))
    M = pin.crba(model, model.createData(), np.zeros(3))
    assert np.allclose(np.triu(M) + np.triu(M, 1).T, expected, rtol=1e-12, atol=1e-15)


def test_the_lock_margin_is_the_distance_to_the_singular_chain(tmp_path):
    """90 deg - |q2| (the third axis turns about the second, perpendicular to both others), and
    where it is 0 the axes [a1 a2 a3] lose rank: the chain's angular velocity loses a freedom."""
    _, mech = _spherical_pendulum(tmp_path)
    model, data = mech.model, mech.model.createData()
    for q2 in (0.0, 0.3, -1.2, math.pi / 2):
        q = np.array([0.7, q2, -0.4])
        (margin,) = lock_margins(model, q).values()
        assert margin == pytest.approx(math.pi / 2 - abs(q2), abs=1e-12)
        pin.computeJointJacobians(model, data, q)
        A = pin.getJointJacobian(model, data, 3, pin.ReferenceFrame.WORLD)[3:, :]
        assert np.linalg.svd(A, compute_uv=False)[-1] == pytest.approx(_smin(q2), abs=1e-12)
    assert lock_margins(model, np.array([0.0, math.pi / 2, 0.0]))["S"] == pytest.approx(0.0, abs=1e-12)


def _smin(q2):
    """Smallest singular value of [a1 a2 a3] with a2 perpendicular to a1 and a3, and the angle
    between a1 and a3 equal to 90 deg - q2: the Gram matrix has eigenvalues 1 and 1 -+ |cos(a1, a3)|."""
    return math.sqrt(1.0 - abs(math.sin(q2)))


def test_write_turns_a_spherical_chain_to_its_start(tmp_path):
    """Given rpy and chain angles, write() moves the chain's rotation into its frame: the same
    start pose (the bob's world rotation R(rpy) Rx(q1) Ry(q2) Rz(q3)), chain angles 0, 90 deg
    from the lock."""
    rpy, q = (0.2, -0.5, 1.1), (0.3, 1.2, -0.2)
    _, mech = _spherical_pendulum(tmp_path, rpy=rpy, q=q)
    expected = pin.rpy.rpyToMatrix(*rpy)
    for axis, a in zip(np.eye(3), q):
        expected = expected @ pin.exp3(axis * a)
    data = mech.model.createData()
    pin.forwardKinematics(mech.model, data, mech.q0)
    assert np.allclose(mech.q0, 0.0, atol=0) and np.allclose(data.oMi[3].rotation, expected, atol=1e-14)
    assert lock_margins(mech.model, mech.q0)["S"] == pytest.approx(math.pi / 2, abs=1e-12)
    text = (tmp_path / "sph.yaml").read_text()
    assert "S_1: 0.0, S_2: 0.0, S_3: 0.0" in text


def test_a_universal_joint_keeps_its_axes_perpendicular(tmp_path):
    b = Builder("uj").body("arm", **BOB)
    with pytest.raises(InputError, match=r"axis .* and axis2 .* are not perpendicular \(angle 45 deg"):
        b.joint("U", "universal", "ground", "arm", axis=(1, 0, 0), axis2=(1, 1, 0))
    b.joint("U", "universal", "ground", "arm", axis=(1, 1, 0), axis2=(0, 0, 1), q=(0.2, -0.3))
    mech = b.write(tmp_path)
    model, data = mech.model, mech.model.createData()
    assert [model.names[j] for j in (1, 2)] == ["U_1", "U_2"] and model.inertias[1].mass == 0.0
    assert spherical_chains(model) == []
    for q in (np.array([0.2, -0.3]), np.array([1.4, 2.9])):
        pin.computeJointJacobians(model, data, q)
        A = pin.getJointJacobian(model, data, 2, pin.ReferenceFrame.WORLD)[3:, :]
        assert abs(A[:, 0] @ A[:, 1]) < 1e-14 and np.allclose(np.linalg.norm(A, axis=0), 1.0, atol=1e-14)
        assert np.allclose(A[:, 0], np.array([1, 1, 0]) / math.sqrt(2), atol=1e-14)


@pytest.mark.parametrize("kw, match", [
    ({"type": "spherical", "axis": (0, 0, 1)}, "takes no axis"),
    ({"type": "spherical", "v": (0, 0, 0)}, "takes no initial v"),
    ({"type": "spherical", "q": (0.1, 0.2)}, r"3 angles \[rad\], one per axis"),
    ({"type": "universal", "q": 0.1}, r"2 angles \[rad\], one per axis"),
    ({"type": "revolute", "axis2": (0, 1, 0)}, "axis2 is a universal joint's"),
    ({"type": "revolute", "axis": (0, 0, 0)}, "not a direction")])
def test_chain_mistakes_are_refused_where_made(kw, match):
    b = Builder("m").body("arm", 1.0)
    with pytest.raises(InputError, match=match):
        b.joint("J", parent="ground", child="arm", **kw)


def test_names_are_unique_including_the_chains(tmp_path):
    b = Builder("m").body("arm", 1.0).body("hand", 1.0)
    b.joint("S", "spherical", "ground", "arm")
    with pytest.raises(InputError, match="joint 'S_2' defined twice"):
        b.joint("S_2", "revolute", "arm", "hand")
    with pytest.raises(InputError, match="body 'S_link1' defined twice"):
        b.body("S_link1", 1.0)
    with pytest.raises(InputError, match="body 'arm' already hangs from a joint"):
        b.joint("K", "revolute", "hand", "arm")
    b.closure("C", "spherical", ("ground", (0, 0, 0)), ("hand", (0, 0, 0)))
    with pytest.raises(InputError, match="closure 'C' defined twice"):
        b.closure("C", "spherical", ("ground", (0, 0, 0)), ("hand", (0, 0, 0)))
    with pytest.raises(InputError, match="joint 'C' defined twice"):
        b.joint("C", "revolute", "arm", "hand")
