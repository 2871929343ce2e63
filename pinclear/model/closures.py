"""Loop closures: each closure type is a fixed combination of a few geometric primitives.

Every closure joins frame F1 (on body 1) and frame F2 (on body 2). The joint axes are the
frames' z axes:

=============  ====  =====================================================================
type           rows  equations
=============  ====  =====================================================================
spherical        3   p1 = p2
revolute         5   p1 = p2, x1.z2 = 0, y1.z2 = 0         (axis z, common to both frames)
universal        4   p1 = p2, z1.z2 = 0                    (first axis z1, second axis z2)
prismatic        5   x1.y2 = y1.z2 = z1.x2 = 0, x1.d = y1.d = 0   (slide along z1, d = p2 - p1)
cylindrical      4   x1.z2 = y1.z2 = 0, x1.d = y1.d = 0
weld             6   p1 = p2, x1.y2 = y1.z2 = z1.x2 = 0
planar_point     2   E^T (p1 - p2) = 0, E spans the plane normal to n (world, default z)
distance         1   |p1 - p2| = L
coupling         1   q(joint2) = ratio q(joint1) + offset  (pinclear.model.coupling)
=============  ====  =====================================================================

The primitives of all closures are compiled into one table evaluated by the kernel
``pinclear.core.dense.closure_rows`` from the frame kinematics; a closure never calls Pinocchio.
Velocity-level rows are J v; acceleration level J a + bias, the bias being the value of the
second time derivative at zero joint acceleration (from Pinocchio's dJ/dt, no finite differences).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np

from pinclear.core.errors import ModelFileError
from pinclear.core.registry import Key
from pinclear.model.coupling import COUPLING_KEYS
from pinclear.model.coupling import KEYS as COUPLING_ENTRY_KEYS
from pinclear.model.rows import COUPLE, DIST, DOT, PERP, PLANE, POINT

# (primitive, arguments, row labels)
_POINT = ("point", (), ("x", "y", "z"))
_ORIENT = [("dot", (0, 1), ("rz",)), ("dot", (1, 2), ("rx",)), ("dot", (2, 0), ("ry",))]


@dataclass(frozen=True)
class ClosureType:
    """One closure type: its sidecar name, its geometry (primitives of the compiled table:
    (primitive, arguments, row labels)), one line for the key reference, the keys of KEYS it
    reads besides the frames (``keys``) and those its entries must give (``required``)."""

    name: str
    primitives: tuple
    doc: str
    keys: tuple = ()
    required: tuple = ()


_NORMAL = Key("normal", "[x, y, z]", "-", [0, 0, 1], "non-zero (normalised)", "closures.py: E spans the plane "
              "normal to n", "world normal of the plane the point keeps to (planar_point)")
_LENGTH = Key("length", "number", "m", 0.0, "> 0 (distance: required)", "closures.py: |p1 - p2| = L",
              "the distance (distance)")

#: the closure types (sidecar ``closures: [{type: ...}]``): one line each
CLOSURES = MappingProxyType({t.name: t for t in (
    ClosureType("spherical", (_POINT,), "p1 = p2 (3 rows)"),
    ClosureType("revolute", (_POINT, ("dot", (0, 2), ("ry",)), ("dot", (1, 2), ("rx",))),
                "p1 = p2, x1.z2 = y1.z2 = 0: a hinge about the common z axis (5 rows)"),
    ClosureType("universal", (_POINT, ("dot", (2, 2), ("rn",))), "p1 = p2, z1.z2 = 0 (4 rows)"),
    ClosureType("prismatic", tuple(_ORIENT) + (("perp", (0,), ("x",)), ("perp", (1,), ("y",))),
                "orientations equal, x1.d = y1.d = 0: a slide along z1 (5 rows)"),
    ClosureType("cylindrical", (("dot", (0, 2), ("ry",)), ("dot", (1, 2), ("rx",)), ("perp", (0,), ("x",)),
                                ("perp", (1,), ("y",))), "x1.z2 = y1.z2 = 0, x1.d = y1.d = 0 (4 rows)"),
    ClosureType("weld", (_POINT,) + tuple(_ORIENT), "p1 = p2, orientations equal (6 rows)"),
    ClosureType("planar_point", (("plane", (), ("u", "v")),), "E^T (p1 - p2) = 0, E spanning the plane normal "
                "to ``normal``: the point of a planar hinge (2 rows)", keys=(_NORMAL,)),
    ClosureType("distance", (("distance", (), ("d",)),), "|p1 - p2| = L (1 row)", keys=(_LENGTH,),
                required=("length",)),
    ClosureType("coupling", (("couple", (), ("c",)),), "q(joint2) = ratio q(joint1) + offset between two 1-dof "
                "joints, no frames (1 row; pinclear.model.coupling: a gearbox, a mimic)", keys=COUPLING_KEYS,
                required=("joint1", "joint2", "ratio")),
)})
#: the keys of a ``closures:`` entry (every type accepts them all; ``ClosureType.keys`` says which it reads)
KEYS = (Key("name", "string", "-", "loop<index>", "unique", doc="the closure's name (rows are NAME.x, ...)"),
        Key("type", "string", "-", range="a closure type", doc="the closure type (below)"),
        Key("frame1", "frame", doc="frame on body 1 (socket, bearing, guide of a clearance): a frame name or "
            "{parent, xyz, rpy | axis, name}"),
        Key("frame2", "frame", doc="frame on body 2 (ball, journal, slider), on another body"),
        _NORMAL, _LENGTH)

#: closure type -> its primitives (the compiled table's rows)
CLOSURE_TYPES: dict[str, list] = {n: list(t.primitives) for n, t in CLOSURES.items()}
#: closure types Pinocchio's rigid constraints express exactly (pin.ContactType)
PINOCCHIO_TYPES = {"spherical": "CONTACT_3D", "weld": "CONTACT_6D"}


@dataclass
class Closure:
    """One loop closure (immutable description)."""

    name: str
    type: str
    frame1: str
    frame2: str
    f1: int                      # frame ids in the Pinocchio model
    f2: int
    normal: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, 1.0]))
    length: float = 0.0
    coupling: tuple = None       # (iq1, iv1, iq2, iv2, ratio, offset) of a coupling (pinclear.model.coupling)

    @property
    def nrows(self) -> int:
        return sum(len(p[2]) for p in CLOSURE_TYPES[self.type])

    def row_names(self) -> list[str]:
        return [f"{self.name}.{lab}" for p in CLOSURE_TYPES[self.type] for lab in p[2]]


def plane_basis(n):
    """Two orthonormal vectors spanning the plane normal to n."""
    n = np.asarray(n, float) / np.linalg.norm(n)
    a = np.eye(3)[np.argmin(np.abs(n))]
    e1 = np.cross(n, a)
    e1 /= np.linalg.norm(e1)
    return np.stack([e1, np.cross(n, e1)])


class CompiledClosures:
    """All closure rows of a mechanism, grouped by primitive for vectorised evaluation.

    ``frames`` lists the distinct frame ids the closures use; primitives index into it.
    """

    def __init__(self, closures: list[Closure]):
        self.closures = closures
        frames: list[int] = []

        def slot(fid):
            if fid not in frames:
                frames.append(fid)
            return frames.index(fid)

        groups: dict[str, dict[str, list]] = {}
        row = 0
        # each row's unit group: a closure's length rows and its angle (dot) rows. S's diagonal
        # is summed over a group (invariant under rotating the closure's frame, and a flat
        # passage never vanishes all of a group's rows) to scale the manifold's filter per unit
        kinds: dict[tuple, int] = {}
        row_group = []
        for ic, c in enumerate(closures):
            i1, i2 = slot(c.f1), slot(c.f2)
            for prim, args, labels in CLOSURE_TYPES[c.type]:
                row_group += [kinds.setdefault((ic, prim == "dot"), len(kinds))] * len(labels)
                g = groups.setdefault(prim, {"i1": [], "i2": [], "rows": [], "args": []})
                g["i1"].append(i1)
                g["i2"].append(i2)
                g["rows"].append(list(range(row, row + len(labels))))
                if prim == "plane":
                    g["args"].append(plane_basis(c.normal))
                elif prim == "distance":
                    g["args"].append(c.length)
                elif prim == "couple":
                    g["args"].append(c)
                else:
                    g["args"].append(args)
                row += len(labels)
        self.m = row
        self.frames = np.array(frames, dtype=int)
        self.row_names = [n for c in closures for n in c.row_names()]
        self.row_group = np.array(row_group, dtype=np.int64)
        self.row_group.flags.writeable = False
        # flat table for the compiled kernel: (code, i1, i2, first row, axis a, axis b)
        codes = {"point": POINT, "plane": PLANE, "dot": DOT, "perp": PERP, "distance": DIST, "couple": COUPLE}
        table, E, L = [], [], []
        for prim, g in groups.items():
            for k in range(len(g["i1"])):
                arg = g["args"][k]
                ab = tuple(arg) + (0, 0) if isinstance(arg, tuple) else (0, 0)
                if prim == "couple":
                    from pinclear.model.coupling import table_entry

                    ab, arg = table_entry(arg)
                table.append((codes[prim], g["i1"][k], g["i2"][k], g["rows"][k][0], ab[0], ab[1]))
                E.append(arg if prim in ("plane", "couple") else np.zeros((2, 3)))
                L.append(arg if prim == "distance" else 0.0)
        self.table = np.array(table, dtype=np.int64).reshape(-1, 6)
        self.E = np.array(E, float).reshape(-1, 2, 3)
        self.L = np.array(L, float)


def coupling_closure(model, spec, file, key, name):
    """The Closure of a sidecar ``type: coupling`` entry (the joints checked as 1-dof joints)."""
    from pinclear.core.values import check_keys as _check_keys
    from pinclear.core.values import joint as _joint
    from pinclear.core.values import number as _number

    _check_keys(spec, COUPLING_ENTRY_KEYS, file, key)
    ends = []
    for k in ("joint1", "joint2"):
        if k not in spec:
            raise ModelFileError(file, f"{key}.{k}", "missing (a coupling joins two 1-dof joints)")
        jm = _joint(model, spec[k], file, f"{key}.{k}", one_dof=True)
        jid = model.getJointId(spec[k])
        body = next(f for f in model.frames if f.parentJoint == jid and f.placement.isIdentity(0.0))
        ends.append((jm, model.getFrameId(body.name, body.type), body.name))
    if ends[0][1] == ends[1][1]:
        raise ModelFileError(file, f"{key}.joint2", "couples a joint with itself")
    if "ratio" not in spec:
        raise ModelFileError(file, f"{key}.ratio", "missing: q(joint2) = ratio q(joint1) + offset")
    ratio = _number(spec["ratio"], file, f"{key}.ratio")
    offset = _number(spec.get("offset", 0.0), file, f"{key}.offset")
    (j1, f1, n1), (j2, f2, n2) = ends
    return Closure(name, "coupling", n1, n2, f1, f2,
                   coupling=(j1.idx_q, j1.idx_v, j2.idx_q, j2.idx_v, ratio, offset))
