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

    def skip(self, what, where, why):
        self.not_imported.append((what, where, why))


def se3(xyz, rpy) -> pin.SE3:
    return pin.SE3(pin.rpy.rpyToMatrix(np.asarray(rpy, float)), np.asarray(xyz, float))


def unit(v, file, key):
    from pinclear.core.errors import ModelFileError

    v = np.asarray(v, float)
    n = np.linalg.norm(v)
    if not n > 0:
        raise ModelFileError(file, key, "is the zero vector: an axis needs a direction")
    return v / n
