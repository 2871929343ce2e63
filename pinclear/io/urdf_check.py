"""A URDF checked before Pinocchio parses it: bounded size, tree shape and finite numbers.

Pinocchio's URDF parser recurses once per level of the kinematic tree (a chain of about 4000
links overflows an 8 MB stack: a segmentation fault, no error), reads ``nan``/``inf`` masses as
a missing inertial element (mass 0, a warning on stderr, the run goes on with other dynamics)
and builds an empty model from links whose joints form a cycle. So pinclear parses the XML
itself first, with the standard library's expat (no DOCTYPE, hence no entity of any kind), and
refuses each of these with the file, the element and the limit or the valid values. The text it
checked is the text Pinocchio gets (:func:`checked_urdf_text`), never a second read of the file.

The limits below are far above real robots: the largest URDF shipped by example-robot-data
(tiago_dual) is 211 kB with 130 links and a longest chain of 21 joints.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from xml.parsers import expat

from pinclear.core.bounded import read_bounded
from pinclear.core.errors import ModelFileError

#: bytes of a URDF (50x the largest robot of example-robot-data)
MAX_URDF_BYTES = 10_000_000
#: links of a URDF (about 8x the largest robot of example-robot-data)
MAX_URDF_LINKS = 1000
#: joints on the longest chain from the root: Pinocchio's parser overflows an 8 MB stack
#: between 3000 and 4000; 256 keeps a 12x margin (also for 1 MB thread stacks)
MAX_URDF_DEPTH = 256

_INERTIA = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")
_MOVING = ("revolute", "continuous", "prismatic")


def _refuse_doctype(data: bytes, file):
    """Well-formed XML without a DOCTYPE: a URDF declares no entities, and refusing the
    declaration refuses every entity trick (expansion bombs, external files) at once."""
    p = expat.ParserCreate()

    def doctype(name, *args):
        raise ModelFileError(file, "urdf", f"has a DOCTYPE declaration ({name!r}): a URDF needs none, and "
                             "entity declarations are not accepted")

    p.StartDoctypeDeclHandler = doctype
    p.EntityDeclHandler = lambda name, *a: doctype(name)
    try:
        p.Parse(data, True)
    except expat.ExpatError as exc:
        raise ModelFileError(file, "urdf", f"malformed XML: {expat.ErrorString(exc.code)}: line {exc.lineno}, "
                             f"column {exc.offset}") from None


def _at(el, key) -> str:
    """``key`` with the element's line when the parser recorded one (the importers' expat reader,
    pinclear.io.importers.xml, does; ElementTree does not)."""
    line = getattr(el, "line", 0)
    return f"{key} (line {line})" if line else key


def _numbers(el, attr, n, file, key, default=None):
    """``n`` finite numbers from the attribute ``attr`` of ``el`` (None when absent and no default)."""
    text = el.get(attr)
    if text is None:
        return default
    parts = text.split()
    try:
        vals = [float(x) for x in parts]
    except ValueError:
        vals = None
    if vals is None or len(vals) != n:
        raise ModelFileError(file, _at(el, key), f"expected {n} number(s), got {text!r}")
    if not all(math.isfinite(v) for v in vals):
        raise ModelFileError(file, _at(el, key), f"{text!r} is not finite (nan and inf are not accepted)")
    return vals


def _origin(el, file, key):
    o = el.find("origin")
    if o is not None:
        _numbers(o, "xyz", 3, file, f"{key}.origin.xyz")
        _numbers(o, "rpy", 3, file, f"{key}.origin.rpy")


def _check_link(link, file):
    name = link.get("name")
    key = f"link {name!r}"
    for tag in ("visual", "collision"):
        for k, el in enumerate(link.findall(tag)):
            _origin(el, file, f"{key}.{tag}[{k}]")
    inertial = link.find("inertial")
    if inertial is None:
        return
    _origin(inertial, file, f"{key}.inertial")
    mass = inertial.find("mass")
    if mass is not None:
        (m,) = _numbers(mass, "value", 1, file, f"{key}.inertial.mass", default=[0.0])
        if m < 0:
            raise ModelFileError(file, _at(mass, f"{key}.inertial.mass"), f"{m} kg: a mass is >= 0")
    inertia = inertial.find("inertia")
    if inertia is not None:
        for a in _INERTIA:
            _numbers(inertia, a, 1, file, f"{key}.inertial.inertia.{a}")


def _check_joint(joint, links, file, mimic_ok=False):
    name = joint.get("name")
    key = f"joint {name!r}"
    ends = []
    for end in ("parent", "child"):
        el = joint.find(end)
        link = el.get("link") if el is not None else None
        if link is None:
            raise ModelFileError(file, _at(joint, f"{key}.{end}"), "missing (a joint names its parent and child links)")
        if link not in links:
            raise ModelFileError(file, _at(el, f"{key}.{end}"), f"unknown link {link!r}", choices=links)
        ends.append(link)
    if ends[0] == ends[1]:
        raise ModelFileError(file, _at(joint, key), f"joins link {ends[0]!r} to itself")
    mimic = joint.find("mimic")
    if mimic is not None and not mimic_ok:
        # Pinocchio's URDF parser builds a mimic joint as an independent one: info and simulate
        # would describe another mechanism (one more degree of freedom)
        raise ModelFileError(file, f"{key}.mimic", f"couples the joint to {mimic.get('joint')!r}, which pinclear does "
                             "not model yet (it would be simulated as an independent joint); remove <mimic> and "
                             "couple the joints with a closure or a drive")
    _origin(joint, file, key)
    axis = joint.find("axis")
    if axis is not None:
        xyz = _numbers(axis, "xyz", 3, file, f"{key}.axis.xyz")
        if xyz is not None and joint.get("type") in _MOVING and not any(xyz):
            raise ModelFileError(file, _at(axis, f"{key}.axis.xyz"), "is the zero vector: a joint axis needs a "
                                 "direction")
    for tag, attrs in (("limit", ("lower", "upper", "effort", "velocity")), ("dynamics", ("damping", "friction"))):
        el = joint.find(tag)
        if el is not None:
            for a in attrs:
                _numbers(el, a, 1, file, f"{key}.{tag}.{a}")
    return ends


def check_urdf_tree(root, file, mimic_ok=False):
    """Refuse what Pinocchio's parser would crash on or silently misread: more than
    MAX_URDF_LINKS links or joints, a chain deeper than MAX_URDF_DEPTH, a link with two parents,
    joints forming a cycle, two joints of one name, a non-finite or negative number where a
    number is read. ``mimic_ok``: a ``<mimic>`` is read by the caller (the closing-frame
    importer makes it a coupling), not refused."""
    if root.tag != "robot":
        raise ModelFileError(file, "urdf", f"the root element is <{root.tag}>, not <robot>")
    links = [el for el in root.findall("link")]
    joints = root.findall("joint")
    for what, els in (("links", links), ("joints", joints)):
        if len(els) > MAX_URDF_LINKS:
            raise ModelFileError(file, "urdf", f"{len(els)} {what}: more than pinclear accepts in one URDF "
                                 f"(at most {MAX_URDF_LINKS})")
    names = []
    for el in links:
        n = el.get("name")
        if not n:
            raise ModelFileError(file, _at(el, "link"), "a <link> without a name")
        names.append(n)
    for what, els in (("link", links), ("joint", joints)):
        seen = {}
        for el in els:
            n = el.get("name")
            if what == "joint" and not n:
                raise ModelFileError(file, _at(el, "joint"), "a <joint> without a name")
            if n in seen:
                raise ModelFileError(file, _at(el, f"{what} {n!r}"), "defined twice"
                                     f"{' (first on line ' + str(seen[n]) + ')' if seen[n] else ''}")
            seen[n] = getattr(el, "line", 0)
    known = set(names)
    for el in links:
        _check_link(el, file)
    parent: dict = {}
    children: dict = {}
    joined: dict = {}
    for j in joints:
        p, c = _check_joint(j, known, file, mimic_ok)
        joined.setdefault(c, []).append(j.get("name"))
        parent[c] = (p, j.get("name"))
        children.setdefault(p, []).append(c)
    loops = {c: js for c, js in joined.items() if len(js) > 1}
    if loops:
        c, js = next(iter(loops.items()))
        raise ModelFileError(file, f"link {c!r}", f"is the child of {len(js)} joints ({', '.join(js)}): a URDF must be "
                             "a tree; keep one joint in the URDF and declare the cut one under 'closures:' in the "
                             "sidecar")
    if not names:
        raise ModelFileError(file, "urdf", "no <link> element")
    roots = [n for n in names if n not in parent]
    # every link has one parent at most, so a link unreachable from the root is on a cycle
    if not roots:
        cyc = _cycle(names[0], parent)
        raise ModelFileError(file, f"link {cyc[0]!r}", f"is its own ancestor (joint cycle {' -> '.join(cyc)}): "
                             "a URDF must be a tree with one root link")
    if len(roots) > 1:
        raise ModelFileError(file, "urdf", f"{len(roots)} root links ({', '.join(roots[:5])}): links without a parent "
                             "joint; a URDF is one tree with one root link")
    depth, frontier, seen = 0, [roots[0]], {roots[0]}
    while frontier:
        nxt = [c for p in frontier for c in children.get(p, ())]
        if nxt:
            depth += 1
            if depth > MAX_URDF_DEPTH:
                raise ModelFileError(file, f"link {nxt[0]!r}", f"lies {depth} joints below the root: deeper than "
                                     f"pinclear accepts (at most {MAX_URDF_DEPTH} joints on a chain)")
        seen.update(nxt)
        frontier = nxt
    lost = [n for n in names if n not in seen]
    if lost:
        cyc = _cycle(lost[0], parent)
        raise ModelFileError(file, f"link {cyc[0]!r}", f"is its own ancestor (joint cycle {' -> '.join(cyc)}): "
                             f"a URDF must be a tree, every link below the root link {roots[0]!r}")


def _cycle(start, parent):
    """The links of the cycle reached by walking up from ``start`` (every link on the walk
    has a parent), closed: [a, b, ..., a]."""
    order, pos, n = [], {}, start
    while n not in pos:
        pos[n] = len(order)
        order.append(n)
        n = parent[n][0]
    cyc = order[pos[n]:]
    return list(reversed(cyc + [cyc[0]]))


def checked_urdf_text(path) -> str:
    """The text of the URDF at ``path`` after every check above (bounded read, regular file,
    well-formed, no DOCTYPE, the tree's size, depth and shape, finite numbers)."""
    file = str(path)
    data = read_bounded(path, MAX_URDF_BYTES, "urdf", "URDF")
    _refuse_doctype(data, file)
    try:
        root = ET.fromstring(data)
    except ET.ParseError as exc:
        raise ModelFileError(file, "urdf", f"malformed XML: {exc}") from None
    check_urdf_tree(root, file)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ModelFileError(file, "urdf", f"not UTF-8 text ({exc.reason} at byte {exc.start})") from None
