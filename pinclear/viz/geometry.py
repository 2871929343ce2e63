"""Visual geometry of a mechanism: the URDF's own <visual> elements when it has them,
otherwise primitives derived from the kinematic model itself.

Everything here is expressed in the frame of the Pinocchio joint that carries the body, so
a body's primitives move with a single transform (``data.oMi[j]``) and the scene animates
one node per body.

Automatic primitives, per moving body (= Pinocchio joint ``j``):

* the body's *attachment points* are its joint origin, the origins of its child joints and
  of the frames that hang on it (closure frames, fixed links, platform frame);
* three or more attachment points spread in a plane make a *platform*: a thin disc fitted
  to them (normal = least-variance direction), plus rods from the disc centre to points
  off the disc;
* otherwise the points are joined by *rods* (cylinders) from the joint origin;
* a body whose only attachment point is its origin gets a rod of twice its centre-of-mass
  offset (a uniform rod has its centre of mass in the middle), or a sphere sized from its
  rotational inertia when the centre of mass sits on the origin;
* joint markers: sphere at spherical joints, short cylinder along the axis at revolute
  joints, small box at prismatic joints and a smaller sphere at universal joints.

The ground gets a plate under its anchors when they span a plane, and a small block at
each anchor.  Sizes scale with the mechanism's extent at the configuration given.

URDF meshes are confined: an untrusted URDF's mesh must lie in the sidecar's or the URDF's
folder, pinclear's bundled models or example-robot-data's robots; anything else is refused
before it is opened.  A mesh reaches a page only as the triangles Pinocchio's mesh loader
parsed from it, never as the file's bytes.
"""
from __future__ import annotations

import colorsys
import warnings
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path

import meshcat.geometry as mg
import numpy as np
import pinocchio as pin

from pinclear.core.errors import ModelFileError
from pinclear.core.models import example_robot_data_dir
from pinclear.io.sidecar import allowed_roots
from pinclear.model.timelaws import TRUST_ENV, trusted

GROUND_COLOR = 0x8A8F98
_EPS = 1e-9


@dataclass
class Primitive:
    """One visual element rigidly attached to a body."""

    name: str
    geometry: mg.Geometry
    color: int
    placement: pin.SE3            # in the frame of the carrying joint
    kind: str                     # rod | platform | plate | sphere | joint | anchor | urdf
    opacity: float = 1.0
    scale: np.ndarray = field(default_factory=lambda: np.ones(3))   # mesh scale (URDF meshes)

    def material(self):
        mat = mg.MeshPhongMaterial(color=self.color)
        if self.opacity < 1.0:
            mat.transparent = True
            mat.opacity = self.opacity
        return mat

    def matrix(self):
        T = self.placement.homogeneous.copy()
        T[:3, :3] = T[:3, :3] * self.scale[None, :]
        return T


#: HSV saturation and value of the body colours: pastel, so the fully saturated overlay colours
#: (force arrows, eccentricity, traces: pinclear.viz.scene) never look like a body
BODY_SATURATION, BODY_VALUE = 0.32, 0.93


def body_color(k: int, n: int) -> int:
    """Distinct pastel colours (hue wheel), so bodies stand out against meshcat's grey and the
    saturated force arrows stand out against the bodies."""
    h = (0.61803398875 * k) % 1.0
    r, g, b = colorsys.hsv_to_rgb(h, BODY_SATURATION, BODY_VALUE)
    return (int(r * 255) << 16) | (int(g * 255) << 8) | int(b * 255)


def rotation_y_to(d: np.ndarray) -> np.ndarray:
    """Rotation taking three.js' cylinder axis (y) onto the unit vector d."""
    return pin.Quaternion.FromTwoVectors(np.array([0.0, 1.0, 0.0]), d).toRotationMatrix()


def segment_placement(a: np.ndarray, b: np.ndarray) -> tuple[pin.SE3, float]:
    """Placement of a cylinder spanning a -> b, and its length."""
    d = b - a
    L = float(np.linalg.norm(d))
    R = rotation_y_to(d / L) if L > _EPS else np.eye(3)
    return pin.SE3(R, 0.5 * (a + b)), L


def body_names(model: pin.Model) -> list[str]:
    """Display name of each Pinocchio body (index = joint id): the link that the joint
    carries (first BODY frame on the joint), falling back to the joint name."""
    names = ["ground"] + [model.names[j] for j in range(1, model.njoints)]
    seen = set()
    for f in model.frames:
        if f.type == pin.FrameType.BODY and f.parentJoint not in seen:
            seen.add(f.parentJoint)
            if f.parentJoint > 0:
                names[f.parentJoint] = f.name
    return names


def mechanism_extent(model: pin.Model, q: np.ndarray) -> tuple[np.ndarray, float, np.ndarray]:
    """World points of all joint and frame origins at q: (points, size, centre)."""
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    pts = np.array([M.translation for M in data.oMi] + [M.translation for M in data.oMf]
                   + [M.act(2.0 * Y.lever) for M, Y in zip(data.oMi, model.inertias)])
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    size = float(np.linalg.norm(hi - lo))
    return pts, (size if size > 1e-6 else 1.0), 0.5 * (lo + hi)


def _unique(points: list[np.ndarray], tol: float) -> list[np.ndarray]:
    out: list[np.ndarray] = []
    for p in points:
        if all(np.linalg.norm(p - o) > tol for o in out):
            out.append(p)
    return out


def _attachments(model: pin.Model, j: int, tol: float, extra=()) -> list[np.ndarray]:
    """Origins, in joint j's frame, of what hangs on body j (child joints and frames).

    For a moving body the joint origin comes first; the ground has no origin of its own
    (the world origin is an anchor only if something is attached there)."""
    pts = [np.zeros(3)] if j > 0 else []
    pts += [model.jointPlacements[c].translation.copy() for c in model.children[j]]
    for fid, f in enumerate(model.frames):
        if f.parentJoint != j or f.type == pin.FrameType.JOINT or fid == 0:
            continue
        if j == 0 and f.type == pin.FrameType.BODY:
            continue
        pts.append(f.placement.translation.copy())
    pts += [np.asarray(p, float) for p in extra]
    return _unique(pts, tol)


def _plane_fit(pts: np.ndarray):
    """Centroid, unit normal and flatness of a point set (SVD of the centred points)."""
    c = pts.mean(axis=0)
    _, s, vt = np.linalg.svd(pts - c)
    return c, vt[2], s


def _coplanar_subset(pts: list[np.ndarray], r: float):
    """Largest plate-like subset of the points: the plane through some three of them that
    holds the most points within a rod radius (a platform with a rod hanging off it keeps
    its plate).  Returns (points, centre, normal); fewer than 4 points means no plate."""
    from itertools import combinations

    P = np.array(pts)
    best = np.zeros(len(P), bool)
    for i, j, k in combinations(range(len(P)), 3):
        nrm = np.cross(P[j] - P[i], P[k] - P[i])
        if np.linalg.norm(nrm) < r * r:          # (nearly) collinear triple
            continue
        inl = np.abs((P - P[i]) @ (nrm / np.linalg.norm(nrm))) <= r
        if inl.sum() > best.sum():
            best = inl
    if best.sum() < 4:
        return [], None, None
    Q = P[best]
    c, nrm, s = _plane_fit(Q)
    if s[1] <= 0.25 * s[0]:                      # a row of points is a rod, not a plate
        return [], None, None
    return list(Q), c, nrm


def _prismatic_axis(model: pin.Model, j: int):
    """Unit axis (joint frame) of a 1-DoF prismatic joint, None for other joints."""
    kind = model.joints[j].shortname()
    if kind in ("JointModelPX", "JointModelPY", "JointModelPZ"):
        return np.eye(3)["XYZ".index(kind[-1])]
    if kind == "JointModelPrismaticUnaligned":
        ax = np.asarray(model.joints[j].extract().axis, float)
        return ax / np.linalg.norm(ax)
    return None


def _joint_marker(model: pin.Model, j: int, r: float, color: int) -> list[Primitive]:
    kind = model.joints[j].shortname()
    out = []
    if "Spherical" in kind:
        out.append(Primitive("joint", mg.Sphere(2.0 * r), color, pin.SE3.Identity(), "joint"))
    elif "Universal" in kind:
        out.append(Primitive("joint", mg.Sphere(1.6 * r), color, pin.SE3.Identity(), "joint"))
    elif "Revolute" in kind or kind in ("JointModelRX", "JointModelRY", "JointModelRZ"):
        if kind.endswith(("RX", "RUBX")):
            axis = np.array([1.0, 0, 0])
        elif kind.endswith(("RY", "RUBY")):
            axis = np.array([0, 1.0, 0])
        elif kind.endswith(("RZ", "RUBZ")):
            axis = np.array([0, 0, 1.0])
        else:
            axis = np.asarray(model.joints[j].extract().axis, float)
        M = pin.SE3(rotation_y_to(axis / np.linalg.norm(axis)), np.zeros(3))
        out.append(Primitive("joint", mg.Cylinder(4.0 * r, 1.6 * r), color, M, "joint"))
    elif "Prismatic" in kind or kind in ("JointModelPX", "JointModelPY", "JointModelPZ"):
        out.append(Primitive("joint", mg.Box([3.0 * r] * 3), color, pin.SE3.Identity(), "joint"))
    return out


def automatic_primitives(model: pin.Model, q: np.ndarray, size: float | None = None,
                         extra_points: dict | None = None,
                         ground_plate: bool = True) -> dict[int, list[Primitive]]:
    """Primitives for every body of ``model`` (joint id -> list), sized from the model.

    ``extra_points``: joint id -> list of points (joint frame) to treat as attachments, e.g.
    closure frame origins that are not model frames.
    """
    if size is None:
        size = mechanism_extent(model, q)[1]
    r = 0.012 * size                      # rod radius
    tol = 0.5 * r
    extra_points = extra_points or {}
    out: dict[int, list[Primitive]] = {}
    n = model.njoints

    # ground: plate under the anchors if they span a plane, a block at each anchor
    anchors = _attachments(model, 0, tol, extra_points.get(0, ()))
    prims: list[Primitive] = []
    if ground_plate and len(anchors) >= 3:
        c, nrm, s = _plane_fit(np.array(anchors))
        if s[1] > 10 * tol and s[2] < 0.1 * s[1]:
            rad = max(np.linalg.norm((p - c) - np.dot(p - c, nrm) * nrm) for p in anchors) + 3 * r
            M = pin.SE3(rotation_y_to(nrm), c)
            prims.append(Primitive("plate", mg.Cylinder(0.6 * r, rad), GROUND_COLOR, M, "plate",
                                   opacity=0.55))
    for k, p in enumerate(anchors):
        prims.append(Primitive(f"anchor{k}", mg.Box([2.5 * r] * 3), GROUND_COLOR,
                               pin.SE3(np.eye(3), p), "anchor"))
    # a slider on the ground runs in a guide: a rail along its axis, centred on the slider
    for c in model.children[0]:
        axis = _prismatic_axis(model, c)
        if axis is None:
            continue
        Mj = model.jointPlacements[c]
        a = Mj.rotation @ axis
        mid = Mj.translation + a * float(q[model.joints[c].idx_q])
        M, _ = segment_placement(mid - 0.3 * size * a, mid + 0.3 * size * a)
        prims.append(Primitive(f"rail{c}", mg.Cylinder(0.6 * size, 0.5 * r), GROUND_COLOR, M, "rail"))
    out[0] = prims

    for j in range(1, n):
        color = body_color(j - 1, n - 1)
        pts = _attachments(model, j, tol, extra_points.get(j, ()))
        prims = _joint_marker(model, j, r, color)
        Y = model.inertias[j]
        com = np.asarray(Y.lever, float)
        # a body whose mass sits far from everything attached to it (a telescopic rod hanging
        # from its slider) extends beyond its attachments: a uniform rod of twice that offset
        if np.linalg.norm(com) > tol:
            P = np.array(pts)
            spread = max(np.ptp(P, axis=0).max(), tol)
            if np.linalg.norm(com - P.mean(axis=0)) > 0.5 * spread:
                pts = _unique(pts + [2.0 * com], tol)
        far = pts[1:]
        flat, c, nrm = _coplanar_subset(pts, r)
        if len(flat) >= 4:
            rad = max(np.linalg.norm((p - c) - np.dot(p - c, nrm) * nrm) for p in flat) + r
            prims.append(Primitive("platform", mg.Cylinder(1.2 * r, rad), color,
                                   pin.SE3(rotation_y_to(nrm), c), "platform"))
            for k, p in enumerate(pts):
                if abs(np.dot(p - c, nrm)) > 2 * r:
                    M, L = segment_placement(c, p)
                    prims.append(Primitive(f"rod{k}", mg.Cylinder(L, r), color, M, "rod"))
        else:
            for k, p in enumerate(far):
                M, L = segment_placement(np.zeros(3), p)
                prims.append(Primitive(f"rod{k}", mg.Cylinder(L, r), color, M, "rod"))
        if not far:
            if Y.mass > 0:
                # solid sphere: I = 2/5 m rho^2
                rho = np.sqrt(2.5 * np.trace(Y.inertia) / 3.0 / Y.mass)
                rho = float(np.clip(rho, 1.5 * r, 6 * r))
                prims.append(Primitive("body", mg.Sphere(rho), color, pin.SE3.Identity(), "sphere"))
            if not prims:
                prims.append(Primitive("body", mg.Sphere(1.5 * r), color, pin.SE3.Identity(), "sphere"))
        out[j] = prims
    return out


def viewer_trust(mech=None, trust=None) -> bool:
    """Whether the viewer may read files outside a mechanism's folders: ``trust`` if given,
    else yes when the mechanism was loaded trusted or PINCLEAR_TRUST is set."""
    if trust is not None:
        return bool(trust)
    return bool((getattr(mech, "load_args", None) or {}).get("trust")) or trusted(None)


def mesh_roots(urdf_path, sidecar_path=None) -> list[Path]:
    """Folders an untrusted URDF's meshes may come from: the sidecar's and the URDF's folders,
    pinclear's bundled models and example-robot-data's robots (see pinclear.io.sidecar)."""
    roots = allowed_roots(sidecar_path if sidecar_path is not None else urdf_path)
    own = Path(urdf_path).resolve().parent
    return roots if own in roots else roots + [own]


def mesh_package_dirs(urdf_path) -> list[Path]:
    """Where ``package://PKG/...`` mesh names are looked up: the URDF's folder and
    example-robot-data's share folder (``package://example-robot-data/robots/...``)."""
    dirs = [Path(urdf_path).resolve().parent]
    erd = example_robot_data_dir()
    if erd is not None:
        dirs.append(Path(erd).parents[1])
    return dirs


def resolve_mesh(filename: str, urdf_path, package_dirs) -> Path | None:
    """The file a URDF ``<mesh filename>`` names (as Pinocchio reads it: ``package://`` in the
    package folders, ``file://`` and absolute paths as they are, others beside the URDF),
    with symbolic links and ``..`` resolved; None for a package mesh found nowhere.  Nothing
    is opened."""
    if filename.startswith("package://"):
        rest = filename[len("package://"):]
        for d in package_dirs:
            p = Path(d) / rest
            if p.exists():
                return p.resolve()
        return None
    if filename.startswith("file://"):
        filename = filename[len("file://"):]
    p = Path(filename)
    return (p if p.is_absolute() else Path(urdf_path).resolve().parent / p).resolve()


def _outside(path: Path, roots) -> bool:
    return not any(path.is_relative_to(r) for r in roots)


def _refuse(urdf_path, key, shown, path, roots):
    raise ModelFileError(str(urdf_path), key,
                         f"mesh {shown!r} resolves to {str(path)!r}, outside the folders a mechanism file may "
                         f"read ({', '.join(map(str, roots))}); keep meshes beside the URDF or sidecar, or "
                         f"trust the file (trust=True, --trust, {TRUST_ENV}=1)")


def _read_urdf(path) -> str:
    try:
        return Path(path).read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise ModelFileError(str(path), "urdf", f"not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    except OSError as exc:
        raise ModelFileError(str(path), "urdf", f"cannot be read: {exc.strerror}") from None


def confined_visual_model(model: pin.Model, urdf_path, roots, trust: bool = False) -> pin.GeometryModel:
    """The URDF's <visual> geometry, every mesh name resolved and checked before anything
    reads it: a mesh outside ``roots`` raises ModelFileError unless ``trust``.  Pinocchio then
    gets the checked absolute paths, so it never searches folders of its own (ROS_PACKAGE_PATH)."""
    text = _read_urdf(urdf_path)
    try:
        tree = ET.fromstring(text)
    except ET.ParseError as exc:
        raise ModelFileError(str(urdf_path), "xml", f"not valid XML ({exc})") from None
    dirs = mesh_package_dirs(urdf_path)
    for link in tree.iter("link"):
        for k, vis in enumerate(link.findall("visual")):
            for mesh in vis.iter("mesh"):
                name = mesh.get("filename") or ""
                key = f"link {link.get('name')!r} visual {k} mesh"
                path = resolve_mesh(name, urdf_path, dirs)
                if path is None:
                    raise ValueError(f"mesh {name!r} not found in {', '.join(map(str, dirs))}")
                if not trust and _outside(path, roots):
                    _refuse(urdf_path, key, name, path, roots)
                mesh.set("filename", str(path))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return pin.buildGeomFromUrdfString(model, ET.tostring(tree, encoding="unicode"),
                                           pin.GeometryType.VISUAL, package_dirs=[str(d) for d in dirs])


def mesh_geometry(go) -> mg.Geometry | None:
    """A mesh as meshcat triangles, from the vertices and faces Pinocchio's mesh loader parsed
    (scale applied): the file's own bytes are never passed on, so a text that is not a mesh
    cannot reach a page.  None when the object holds no parsed mesh."""
    import coal
    from pinocchio.visualize.meshcat_visualizer import loadMesh

    if not isinstance(go.geometry, (coal.BVHModelBase, coal.Convex)):
        return None
    obj = loadMesh(go.geometry)
    return obj if isinstance(obj, mg.TriangularMeshGeometry) else None


def urdf_primitives(model: pin.Model, urdf_path=None, roots=None, trust: bool = False,
                    visual_model: pin.GeometryModel | None = None) -> dict[int, list[Primitive]]:
    """The URDF's <visual> elements as primitives (joint id -> list); empty if it has none.

    ``visual_model``: an already built ``pin.GeometryModel`` (e.g. ``mech.visual_model``);
    otherwise it is built from ``urdf_path`` (:func:`confined_visual_model`).  ``roots``: the
    folders meshes may come from unless ``trust`` (default :func:`mesh_roots` of the URDF).
    Shapes are converted by Pinocchio's meshcat bridge; meshes are embedded as the triangles
    Pinocchio parsed (:func:`mesh_geometry`), never as the file's text.
    """
    from pinocchio.visualize import MeshcatVisualizer
    from pinocchio.visualize.meshcat_visualizer import hasMeshFileInfo

    if roots is None and urdf_path is not None:
        roots = mesh_roots(urdf_path)
    if visual_model is None:
        if urdf_path is None:
            return {}
        text = _read_urdf(urdf_path)
        if "<visual" not in text:
            return {}
        # without any <material> every visual would be Pinocchio's default grey: body colours
        own_colors = "<material" in text
        try:
            vmodel = confined_visual_model(model, urdf_path, roots, trust)
        except (ValueError, RuntimeError) as exc:
            if isinstance(exc, ModelFileError):
                raise
            # e.g. a package:// mesh found nowhere, or a file that is not a mesh: draw the
            # automatic primitives instead
            warnings.warn(f"{urdf_path}: URDF visuals not used ({' '.join(str(exc).split())}); "
                          "showing automatic primitives", stacklevel=2)
            return {}
    else:
        vmodel = visual_model
        cols = {tuple(np.round(go.meshColor, 6)) for go in vmodel.geometryObjects}
        own_colors = len(cols) > 1
        for go in vmodel.geometryObjects:
            if hasMeshFileInfo(go) and not trust and roots is not None:
                path = Path(go.meshPath).resolve()
                if _outside(path, roots):
                    _refuse(urdf_path or "<visual model>", f"visual {go.name!r}", go.meshPath, path, roots)
    bridge = MeshcatVisualizer(model, None, vmodel)
    out: dict[int, list[Primitive]] = {}
    for k, go in enumerate(vmodel.geometryObjects):
        scale = np.asarray(go.meshScale, float).copy()
        try:
            if hasMeshFileInfo(go):
                obj = mesh_geometry(go)
                scale = np.ones(3)            # the parsed vertices are already scaled
            else:
                obj = bridge.loadPrimitive(go)
        except Exception as exc:  # an unreadable shape must not stop the viewer
            warnings.warn(f"{urdf_path}: visual '{go.name}' not shown: {exc}", stacklevel=2)
            continue
        if not isinstance(obj, mg.Geometry):
            warnings.warn(f"{urdf_path}: visual '{go.name}' ({go.meshPath}) not shown: no triangles "
                          "parsed from it", stacklevel=2)
            continue
        rgba = np.asarray(go.meshColor, float)
        if own_colors:
            color = (int(rgba[0] * 255) << 16) | (int(rgba[1] * 255) << 8) | int(rgba[2] * 255)
        else:
            color = body_color(go.parentJoint - 1, model.njoints - 1) if go.parentJoint else GROUND_COLOR
            rgba[3] = 1.0
        out.setdefault(go.parentJoint, []).append(
            Primitive(f"urdf{k}", obj, color, go.placement, "urdf", opacity=float(rgba[3]), scale=scale))
    return out


def mechanism_primitives(model: pin.Model, q: np.ndarray, urdf_path=None, size=None,
                         extra_points=None, use_urdf_visuals=True, ground_plate=True,
                         visual_model=None, roots=None, trust: bool = False) -> dict[int, list[Primitive]]:
    """URDF visuals for the bodies that have them (plus the joint markers), automatic
    primitives for the others."""
    auto = automatic_primitives(model, q, size=size, extra_points=extra_points,
                                ground_plate=ground_plate)
    if not use_urdf_visuals or (urdf_path is None and visual_model is None):
        return auto
    urdf = urdf_primitives(model, urdf_path, roots=roots, trust=trust, visual_model=visual_model)
    out = {}
    for j, prims in auto.items():
        if urdf.get(j):
            out[j] = urdf[j] + [p for p in prims if p.kind in ("joint", "anchor", "rail")]
        else:
            out[j] = prims
    return out
