"""Hostile input to every importer (issue 53, items 4, 8 and 9): degenerate values, broken
structure and bad names in SDF, MJCF and closing-frame URDF are each one line naming the source
file, the element and its line, found by the reader (never at the generated sidecar's load-back,
never naming a temporary file), and end in exit 2 on the command line, never in exit 3. Every
case is a small valid file with one change, so the refusal is that change's."""
from __future__ import annotations

import contextlib
import io
from pathlib import Path

import pytest

from pinclear.core.errors import ModelFileError
from pinclear.io.importers import convert

MJCF = """<mujoco model="m">
  <compiler angle="radian"/>
  <worldbody>
    <body name="a" pos="0 0 0">
      <joint name="ja" type="hinge" axis="0 0 1" range="-1 1"/>
      <inertial pos="0.5 0 0" mass="1" diaginertia="0.01 0.1 0.1"/>
      <body name="b" pos="1 0 0">
        <joint name="jb" type="hinge" axis="0 0 1" damping="0.1"/>
        <inertial pos="0.5 0 0" mass="1" diaginertia="0.01 0.1 0.1"/>
        <site name="tip" pos="1 0 0"/>
      </body>
    </body>
    <site name="anchor" pos="2 0 0"/>
  </worldbody>
  <equality>
    <connect name="C" site1="tip" site2="anchor"/>
  </equality>
</mujoco>
"""

SDF = """<sdf version="1.7">
  <model name="m">
    <link name="base"/>
    <link name="a"><inertial><mass>1</mass><inertia><ixx>0.01</ixx><iyy>0.1</iyy><izz>0.1</izz></inertia></inertial></link>
    <link name="b"><pose>1 0 0 0 0 0</pose><inertial><mass>1</mass><inertia><ixx>0.01</ixx><iyy>0.1</iyy><izz>0.1</izz></inertia></inertial></link>
    <frame name="f1" attached_to="a"><pose>0.5 0 0 0 0 0</pose></frame>
    <joint name="fix" type="fixed"><parent>world</parent><child>base</child></joint>
    <joint name="ja" type="revolute"><parent>base</parent><child>a</child><axis><xyz>0 0 1</xyz><limit><lower>-1</lower><upper>1</upper></limit></axis></joint>
    <joint name="jb" type="revolute"><parent>a</parent><child>b</child><axis><xyz>0 0 1</xyz><dynamics><damping>0.1</damping></dynamics></axis></joint>
  </model>
</sdf>
"""

URDF = """<robot name="m">
  <link name="base"/>
  <link name="a"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="b"><inertial><mass value="1"/><inertia ixx="0.01" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>
  <link name="closing_C_1"/>
  <link name="closing_C_2"/>
  <joint name="ja" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="jb" type="revolute"><parent link="a"/><child link="b"/><origin xyz="1 0 0"/><axis xyz="0 0 1"/><dynamics damping="0.1"/></joint>
  <joint name="c1" type="fixed"><parent link="b"/><child link="closing_C_1"/><origin xyz="1 0 0"/></joint>
  <joint name="c2" type="fixed"><parent link="base"/><child link="closing_C_2"/><origin xyz="2 0 0"/></joint>
</robot>
"""
BASE = {"xml": MJCF, "sdf": SDF, "urdf": URDF}
ANN = '<custom><text name="pinclear:sidecar" data="{data}"/></custom>\n</mujoco>'


def _ann(data):
    return ("</mujoco>", ANN.replace("{data}", data))


#: (id, format, (old, new) edits of the base file, what the one line must say). Each is a member
#: of one class of bad input the audit found ending in exit 3, a silent misreading, or a refusal
#: naming the generated files.
CASES = [
    # degenerate values (item 8)
    ("mjcf-mass-negative", "xml", [('mass="1" diaginertia', 'mass="-1" diaginertia')], "(line 6): mass -1.0 kg"),
    ("mjcf-mass0-inertia", "xml", [('mass="1" diaginertia', 'mass="0" diaginertia')], "mass 0 with a non-zero inertia"),
    ("mjcf-quat-zero", "xml", [('name="b" pos="1 0 0"', 'name="b" pos="1 0 0" quat="0 0 0 0"')],
     "line 7): quat '0 0 0 0' is zero"),
    ("mjcf-eulerseq-one", "xml", [('angle="radian"', 'angle="radian" eulerseq="x"'),
                                  ('name="b" pos="1 0 0"', 'name="b" pos="1 0 0" euler="0.1 0.2 0.3"')],
     "line 2): eulerseq 'x'"),
    ("mjcf-eulerseq-letters", "xml", [('angle="radian"', 'angle="radian" eulerseq="abc"')], "eulerseq 'abc'"),
    ("mjcf-angle-unit", "xml", [('angle="radian"', 'angle="grad"')], "angle 'grad' (valid: degree, radian)"),
    ("mjcf-two-orientations", "xml", [('name="b" pos="1 0 0"', 'name="b" quat="1 0 0 0" euler="0 0 1"')],
     "quat and euler: one orientation"),
    ("mjcf-axisangle-zero", "xml", [('name="b" pos="1 0 0"', 'name="b" axisangle="0 0 0 1"')],
     "axisangle: the axis is the zero vector"),
    ("mjcf-xyaxes-parallel", "xml", [('name="b" pos="1 0 0"', 'name="b" xyaxes="1 0 0 2 0 0"')],
     "xyaxes: the two axes"),
    ("mjcf-pos-inf", "xml", [('name="b" pos="1 0 0"', 'name="b" pos="1 inf 0"')], "line 7) pos: '1 inf 0' is not finite"),
    ("mjcf-axis-zero", "xml", [('name="jb" type="hinge" axis="0 0 1"', 'name="jb" type="hinge" axis="0 0 0"')],
     "line 8) axis: is the zero vector"),
    ("mjcf-armature-text", "xml", [('damping="0.1"', 'damping="0.1" armature="abc"')],
     "line 8) armature: expected 1 number(s), got 'abc'"),
    ("mjcf-damping-negative", "xml", [('damping="0.1"', 'damping="-1"')], "joint 'jb' (line 8): damping -1.0"),
    ("mjcf-range-nan", "xml", [('range="-1 1"', 'range="-1 nan"')], "line 5) range: '-1 nan' is not finite"),
    ("mjcf-range-reversed", "xml", [('range="-1 1"', 'range="1 -1"')], "lower limit 1.0 above the upper limit -1.0"),
    ("mjcf-inertial-no-mass", "xml", [('pos="0.5 0 0" mass="1" diaginertia="0.01 0.1 0.1"/>\n      <body',
                                       'pos="0.5 0 0" diaginertia="0.01 0.1 0.1"/>\n      <body')],
     "line 6): an <inertial> needs mass"),
    ("mjcf-inertial-no-inertia", "xml", [('mass="1" diaginertia="0.01 0.1 0.1"/>\n      <body', 'mass="1"/>\n      <body')],
     "exactly one of diaginertia and fullinertia (given: neither)"),
    # structure (items 4 and 9)
    ("mjcf-duplicate-joint", "xml", [('name="jb"', 'name="ja"')], "joint 'ja' (line 8): the name is used twice"),
    ("mjcf-unknown-site", "xml", [('site2="anchor"', 'site2="nowhere"')], "line 16) site2: 'nowhere': names no site"),
    ("mjcf-site-missing", "xml", [(' site2="anchor"', '')], "site2: missing: names no site"),
    ("mjcf-duplicate-site", "xml", [('<site name="anchor"', '<site name="tip"')], "site name 'tip' used twice"),
    ("mjcf-ball-in-tree", "xml", [('name="jb" type="hinge"', 'name="jb" type="ball"')], "joint type 'ball'"),
    ("mjcf-body-world", "xml", [('body name="b"', 'body name="world"')], "body name 'world' used twice (or reserved)"),
    ("mjcf-connect-unknown-body", "xml", [('site1="tip" site2="anchor"', 'body1="zz"')], "unknown body 'zz'"),
    ("mjcf-joint-eq-no-joint2", "xml", [('<connect name="C" site1="tip" site2="anchor"/>', '<joint joint1="ja"/>')],
     "without joint2"),
    ("mjcf-joint-eq-unknown", "xml", [('<connect name="C" site1="tip" site2="anchor"/>',
                                       '<joint name="k" joint1="ja" joint2="zz"/>')],
     "coupling 'k' (line 16): names 'zz', not a revolute or prismatic joint"),
    ("mjcf-generated-name", "xml", [('name="jb" type="hinge"', 'name="jb" pos="0.2 0 0" type="hinge"'),
                                    ('<site name="anchor" pos="2 0 0"/>', '<site name="anchor" pos="2 0 0"/><body name="b__ref"/>')],
     "is also the name of body 'b__ref'"),
    ("mjcf-no-body", "xml", [('<body name="a" pos="0 0 0">', '<site name="a"/><x>'), ("</body>\n    </body>",
                                                                                      "</body>\n    </x>"),
                                ('<connect name="C" site1="tip" site2="anchor"/>', "")],
     "bodies: the file holds no body to import"),
    # the pinclear annotation (items 1 and 9)
    ("ann-list", "xml", [_ann("[1, 2]")], "the pinclear annotation is a JSON list, not a mapping"),
    ("ann-deep", "xml", [_ann('{&quot;parameters&quot;: ' + "[" * 40 + "]" * 40 + "}")], "nested more than 20 levels"),
    ("ann-very-deep", "xml", [_ann("[" * 100000 + "]" * 100000)], "nested more than 20 levels"),
    ("ann-not-json", "xml", [_ann("{drives: [")], "not valid JSON"),
    ("ann-code", "xml", [_ann('{&quot;drives&quot;: [{&quot;joint&quot;: &quot;ja&quot;, &quot;law&quot;: '
                              '{&quot;type&quot;: &quot;python&quot;, &quot;function&quot;: &quot;os:system&quot;}}]}')],
     "drives[0].law.function: 'os:system' names code"),
    ("ann-function-string", "xml", [_ann('{&quot;options&quot;: {&quot;f&quot;: {&quot;default&quot;: '
                                         '&quot;subprocess:run&quot;}}}')], "spelled like a function name"),
    ("ann-file", "xml", [_ann('{&quot;forces&quot;: [{&quot;name&quot;: &quot;x&quot;, &quot;mesh&quot;: '
                              '&quot;a.stl&quot;}]}')], "forces[0].mesh: names a file"),
    ("ann-path", "xml", [_ann('{&quot;closures&quot;: [{&quot;name&quot;: &quot;../../etc/passwd&quot;}]}')],
     "looks like a file path"),
    ("ann-hook", "xml", [_ann('{&quot;hook&quot;: &quot;pinclear.cli:main&quot;}')], "hook: 'pinclear.cli:main' names code"),
    ("ann-unknown-key", "xml", [_ann('{&quot;evil&quot;: 1}')], "evil: not a sidecar key"),
    ("ann-nan", "xml", [_ann('{&quot;gravity&quot;: [0, 0, NaN]}')], "not valid JSON (NaN is not a finite number)"),
    # SDF
    ("sdf-mass-negative", "sdf", [("<mass>1</mass>", "<mass>-1</mass>")], "line 4): -1.0 kg: a mass is >= 0"),
    ("sdf-mass0-inertia", "sdf", [("<mass>1</mass>", "<mass>0</mass>")], "body 'a' (line 4): mass 0 with a non-zero"),
    ("sdf-axis-zero", "sdf", [("<child>b</child><axis><xyz>0 0 1</xyz>", "<child>b</child><axis><xyz>0 0 0</xyz>")],
     "line 9): is the zero vector"),
    ("sdf-lower-nan", "sdf", [("<lower>-1</lower>", "<lower>nan</lower>")], "'nan' is not finite"),
    ("sdf-limits-reversed", "sdf", [("<lower>-1</lower><upper>1</upper>", "<lower>2</lower><upper>1</upper>")],
     "joint 'ja' (line 8): lower limit 2.0 above the upper limit 1.0"),
    ("sdf-duplicate-joint", "sdf", [('joint name="jb"', 'joint name="ja"')], "share one namespace"),
    ("sdf-no-parent", "sdf", [("<parent>a</parent>", "")], "line 9): <parent> missing"),
    ("sdf-self-parent", "sdf", [("<parent>a</parent><child>b</child>", "<parent>b</parent><child>b</child>")],
     "joins link 'b' to itself"),
    ("sdf-unknown-frame", "sdf", [("<pose>1 0 0 0 0 0</pose>", '<pose relative_to="zz">1 0 0 0 0 0</pose>')],
     "names the frame 'zz'"),
    ("sdf-frame-cycle", "sdf", [('attached_to="a"><pose>', 'attached_to="a"><pose relative_to="f1">')],
     "relative to itself (a cycle of relative_to / frame attributes: f1 -> f1)"),
    ("sdf-degrees-word", "sdf", [("<pose>1 0 0 0 0 0</pose>", '<pose degrees="maybe">1 0 0 0 0 0</pose>')],
     "degrees 'maybe'"),
    ("sdf-quat-zero", "sdf", [("<pose>1 0 0 0 0 0</pose>", '<pose rotation_format="quat_xyzw">1 0 0 0 0 0 0</pose>')],
     "the quaternion is zero"),
    ("sdf-damping-negative", "sdf", [("<damping>0.1</damping>", "<damping>-1</damping>")],
     "damping and spring_stiffness are >= 0"),
    ("sdf-gearbox-ref", "sdf", [("</model>", ('<joint name="g" type="gearbox"><parent>a</parent><child>b</child>'
                                 "<gearbox_reference_body>zz</gearbox_reference_body><axis><xyz>0 0 1</xyz></axis>"
                                 "<axis2><xyz>0 0 1</xyz></axis2></joint></model>"))],
     "gearbox_reference_body 'zz' names no link"),
    ("sdf-inertia-inf", "sdf", [("<ixx>0.01</ixx>", "<ixx>inf</ixx>")], "'inf' is not finite"),
    # closing-frame URDF
    ("urdf-mass-negative", "urdf", [('<mass value="1"/>', '<mass value="-1"/>')],
     "link 'a'.inertial.mass (line 3): -1.0 kg: a mass is >= 0"),
    ("urdf-mass0-inertia", "urdf", [('<mass value="1"/>', '<mass value="0"/>')], "body 'a' (line 3): mass 0 with a non-zero"),
    ("urdf-axis-zero", "urdf", [('<child link="a"/><axis xyz="0 0 1"/>', '<child link="a"/><axis xyz="0 0 0"/>')],
     "joint 'ja'.axis.xyz (line 7): is the zero vector"),
    ("urdf-lower-nan", "urdf", [('lower="-1"', 'lower="nan"')], "joint 'ja'.limit.lower (line 7): 'nan' is not finite"),
    ("urdf-lower-text", "urdf", [('lower="-1"', 'lower="abc"')], "expected 1 number(s), got 'abc'"),
    ("urdf-limits-reversed", "urdf", [('lower="-1" upper="1"', 'lower="2" upper="1"')], "lower limit 2.0 above"),
    ("urdf-effort-negative", "urdf", [('effort="1"', 'effort="-1"')], "effort -1.0: finite and >= 0"),
    ("urdf-damping-negative", "urdf", [('damping="0.1"', 'damping="-1"')], "damping -1.0: finite and >= 0"),
    ("urdf-duplicate-joint", "urdf", [('joint name="jb"', 'joint name="ja"')], "joint 'ja' (line 8): defined twice"),
    ("urdf-no-parent", "urdf", [('<parent link="a"/><child link="b"/>', '<child link="b"/>')],
     "joint 'jb'.parent (line 8): missing"),
    ("urdf-unknown-parent", "urdf", [('<parent link="a"/><child link="b"/>', '<parent link="zz"/><child link="b"/>')],
     "joint 'jb'.parent (line 8): unknown link 'zz'"),
    ("urdf-self-parent", "urdf", [('<parent link="a"/><child link="b"/>', '<parent link="b"/><child link="b"/>')],
     "joint 'jb' (line 8): joins link 'b' to itself"),
    ("urdf-two-parents", "urdf", [('<parent link="base"/><child link="closing_C_2"/>',
                                   '<parent link="base"/><child link="b"/>')], "is the child of 2 joints"),
    ("urdf-cycle", "urdf", [("</robot>", ('<link name="x"/><link name="y"/><joint name="xy" type="fixed"><parent link="x"/>'
                             '<child link="y"/></joint><joint name="yx" type="fixed"><parent link="y"/><child link="x"/>'
                             "</joint></robot>"))], "is its own ancestor"),
    ("urdf-mimic-text", "urdf", [('<dynamics damping="0.1"/>', '<mimic joint="ja" multiplier="abc"/>')],
     "multiplier: expected 1 number(s), got 'abc'"),
    ("urdf-mimic-unknown", "urdf", [('<dynamics damping="0.1"/>', '<mimic joint="zz"/>')], "names 'zz', not a revolute"),
    ("urdf-mimic-self", "urdf", [('<dynamics damping="0.1"/>', '<mimic joint="jb"/>')], "couples joint 'jb' to itself"),
    ("urdf-lonely-closing", "urdf", [('<link name="closing_C_2"/>', '<link name="closing_D_2"/>'),
                                     ('<child link="closing_C_2"/>', '<child link="closing_D_2"/>')],
     "closing frame without its partner"),
    ("urdf-inertia-inf", "urdf", [('ixx="0.01"', 'ixx="inf"')], "'inf' is not finite"),
]


def _write(tmp_path, fmt, edits, name="bad"):
    text = BASE[fmt]
    for old, new in edits:
        assert old in text, (old, fmt)
        text = text.replace(old, new, 1)
    path = tmp_path / f"{name}.{fmt}"
    path.write_text(text)
    return path


@pytest.mark.parametrize("fmt", sorted(BASE))
def test_the_base_files_import(fmt, tmp_path):
    """The control: each base file imports, with its closure C (3 rows) and the damper."""
    _, sidecar, report = convert(_write(tmp_path, fmt, [], "ok"))
    assert report["closure_rows"] == (3 if fmt != "sdf" else 0)
    assert [f["type"] for f in sidecar.get("forces", [])] == ["joint_spring"]


@pytest.mark.parametrize("case, fmt, edits, expect", CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_one_line_naming_the_source(case, fmt, edits, expect, tmp_path):
    path = _write(tmp_path, fmt, edits)
    with pytest.raises(ModelFileError) as exc:
        convert(path)
    msg = str(exc.value)
    assert msg.startswith(f"{path}: ") and "\n" not in msg, msg
    assert expect in msg, msg
    assert ".tmp" not in msg and "Traceback" not in msg


def _cli(argv):
    from pinclear.cli import commands

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        rc = commands.main(argv)
    return rc, err.getvalue()


@pytest.mark.parametrize("case, fmt, edits, expect", CASES, ids=[c[0] for c in CASES])
def test_bad_input_on_the_command_line_is_exit_2_and_writes_nothing(case, fmt, edits, expect, tmp_path):
    """`pinclear import BAD --out OUT`: exit 2 (never 3, the catch-all), one line naming the
    source, nothing left in OUT."""
    path = _write(tmp_path, fmt, edits)
    out = tmp_path / "out"
    rc, err = _cli(["import", str(path), "--out", str(out)])
    assert rc == 2, err
    assert err.count("\n") == 1 and err.startswith(f"pinclear: error: {path}: ") and expect in err, err
    assert not out.exists()                          # not even the folder the import would have made


def test_every_reader_has_cases():
    """The class covers every reader (a new reader joins the READERS table and these cases)."""
    from pinclear.io.importers import READERS

    fmts = {f for _, f, _, _ in CASES}
    assert {s.lstrip(".") for s in READERS} - {"mjcf"} <= fmts


@pytest.mark.slow
def test_pinclear_import_processes_exit_2_on_a_member_of_each_class(tmp_path):
    """The installed command itself (a separate process, as a user runs it): a degenerate value,
    a broken structure and a refused annotation, one per reader, each exit 2 with one line."""
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[2]
    picks = ["mjcf-quat-zero", "mjcf-unknown-site", "ann-code", "sdf-frame-cycle", "urdf-cycle", "urdf-lower-nan"]
    for case, fmt, edits, expect in (c for c in CASES if c[0] in picks):
        path = _write(tmp_path, fmt, edits, case)
        r = subprocess.run([sys.executable, "-m", "pinclear.cli", "import", str(path), "--out", str(tmp_path / "o")],
                           capture_output=True, text=True, cwd=root, timeout=600, check=False,
                           env={"PYTHONPATH": str(root), "PATH": "/usr/bin:/bin", "NUMBA_NUM_THREADS": "1"})
        assert r.returncode == 2 and r.stderr.count("\n") == 1 and expect in r.stderr, (case, r.stderr)
