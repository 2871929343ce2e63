"""Property-based fuzzing of every importer (issue 53, item 4): a mutated SDF, MJCF or
closing-frame URDF, or a random joint graph (cycles, self-parents, unknown links, joints between
the same links), ends either in an import or in a one-line ModelFileError naming the file; never
in another exception, never in a hang. Derandomized, a deadline per example, a wall-clock alarm
as the backstop for a hang; a few seconds per reader."""
from __future__ import annotations

import copy
import xml.etree.ElementTree as ET

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from pinclear.core.errors import ModelFileError
from pinclear.io.importers import convert
from tests.helpers import alarm
from tests.io.test_import_hostile import BASE

#: seconds one example may take before it counts as a hang (a convert takes ~0.05 s)
CASE_LIMIT = 20
FAST = settings(max_examples=40, deadline=5000, derandomize=True, database=None,
                suppress_health_check=list(HealthCheck))
#: a random graph converts in ~0.02 s: more examples in the same few seconds
GRAPHS = settings(FAST, max_examples=150)

JUNK = st.sampled_from(["", "nan", "-inf", "1e400", "-1", "0", "0 0 0", "0 0 0 0", "1 2", "abc", "1e-300", "x y z",
                        "world", "a", "b", "zz", "../x", "os:system", "1 0 0 0 0 0 0", "&amp;", "true", "ball",
                        "free", "continuous", "gearbox", "closing_C_1", "[1]", "{}"]) | st.text(max_size=8)




def _imports_or_one_line(path):
    with alarm(CASE_LIMIT):
        try:
            convert(path)
        except ModelFileError as exc:
            msg = str(exc)
            assert msg.startswith(f"{path}: ") and "\n" not in msg, msg


def _mutate(text, data):
    """The base file with one to three edits: an attribute or a text set to junk, an element
    removed or duplicated, or a tag renamed."""
    root = ET.fromstring(text)
    for _ in range(data.draw(st.integers(1, 3))):
        els = list(root.iter())
        el = els[data.draw(st.integers(0, len(els) - 1))]
        what = data.draw(st.sampled_from(["attr", "text", "remove", "duplicate", "tag"]))
        if what == "attr" and el.attrib:
            el.set(data.draw(st.sampled_from(sorted(el.attrib))), data.draw(JUNK))
        elif what == "text":
            el.text = data.draw(JUNK)
        elif what in ("remove", "duplicate") and el is not root:
            parent = next(p for p in root.iter() if el in list(p))
            if what == "remove":
                parent.remove(el)
            else:
                parent.append(copy.deepcopy(el))
        elif what == "tag" and el is not root:
            el.tag = data.draw(st.sampled_from(["joint", "body", "link", "site", "frame", "inertial", "pose", "x"]))
    return ET.tostring(root, encoding="unicode")


@pytest.mark.parametrize("fmt", sorted(BASE))
def test_mutated_files_import_or_fail_in_one_line(fmt, tmp_path_factory):
    folder = tmp_path_factory.mktemp(f"fuzz_{fmt}")

    @FAST
    @given(data=st.data())
    def run(data):
        path = folder / f"m.{fmt}"
        path.write_text(_mutate(BASE[fmt], data))
        _imports_or_one_line(path)

    run()


GRAPH = st.tuples(st.integers(1, 6), st.lists(st.tuples(st.integers(-2, 6), st.integers(-2, 6),
                                                        st.sampled_from(["revolute", "fixed", "prismatic", "ball"])),
                                              max_size=10))


def _graph_text(fmt, n, joints):
    """n links and the joints (parent, child, type) between them: -1 the world, -2 and indices
    past n unknown names, so cycles, self-parents, two parents and loose links all occur."""
    def name(k):
        return "world" if k == -1 else f"l{k}" if 0 <= k < n else "zz"
    inertial_sdf = "<inertial><mass>1</mass><inertia><ixx>0.1</ixx><iyy>0.1</iyy><izz>0.1</izz></inertia></inertial>"
    inertial_urdf = ('<inertial><mass value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/>'
                     "</inertial>")
    if fmt == "sdf":
        body = "".join(f'<link name="l{k}"><pose>{k} 0 0 0 0 0</pose>{inertial_sdf}</link>' for k in range(n))
        body += "".join(f'<joint name="j{i}" type="{t}"><parent>{name(p)}</parent><child>{name(c)}</child></joint>'
                        for i, (p, c, t) in enumerate(joints))
        return f'<sdf version="1.7"><model name="m">{body}</model></sdf>'
    body = "".join(f'<link name="l{k}">{inertial_urdf}</link>' for k in range(n))
    body += "".join(f'<joint name="j{i}" type="{t}"><parent link="{name(p)}"/><child link="{name(c)}"/>'
                    f'<origin xyz="{i} 0 0"/><axis xyz="0 0 1"/></joint>' for i, (p, c, t) in enumerate(joints))
    return f'<robot name="m"><link name="world"/>{body}</robot>'


@pytest.mark.parametrize("fmt", ["sdf", "urdf"])
def test_random_joint_graphs_import_or_fail_in_one_line(fmt, tmp_path_factory):
    folder = tmp_path_factory.mktemp(f"graph_{fmt}")

    @GRAPHS
    @given(graph=GRAPH)
    def run(graph):
        path = folder / f"g.{fmt}"
        path.write_text(_graph_text(fmt, *graph))
        _imports_or_one_line(path)

    run()


def _nested_mjcf(shape):
    """Bodies nested as the shape says (each entry: how many children), hinge or slide joints,
    some bodies without a joint (welded) or with several (a chain of massless links)."""
    out, k = [], [0]

    def body(depth):
        i = k[0]
        k[0] += 1
        n = shape[i % len(shape)] if depth < 6 and k[0] < 20 else 0
        joints = "".join(f'<joint name="j{i}_{m}" type="{"slide" if (i + m) % 3 == 0 else "hinge"}" axis="0 {m} 1"/>'
                         for m in range(i % 3))
        out.append(f'<body name="b{i}" pos="0.1 0 0">{joints}<inertial pos="0 0 0" mass="1" '
                   'diaginertia="0.1 0.1 0.1"/>')
        for _ in range(n):
            body(depth + 1)
        out.append("</body>")
    body(0)
    return f'<mujoco model="m"><worldbody>{"".join(out)}</worldbody></mujoco>'


def test_random_mjcf_body_trees_import_or_fail_in_one_line(tmp_path_factory):
    folder = tmp_path_factory.mktemp("tree_xml")

    @FAST
    @given(shape=st.lists(st.integers(0, 3), min_size=1, max_size=6))
    def run(shape):
        path = folder / "t.xml"
        path.write_text(_nested_mjcf(shape))
        _imports_or_one_line(path)

    run()
