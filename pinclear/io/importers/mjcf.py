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

import json

import numpy as np
import pinocchio as pin

from pinclear.core.errors import ModelFileError
from pinclear.io.importers import xml
from pinclear.io.importers.graph import WORLD, Body, Closing, Coupling, Graph, Joint

ANNOTATION = "pinclear:sidecar"
LINK = "pinclear:link:"
FRAME_SITE = "pinclear:frame:"
LEFT_OUT = {"geom": "collision/visual geometry is not part of a pinclear mechanism",
            "site": "read where an equality names it", "camera": "not simulated", "light": "not simulated",
            "actuator": "actuators are not imported (declare drives in the sidecar)",
            "sensor": "sensors are not simulated", "tendon": "tendons are not imported", "contact": "no contacts",
            "asset": "meshes and textures are not imported", "default": "class defaults are not applied: give "
            "every value on its element", "visual": "rendering settings", "statistic": "rendering settings",
            "size": "engine memory settings", "keyframe": "keyframes are not imported", "extension": "plugins"}


def _floats(el, attr, n, file, default=None):
    text = el.get(attr)
    if text is None:
        return None if default is None else np.array(default, float)
    return np.array(xml.numbers(text, n, file, el, attr))


def _pose(el, file, degrees, seq):
    """The SE3 of an element's pos + quat / euler / axisangle, relative to its parent body."""
    p = _floats(el, "pos", 3, file, [0, 0, 0])
    if el.get("quat") is not None:
        w, x, y, z = _floats(el, "quat", 4, file)
        R = pin.Quaternion(w, x, y, z).normalized().toRotationMatrix()
    elif el.get("euler") is not None:
        a = _floats(el, "euler", 3, file) * (np.pi / 180 if degrees else 1.0)
        R = np.eye(3)
        for ang, ax in zip(a, seq):
            Ri = pin.exp3(ang * np.eye(3)["xyzXYZ".index(ax) % 3])
            R = R @ Ri if ax.islower() else Ri @ R          # lower case: rotating axes (MuJoCo)
    elif el.get("axisangle") is not None:
        aa = _floats(el, "axisangle", 4, file)
        ang = aa[3] * (np.pi / 180 if degrees else 1.0)
        R = pin.exp3(ang * aa[:3] / np.linalg.norm(aa[:3]))
    else:
        R = np.eye(3)
    return pin.SE3(R, p)


def read(path) -> Graph:
    file = str(path)
    root = xml.parse_root(path, "mujoco", "an MJCF file")
    g = Graph(root.get("model", "model"), file, "mjcf")
    comp = root.find("compiler")
    degrees = comp is None or comp.get("angle", "degree") == "degree"
    seq = comp.get("eulerseq", "xyz") if comp is not None else "xyz"
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
    sites = {}
    # the links of bodies a pinclear export merged into their child (pinclear.io.export_mjcf._tree_xml)
    links = {t.get("name")[len(LINK):]: t.get("data") for t in root.findall("custom/text")
             if (t.get("name") or "").startswith(LINK)}
    _bodies(world, WORLD, pin.SE3.Identity(), g, file, (degrees, seq, links), sites)
    annotated = _annotation(root, file)
    eq = root.find("equality")
    for e in eq if eq is not None and annotated is None else ():
        _equality(e, g, file, sites)
    g.root = next(iter(g.bodies), None)
    g.sidecar = annotated
    # sites a pinclear export wrote for the named frames of its tree (merged links, the root link)
    g.frames = [(n[len(FRAME_SITE):], b, X) for n, (b, X) in sites.items()
                if n and n.startswith(FRAME_SITE) and n[len(FRAME_SITE):] != WORLD]
    return g


def _bodies(parent_el, parent, X_parent, g, file, how, sites):
    """Read the bodies under ``parent_el``; ``how``: (angles in degrees, euler sequence, {joint:
    link} of the merged bodies)."""
    degrees, seq, links = how
    for s in parent_el.findall("site"):
        sites[s.get("name")] = (parent, X_parent * _pose(s, file, degrees, seq))
    for el in parent_el:
        if el.tag in ("geom", "camera", "light"):
            g.skip(el.tag, xml.where(el), LEFT_OUT[el.tag])
        elif el.tag not in ("body", "site", "joint", "inertial", "freejoint"):
            g.skip(el.tag, xml.where(el), "unknown element")
    for b in parent_el.findall("body"):
        name = b.get("name") or f"body_line{b.line}"
        if name in g.bodies or name == WORLD:
            raise ModelFileError(file, xml.where(b), f"body name {name!r} used twice (or reserved)")
        X = X_parent * _pose(b, file, degrees, seq)
        body = Body(name, X, C=X, line=b.line)
        ine = b.find("inertial")
        if ine is not None:
            body.C = X * _pose(ine, file, degrees, seq)
            body.mass = float(_floats(ine, "mass", 1, file)[0])
            if ine.get("fullinertia") is not None:
                a = _floats(ine, "fullinertia", 6, file)
                body.inertia = np.array([[a[0], a[3], a[4]], [a[3], a[1], a[5]], [a[4], a[5], a[2]]])
            else:
                body.inertia = np.diag(_floats(ine, "diaginertia", 3, file))
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


def _joint(j, parent, child, X, g, file, degrees, seq):
    kind = "free" if j.tag == "freejoint" else j.get("type", "hinge")
    types = {"hinge": "revolute", "slide": "prismatic"}
    if kind not in types:
        raise ModelFileError(file, xml.where(j), f"joint type {kind!r} inside the body tree has no URDF form",
                             choices=sorted(types))
    Xj = X * pin.SE3(np.eye(3), _floats(j, "pos", 3, file, [0, 0, 0]))
    axis = X.rotation @ _floats(j, "axis", 3, file, [0, 0, 1])
    jt = Joint(j.get("name") or f"{child}_joint", types[kind], parent, child, Xj, axis / np.linalg.norm(axis),
               line=j.line)
    rng = j.get("range")
    if rng is not None:
        lo, hi = xml.numbers(rng, 2, file, j, "range")
        k = np.pi / 180 if degrees and kind == "hinge" else 1.0
        jt.lower, jt.upper = lo * k, hi * k
    jt.stiffness = float(_floats(j, "stiffness", 1, file, [0.0])[0])
    jt.damping = float(_floats(j, "damping", 1, file, [0.0])[0])
    jt.reference = float(_floats(j, "springref", 1, file, [0.0])[0])
    for a in ("armature", "frictionloss"):
        if j.get(a) is not None and float(j.get(a)) != 0.0:
            g.skip(f"joint {a}", xml.where(j), "not modelled by pinclear's ideal joints")
    g.joints.append(jt)


def _equality(e, g, file, sites):
    soft = {k: e.get(k) for k in ("solref", "solimp") if e.get(k) is not None}
    if soft:
        g.notes.append(f"{xml.where(e)}: MuJoCo softness {soft} (pinclear's closure is exact)")
    name = e.get("name") or f"{e.tag}_line{e.line}"
    if e.tag in ("connect", "weld"):
        if e.get("site1") is not None:
            (b1, X1), (b2, X2) = (sites[e.get(k)] for k in ("site1", "site2"))
        else:
            b1, b2 = e.get("body1"), e.get("body2") or WORLD
            for b in (b1, b2):
                if b not in g.bodies and b != WORLD:
                    raise ModelFileError(file, xml.where(e), f"unknown body {b!r}", choices=sorted(g.bodies))
            anchor = _floats(e, "anchor", 3, file, [0, 0, 0])
            Xb1 = g.bodies[b1].X
            X1 = Xb1 * pin.SE3(np.eye(3), anchor)
            X2 = X1 if e.tag == "connect" else X1
        g.closings.append(Closing(name, "spherical" if e.tag == "connect" else "weld", b1, b2, X1, X2, e.line))
    elif e.tag == "joint":
        c = xml.numbers(e.get("polycoef", "0 1 0 0 0"), 5, file, e, "polycoef")
        if any(c[2:]):
            raise ModelFileError(file, xml.where(e), "polycoef: only a linear polynomial is a coupling")
        # MuJoCo: joint1 = c0 + c1 joint2 (qpos0 = 0)
        g.couplings.append(Coupling(name, c[1], c[0], joint1=e.get("joint2"), joint2=e.get("joint1"), line=e.line))
    else:
        g.skip(f"equality {e.tag}", xml.where(e), "no pinclear closure of this kind")


def _annotation(root, file):
    """The sidecar mapping a pinclear export left in <custom><text name="pinclear:sidecar">."""
    for t in root.findall("custom/text"):
        if t.get("name") == ANNOTATION:
            try:
                return json.loads(t.get("data", ""))
            except ValueError:
                raise ModelFileError(file, xml.where(t), "the pinclear annotation is not valid JSON") from None
    return None
