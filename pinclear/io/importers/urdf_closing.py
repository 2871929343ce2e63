"""URDF with closing frames (onshape-to-robot's convention) read into pinclear.io.importers.graph.

A CAD exporter writes the spanning tree as URDF and marks each cut joint by two frames, links
named ``closing_<name>_1`` and ``closing_<name>_2`` fixed to the two bodies the cut joint
joins (onshape-to-robot: "closing_" frames, made coincident by a ball constraint). Each pair
becomes a spherical closure ``<name>``; a frame without its partner is an error naming it. URDF's
``<mimic joint= multiplier= offset=>`` becomes a coupling closure (the mimicking joint =
multiplier x the mimicked + offset) and ``<dynamics damping>`` a joint damper; ``friction`` is
named, not modelled. The tree is the file's own (URDF holds no loop).
"""
from __future__ import annotations

import re

import numpy as np
import pinocchio as pin

from pinclear.core.errors import ModelFileError
from pinclear.io.importers import xml
from pinclear.io.importers.graph import WORLD, Body, Closing, Coupling, Graph, Joint, se3, unit
from pinclear.io.urdf_check import check_urdf_tree

CLOSING = re.compile(r"^closing_(.+)_([12])$")
TYPES = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic", "fixed": "fixed"}


def _origin(el, file):
    o = el.find("origin")
    if o is None:
        return pin.SE3.Identity()
    return se3(xml.numbers(o.get("xyz", "0 0 0"), 3, file, o, "xyz"),
               xml.numbers(o.get("rpy", "0 0 0"), 3, file, o, "rpy"))


def read(path) -> Graph:
    file = str(path)
    root = xml.parse_root(path, "robot", "a URDF file")
    # the checks every URDF meets before Pinocchio reads it (counts, one tree without cycles or
    # a link with two parents, the depth, finite numbers, masses >= 0, non-zero axes, unique
    # names), each naming the element's line; <mimic> is read below as a coupling
    check_urdf_tree(root, file, mimic_ok=True)
    g = Graph(root.get("name", "robot"), file, "urdf")
    g.gravity_source = "the default (a URDF holds no gravity)"
    links = {el.get("name"): el for el in root.findall("link")}
    joints = root.findall("joint")
    child_of = {j.find("child").get("link"): j for j in joints}
    children = {}
    for j in joints:
        children.setdefault(j.find("parent").get("link"), []).append(j)
    roots = [n for n in links if n not in child_of]          # one, check_urdf_tree says
    X = {roots[0]: pin.SE3.Identity()}
    order = [roots[0]]
    for n in order:                          # breadth-first over the file's tree (a tree: checked)
        for j in children.get(n, ()):
            c = j.find("child").get("link")
            X[c] = X[n] * _origin(j, file)
            order.append(c)
    for n in order:
        if n != WORLD:                       # a root link named "world" is the world itself
            g.bodies[n] = _body(links[n], X[n], file, g)
    g.root = roots[0]
    if roots[0] != WORLD:
        g.joints.append(Joint(f"{roots[0]}__fixed", "fixed", WORLD, roots[0], pin.SE3.Identity()))
    for j in joints:
        _joint(j, X, g, file)
    _closings(g, file)
    return g


def _body(el, X, file, g):
    b = Body(el.get("name"), X, C=X, line=el.line)
    ine = el.find("inertial")
    if ine is not None:
        b.C = X * _origin(ine, file)
        m = ine.find("mass")
        b.mass = xml.numbers(m.get("value"), 1, file, m, "value")[0] if m is not None else 0.0
        i = ine.find("inertia")
        if i is not None:
            v = {k: xml.numbers(i.get(k, "0"), 1, file, i, k)[0] for k in ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")}
            b.inertia = np.array([[v["ixx"], v["ixy"], v["ixz"]], [v["ixy"], v["iyy"], v["iyz"]],
                                  [v["ixz"], v["iyz"], v["izz"]]])
    for c in el:
        if c.tag == "collision":
            g.skip("collision", xml.where(c), "collision geometry is not part of a pinclear mechanism")
        elif c.tag == "visual":
            g.skip("visual", xml.where(c), "visuals of a URDF import are not carried over (yet)")
    return b


def _joint(j, X, g, file):
    jtype = j.get("type")
    if jtype not in TYPES:
        raise ModelFileError(file, xml.where(j), f"joint type {jtype!r} is not imported", choices=sorted(TYPES))
    p, c = j.find("parent").get("link"), j.find("child").get("link")
    Xj = X[c]
    ax = j.find("axis")
    axis = np.array(xml.numbers(ax.get("xyz"), 3, file, ax, "xyz")) if ax is not None else np.array([1.0, 0, 0])
    jt = Joint(j.get("name"), TYPES[jtype], p, c, Xj, unit(Xj.rotation @ axis, file, xml.where(j)), line=j.line)
    lim = j.find("limit")
    if lim is not None and jtype != "continuous":
        jt.lower, jt.upper = (xml.number(lim, k, file) for k in ("lower", "upper"))
        jt.effort, jt.velocity = (xml.number(lim, k, file) for k in ("effort", "velocity"))
    dyn = j.find("dynamics")
    if dyn is not None:
        jt.damping = xml.number(dyn, "damping", file, 0.0)
        if xml.number(dyn, "friction", file, 0.0):
            g.skip("dynamics friction", xml.where(dyn), "Coulomb joint friction is not modelled by an ideal joint")
    mim = j.find("mimic")
    if mim is not None:
        if mim.get("joint") is None:
            raise ModelFileError(file, xml.where(mim), "a <mimic> names the joint it follows (joint=...)")
        g.couplings.append(Coupling(f"{jt.name}.mimic", xml.number(mim, "multiplier", file, 1.0),
                                    xml.number(mim, "offset", file, 0.0),
                                    joint1=mim.get("joint"), joint2=jt.name, line=mim.line))
    g.joints.append(jt)


def _closings(g, file):
    pairs = {}
    for name in g.bodies:
        m = CLOSING.match(name)
        if m:
            pairs.setdefault(m.group(1), {})[m.group(2)] = name
    for name, pair in sorted(pairs.items()):
        if set(pair) != {"1", "2"}:
            have = next(iter(pair.values()))
            raise ModelFileError(file, f"link {have!r} (line {g.bodies[have].line})",
                                 f"closing frame without its partner closing_{name}_{'2' if '1' in pair else '1'}")
        b1, b2 = pair["1"], pair["2"]
        g.closings.append(Closing(name, "spherical", b1, b2, g.bodies[b1].X, g.bodies[b2].X, g.bodies[b1].line))
