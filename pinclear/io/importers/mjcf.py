"""MJCF (MuJoCo) read into pinclear.io.importers.graph: the body tree, joints, inertials and the
equality constraints.

Bodies nest (MJCF is a tree); a body has joints (hinge, slide) or none (welded to its parent).
Several joints in one body (MuJoCo applies them in order) become a chain of massless links, named
by ``<custom><text name="pinclear:link:JOINT" data="LINK">`` where a pinclear export merged them
(pinclear.io.export_mjcf), else BODY__JOINT. Poses: ``pos`` and ``quat`` (w x y z) or ``euler``
with ``<compiler angle>`` and ``eulerseq``; a joint's ``pos`` and ``axis`` are in its body's frame. Inertials: ``pos``,
``quat``, ``mass``, ``diaginertia`` or ``fullinertia``. Equalities: ``connect`` (sites, or
body1/body2 + anchor) -> spherical closure, ``weld`` (sites, or body1/body2) -> weld, ``joint``
(polycoef: a linear polynomial) -> coupling. Each equality's ``solref``/``solimp`` (MuJoCo's
constraint softness; pinclear's closures are exact) is kept in the report, not dropped.
A ball joint inside the MJCF tree has no URDF form: it is refused, naming the line. A file
written by ``pinclear export --mjcf`` carries its sidecar in ``<custom><text
name="pinclear:sidecar">``: its closures, drives and forces are then taken from there (the
exact types MuJoCo cannot express).
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin

from pinclear.core.errors import ModelFileError
from pinclear.io.importers import xml
from pinclear.io.importers.graph import MAX_BODIES, MAX_JOINTS, WORLD, Body, Closing, Coupling, Graph, Joint, unit

ANNOTATION = "pinclear:sidecar"
LINK = "pinclear:link:"
FRAME_SITE = "pinclear:frame:"
LEFT_OUT = {"geom": "collision/visual geometry is not part of a pinclear mechanism",
            "site": "read where an equality names it", "camera": "not simulated", "light": "not simulated",
            "actuator": "actuators are not imported (declare drives in the sidecar)",
            "sensor": "sensors are not simulated", "tendon": "tendons are not imported", "contact": "no contacts",
            "asset": "meshes and textures are not imported", "default": "class defaults are not applied: give "
            "every value on its element", "visual": "rendering settings", "statistic": "rendering settings",
            "size": "engine memory settings", "keyframe": "keyframes are not imported", "extension": "plugins",
            "include": "included files are never read: merge them into one file", "deformable": "not simulated",
            "flexcomp": "not simulated", "frame": "MuJoCo <frame> elements (and the bodies inside them) are not "
            "imported: place the bodies themselves"}


def _floats(el, attr, n, file, default=None):
    text = el.get(attr)
    if text is None:
        return None if default is None else np.array(default, float)
    return np.array(xml.numbers(text, n, file, el, attr))


ORIENTATIONS = ("quat", "euler", "axisangle", "xyaxes", "zaxis")


def _z_to_minimal(v):
    """The smallest rotation taking z onto the unit vector v (MuJoCo's zaxis; z onto -z: half a
    turn about x, as MuJoCo's mju_quatZ2Vec)."""
    c = float(v[2])
    axis = np.cross([0.0, 0.0, 1.0], v)
    s = float(np.linalg.norm(axis))
    if s < 1e-14:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    return pin.exp3(axis / s * np.arctan2(s, c))


def _pose(el, file, degrees, seq):
    """The SE3 of an element's pos + quat / euler / axisangle / xyaxes / zaxis, relative to its
    parent body; a zero quaternion or axis, or two orientations on one element, are refused."""
    p = _floats(el, "pos", 3, file, [0, 0, 0])
    given = [a for a in ORIENTATIONS if el.get(a) is not None]
    if len(given) > 1:
        raise ModelFileError(file, xml.where(el), f"{' and '.join(given)}: one orientation per element (MuJoCo "
                             "refuses more)")
    kind = given[0] if given else None
    if kind == "quat":
        w, x, y, z = _floats(el, "quat", 4, file)
        n = np.sqrt(w * w + x * x + y * y + z * z)
        if not n > 1e-12:
            raise ModelFileError(file, xml.where(el), f"quat {el.get('quat')!r} is zero: a quaternion needs a norm")
        R = pin.Quaternion(w / n, x / n, y / n, z / n).toRotationMatrix()
    elif kind == "euler":
        a = _floats(el, "euler", 3, file) * (np.pi / 180 if degrees else 1.0)
        R = np.eye(3)
        for ang, ax in zip(a, seq):
            Ri = pin.exp3(ang * np.eye(3)["xyzXYZ".index(ax) % 3])
            R = R @ Ri if ax.islower() else Ri @ R          # lower case: rotating axes (MuJoCo)
    elif kind == "axisangle":
        aa = _floats(el, "axisangle", 4, file)
        n = np.linalg.norm(aa[:3])
        if not n > 1e-12:
            raise ModelFileError(file, xml.where(el), "axisangle: the axis is the zero vector")
        R = pin.exp3(aa[3] * (np.pi / 180 if degrees else 1.0) * aa[:3] / n)
    elif kind == "xyaxes":
        a = _floats(el, "xyaxes", 6, file)
        x = a[:3] / (np.linalg.norm(a[:3]) or np.nan)
        y = a[3:] - (a[3:] @ x) * x                        # MuJoCo: y made orthogonal to x
        y = y / (np.linalg.norm(y) or np.nan)
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
            raise ModelFileError(file, xml.where(el), "xyaxes: the two axes must be non-zero and not parallel")
        R = np.column_stack([x, y, np.cross(x, y)])
    elif kind == "zaxis":
        v = _floats(el, "zaxis", 3, file)
        n = np.linalg.norm(v)
        if not n > 1e-12:
            raise ModelFileError(file, xml.where(el), "zaxis is the zero vector")
        R = _z_to_minimal(v / n)
    else:
        R = np.eye(3)
    return pin.SE3(R, p)


def _compiler(root, file):
    """(angles in degrees, Euler sequence) of <compiler>, each checked (MuJoCo's defaults:
    degree, xyz)."""
    comp = root.find("compiler")
    if comp is None:
        return True, "xyz"
    angle = comp.get("angle", "degree")
    if angle not in ("degree", "radian"):
        raise ModelFileError(file, xml.where(comp), f"angle {angle!r}", choices=["degree", "radian"])
    seq = comp.get("eulerseq", "xyz")
    if len(seq) != 3 or any(c not in "xyzXYZ" for c in seq):
        raise ModelFileError(file, xml.where(comp), f"eulerseq {seq!r}: three of x y z (rotating axes) or X Y Z "
                             "(fixed axes), one per euler angle")
    return angle == "degree", seq


def read(path) -> Graph:
    file = str(path)
    root = xml.parse_root(path, "mujoco", "an MJCF file")
    g = Graph(root.get("model", "model"), file, "mjcf")
    degrees, seq = _compiler(root, file)
    opt = root.find("option")
    if opt is not None and opt.get("gravity"):
        g.gravity = _floats(opt, "gravity", 3, file)
        g.gravity_source = f"<option gravity> (line {opt.line})"
    else:
        g.gravity_source = "MuJoCo's default gravity"
    for el in root:
        if el.tag in LEFT_OUT:
            g.skip(el.tag, xml.where(el), LEFT_OUT[el.tag])
        elif el.tag not in ("compiler", "option", "worldbody", "equality", "custom"):
            g.skip(el.tag, xml.where(el), "unknown element")
    world = root.find("worldbody")
    if world is None:
        raise ModelFileError(file, xml.where(root), "no <worldbody>")
    # bounded before any body is built (the writer's limits, pinclear.io.importers.graph)
    for tag, limit in (("body", MAX_BODIES), ("joint", MAX_JOINTS), ("site", MAX_JOINTS)):
        els = list(world.iter(tag))
        if len(els) > limit:
            raise ModelFileError(file, xml.where(els[limit]), f"{len(els)} <{tag}> elements: more than pinclear "
                                 f"imports from one file (at most {limit})")
    sites = {}
    # the links of bodies a pinclear export merged into their child (pinclear.io.export_mjcf._tree_xml)
    links = {t.get("name")[len(LINK):]: t.get("data") for t in root.findall("custom/text")
             if (t.get("name") or "").startswith(LINK)}
    _bodies(world, WORLD, pin.SE3.Identity(), g, file, (degrees, seq, links), sites)
    annotated, ann_el = _annotation(root, file)
    eq = root.find("equality")
    own = [e for e in eq] if eq is not None else []
    if annotated is not None and own:
        g.replaced = (f"the pinclear annotation {xml.where(ann_el)} replaced the file's own {len(own)} equality "
                      f"element{'s' if len(own) > 1 else ''} ({', '.join(xml.where(e) for e in own[:4])}"
                      f"{', ...' if len(own) > 4 else ''}): its closures, drives and forces are imported instead")
    for e in own if annotated is None else ():
        _equality(e, g, file, sites)
    g.root = next(iter(g.bodies), None)
    g.sidecar = annotated
    g.sidecar_where = xml.where(ann_el) if ann_el is not None else None
    # sites a pinclear export wrote for the named frames of its tree (merged links, the root link)
    g.frames = [(n[len(FRAME_SITE):], b, X) for n, (b, X) in sites.items()
                if n and n.startswith(FRAME_SITE) and n[len(FRAME_SITE):] != WORLD]
    return g


def _bodies(parent_el, parent, X_parent, g, file, how, sites):
    """Read the bodies under ``parent_el``; ``how``: (angles in degrees, euler sequence, {joint:
    link} of the merged bodies). The recursion is one level a body, so bounded by the XML depth
    (pinclear.io.importers.xml.MAX_XML_DEPTH)."""
    degrees, seq, links = how
    for s in parent_el.findall("site"):
        name = s.get("name")
        if name is not None and name in sites:
            raise ModelFileError(file, xml.where(s), f"site name {name!r} used twice")
        sites[name if name is not None else f"site_line{s.line}"] = (parent, X_parent * _pose(s, file, degrees, seq))
    for el in parent_el:
        if el.tag in ("geom", "camera", "light", "frame"):
            g.skip(el.tag, xml.where(el), LEFT_OUT[el.tag])
        elif el.tag not in ("body", "site", "joint", "inertial", "freejoint"):
            g.skip(el.tag, xml.where(el), "unknown element")
    for b in parent_el.findall("body"):
        name = b.get("name") or f"body_line{b.line}"
        if name in g.bodies or name == WORLD:
            raise ModelFileError(file, xml.where(b), f"body name {name!r} used twice (or reserved)")
        X = X_parent * _pose(b, file, degrees, seq)
        body = Body(name, X, C=X, line=b.line)
        ines = b.findall("inertial")
        if len(ines) > 1:
            raise ModelFileError(file, xml.where(ines[1]), "a body has one <inertial>")
        if ines:
            _inertial(ines[0], body, X, file, degrees, seq)
        joints = b.findall("joint") + b.findall("freejoint")
        if not joints:
            g.joints.append(Joint(f"{name}_weld", "fixed", parent, name, X, line=b.line))
        # MuJoCo applies a body's joints in order, each in the body's frame as moved by the ones
        # before: a chain of massless links, one per joint but the last (pinclear.io.export_mjcf)
        prev = parent
        for k, j in enumerate(joints):
            child = name
            if k < len(joints) - 1:
                jname = j.get("name") or f"{name}_joint{k}"
                child = links.get(jname) or f"{name}__{jname}"
                if child in g.bodies or child == WORLD:
                    raise ModelFileError(file, xml.where(j), f"link name {child!r} used twice (or reserved)")
                Xc = X * pin.SE3(np.eye(3), _floats(j, "pos", 3, file, [0, 0, 0]))
                g.bodies[child] = Body(child, Xc, C=Xc, line=j.line)
            _joint(j, prev, child, X, g, file, degrees, seq)
            prev = child
        g.bodies[name] = body                 # after its chain's links: the file's order, root first
        _bodies(b, name, X, g, file, how, sites)


def _inertial(ine, body, X, file, degrees, seq):
    """A body's <inertial>: MuJoCo requires its mass and one of diaginertia / fullinertia."""
    body.C = X * _pose(ine, file, degrees, seq)
    if ine.get("mass") is None:
        raise ModelFileError(file, xml.where(ine), "an <inertial> needs mass (MuJoCo requires it)")
    body.mass = xml.number(ine, "mass", file)
    if body.mass < 0:
        raise ModelFileError(file, xml.where(ine), f"mass {body.mass!r} kg: a mass is >= 0")
    given = [a for a in ("diaginertia", "fullinertia") if ine.get(a) is not None]
    if len(given) != 1:
        raise ModelFileError(file, xml.where(ine), "an <inertial> needs exactly one of diaginertia and fullinertia "
                             f"(given: {', '.join(given) or 'neither'})")
    if given[0] == "fullinertia":
        a = _floats(ine, "fullinertia", 6, file)
        body.inertia = np.array([[a[0], a[3], a[4]], [a[3], a[1], a[5]], [a[4], a[5], a[2]]])
    else:
        body.inertia = np.diag(_floats(ine, "diaginertia", 3, file))


def _joint(j, parent, child, X, g, file, degrees, seq):
    kind = "free" if j.tag == "freejoint" else j.get("type", "hinge")
    types = {"hinge": "revolute", "slide": "prismatic"}
    if kind not in types:
        raise ModelFileError(file, xml.where(j), f"joint type {kind!r} inside the body tree has no URDF form",
                             choices=sorted(types))
    Xj = X * pin.SE3(np.eye(3), _floats(j, "pos", 3, file, [0, 0, 0]))
    axis = unit(X.rotation @ _floats(j, "axis", 3, file, [0, 0, 1]), file, f"{xml.where(j)} axis")
    jt = Joint(j.get("name") or f"{child}_joint", types[kind], parent, child, Xj, axis, line=j.line)
    k = np.pi / 180 if degrees and kind == "hinge" else 1.0
    # MuJoCo's ref: the joint's value in the file's pose; pinclear's coordinate is zero there, so
    # every position attribute is shifted by it (a joint equality already reads q - ref)
    ref = xml.number(j, "ref", file, 0.0) * k
    if ref:
        g.notes.append(f"{xml.where(j)}: ref {j.get('ref')}: the imported coordinate is MuJoCo's minus {ref!r} "
                       "(zero at the file's pose); range and springref shifted alike")
    rng = j.get("range")
    if rng is not None and j.get("limited", "auto") != "false":
        lo, hi = xml.numbers(rng, 2, file, j, "range")
        jt.lower, jt.upper = lo * k - ref, hi * k - ref
    jt.stiffness = xml.number(j, "stiffness", file, 0.0)
    jt.damping = xml.number(j, "damping", file, 0.0)
    jt.reference = xml.number(j, "springref", file, 0.0) * k - ref
    for a in ("armature", "frictionloss"):
        if xml.number(j, a, file, 0.0) != 0.0:
            g.skip(f"joint {a}", xml.where(j), "not modelled by pinclear's ideal joints")
    g.joints.append(jt)


def _site(e, key, sites, file):
    name = e.get(key)
    if name is None or name not in sites:
        raise ModelFileError(file, f"{xml.where(e)} {key}", f"{'missing' if name is None else repr(name)}: "
                             "names no site of the file", choices=[n for n in sites if n is not None][:50])
    return sites[name]


def _equality(e, g, file, sites):
    if e.get("active", "true") == "false":
        g.skip(f"equality {e.tag}", xml.where(e), "inactive in the file (active=\"false\")")
        return
    soft = {k: e.get(k) for k in ("solref", "solimp") if e.get(k) is not None}
    if soft:
        g.notes.append(f"{xml.where(e)}: MuJoCo softness {soft} (pinclear's closure is exact)")
    name = e.get("name") or f"{e.tag}_line{e.line}"
    if e.tag in ("connect", "weld"):
        if e.get("site1") is not None or e.get("site2") is not None:
            (b1, X1), (b2, X2) = (_site(e, k, sites, file) for k in ("site1", "site2"))
        else:
            b1, b2 = e.get("body1"), e.get("body2") or WORLD
            if b1 is None:
                raise ModelFileError(file, xml.where(e), "needs body1 (and body2, default the world) or site1 and "
                                     "site2")
            for b in (b1, b2):
                if b not in g.bodies and b != WORLD:
                    raise ModelFileError(file, xml.where(e), f"unknown body {b!r}", choices=sorted(g.bodies))
            anchor = _floats(e, "anchor", 3, file, [0, 0, 0])
            Xb1 = g.bodies[b1].X if b1 != WORLD else pin.SE3.Identity()
            X1 = X2 = Xb1 * pin.SE3(np.eye(3), anchor)
        g.closings.append(Closing(name, "spherical" if e.tag == "connect" else "weld", b1, b2, X1, X2, e.line))
    elif e.tag == "joint":
        c = xml.numbers(e.get("polycoef", "0 1 0 0 0"), 5, file, e, "polycoef")
        if any(c[2:]):
            raise ModelFileError(file, xml.where(e), "polycoef: only a linear polynomial is a coupling")
        if e.get("joint1") is None:
            raise ModelFileError(file, xml.where(e), "a joint equality needs joint1")
        if e.get("joint2") is None:
            raise ModelFileError(file, xml.where(e), "a joint equality without joint2 (joint1 held at polycoef's "
                                 "constant) is not imported: give the joint a drive in the sidecar instead")
        # MuJoCo: joint1 = c0 + c1 joint2 (qpos0 = 0)
        g.couplings.append(Coupling(name, c[1], c[0], joint1=e.get("joint2"), joint2=e.get("joint1"), line=e.line))
    else:
        g.skip(f"equality {e.tag}", xml.where(e), "no pinclear closure of this kind")


def _annotation(root, file):
    """(the sidecar mapping a pinclear export left in <custom><text name="pinclear:sidecar">,
    its element), checked: bounded JSON, a mapping of sidecar keys, nothing that names code or a
    file (pinclear.io.importers.annotation)."""
    from pinclear.io.importers.annotation import check_annotation

    found = [t for t in root.findall("custom/text") if t.get("name") == ANNOTATION]
    if not found:
        return None, None
    t = found[0]
    if len(found) > 1:
        raise ModelFileError(file, xml.where(found[1]), "a second pinclear annotation: a file carries one")
    return check_annotation(t.get("data", ""), file, xml.where(t)), t
