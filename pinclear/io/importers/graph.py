"""The neutral description every importer fills and the one writer reads.

A mechanism file (SDF, MJCF, URDF with closing frames) becomes bodies and joints placed in the
world at the file's reference configuration (all joint coordinates zero), plus the couplings
between joints (an SDF gearbox, an MJCF joint equality). pinclear.io.importers.cuts picks the
spanning tree, pinclear.io.importers.write writes the URDF tree and the sidecar.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

#: closure rows a cut joint of each type gives (pinclear.model.closures)
ROWS = {"ball": 3, "universal": 4, "revolute": 5, "prismatic": 5, "fixed": 6}
#: joint types a URDF tree can hold (URDF has no ball or universal joint)
TREE_TYPES = ("revolute", "prismatic", "fixed")
#: the closure type a cut joint of each type becomes
CLOSURE_OF = {"ball": "spherical", "universal": "universal", "revolute": "revolute", "prismatic": "prismatic",
              "fixed": "weld"}
WORLD = "world"

#: what one imported mechanism may hold (docs/security.md, "Importers"). The written URDF has at
#: most 1 + 2 MAX_BODIES + MAX_FRAMES links (a body, its ``__ref`` frame link, the kept frames)
#: and a chain at most MAX_DEPTH + 1 joints long: inside pinclear.io.urdf_check's limits (1000
#: links, 256 joints on a chain), which every URDF meets before Pinocchio's parser sees it
MAX_BODIES = 400
#: joints, couplings and closing-frame pairs together (a loop adds joints, not bodies)
MAX_JOINTS = 800
#: named frames kept in the tree (an exported MJCF's pinclear:frame: sites)
MAX_FRAMES = 100
#: joints on the longest chain of the spanning tree from the world
MAX_DEPTH = 250
#: frames on the longest chain of SDF poses, each relative to the next (a link's pose relative to
#: its joint's, the joint's to the parent link: two a level of the tree)
MAX_FRAME_CHAIN = 600


@dataclass
class Body:
    """A rigid body: its frame X (world, at the reference configuration), mass, the inertial
    frame C (world) and the rotational inertia about C's origin in C's axes."""

    name: str
    X: pin.SE3
    mass: float = 0.0
    C: pin.SE3 = None
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    visuals: list = field(default_factory=list)      # (X world, geometry dict)
    line: int = 0


@dataclass
class Joint:
    """A joint between two bodies: type (ROWS' keys), its frame X in the world (the axis line
    passes through X's origin), the axis (world, unit; axis2 for a universal joint), limits and
    the joint's spring and damper (SDF's <dynamics>)."""

    name: str
    type: str
    parent: str
    child: str
    X: pin.SE3
    axis: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    axis2: np.ndarray = None
    lower: float = None
    upper: float = None
    effort: float = None
    velocity: float = None
    damping: float = 0.0
    stiffness: float = 0.0
    reference: float = 0.0
    line: int = 0


@dataclass
class Coupling:
    """q(joint2) = ratio q(joint1) + offset between two 1-dof joints (an MJCF joint equality,
    a URDF mimic), or a gearbox (SDF): theta2 = -ratio theta1, the angles of ``body1`` and
    ``body2`` about ``axis1``/``axis2`` (world) relative to ``reference``, resolved to joints once
    the tree is known."""

    name: str
    ratio: float
    offset: float = 0.0
    joint1: str = None
    joint2: str = None
    reference: str = None
    body1: str = None
    body2: str = None
    axis1: np.ndarray = None
    axis2: np.ndarray = None
    line: int = 0


@dataclass
class Closing:
    """A closure given as two frames (a URDF's closing frames, an MJCF connect/weld): type
    (a pinclear closure type), the frames' bodies and world placements at the reference."""

    name: str
    type: str
    body1: str
    body2: str
    X1: pin.SE3
    X2: pin.SE3
    line: int = 0


@dataclass
class Graph:
    """What an importer read: bodies, joints, couplings, closures given as frame pairs, and
    the report's lines about everything not imported (named, never dropped silently)."""

    name: str
    file: str
    fmt: str
    bodies: dict = field(default_factory=dict)
    joints: list = field(default_factory=list)
    couplings: list = field(default_factory=list)
    closings: list = field(default_factory=list)
    gravity: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))
    gravity_source: str = "the SDF default (a model file holds no gravity)"
    not_imported: list = field(default_factory=list)  # (what, where, why)
    notes: list = field(default_factory=list)         # (what, soft parameters kept as data)
    root: str = None
    frames: list = field(default_factory=list)        # (name, body, X world): named frames to keep
    sidecar: dict = None                              # a pinclear description the file carries
    sidecar_where: str = None                         # where the file carries it (element, line)
    replaced: str = None                              # what of the file that description replaced
    warnings: list = field(default_factory=list)      # lines the command prints as warnings

    def skip(self, what, where, why):
        self.not_imported.append((what, where, why))


def _finite(x) -> bool:
    return bool(np.all(np.isfinite(np.asarray(x, float))))


def _se3_ok(X) -> bool:
    return X is not None and _finite(X.homogeneous)


def validate(g):
    """Refuse, naming the source file, the element and its line, what the writer could not turn
    into a model with the file's meaning: more than the limits above, names used twice, a joint
    whose ends are unknown or the same body, a non-finite pose or axis, a negative or non-finite
    mass, inertia that is not finite and symmetric, a massless body with rotational inertia
    (I <= m r^2 for every mass element: no mass, no inertia), limits that are not finite or out
    of order, a negative effort, velocity, damping or stiffness, a coupling naming no 1-dof
    joint. Every reader's Graph passes here before anything is written."""
    _check_counts(g)
    _check_bodies(g)
    _check_names(g)
    ends = set(g.bodies) | {WORLD}
    _check_joints(g, ends)
    _check_couplings_closings_frames(g, ends)


def _check_counts(g):
    """The file has bodies, and no more bodies, joints or frames than the limits."""
    from pinclear.core.errors import ModelFileError

    file = g.file
    if not g.bodies:
        raise ModelFileError(file, "bodies", "the file holds no body to import")
    if len(g.bodies) > MAX_BODIES:
        b = list(g.bodies.values())[MAX_BODIES]
        raise ModelFileError(file, f"body {b.name!r} (line {b.line})", f"{len(g.bodies)} bodies: more than pinclear "
                             f"imports from one file (at most {MAX_BODIES})")
    n_joints = len(g.joints) + len(g.couplings) + len(g.closings)
    if n_joints > MAX_JOINTS:
        raise ModelFileError(file, "joints", f"{n_joints} joints, couplings and closures: more than pinclear imports "
                             f"from one file (at most {MAX_JOINTS})")
    if len(g.frames) > MAX_FRAMES:
        raise ModelFileError(file, "frames", f"{len(g.frames)} named frames: more than pinclear keeps (at most "
                             f"{MAX_FRAMES})")


def _check_bodies(g):
    """Each body's pose, mass and inertia."""
    from pinclear.core.errors import ModelFileError

    file = g.file
    for b in g.bodies.values():
        where = f"body {b.name!r} (line {b.line})"
        if not (_se3_ok(b.X) and _se3_ok(b.C)):
            raise ModelFileError(file, where, "its pose is not finite")
        I = np.asarray(b.inertia, float)
        if not (np.isfinite(b.mass) and b.mass >= 0):
            raise ModelFileError(file, where, f"mass {b.mass!r} kg: a mass is finite and >= 0")
        if I.shape != (3, 3) or not _finite(I) or np.abs(I - I.T).max() > 1e-12 * max(1.0, np.abs(I).max()):
            raise ModelFileError(file, where, "its inertia is not a finite symmetric 3x3 matrix")
        if b.mass == 0 and np.any(I != 0):
            raise ModelFileError(file, where, "mass 0 with a non-zero inertia: a body without mass has no rotational "
                                 "inertia (every mass element adds m r^2); give its mass, or leave the inertia out")


def _check_names(g):
    """Joint, coupling and closure names: present and unique."""
    from pinclear.core.errors import ModelFileError

    file = g.file
    seen = {}
    items = [("joint", j.name, j.line) for j in g.joints] + [("coupling", c.name, c.line) for c in g.couplings]
    items += [("closure", c.name, c.line) for c in g.closings]
    for kind, name, line in items:
        if not isinstance(name, str) or not name:
            raise ModelFileError(file, f"{kind} (line {line})", "has no name")
        if name in seen:
            raise ModelFileError(file, f"{kind} {name!r} (line {line})", f"the name is used twice (first by the "
                                 f"{seen[name][0]} on line {seen[name][1]}): joint, coupling and closure names are "
                                 "unique")
        seen[name] = (kind, line)


def _check_joints(g, ends):
    """Each joint's type, ends, pose, axes and limits."""
    from pinclear.core.errors import ModelFileError

    file = g.file
    for j in g.joints:
        where = f"joint {j.name!r} (line {j.line})"
        if j.type not in ROWS:
            raise ModelFileError(file, where, f"joint type {j.type!r} is not imported", choices=sorted(ROWS))
        for end in (j.parent, j.child):
            if end not in ends:
                raise ModelFileError(file, where, f"joins the unknown body {end!r}", choices=sorted(ends))
        if j.parent == j.child:
            raise ModelFileError(file, where, f"joins body {j.parent!r} to itself")
        if not _se3_ok(j.X):
            raise ModelFileError(file, where, "its pose is not finite")
        for ax in (j.axis, j.axis2) if j.type == "universal" else (j.axis,):
            a = np.asarray(ax, float) if ax is not None else None
            if a is None or a.shape != (3,) or not _finite(a) or abs(np.linalg.norm(a) - 1.0) > 1e-9:
                raise ModelFileError(file, where, "its axis is not a finite non-zero direction")
        for attr in ("lower", "upper", "effort", "velocity"):
            v = getattr(j, attr)
            if v is not None and not np.isfinite(v):
                raise ModelFileError(file, where, f"{attr} {v!r} is not finite (leave the limit out for none)")
        if j.lower is not None and j.upper is not None and j.lower > j.upper:
            raise ModelFileError(file, where, f"lower limit {j.lower!r} above the upper limit {j.upper!r}")
        for attr in ("effort", "velocity", "damping", "stiffness"):
            v = getattr(j, attr)
            if v is not None and not (np.isfinite(v) and v >= 0):
                raise ModelFileError(file, where, f"{attr} {v!r}: finite and >= 0")
        if not np.isfinite(j.reference):
            raise ModelFileError(file, where, f"spring reference {j.reference!r} is not finite")


def _check_couplings_closings_frames(g, ends):
    """Couplings name 1-dof joints or known bodies; closures and frames known bodies and finite poses."""
    from pinclear.core.errors import ModelFileError

    file = g.file
    one_dof = {j.name for j in g.joints if j.type in ("revolute", "prismatic")}
    for c in g.couplings:
        where = f"coupling {c.name!r} (line {c.line})"
        if not (np.isfinite(c.ratio) and np.isfinite(c.offset)):
            raise ModelFileError(file, where, "its ratio and offset must be finite")
        if c.joint1 is not None or c.joint2 is not None:
            for jn in (c.joint1, c.joint2):
                if jn not in one_dof:
                    raise ModelFileError(file, where, f"names {jn!r}, not a revolute or prismatic joint of the file",
                                         choices=sorted(one_dof))
            if c.joint1 == c.joint2:
                raise ModelFileError(file, where, f"couples joint {c.joint1!r} to itself")
        else:
            for b in (c.body1, c.body2, c.reference):
                if b not in ends:
                    raise ModelFileError(file, where, f"names the unknown body {b!r}", choices=sorted(ends))
    for c in g.closings:
        where = f"closure {c.name!r} (line {c.line})"
        for b in (c.body1, c.body2):
            if b not in ends:
                raise ModelFileError(file, where, f"names the unknown body {b!r}", choices=sorted(ends))
        if c.body1 == c.body2:
            raise ModelFileError(file, where, f"joins body {c.body1!r} to itself")
        if not (_se3_ok(c.X1) and _se3_ok(c.X2)):
            raise ModelFileError(file, where, "its frames are not finite")
    names = set(g.bodies)
    for name, body, X in g.frames:
        if body not in ends or not _se3_ok(X):
            raise ModelFileError(file, f"frame {name!r}", f"on the unknown body {body!r} or not finite")
        if name in names:
            raise ModelFileError(file, f"frame {name!r}", "the name is used twice (a body or another frame)")
        names.add(name)


def se3(xyz, rpy) -> pin.SE3:
    return pin.SE3(pin.rpy.rpyToMatrix(np.asarray(rpy, float)), np.asarray(xyz, float))


def unit(v, file, key):
    from pinclear.core.errors import ModelFileError

    v = np.asarray(v, float)
    n = np.linalg.norm(v)
    if not n > 0:
        raise ModelFileError(file, key, "is the zero vector: an axis needs a direction")
    return v / n
