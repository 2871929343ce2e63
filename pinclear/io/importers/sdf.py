"""SDF (1.6 and later) read into pinclear.io.importers.graph: links, inertials, joints, frames.

Poses: SDF 1.6's ``<pose frame="F">`` and 1.7+'s ``relative_to="F"``; the defaults of the SDF
specification (sdformat.org, "Pose frame semantics"): a link's pose is relative to the model
frame, a joint's to its child link, an inertial's, visual's and collision's to their link, a
``<frame>``'s to the frame it is attached to. Axes: ``<use_parent_model_frame>`` (1.6: the
model frame) or ``<xyz expressed_in="F">`` (1.7+), otherwise the joint frame. A gearbox joint
(SDF: theta2 = -gearbox_ratio theta1, both relative to gearbox_reference_body) becomes a
coupling; ball joints become spherical closures (URDF has no ball joint).
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin

from pinclear.core.errors import ModelFileError
from pinclear.io.importers import xml
from pinclear.io.importers.graph import (
    MAX_BODIES,
    MAX_FRAME_CHAIN,
    MAX_JOINTS,
    WORLD,
    Body,
    Coupling,
    Graph,
    Joint,
    se3,
    unit,
)

MODEL_TAGS = {"link", "joint", "frame", "pose", "static", "self_collide", "allow_auto_disable", "plugin",
              "include", "model", "enable_wind", "gripper"}
LINK_TAGS = {"pose", "inertial", "visual", "collision", "sensor", "self_collide", "gravity", "kinematic",
             "must_be_base_link", "velocity_decay", "light", "battery", "projector", "enable_wind"}
JOINT_TAGS = {"parent", "child", "pose", "axis", "axis2", "physics", "sensor", "gearbox_ratio",
              "gearbox_reference_body", "thread_pitch"}
AXIS_TAGS = {"xyz", "use_parent_model_frame", "limit", "dynamics", "initial_position"}
JOINT_TYPES = {"revolute": "revolute", "continuous": "revolute", "prismatic": "prismatic", "fixed": "fixed",
               "ball": "ball", "universal": "universal"}
#: elements read by no importer step: why each is left out (the report names every one)
LEFT_OUT = {"collision": "collision geometry is not part of a pinclear mechanism (clearances are declared in the "
                         "sidecar)",
            "sensor": "sensors are not simulated", "plugin": "plugins are code: never loaded",
            "self_collide": "no collisions between bodies", "physics": "engine-specific solver settings",
            "gravity": "per-link gravity switch", "static": "a static model: read as a fixed root",
            "allow_auto_disable": "engine setting", "kinematic": "engine setting",
            "velocity_decay": "engine damping", "initial_position": "the import starts at the reference pose",
            "surface": "contact parameters", "enable_wind": "no wind"}


def read(path) -> Graph:
    """The Graph of the first <model> of an SDF file (SDF 1.6 or later)."""
    file = str(path)
    root = xml.parse_root(path, "sdf", "an SDF file")
    version = root.get("version", "")
    try:
        major_minor = tuple(int(x) for x in version.split(".")[:2])
    except ValueError:
        major_minor = ()
    if len(major_minor) != 2 or major_minor < (1, 6):
        raise ModelFileError(file, xml.where(root), f"SDF version {version!r}: pinclear reads SDF 1.6 and later")
    models = root.findall("model") or [m for w in root.findall("world") for m in w.findall("model")]
    if not models:
        raise ModelFileError(file, xml.where(root), "no <model> element (a world's models are read too)")
    model = models[0]
    g = Graph(model.get("name", "model"), file, "sdf")
    for extra in models[1:]:
        g.skip("model", xml.where(extra), "only the first model of a file is imported")
    # bounded before anything is built (the writer's limits, pinclear.io.importers.graph)
    for tag, limit in (("link", MAX_BODIES), ("joint", MAX_JOINTS), ("frame", MAX_JOINTS)):
        els = model.findall(tag)
        if len(els) > limit:
            raise ModelFileError(file, xml.where(els[limit]), f"{len(els)} <{tag}> elements: more than pinclear "
                                 f"imports from one model (at most {limit})")
    _frames = _Frames(model, file)
    X_model = _frames.pose_of(model.find("pose"), None, model) if model.find("pose") is not None else pin.SE3.Identity()
    _frames.world = X_model
    for el in model:
        if el.tag not in MODEL_TAGS:
            g.skip(el.tag, xml.where(el), "unknown element")
        elif el.tag in ("include", "model"):
            g.skip(el.tag, xml.where(el), "nested and included models are not imported: merge them into one model")
        elif el.tag in LEFT_OUT:
            g.skip(el.tag, xml.where(el), LEFT_OUT[el.tag])
    for el in model.findall("link"):
        body = _link(el, _frames, g, file)
        if body.name in g.bodies or body.name == WORLD:
            raise ModelFileError(file, xml.where(el), f"link name {body.name!r} used twice (or reserved)")
        g.bodies[body.name] = body
    if not g.bodies:
        raise ModelFileError(file, xml.where(model), "the model has no <link>")
    for el in model.findall("frame"):          # every frame resolves (no cycle, no unknown name)
        if not el.get("name"):
            raise ModelFileError(file, xml.where(el), "a frame needs a name")
        _frames.frame(el.get("name"), el)
    for el in model.findall("joint"):
        _joint(el, _frames, g, file)
    g.root = model.findall("link")[0].get("name")       # SDF's canonical link: the first one
    if model.find("static") is not None and (model.find("static").text or "").strip() in ("1", "true"):
        g.skip("static", xml.where(model.find("static")), "a static model: every joint is read as it is")
    return g


class _Frames:
    """Named frames of a model and their poses in the world, resolved on demand by a loop (not
    a recursion): a chain of relative_to / frame / attached_to references longer than
    MAX_FRAME_CHAIN, or one that comes back to itself, is refused."""

    def __init__(self, model, file):
        self.file, self.model = file, model
        self.world = pin.SE3.Identity()
        self.elements = {}
        for tag in ("link", "joint", "frame"):
            for el in model.findall(tag):
                name = el.get("name")
                if name in self.elements:
                    raise ModelFileError(file, xml.where(el), f"the name {name!r} is also "
                                         f"{xml.where(self.elements[name])}: links, joints and frames of a model "
                                         "share one namespace (SDF)")
                self.elements[name] = el
        self.done, self.depth = {}, {}

    def default_base(self, el):
        """The frame an element's pose is relative to when its pose names none."""
        if el.tag == "joint":
            c = el.find("child")
            return (c.text or "").strip() if c is not None else None
        if el.tag == "frame":
            return el.get("attached_to") or None
        return None                                          # link: the model frame

    def _base(self, name):
        """The placement of a frame that needs no element: the model frame, the world, or one
        already resolved (None otherwise)."""
        if name in (None, "", "__model__"):
            return self.world
        if name == WORLD:
            return pin.SE3.Identity()
        return self.done.get(name)

    def frame(self, name, el):
        """World placement of the frame ``name`` (a link, joint, <frame>, __model__, world)."""
        chain, n, asker = [], name, el
        while (X := self._base(n)) is None:
            if len(chain) >= MAX_FRAME_CHAIN:
                raise ModelFileError(self.file, xml.where(asker), f"a chain of more than {MAX_FRAME_CHAIN} frames, "
                                     "each relative to the next: deeper than pinclear resolves")
            if n not in self.elements:
                raise ModelFileError(self.file, xml.where(asker), f"names the frame {n!r}, which the model does not "
                                     "define", choices=sorted(self.elements))
            if n in chain:
                raise ModelFileError(self.file, xml.where(asker), f"the pose of {n!r} is relative to itself (a cycle "
                                     f"of relative_to / frame attributes: {' -> '.join(chain[chain.index(n):] + [n])})")
            chain.append(n)
            src = self.elements[n]
            pose = src.find("pose")
            n = self._pose_base(pose, self.default_base(src))
            asker = pose if pose is not None else src
        # the chain's length from the model frame, whatever order the file lists the frames in
        depth = self.depth.get(n, 0) + len(chain)
        if depth > MAX_FRAME_CHAIN:
            raise ModelFileError(self.file, xml.where(self.elements[chain[0]]), f"a chain of {depth} frames, each "
                                 f"relative to the next: deeper than pinclear resolves (at most {MAX_FRAME_CHAIN})")
        for k, n in enumerate(reversed(chain)):
            pose = self.elements[n].find("pose")
            X = X * self._local(pose) if pose is not None else X
            self.done[n] = X
            self.depth[n] = depth - len(chain) + k + 1
        return X

    def _pose_base(self, pose, default_base):
        if pose is None:
            return default_base
        return pose.get("relative_to") or pose.get("frame") or default_base

    def _local(self, pose) -> pin.SE3:
        """A <pose>'s own transform: x y z roll pitch yaw (``degrees="true"``: the angles in
        degrees, SDF 1.9), or x y z and a quaternion x y z w (``rotation_format="quat_xyzw"``)."""
        fmt = pose.get("rotation_format", "euler_rpy")
        if fmt == "quat_xyzw":
            v = xml.numbers(pose.text, 7, self.file, pose)
            n = float(np.linalg.norm(v[3:]))
            if not n > 1e-12:
                raise ModelFileError(self.file, xml.where(pose), "the quaternion is zero")
            return pin.SE3(pin.Quaternion(v[6] / n, v[3] / n, v[4] / n, v[5] / n).toRotationMatrix(), np.array(v[:3]))
        if fmt != "euler_rpy":
            raise ModelFileError(self.file, xml.where(pose), f"rotation_format {fmt!r}",
                                 choices=["euler_rpy", "quat_xyzw"])
        v = xml.numbers(pose.text, 6, self.file, pose)
        deg = (pose.get("degrees") or "false").strip()
        if deg not in ("true", "false", "1", "0"):
            raise ModelFileError(self.file, xml.where(pose), f"degrees {deg!r}", choices=["true", "false"])
        k = np.pi / 180 if deg in ("true", "1") else 1.0
        return se3(v[:3], [a * k for a in v[3:]])

    def pose_of(self, pose, default_base, owner):
        """World placement of a <pose> (its base frame: relative_to, 1.6's frame, or the default)."""
        if pose is None:
            return self.frame(default_base, owner)
        return self.frame(self._pose_base(pose, default_base), pose) * self._local(pose)

    def local(self, pose, base_X):
        """A <pose> of a child element relative to its owner placed at base_X (relative_to wins)."""
        if pose is None:
            return base_X
        base = pose.get("relative_to") or pose.get("frame")
        X0 = self.frame(base, pose) if base else base_X
        return X0 * self._local(pose)


def _link(el, frames, g, file) -> Body:
    name = el.get("name")
    if not name:
        raise ModelFileError(file, xml.where(el), "a link needs a name")
    X = frames.frame(name, el)
    body = Body(name, X, C=X, line=el.line)
    for c in el:
        if c.tag not in LINK_TAGS:
            g.skip(c.tag, xml.where(c), "unknown element")
        elif c.tag in LEFT_OUT:
            g.skip(c.tag, xml.where(c), LEFT_OUT[c.tag])
        elif c.tag not in ("pose", "inertial", "visual"):
            g.skip(c.tag, xml.where(c), "not part of a pinclear mechanism")
    inertial = el.find("inertial")
    if inertial is not None:
        body.C = frames.local(inertial.find("pose"), X)
        body.mass = xml.child_number(inertial, "mass", file, 1.0)   # SDF's default mass is 1 kg
        if body.mass < 0:
            raise ModelFileError(file, xml.where(inertial.find("mass")), f"{body.mass} kg: a mass is >= 0")
        ine = inertial.find("inertia")
        # SDF's default inertia is identity; a massless link that gives none has none
        I = np.zeros((3, 3)) if ine is not None or body.mass == 0 else np.eye(3)
        if ine is not None:
            for (i, j), key, default in (((0, 0), "ixx", 1.0), ((1, 1), "iyy", 1.0), ((2, 2), "izz", 1.0),
                                         ((0, 1), "ixy", 0.0), ((0, 2), "ixz", 0.0), ((1, 2), "iyz", 0.0)):
                I[i, j] = I[j, i] = xml.child_number(ine, key, file, default)
        body.inertia = I
    for vis in el.findall("visual"):
        geom = _geometry(vis.find("geometry"), file, g)
        if geom is not None:
            body.visuals.append((frames.local(vis.find("pose"), X), geom))
    return body


def _geometry(el, file, g):
    """A visual's geometry as a dict (box, cylinder, sphere, mesh with a package:// URI)."""
    if el is None or len(el) == 0:
        return None
    shape = el[0]
    if shape.tag == "box":
        return {"box": xml.numbers(shape.findtext("size"), 3, file, shape, "size")}
    if shape.tag == "sphere":
        return {"sphere": xml.child_number(shape, "radius", file, 1.0)}
    if shape.tag == "cylinder":
        return {"cylinder": (xml.child_number(shape, "radius", file, 1.0),
                             xml.child_number(shape, "length", file, 1.0))}
    if shape.tag == "mesh":
        uri = (shape.findtext("uri") or "").strip()
        scale = shape.find("scale")
        s = xml.numbers(scale.text, 3, file, scale) if scale is not None else [1.0, 1.0, 1.0]
        # model://PACKAGE/path is resolved like URDF's package://PACKAGE/path (Gazebo's model path
        # and ROS's package path name the same folders for the robots of example-robot-data)
        if uri.startswith("model://"):
            uri = "package://" + uri[len("model://"):]
        if not uri.startswith("package://"):
            uri = _mesh_file(uri, file, g, xml.where(shape))
        return {"mesh": uri, "scale": s} if uri else None
    g.skip(shape.tag, xml.where(shape), "visual geometry of this kind is not imported")
    return None


def _utf8(text) -> bool:
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return True


def _mesh_file(uri, file, g, where):
    """A mesh named by a file path (relative to the SDF's folder, absolute, ``file://``) as the
    absolute path the written URDF names (it is written into --out, not beside the SDF); a file
    outside the SDF's folder, a missing one or another URI scheme is not imported: named in the
    report and printed as a warning, never opened."""
    from pathlib import Path

    path = uri.removeprefix("file://")
    here = Path(file).resolve().parent
    why = None
    if not path or "://" in path or "\x00" in path:
        why = "only package://, model:// and files in the SDF's folder are imported"
    else:
        target = (here / path).resolve()
        if not target.is_relative_to(here):
            why = f"it lies outside the SDF's folder {str(here)!r} (a data file names no file elsewhere)"
        elif not target.is_file():
            why = "no such file"
        elif not _utf8(str(target)):
            why = f"its path {str(target).encode('utf-8', 'surrogateescape')!r} is not UTF-8: a URDF cannot name it"
    if why is not None:
        g.skip("mesh", where, f"mesh {uri!r}: {why}")
        g.warnings.append(f"{where}: mesh {uri!r} not imported: {why}")
        return None
    return str(target)


def _axis(el, joint_X, frames, file, tag="axis"):
    """(unit axis in the world, limits, dynamics) of a joint's <axis> or <axis2>."""
    ax = el.find(tag)
    if ax is None:
        return np.array([0.0, 0.0, 1.0]) if tag == "axis" else None, None, None
    xyz_el = ax.find("xyz")
    v = np.array(xml.numbers(xyz_el.text, 3, file, xyz_el) if xyz_el is not None else [0.0, 0.0, 1.0])
    upm = ax.find("use_parent_model_frame")
    if xyz_el is not None and xyz_el.get("expressed_in"):
        R = frames.frame(xyz_el.get("expressed_in"), xyz_el).rotation
    elif upm is not None and (upm.text or "").strip() in ("1", "true"):
        R = frames.world.rotation
    else:
        R = joint_X.rotation
    return unit(R @ v, file, xml.where(xyz_el if xyz_el is not None else ax)), ax.find("limit"), ax.find("dynamics")


def _joint(el, frames, g, file):
    name, jtype = el.get("name"), el.get("type")
    if not name:
        raise ModelFileError(file, xml.where(el), "a joint needs a name")
    ends = []
    for end in ("parent", "child"):
        e = el.find(end)
        link = (e.text or "").strip() if e is not None else ""
        if not link:
            raise ModelFileError(file, xml.where(el), f"<{end}> missing (a joint names its parent and child links)")
        if link not in g.bodies and link != WORLD:
            raise ModelFileError(file, xml.where(e), f"unknown link {link!r}", choices=sorted(g.bodies) + [WORLD])
        ends.append(link)
    for c in el:
        if c.tag not in JOINT_TAGS:
            g.skip(c.tag, xml.where(c), "unknown element")
        elif c.tag in ("physics", "sensor"):
            g.skip(c.tag, xml.where(c), LEFT_OUT[c.tag])
    X = frames.frame(name, el)
    if jtype == "gearbox":
        _gearbox(el, ends, X, frames, g, file)
        return
    if jtype not in JOINT_TYPES:
        raise ModelFileError(file, xml.where(el), f"joint type {jtype!r} is not imported",
                             choices=sorted(JOINT_TYPES) + ["gearbox"])
    if ends[0] == ends[1]:
        raise ModelFileError(file, xml.where(el), f"joins link {ends[0]!r} to itself")
    axis, limit, dyn = _axis(el, X, frames, file)
    j = Joint(name, JOINT_TYPES[jtype], ends[0], ends[1], X, axis, line=el.line)
    if jtype == "universal":
        j.axis2 = _axis(el, X, frames, file, "axis2")[0]
        if j.axis2 is None:
            raise ModelFileError(file, xml.where(el), "a universal joint needs <axis2>")
    for tag in ("axis", "axis2"):
        ax = el.find(tag)
        for c in ax if ax is not None else ():
            if c.tag not in AXIS_TAGS:
                g.skip(c.tag, xml.where(c), "unknown element")
            elif c.tag in LEFT_OUT:
                g.skip(c.tag, xml.where(c), LEFT_OUT[c.tag])
    if limit is not None:
        j.lower, j.upper = xml.child_number(limit, "lower", file), xml.child_number(limit, "upper", file)
        # SDF: a negative effort or velocity (the default, -1) is no limit
        j.effort, j.velocity = (v if v is not None and v >= 0 else None
                                for v in (xml.child_number(limit, k, file) for k in ("effort", "velocity")))
        for c in limit:
            if c.tag in ("stiffness", "dissipation"):
                g.skip(f"limit/{c.tag}", xml.where(c), "joint-limit contacts are not modelled")
    if dyn is not None:
        j.damping = xml.child_number(dyn, "damping", file, 0.0)
        j.stiffness = xml.child_number(dyn, "spring_stiffness", file, 0.0)
        j.reference = xml.child_number(dyn, "spring_reference", file, 0.0)
        fr = xml.child_number(dyn, "friction", file, 0.0)
        if fr:
            g.skip("dynamics/friction", xml.where(dyn.find("friction")), f"Coulomb joint friction {fr} is not "
                   "modelled by an ideal joint (declare a clearance joint with friction instead)")
        if j.damping < 0 or j.stiffness < 0:
            raise ModelFileError(file, xml.where(dyn), "damping and spring_stiffness are >= 0")
    g.joints.append(j)


def _gearbox(el, ends, X, frames, g, file):
    """SDF gearbox: theta2 = -gearbox_ratio * theta1 (the SDF specification's <gearbox_ratio>),
    theta1 the parent link's angle about <axis>, theta2 the child's about <axis2>, both
    relative to <gearbox_reference_body>."""
    ref = (el.findtext("gearbox_reference_body") or "").strip()
    if ref not in g.bodies and ref != WORLD:
        raise ModelFileError(file, xml.where(el), f"gearbox_reference_body {ref!r} names no link",
                             choices=sorted(g.bodies))
    ratio_el = el.find("gearbox_ratio")
    ratio = xml.numbers(ratio_el.text, 1, file, ratio_el)[0] if ratio_el is not None else 1.0
    a1 = _axis(el, X, frames, file)[0]
    a2 = _axis(el, X, frames, file, "axis2")[0]
    if a2 is None:
        raise ModelFileError(file, xml.where(el), "a gearbox joint needs <axis2>")
    g.couplings.append(Coupling(el.get("name"), -ratio, reference=ref, body1=ends[0], body2=ends[1],
                                axis1=a1, axis2=a2, line=el.line))
