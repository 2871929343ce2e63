"""The importers' limits (docs/security.md, "Importers"), each at the limit (imported) and one
past it (one line naming the source file): bodies, joints, the spanning tree's depth, SDF frame
chains, the XML's bytes, elements and nesting, the pinclear annotation's bytes and nesting; for
every reader the limit applies to. Nothing past a limit reaches Pinocchio's parser."""
from __future__ import annotations

import pytest

from pinclear.core.errors import ModelFileError
from pinclear.io.importers import convert

INERTIAL_MJCF = '<inertial pos="0 0 0" mass="1" diaginertia="0.1 0.1 0.1"/>'
INERTIAL_SDF = "<inertial><mass>1</mass><inertia><ixx>0.1</ixx><iyy>0.1</iyy><izz>0.1</izz></inertia></inertial>"
INERTIAL_URDF = ('<inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/>'
                 "</inertial>")


def _limits():
    from pinclear.io.importers import graph

    return graph


def star(fmt, n):
    """n bodies, each on its own revolute joint to the world."""
    if fmt == "xml":
        bodies = "".join(f'<body name="b{k}" pos="{k} 0 0"><joint name="j{k}" axis="0 0 1"/>{INERTIAL_MJCF}</body>'
                         for k in range(n))
        return f'<mujoco model="m"><worldbody>{bodies}</worldbody></mujoco>'
    if fmt == "sdf":
        links = "".join(f'<link name="b{k}"><pose>{k} 0 0 0 0 0</pose>{INERTIAL_SDF}</link>'
                        f'<joint name="j{k}" type="revolute"><parent>world</parent><child>b{k}</child></joint>'
                        for k in range(n))
        return f'<sdf version="1.7"><model name="m">{links}</model></sdf>'
    links = "".join(f'<link name="b{k}">{INERTIAL_URDF}</link><joint name="j{k}" type="revolute"><parent link="world"/>'
                    f'<child link="b{k}"/><origin xyz="{k} 0 0"/><axis xyz="0 0 1"/></joint>' for k in range(n))
    return f'<robot name="m"><link name="world"/>{links}</robot>'


def chain(fmt, n):
    """n bodies in a chain, each on a revolute joint to the one before: n joints deep."""
    if fmt == "xml":
        head = "".join(f'<body name="b{k}" pos="0.01 0 0"><joint name="j{k}" axis="0 0 1"/>{INERTIAL_MJCF}'
                       for k in range(n))
        return f'<mujoco model="m"><worldbody>{head}{"</body>" * n}</worldbody></mujoco>'
    if fmt == "sdf":
        links = "".join(f'<link name="b{k}"><pose>{0.01 * k} 0 0 0 0 0</pose>{INERTIAL_SDF}</link>'
                        f'<joint name="j{k}" type="revolute"><parent>{"world" if k == 0 else f"b{k - 1}"}</parent>'
                        f"<child>b{k}</child></joint>" for k in range(n))
        return f'<sdf version="1.7"><model name="m">{links}</model></sdf>'
    links = "".join(f'<link name="b{k}">{INERTIAL_URDF}</link><joint name="j{k}" type="revolute">'
                    f'<parent link="{"world" if k == 0 else f"b{k - 1}"}"/><child link="b{k}"/>'
                    '<origin xyz="0.01 0 0"/><axis xyz="0 0 1"/></joint>' for k in range(n))
    return f'<robot name="m"><link name="world"/>{links}</robot>'


def _convert(tmp_path, fmt, text):
    path = tmp_path / f"m.{fmt}"
    path.write_text(text)
    return path, convert(path)


def _refused(tmp_path, fmt, text, *expect):
    path = tmp_path / f"m.{fmt}"
    path.write_text(text)
    with pytest.raises(ModelFileError) as exc:
        convert(path)
    msg = str(exc.value)
    assert msg.startswith(f"{path}: ") and "\n" not in msg and all(e in msg for e in expect), msg


@pytest.mark.parametrize("fmt", ["xml", "sdf", "urdf"])
def test_bodies_at_the_limit_and_one_past(fmt, tmp_path):
    n = _limits().MAX_BODIES
    _, (_, _, report) = _convert(tmp_path, fmt, star(fmt, n))
    assert report["bodies"] == n
    _refused(tmp_path, fmt, star(fmt, n + 1), f"at most {n}")


@pytest.mark.parametrize("fmt", ["xml", "sdf", "urdf"])
def test_tree_depth_at_the_limit_and_one_past(fmt, tmp_path):
    """A chain MAX_DEPTH joints deep imports; one more is refused before the URDF text reaches
    Pinocchio (whose parser recurses once a level)."""
    n = _limits().MAX_DEPTH
    _, (_, _, report) = _convert(tmp_path, fmt, chain(fmt, n))
    assert report["depth"] == n
    _refused(tmp_path, fmt, chain(fmt, n + 1), f"lies {n + 1} joints below the world", f"at most {n}")


@pytest.mark.parametrize("fmt", ["xml", "sdf"])
def test_joints_at_the_limit_and_one_past(fmt, tmp_path):
    """MAX_JOINTS joints between two bodies (one kept, the others cut into welds)."""
    n = _limits().MAX_JOINTS
    if fmt == "xml":
        def text(m):
            joints = "".join('<joint type="slide" axis="1 0 0"/>' for _ in range(m))
            return f'<mujoco model="m"><worldbody><body name="b">{joints}{INERTIAL_MJCF}</body></worldbody></mujoco>'
        # one body with m joints is a chain of m - 1 massless links: past MAX_BODIES first
        _refused(tmp_path, fmt, text(n + 1), f"{n + 1} <joint> elements", f"at most {n}")
        return

    def text(m):
        joints = "".join(f'<joint name="j{k}" type="fixed"><parent>world</parent><child>b</child></joint>'
                         for k in range(m))
        return f'<sdf version="1.7"><model name="m"><link name="b">{INERTIAL_SDF}</link>{joints}</model></sdf>'
    _, (_, sidecar, _) = _convert(tmp_path, fmt, text(n))
    assert len(sidecar["closures"]) == n - 1
    _refused(tmp_path, fmt, text(n + 1), f"at most {n}")


def _frames(n, reverse):
    """An SDF model with a chain of n frames, f0 attached to the link base, each next one to the
    one before; listed last to first when ``reverse`` (the limit does not depend on the order)."""
    frames = [f'<frame name="f{k}" attached_to="{"base" if k == 0 else f"f{k - 1}"}"><pose>0.001 0 0 0 0 0</pose>'
              "</frame>" for k in range(n)]
    if reverse:
        frames.reverse()
    return (f'<sdf version="1.7"><model name="m"><link name="base"/>{"".join(frames)}<link name="a">{INERTIAL_SDF}'
            '</link><joint name="j" type="revolute"><parent>base</parent><child>a</child></joint></model></sdf>')


@pytest.mark.parametrize("reverse", [False, True])
def test_sdf_frame_chain_at_the_limit_and_one_past(reverse, tmp_path):
    """A frame's depth is its chain's length from the model frame (the link base is 1, f0 2, ...);
    resolved by a loop, not a recursion (3000 chained frames ended in a RecursionError)."""
    m = _limits().MAX_FRAME_CHAIN
    _, (_, _, report) = _convert(tmp_path, "sdf", _frames(m - 1, reverse))
    assert report["bodies"] == 2
    _refused(tmp_path, "sdf", _frames(m, reverse), f"a chain of {m + 1} frames", f"at most {m}")
    _refused(tmp_path, "sdf", _frames(m + 100, reverse), "frames, each relative to the next")
    _refused(tmp_path, "sdf", _frames(3000, reverse), "3000 <frame> elements")


@pytest.mark.parametrize("fmt, root", [("xml", "mujoco"), ("sdf", "sdf"), ("urdf", "robot")])
def test_xml_bytes_and_nesting_one_past(fmt, root, tmp_path):
    from pinclear.io.importers import xml

    _refused(tmp_path, fmt, f"<{root}>" + " " * xml.MAX_XML_BYTES + f"</{root}>",
             f"more than {xml.MAX_XML_BYTES} bytes")
    d = xml.MAX_XML_DEPTH
    _refused(tmp_path, fmt, f"<{root}>" + "<a>" * d + "</a>" * d + f"</{root}>", f"nested more than {d} levels")
    # at the nesting limit the parser reads it (the reader then names what it lacks)
    _refused(tmp_path, fmt, f"<{root}>" + "<a>" * (d - 1) + "</a>" * (d - 1) + f"</{root}>")


@pytest.mark.slow
@pytest.mark.parametrize("fmt, root", [("xml", "mujoco"), ("sdf", "sdf"), ("urdf", "robot")])
def test_xml_elements_one_past(fmt, root, tmp_path):
    from pinclear.io.importers import xml

    _refused(tmp_path, fmt, f"<{root}>" + "<a/>" * xml.MAX_XML_ELEMENTS + f"</{root}>",
             f"more than {xml.MAX_XML_ELEMENTS} elements")


def test_annotation_bytes_and_nesting_at_the_limit_and_one_past():
    from pinclear.io.importers.annotation import MAX_ANNOTATION_BYTES, MAX_ANNOTATION_DEPTH, check_annotation

    d = MAX_ANNOTATION_DEPTH
    nested = '{"parameters": ' + "[" * (d - 1) + "]" * (d - 1) + "}"
    got, depth = check_annotation(nested, "f.xml", "<text>")["parameters"], 1
    while got:
        got, depth = got[0], depth + 1
    assert depth == d - 1
    with pytest.raises(ModelFileError, match=f"nested more than {d} levels"):
        check_annotation('{"parameters": ' + "[" * d + "]" * d + "}", "f.xml", "<text>")
    pad = '{"description": "' + "x" * (MAX_ANNOTATION_BYTES - 19) + '"}'
    assert len(pad) == MAX_ANNOTATION_BYTES and check_annotation(pad, "f.xml", "<text>")["description"]
    with pytest.raises(ModelFileError, match=f"{MAX_ANNOTATION_BYTES + 1} bytes"):
        check_annotation(pad[:-2] + 'x"}', "f.xml", "<text>")
