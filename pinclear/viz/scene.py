"""A meshcat scene of a mechanism, built offline and inspectable without a browser.

The scene is written through meshcat-python's own ``Visualizer`` API into a
:class:`SceneRecorder` that stands in for meshcat's server: it keeps the scene tree the
server would keep (object, properties, transform per path; the animation), so the same
scene can be

* inspected in tests (``scene.recorder.paths()``),
* exported as standalone HTML (:mod:`pinclear.viz.html`),
* replayed into a live meshcat server (:meth:`MechanismScene.push`).

Tree layout (root ``/meshcat/pinclear``; its transform centres the mechanism at meshcat's
origin and turns "against gravity" to screen-up)::

    bodies/<body>                   one node per rigid body (Pinocchio joint; 0 = "ground"),
                                    transform = world pose of the joint (animated)
    bodies/<body>/<primitive>       geometry, fixed in the body frame
    bodies/<body>/closure_<c>_f1|f2 closure frames (triads), fixed in the body frame; the
                                    closures replaced by active clearances included
    overlays/clearance/<name>/eccentricity | normal_force | friction_force
                                    arrows: unit shaft along y scaled to the vector (animated)
    overlays/platform/trace | prescribed
                                    platform path over the run and the prescribed path (world)
    overlays/world_frame            world axes
    bodies/<body>/worn_<name>/profile | new
                                    a worn revolute bearing (pinclear.contact.wear): its profile
                                    R_b + wear_scale x depth at the wear nodes, and the new circle
                                    R_b, closed loops in the bearing frame (fixed in its body)

Scale factors of the overlays are *stated*: they are stored in ``scene.info`` and shown in
the HTML legend and printed by the CLI.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import meshcat
import meshcat.geometry as mg
import numpy as np
import pinocchio as pin
import umsgpack
from meshcat.commands import Delete, SetAnimation, SetObject, SetProperty, SetTransform

from pinclear.viz.elements import active_clearances, clearance_plot, clearance_size
from pinclear.viz.geometry import (
    body_names,
    mechanism_extent,
    mechanism_primitives,
    mesh_roots,
    rotation_y_to,
    viewer_trust,
)

ROOT = "pinclear"
# overlays: fully saturated, darker or more vivid than any body (bodies are pastel, see
# pinclear.viz.geometry.body_color), so an arrow is never mistaken for a link
ECC_COLOR = 0xD400D4     # magenta: eccentricity
NORMAL_COLOR = 0x0028FF  # blue: normal force
FRICTION_COLOR = 0xFF6A00  # orange: friction force
TRACE_COLOR = 0x00A0A0   # teal: platform trace
PRESCRIBED_COLOR = 0xE00000  # red: prescribed path
WORN_COLOR = 0x8B0000    # dark red: a worn bearing's profile (depth magnified, stated)
NEW_BEARING_COLOR = 0x606060  # grey: the same bearing new


# --------------------------------------------------------------------------- recorder
@dataclass
class _Node:
    object: object = None          # SetObject command
    properties: list = field(default_factory=list)
    transform: object = None       # SetTransform command


class SceneRecorder:
    """Minimal stand-in for ``meshcat.visualizer.ViewerWindow``: records instead of sending.

    Semantics follow meshcat's server (``meshcat.servers.zmqserver``): set_object replaces
    a node's object and clears its properties; delete removes a subtree.
    """

    def __init__(self):
        self.nodes: dict[str, _Node] = {}
        self.animation = None       # SetAnimation command

    def send(self, command):
        if isinstance(command, SetAnimation):
            self.animation = command
            return
        path = command.path.lower()
        if isinstance(command, Delete):
            for p in [p for p in self.nodes if p == path or p.startswith(path + "/")]:
                del self.nodes[p]
            return
        node = self.nodes.setdefault(path, _Node())
        if isinstance(command, SetObject):
            node.object, node.properties = command, []
        elif isinstance(command, SetTransform):
            node.transform = command
        elif isinstance(command, SetProperty):
            node.properties.append(command)
        else:
            raise TypeError(f"unsupported meshcat command {type(command).__name__}")

    # --- inspection
    def paths(self) -> list[str]:
        return list(self.nodes)

    def commands(self):
        """All commands in replay order: objects before their transforms, the animation last
        (meshcat binds an animation to the nodes that exist when it arrives)."""
        for node in self.nodes.values():
            if node.object is not None:
                yield node.object
            yield from node.properties
            if node.transform is not None:
                yield node.transform
        if self.animation is not None:
            yield self.animation

    def packed(self) -> list[bytes]:
        """The commands as meshcat's wire format (msgpack of the lowered command)."""
        return [umsgpack.packb(c.lower()) for c in self.commands()]


def recording_visualizer() -> tuple[meshcat.Visualizer, SceneRecorder]:
    rec = SceneRecorder()
    return meshcat.Visualizer(window=rec), rec


# --------------------------------------------------------------------------- helpers
def clearance_frames(el) -> tuple[int, int]:
    """(socket/bearing/guide frame, ball/journal/slider frame) of a clearance element."""
    return int(el.f1), int(el.f2)


def round_125(x: float) -> float:
    """Largest value of the 1-2-5 series (x 10^k) not above x: scale factors a reader can use."""
    k = np.floor(np.log10(x))
    for m in (5.0, 2.0, 1.0):
        if m * 10**k <= x * (1 + 1e-12):
            return float(m * 10**k)
    return float(10**k)


def arrow_matrix(start: np.ndarray, vec: np.ndarray) -> np.ndarray:
    """Transform of a unit arrow (shaft along +y from 0 to 1) so it spans start -> start+vec."""
    L = float(np.linalg.norm(vec))
    T = np.eye(4)
    if L > 1e-12:
        T[:3, :3] = rotation_y_to(vec / L)
    T[:3, 3] = start
    T[:3, 1] *= max(L, 1e-9)       # zero-length arrow: collapsed, invisible
    return T


class _OnTopMaterial(mg.MeshBasicMaterial):
    """Unlit material drawn over the bodies: a 0.1 mm eccentricity magnified a hundred times
    still sits inside the joint it describes."""

    def lower(self, object_data):
        d = super().lower(object_data)
        d.update(depthTest=False, depthWrite=False)
        return d


class _OnTopMesh(mg.Mesh):
    def lower(self):
        d = super().lower()
        d["object"]["renderOrder"] = 10
        return d


def _arrow_object(color: int, radius: float):
    """A tapered unit shaft from y = 0 to y = 1: the taper shows the direction."""
    geom = mg.Cylinder(1.0, radiusTop=0.35 * radius, radiusBottom=radius)
    return _OnTopMesh(geom, _OnTopMaterial(color=color))


def _polyline(points: np.ndarray, color: int, on_top: bool = False):
    pts = np.ascontiguousarray(points.T, dtype=np.float32)
    material = (_OnTopLineMaterial if on_top else mg.LineBasicMaterial)(color=color, linewidth=2)
    return mg.Line(mg.PointsGeometry(pts), material)


class _OnTopLineMaterial(mg.LineBasicMaterial):
    """A line drawn over the bodies (a bearing's profile lies inside its link's geometry)."""

    def lower(self, object_data):
        d = super().lower(object_data)
        d.update(depthTest=False, depthWrite=False)
        return d


def worn_bearings(clearances) -> list:
    """The worn revolute clearances (pinclear.contact.wear.WornRevoluteClearance) among
    ``clearances`` whose bearing has worn (some depth > 0)."""
    return [el for el in clearances
            if getattr(el, "wear", None) is not None and np.max(getattr(el, "depth", 0.0)) > 0.0]


def default_wear_scale(worn) -> float:
    """A 1-2-5 magnification drawing the deepest wear a quarter of its bearing's radius."""
    return min(round_125(0.25 * el.R1 / float(np.max(el.depth))) for el in worn)


def worn_profile_points(el, scale: float, depth=None) -> np.ndarray:
    """(N + 1, 3) closed loop of a worn bearing in its own frame (frame1; the wear angle from x
    towards y, pinclear.contact.wear): radius R_b + scale x depth at each wear node's angle
    (``depth`` None: the joint's own)."""
    th = el.wear.angles()
    r = el.R1 + scale * np.asarray(el.depth if depth is None else depth, float)
    pts = np.stack([r * np.cos(th), r * np.sin(th), np.zeros_like(th)], axis=1)
    return np.vstack([pts, pts[:1]])


# --------------------------------------------------------------------------- scene
class MechanismScene:
    """Meshcat scene of a mechanism: one node per body, plus overlays.

    Parameters
    ----------
    mech : pinclear Mechanism (or any object with ``model``, ``q0`` and optionally
        ``name``, ``closures``, ``forces``, ``platform_frame``, ``urdf_path``)
    q : configuration to show (default ``mech.q0``)
    ecc_scale : eccentricity magnification (stated in the legend); None = the largest 1-2-5
        factor that draws the largest clearance at most 8 % of the mechanism's size
    force_scale : metres of arrow per newton; None = chosen from the run (longest arrow =
        a quarter of the mechanism's size) and stated
    trust : read URDF meshes from anywhere (None: as the mechanism was loaded, else the
        PINCLEAR_TRUST environment variable); untrusted meshes must lie in the sidecar's or
        URDF's folder, pinclear's models or example-robot-data's (:func:`geometry.mesh_roots`)
    """

    def __init__(self, mech, q=None, *, ecc_scale: float | None = None, force_scale: float | None = None,
                 show_closure_frames: bool = True, use_urdf_visuals: bool = True, trust: bool | None = None,
                 wear_scale: float | None = None):
        self.mech = mech
        self.trust = viewer_trust(mech, trust)
        self.live = None           # meshcat.Visualizer of a running viewer (see pinclear.viz.show)
        self.server = None         # its LocalServer, when the viewer started one
        self.model: pin.Model = mech.model
        self.data = self.model.createData()
        self.q = np.array(mech.q0 if q is None else q, dtype=float)
        self.vis, self.recorder = recording_visualizer()
        self.root = self.vis[ROOT]
        pts, self.size, self.centre = mechanism_extent(self.model, self.q)
        sv = np.linalg.svd(pts - pts.mean(axis=0), compute_uv=False)
        self.planar = bool(sv[2] < 0.05 * max(sv[0], 1e-12))
        self.rod_radius = 0.012 * self.size
        self.names = _unique_names(body_names(self.model))
        self.body_paths = [f"bodies/{n}" for n in self.names]
        self.clearances = active_clearances(mech)
        if ecc_scale is None:
            cs = [float(np.max(clearance_size(el))) for el in self.clearances]
            ecc_scale = round_125(0.08 * self.size / max(cs)) if cs and max(cs) > 0 else 100.0
        self.info = {"name": getattr(mech, "name", "mechanism"), "ecc_scale": float(ecc_scale),
                     "force_scale": force_scale, "size": self.size}
        self._build_bodies(use_urdf_visuals)
        if show_closure_frames:
            self._build_closure_frames()
        self._build_clearance_overlays()
        self._build_worn_bearings(wear_scale)
        self._background()
        self._camera()
        self.set_configuration(self.q)

    # ---------------- construction
    def _build_bodies(self, use_urdf_visuals):
        urdf = urdf_path(self.mech)
        side = getattr(self.mech, "path", None)
        roots = mesh_roots(urdf, side) if urdf is not None else None
        # a base plate behind a planar mechanism would hide it
        prims = mechanism_primitives(self.model, self.q, urdf_path=urdf, size=self.size,
                                     use_urdf_visuals=use_urdf_visuals, ground_plate=not self.planar,
                                     visual_model=getattr(self.mech, "visual_model", None),
                                     roots=roots, trust=self.trust)
        for j, path in enumerate(self.body_paths):
            node = self.root[path]
            for p in prims.get(j, []):
                child = node[p.name]
                child.set_object(p.geometry, p.material())
                child.set_transform(p.matrix())

    def _build_closure_frames(self):
        model = self.model
        L = 4.0 * self.rod_radius
        closures = list(getattr(self.mech, "closures", []) or [])
        # the ideal closures that active clearances replaced keep their frames on screen
        closures += list((getattr(self.mech, "replaced_closures", None) or {}).values())
        for c in closures:
            for tag, fid in (("f1", c.f1), ("f2", c.f2)):
                f = model.frames[fid]
                node = self.root[self.body_paths[f.parentJoint]][f"closure_{c.name}_{tag}"]
                node.set_object(mg.triad(L))
                node.set_transform(f.placement.homogeneous)

    def _build_clearance_overlays(self):
        r = 0.5 * self.rod_radius
        for el in self.clearances:
            base = self.root["overlays/clearance"][el.name]
            for part, color in (("eccentricity", ECC_COLOR), ("normal_force", NORMAL_COLOR),
                                ("friction_force", FRICTION_COLOR)):
                base[part]["shaft"].set_object(_arrow_object(color, r if part != "eccentricity" else 1.4 * r))
                # shaft spans y in [0, 1] so the parent's y-scale is the arrow length
                base[part]["shaft"].set_transform(pin.SE3(np.eye(3), np.array([0, 0.5, 0])).homogeneous)
                base[part].set_transform(arrow_matrix(np.zeros(3), np.zeros(3)))

    def _build_worn_bearings(self, wear_scale):
        """Each worn bearing's profile (depth x wear_scale, stated in scene.info) and its new
        circle, fixed in the bearing's body at the bearing frame."""
        worn = worn_bearings(self.clearances)
        if not worn:
            return
        scale = float(wear_scale) if wear_scale is not None else default_wear_scale(worn)
        self.info["wear_scale"] = scale
        self.info["worn"] = {el.name: float(np.max(el.depth)) for el in worn}
        for el in worn:
            f = self.model.frames[clearance_frames(el)[0]]
            node = self.root[self.body_paths[f.parentJoint]][f"worn_{el.name}"]
            node.set_transform(f.placement.homogeneous)
            node["profile"].set_object(_polyline(worn_profile_points(el, scale), WORN_COLOR, on_top=True))
            node["new"].set_object(_polyline(worn_profile_points(el, 0.0), NEW_BEARING_COLOR, on_top=True))

    def _background(self):
        # plain light background: bodies' saturated colours stand out (and tests can count them)
        bg = self.vis["/Background"]
        bg.set_property("top_color", [0.96, 0.96, 0.97])
        bg.set_property("bottom_color", [0.82, 0.84, 0.87])

    def _camera(self):
        """Show the mechanism upright (against gravity = screen up), centred, framed by its
        extent; planar mechanisms are seen nearly face-on."""
        pts, size, centre = mechanism_extent(self.model, self.q)
        g = np.asarray(self.model.gravity.linear, float)
        up = -g / np.linalg.norm(g) if np.linalg.norm(g) > 0 else np.array([0.0, 0.0, 1.0])
        Rd = rotation_y_to(np.array([0.0, 0.0, 1.0])) @ rotation_y_to(up).T   # up -> +z
        _, s, vt = np.linalg.svd((pts - pts.mean(axis=0)) @ Rd.T)
        if self.planar:      # face-on from the -y side, slightly from above and aside
            n = vt[2] if vt[2][1] <= 0 else -vt[2]
            d = n + np.array([0.25, 0.0, 0.3])
        else:
            d = np.array([1.0, -1.3, 0.9])
        d = d / np.linalg.norm(d) * 1.05 * size
        # meshcat 0.3's orbit controls always aim at the world origin: bring the mechanism's
        # centre there instead (meshcat's own axes would then mislead, so ours replace them)
        self.root.set_transform(pin.SE3(Rd, -Rd @ centre).homogeneous)
        # meshcat's 20 m floor grid at the world origin would cut through the (now centred)
        # mechanism; the world triad and the ground's anchors give the reference instead
        self.vis["/Grid"].set_property("visible", False)
        self.vis["/Axes"].set_property("visible", False)
        self.root["overlays/world_frame"].set_object(mg.triad(0.15 * size))
        # the camera sits in meshcat's y-up 'rotated' frame: (x, y, z) -> (x, z, -y)
        self.vis["/Cameras/default/rotated/<object>"].set_property("position",
                                                                   [d[0], d[2], -d[1]])
        self.info["camera"] = {"centre": centre.tolist(), "up": up.tolist(), "offset": d.tolist()}

    # ---------------- state
    def body_transforms(self, q) -> np.ndarray:
        """World pose (4x4) of every body at q, stacked (njoints, 4, 4)."""
        pin.forwardKinematics(self.model, self.data, q)
        return np.array([M.homogeneous for M in self.data.oMi])

    def clearance_vectors(self, q, outputs: dict | None = None, k=None):
        """Per active clearance: (start, eccentricity, normal force, friction force) in world.
        ``k``: sample index of the outputs, one for all clearances or a list (one each).

        The eccentricity is recomputed from the kinematics (ball/journal centre minus
        socket/bearing centre, paper 000 eq. 3; for a slider, its part across the guide);
        the forces come from the trajectory's
        outputs when the contact element records them (see :func:`contact_force_vectors`).
        """
        pin.framesForwardKinematics(self.model, self.data, q)
        res = []
        ks = k if isinstance(k, (list, tuple, np.ndarray)) else [k] * len(self.clearances)
        for el, kk in zip(self.clearances, ks):
            f1, f2 = clearance_frames(el)
            p1 = self.data.oMf[f1].translation.copy()
            e = self.data.oMf[f2].translation - p1
            if clearance_plot(el.kind) is not None and clearance_plot(el.kind).travel:
                # a slider's travel along the guide (z of the guide frame) is motion, not play
                z1 = self.data.oMf[f1].rotation[:, 2]
                e = e - (e @ z1) * z1
            fn = ft = np.zeros(3)
            if outputs is not None and kk is not None:
                fn, ft = contact_force_vectors(outputs, el.name, kk, self.data.oMf[f1])
            res.append((p1, e, fn, ft))
        return res

    def set_configuration(self, q, outputs=None, k=None):
        self.q = np.array(q, dtype=float)
        T = self.body_transforms(self.q)
        for j, path in enumerate(self.body_paths):
            self.root[path].set_transform(T[j])
        fs = self.info["force_scale"] or 0.0
        for el, (p1, e, fn, ft) in zip(self.clearances, self.clearance_vectors(self.q, outputs, k)):
            base = self.root["overlays/clearance"][el.name]
            base["eccentricity"].set_transform(arrow_matrix(p1, self.info["ecc_scale"] * e))
            start = p1 + e
            base["normal_force"].set_transform(arrow_matrix(start, fs * fn))
            base["friction_force"].set_transform(arrow_matrix(start, fs * ft))

    def add_paths(self, trace: np.ndarray | None, prescribed: np.ndarray | None):
        """Platform path trace and prescribed path as world polylines (N, 3)."""
        if trace is not None and len(trace) > 1:
            self.root["overlays/platform/trace"].set_object(_polyline(trace, TRACE_COLOR))
        if prescribed is not None and len(prescribed) > 1:
            self.root["overlays/platform/prescribed"].set_object(_polyline(prescribed, PRESCRIBED_COLOR))

    # ---------------- inspection / output
    def paths(self) -> list[str]:
        return self.recorder.paths()

    def body_nodes(self) -> list[str]:
        pre = f"/meshcat/{ROOT}/"
        return [pre + p for p in self.body_paths]

    def overlay_nodes(self) -> list[str]:
        pre = f"/meshcat/{ROOT}/overlays/"
        return [p for p in self.recorder.paths() if p.startswith(pre)]

    def push(self, vis: meshcat.Visualizer):
        """Replay the whole scene (and animation) into a live meshcat visualizer."""
        vis[ROOT].delete()
        for cmd in self.recorder.commands():
            vis.window.send(cmd)

    def close(self):
        """Stop the meshcat server this scene's viewer started (if any)."""
        if self.server is not None:
            self.server.close()


def _unique_names(names):
    seen: dict[str, int] = {}
    out = []
    for n in names:
        n = n.replace("/", "_")
        if n in seen:
            seen[n] += 1
            n = f"{n}_{seen[n]}"
        else:
            seen[n] = 0
        out.append(n)
    return out


def urdf_path(mech):
    """URDF file of a mechanism: its ``urdf_path`` attribute if it has one, else the sidecar's
    ``urdf:`` beside the sidecar (``mech.path``; a mechanism loaded from a .urdf names itself)."""
    p = getattr(mech, "urdf_path", None)
    if isinstance(p, str) or hasattr(p, "__fspath__"):
        return str(p)
    side, sc = getattr(mech, "path", None), getattr(mech, "sidecar", None)
    if side and isinstance(sc, dict) and isinstance(sc.get("urdf"), str):
        return str(Path(side).parent / sc["urdf"])
    return None


# pinclear.contact records "<name>.normal_force" / "<name>.friction_force": force on body 2, world
NORMAL_KEYS = ("normal_force",)
FRICTION_KEYS = ("friction_force",)


def contact_force_vectors(outputs: dict, name: str, k: int, bearing: pin.SE3 | None = None):
    """Normal and friction force vectors (world) of clearance ``name`` at sample k, read from
    a trajectory's outputs. Vectors recorded in the bearing frame (key suffix ``_local``)
    are rotated to world with the bearing frame's pose."""
    def find(keys):
        for key in keys:
            for suffix, local in (("", False), ("_world", False), ("_local", True)):
                arr = outputs.get(f"{name}.{key}{suffix}")
                if arr is not None and np.ndim(arr) == 2 and np.shape(arr)[1] == 3:
                    v = np.asarray(arr[k], float)
                    return bearing.rotation @ v if (local and bearing is not None) else v
        return np.zeros(3)
    return find(NORMAL_KEYS), find(FRICTION_KEYS)
