"""A small builder for a mechanism of one's own: bodies, tree joints, closures (the cut
joints), drives, clearances -> a URDF and its sidecar, checked by loading them.

    b = Builder("rrr3", gravity=(0, 0, -9.81))
    b.body("crank", mass=0.4, com=(0.1, 0, 0), inertia=rod(0.4, 0.2))
    b.joint("A1", "revolute", "ground", "crank", xyz=(0.3, 0, 0), axis=(0, 0, 1), q=1.2)
    b.closure("P2", "planar_point", ("dist2", (0.2, 0, 0)), ("platform", (0.08, 0, 0)))
    b.drive("A1", sines(offset=1.2, amp=0.2, omega=6.28))
    b.clearance("P2", clearance=2e-4, radius=5e-3, length=1e-2)
    mech = b.write("urdf")            # writes urdf/rrr3.urdf + urdf/rrr3.yaml, loads and assembles

The tree is the URDF: every body hangs from one parent joint; each loop of the mechanism is
closed by one closure (a cut joint), and only a cut joint can take a clearance (the loader
replaces its closure by the contact element; docs/tutorial.md). Every key is the sidecar's own
(docs/inputs.md): the builder writes what a user would write by hand, nothing more.

A URDF has no spherical or universal joint: ``joint(NAME, "spherical", ...)`` writes the
revolute joints NAME_1, NAME_2, NAME_3 (axes x, y, z of the joint frame, meeting at its origin)
with two massless links NAME_link1, NAME_link2 between them; ``"universal"`` writes NAME_1 and
NAME_2 (``axis`` and ``axis2``, perpendicular) with one massless link NAME_link1. A spherical
chain locks where its first and last axes align (pinclear.model.joint_chains): :meth:`Builder.write`
turns each chain's frame to the assembled start, so the start sits 90 deg from the lock and a
relative rotation of less than 90 deg from it never reaches the lock (a rotation by an angle
moves an axis by at most that angle); ``pinclear info`` prints the distance at the start.
A universal joint has no lock of its own: its two axes stay perpendicular (each is fixed in
the body the other turns).

Every name the builder writes (the mechanism, which names the files, and its bodies, joints,
closures, drives, clearances and frames) must match :data:`NAME_PATTERN`: a letter or ``_``,
then letters, digits, ``_`` or ``-``. So the files land in the named folder and nothing else,
a name is never markup in the URDF, and ``NAME.key`` overrides (``--set P2.mu=0.1``) can
address it; the XML is escaped as well (pinclear.io.urdf_write).
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from pinclear.core import safeio
from pinclear.core.errors import InputError
from pinclear.io.urdf_write import attr, urdf_joint, urdf_link

#: URDF joint types the builder writes (pinclear's loader accepts what Pinocchio parses), and the
#: two it writes as chains of revolute joints
JOINT_TYPES = ("revolute", "prismatic", "continuous", "fixed", "spherical", "universal")
#: every name the builder writes (module docstring); at most 100 characters
NAME_PATTERN = r"[A-Za-z_][A-Za-z0-9_-]{0,99}"
#: revolute and prismatic joints get these limits: none in effect (the closures bound the motion)
_NO_LIMITS = (-1e9, 1e9)
#: the spherical chain's axes in its joint frame: pairwise perpendicular at the home pose
_SPHERICAL_AXES = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
_AXES = {"x": 0, "y": 1, "z": 2}


def rod(m, L, axis="x", axial=1e-7):
    """Central inertia [kg m^2] of a uniform thin rod of mass ``m`` [kg] and length ``L`` [m]
    along ``axis`` ("x", "y", "z" or a direction in the body frame): m L^2 / 12 about every
    axis across it. The loader rejects a zero principal moment, so the moment about the rod's
    own axis is a token ``axial`` (it enters the dynamics only if the rod spins about its axis,
    which a revolute or prismatic joint across the rod never lets it do).

    Parameters
    ----------
    m : float
        Mass [kg].
    L : float
        Length [m].
    axis : {"x", "y", "z"} or array of 3 floats
        The rod's direction in the body frame: a frame axis by name, or a direction (normalised;
        not all zero). Another name raises InputError.
    axial : float
        The token moment about the rod's own axis [kg m^2].

    Returns
    -------
    ndarray, shape (3, 3)
        The inertia matrix about the centre of mass, in the body frame [kg m^2].
    """
    i = m * L * L / 12.0
    if isinstance(axis, str):
        if axis not in _AXES:
            raise InputError(f"rod: axis {axis!r}: a name or a direction", key="axis", choices=tuple(_AXES))
        d = [i, i, i]
        d[_AXES[axis]] = axial
        return np.diag(d)
    a = _direction(axis, "rod: axis")
    return i * (np.eye(3) - np.outer(a, a)) + axial * np.outer(a, a) + 0.0    # + 0.0: no -0.0 in the file


def plate(mass, radius):
    """Central inertia of a uniform thin disc in the local x-y plane (a plate in planar motion):
    m r^2 / 4 about x and y, m r^2 / 2 about z.

    Parameters
    ----------
    mass : float
        Mass [kg].
    radius : float
        Radius [m].

    Returns
    -------
    ndarray, shape (3, 3)
        The diagonal inertia matrix about the centre [kg m^2].
    """
    i = mass * radius * radius / 4.0
    return np.diag([i, i, 2 * i])


def sines(offset, amp, omega, phase=0.0):
    """A drive law offset + amp sin(omega t + phase), one sine term (pinclear.model.timelaws.Sines).

    Parameters
    ----------
    offset : float
        The constant part [rad for a revolute joint, m for a prismatic one].
    amp : float
        Amplitude [rad or m].
    omega : float
        Angular frequency [rad/s].
    phase : float
        Phase [rad].

    Returns
    -------
    dict
        The sidecar's law mapping ``{"type": "sines", "offset", "terms": [{amp, omega, phase}]}``,
        for :meth:`Builder.drive`.
    """
    return {"type": "sines", "offset": float(offset),
            "terms": [{"amp": float(amp), "omega": float(omega), "phase": float(phase)}]}


def _direction(v, what):
    a = np.asarray(v, float).reshape(-1)
    if a.shape != (3,) or not np.all(np.isfinite(a)) or np.linalg.norm(a) == 0:
        raise InputError(f"{what}: {v!r} is not a direction (3 finite numbers, not all zero)", key="axis")
    return a / np.linalg.norm(a)


def _rotation(rpy):
    """URDF's rpy: R = Rz(yaw) Ry(pitch) Rx(roll)."""
    import pinocchio as pin

    return pin.rpy.rpyToMatrix(*[float(x) for x in rpy])


def _rpy(R):
    import pinocchio as pin

    return tuple(float(x) for x in pin.rpy.matrixToRpy(R))


def _axis_rotation(axis, angle):
    import pinocchio as pin

    return pin.exp3(np.asarray(axis, float) * float(angle))


class Builder:
    """Collects a mechanism and writes NAME.urdf + NAME.yaml (see the module docstring).

    Every adding method returns the builder, so calls can be chained.

    Parameters
    ----------
    name : str
        The mechanism's name, which also names the files (:data:`NAME_PATTERN`).
    gravity : sequence of 3 floats
        Gravitational acceleration in the ground frame [m/s^2].
    description : str, optional
        The sidecar's ``description:`` (omitted when empty).
    ground : str
        The name of the fixed root body (:data:`NAME_PATTERN`).
    """

    def __init__(self, name, gravity=(0.0, 0.0, -9.81), description=None, ground="ground"):
        """Start an empty mechanism: the ground body only (parameters: the class docstring).

        Parameters
        ----------
        name : str
            The mechanism's name and the files' stem.
        gravity : sequence of 3 floats
            Gravitational acceleration [m/s^2].
        description : str, optional
            The sidecar's description.
        ground : str
            The fixed root body's name.
        """
        self.name = str(name)
        self._check_name("mechanism", self.name)
        self.ground = self._check_name("ground body", ground)
        self.sidecar = {"name": self.name, "urdf": f"{self.name}.urdf"}
        if description:
            self.sidecar["description"] = str(description)
        self.sidecar["gravity"] = [float(g) for g in gravity]
        self.links = {self.ground: None}
        self.joints, self.q, self.v = [], {}, {}
        self.closures, self.drives, self.clearances, self.parameters = [], [], [], []
        self.chains = {}          # spherical joint name -> its three joint specs (write() turns them)

    def _check_name(self, what, name):
        """``name`` as written, or one InputError naming it and the pattern it must match."""
        if not isinstance(name, str) or re.fullmatch(NAME_PATTERN, name) is None:
            raise InputError(f"builder {getattr(self, 'name', name)!r}: {what} name {name!r} is not a name: a letter "
                             f"or _, then letters, digits, _ or - (at most 100 characters; pattern {NAME_PATTERN})",
                             key=what.split()[-1])
        return name

    def _new_name(self, what, name, taken):
        self._check_name(what, name)
        if name in taken:
            raise InputError(f"builder {self.name}: {what} {name!r} defined twice", key=what.split()[-1])
        return name

    def body(self, name, mass, com=(0.0, 0.0, 0.0), inertia=None):
        """A rigid body (a URDF link); it hangs from the tree by the :meth:`joint` that names it
        as child.

        Parameters
        ----------
        name : str
            The body's name, new (:data:`NAME_PATTERN`).
        mass : float
            Mass [kg].
        com : sequence of 3 floats
            Centre of mass in the body frame [m].
        inertia : array, optional
            Central inertia in the body frame [kg m^2]: 3 principal moments or a 3x3 matrix
            (e.g. :func:`rod`, :func:`plate`). Default: a point-like token, 1e-7 times the
            identity.

        Returns
        -------
        Builder
            ``self``.
        """
        self._new_name("body", name, self.links)
        inertia = np.eye(3) * 1e-7 if inertia is None else np.asarray(inertia, float)
        inertia = np.diag(inertia) if inertia.ndim == 1 else inertia
        self.links[name] = (float(mass), tuple(float(c) for c in com), inertia)
        return self

    def _joint_names(self):
        return {j["name"] for j in self.joints}

    def _add(self, name, type, parent, child, xyz, axis, rpy):
        spec = {"name": name, "type": type, "parent": parent, "child": child, "xyz": tuple(float(x) for x in xyz),
                "axis": None if type == "fixed" else tuple(float(a) for a in axis),
                "limits": _NO_LIMITS if type in ("revolute", "prismatic") else None,
                "rpy": tuple(float(x) for x in rpy)}
        self.joints.append(spec)
        return spec

    def joint(self, name, type, parent, child, xyz=(0.0, 0.0, 0.0), axis=None, rpy=(0.0, 0.0, 0.0),
              q=None, v=None, axis2=None):
        """A tree joint from ``parent`` to ``child`` at ``xyz``/``rpy`` in the parent's frame; q, v:
        its initial guess (rad or m; rad/s or m/s) for the sidecar's ``initial:``.

        ``axis``: the joint's axis in its frame (default z). ``"spherical"``: three revolute joints
        NAME_1..3 about x, y, z of the joint frame (no ``axis``), ``q`` three angles [rad] (default
        0) and no ``v`` (the start velocity follows from the drives); ``"universal"``: NAME_1
        about ``axis`` (default x) and NAME_2 about ``axis2`` (default y), perpendicular, ``q``
        two angles. Module docstring: the massless links, the lock.

        Parameters
        ----------
        name : str
            The joint's name, new among joints and closures (:data:`NAME_PATTERN`).
        type : {"revolute", "prismatic", "continuous", "fixed", "spherical", "universal"}
            :data:`JOINT_TYPES`; another raises InputError.
        parent, child : str
            Bodies already defined; ``child`` must not hang from another joint yet (nor be the
            ground).
        xyz : sequence of 3 floats
            The joint frame's origin in the parent's frame [m].
        axis : sequence of 3 floats, optional
            The joint's axis in its frame (normalised): default z; a universal joint's first
            axis (default x); none for a spherical joint; ignored for a fixed one.
        rpy : sequence of 3 floats
            The joint frame's orientation in the parent's frame, URDF roll-pitch-yaw [rad].
        q : float or sequence of float, optional
            Initial guess of the coordinate [rad or m]; three angles for a spherical joint, two
            for a universal one [rad].
        v : float, optional
            Initial guess of the velocity [rad/s or m/s]; not for a spherical or universal
            joint.
        axis2 : sequence of 3 floats, optional
            A universal joint's second axis (default y), perpendicular to ``axis``; only there.

        Returns
        -------
        Builder
            ``self``.
        """
        if type not in JOINT_TYPES:
            raise InputError(f"builder {self.name}: joint {name!r}: unknown type {type!r}", key="joint",
                             choices=JOINT_TYPES)
        taken = self._joint_names() | {c["name"] for c in self.closures}
        self._new_name("joint", name, taken)
        for body in (parent, child):
            if body not in self.links:
                raise InputError(f"builder {self.name}: joint {name!r}: no body {body!r} (define it with body() "
                                 "first)", key="joint", choices=sorted(self.links))
        if child == self.ground or any(j["child"] == child for j in self.joints):
            raise InputError(f"builder {self.name}: joint {name!r}: body {child!r} already hangs from a joint (a tree "
                             "gives every body one parent joint; close a loop with closure())", key="joint")
        if type in ("spherical", "universal"):
            return self._chain(name, type, parent, child, xyz, axis, axis2, rpy, q, v, taken)
        if axis2 is not None:
            raise InputError(f"builder {self.name}: joint {name!r}: axis2 is a universal joint's", key="axis2")
        self._add(name, type, parent, child, xyz, (0.0, 0.0, 1.0) if axis is None else _direction(
            axis, f"builder {self.name}: joint {name!r}: axis"), rpy)
        if q is not None:
            self.q[name] = float(q)
        if v is not None:
            self.v[name] = float(v)
        return self

    def _chain(self, name, type, parent, child, xyz, axis, axis2, rpy, q, v, taken):
        where = f"builder {self.name}: {type} joint {name!r}"
        if type == "spherical":
            if axis is not None or axis2 is not None:
                raise InputError(f"{where}: takes no axis (its axes are x, y, z of the joint frame; turn them with rpy)",
                                 key="axis")
            axes = _SPHERICAL_AXES
        else:
            a1 = _direction((1.0, 0.0, 0.0) if axis is None else axis, f"{where}: axis")
            a2 = _direction((0.0, 1.0, 0.0) if axis2 is None else axis2, f"{where}: axis2")
            if abs(a1 @ a2) > 1e-9:
                raise InputError(f"{where}: axis {a1.tolist()} and axis2 {a2.tolist()} are not perpendicular "
                                 f"(angle {math.degrees(math.acos(max(-1.0, min(1.0, a1 @ a2)))):.6g} deg; a "
                                 "universal joint's cross has perpendicular arms)", key="axis2")
            axes = (tuple(a1), tuple(a2))
        if v is not None:
            raise InputError(f"{where}: takes no initial v (the start velocity follows from the drives; "
                             "pinclear.model.kinematics.start_state)", key="v")
        n = len(axes)
        q = (0.0,) * n if q is None else tuple(float(x) for x in np.asarray(q, float).reshape(-1))
        if len(q) != n:
            raise InputError(f"{where}: q {q!r}: {n} angles [rad], one per axis", key="q")
        joints = [f"{name}_{k}" for k in range(1, n + 1)]
        links = [f"{name}_link{k}" for k in range(1, n)]
        for jn in joints:
            self._new_name("joint", jn, taken)
        for ln in links:
            self._new_name("body", ln, self.links)
        ends = [parent, *links, child]
        specs = []
        for k, (jn, a) in enumerate(zip(joints, axes)):
            if k < n - 1:
                self.links[links[k]] = None                   # massless: no inertial element
            first = k == 0
            specs.append(self._add(jn, "revolute", ends[k], ends[k + 1], xyz if first else (0.0, 0.0, 0.0), a,
                                   rpy if first else (0.0, 0.0, 0.0)))
            self.q[jn] = q[k]
        if type == "spherical":
            self.chains[name] = specs
        return self

    def _frame(self, key, fr, where):
        if not isinstance(fr, (tuple, list)) or len(fr) not in (2, 3):
            raise InputError(f"{where}: {key} {fr!r} is (body, xyz) or (body, xyz, rpy)", key=key)
        if fr[0] not in self.links:
            raise InputError(f"{where}: {key}: no body {fr[0]!r}", key=key, choices=sorted(self.links))
        entry = {"parent": fr[0], "xyz": [float(x) for x in fr[1]]}
        if len(fr) > 2:
            entry["rpy"] = [float(x) for x in fr[2]]
        return entry

    def closure(self, name, type, frame1, frame2, **keys):
        """A cut joint closing a loop: ``frame1``/``frame2`` are (body, xyz) or (body, xyz, rpy)
        (pinclear.model.closures: planar_point, revolute, spherical, ...); ``keys``: e.g. normal.

        Parameters
        ----------
        name : str
            The closure's name, new among joints and closures (:data:`NAME_PATTERN`).
        type : str
            A closure type of pinclear.model.closures (planar_point, revolute, spherical, ...),
            checked by the loader at :meth:`write`.
        frame1, frame2 : tuple
            ``(body, xyz)`` or ``(body, xyz, rpy)``: the frames the cut joint ties together, on
            defined bodies, position [m] and roll-pitch-yaw [rad] in the body's frame.
        **keys
            The closure type's own sidecar keys (e.g. ``normal``), written as given.

        Returns
        -------
        Builder
            ``self``.
        """
        self._new_name("closure", name, self._joint_names() | {c["name"] for c in self.closures})
        where = f"builder {self.name}: closure {name!r}"
        entry = {"name": name, "type": type}
        entry["frame1"] = self._frame("frame1", frame1, where)
        entry["frame2"] = self._frame("frame2", frame2, where)
        entry.update(keys)
        self.closures.append(entry)
        return self

    def drive(self, joint, law, name=None):
        """A rheonomic drive of a tree joint: the joint's coordinate follows ``law`` in time.

        Parameters
        ----------
        joint : str
            The driven tree joint's name (checked by the loader at :meth:`write`).
        law : dict
            A sidecar law mapping (docs/inputs.md), e.g. :func:`sines`; values in rad or m.
        name : str, optional
            The drive's name, new among drives; default ``JOINT_drive``.

        Returns
        -------
        Builder
            ``self``.
        """
        name = self._new_name("drive", name or f"{joint}_drive", {d["name"] for d in self.drives})
        self.drives.append({"name": name, "joint": self._check_name("joint", joint), "law": law})
        return self

    def clearance(self, closure, type="planar_revolute", name=None, active=False, **keys):
        """A clearance joint replacing the closure ``closure`` (inactive unless ``active``: turned
        on by ``--clearance NAME`` / load(..., clearances=[NAME])); ``keys``: clearance [m],
        radius [m], length [m], material, ce, mu, friction_law... (docs/inputs.md).

        Parameters
        ----------
        closure : str
            The closure (cut joint) the clearance joint replaces when active.
        type : str
            The clearance joint's type (default "planar_revolute"; the loader's clearance types,
            docs/inputs.md).
        name : str, optional
            The clearance's name, new among clearances; default the closure's name.
        active : bool
            Active whenever the mechanism is loaded; else only when asked for.
        **keys
            The type's own sidecar keys: clearance [m], radius [m], length [m], material, ce, mu,
            friction_law, ..., written as given and checked by the loader at :meth:`write`.

        Returns
        -------
        Builder
            ``self``.
        """
        name = self._new_name("clearance", name or closure, {c["name"] for c in self.clearances})
        self.clearances.append({"name": name, "type": type, "closure": self._check_name("closure", closure),
                                "active": bool(active), **keys})
        return self

    def platform(self, body, xyz=None, name=None):
        """The frame whose motion the platform figure plots (the sidecar's ``platform: frame:``):
        ``body``'s own frame, or a new frame ``name`` at ``xyz`` [m] in it (e.g. the centre).

        Parameters
        ----------
        body : str
            A defined body.
        xyz : sequence of 3 floats, optional
            Position of a new frame in the body's frame [m]; without it the body's own frame.
        name : str, optional
            The new frame's name (only with ``xyz``); default ``BODY_centre``.

        Returns
        -------
        Builder
            ``self``.
        """
        if body not in self.links:
            raise InputError(f"builder {self.name}: platform: no body {body!r}", key="platform",
                             choices=sorted(self.links))
        frame = str(body) if xyz is None else {"parent": str(body), "xyz": [float(x) for x in xyz],
                                               "name": self._check_name("frame", name or f"{body}_centre")}
        self.sidecar["platform"] = {"frame": frame}
        return self

    def parameter(self, name, value, unit, source):
        """A row of the sidecar's parameter table (every number of a model with its source).

        Parameters
        ----------
        name : str
            What the number is (e.g. "crank length").
        value : float or str
            The number, as written.
        unit : str
            Its unit (SI, e.g. "m", "kg", "1").
        source : str
            Where it comes from (a paper's table, a measurement, an assumption).

        Returns
        -------
        Builder
            ``self``.
        """
        self.parameters.append({"name": name, "value": value, "unit": unit, "source": source})
        return self

    def urdf_text(self):
        """The URDF of the tree: every body as a link (a massless one without an inertial
        element) and every tree joint, names and values XML-escaped (pinclear.io.urdf_write).

        Returns
        -------
        str
            The URDF document.
        """
        links = "".join(urdf_link(n, None if p is None else (p[0], p[1], p[2])) for n, p in self.links.items())
        joints = "".join(urdf_joint(j["name"], j["type"], j["parent"], j["child"], j["xyz"], j["axis"], j["limits"],
                                    j["rpy"]) for j in self.joints)
        return (f'<?xml version="1.0"?>\n<!-- written by pinclear.builder -->\n<robot name={attr(self.name)}>\n'
                + links + joints + "</robot>\n")

    def sidecar_dict(self):
        """The sidecar as a mapping: name, urdf, description, gravity, platform, and the
        non-empty sections ``initial`` (q, v), ``closures``, ``drives``, ``clearances`` and
        ``parameters``.

        Returns
        -------
        dict
            What :meth:`write` dumps as NAME.yaml.
        """
        d = dict(self.sidecar)
        init = {k: v for k, v in (("q", self.q), ("v", self.v)) if v}
        for key, val in (("initial", init), ("closures", self.closures), ("drives", self.drives),
                         ("clearances", self.clearances), ("parameters", self.parameters)):
            if val:
                d[key] = val
        return d

    def _write_files(self, folder: Path, head: str) -> Path:
        import yaml

        # root=folder: a file of the builder is a name inside the folder, never a path through it
        safeio.write_text(folder / f"{self.name}.urdf", self.urdf_text(), root=folder)
        text = yaml.safe_dump(self.sidecar_dict(), sort_keys=False, default_flow_style=None, width=110)
        return safeio.write_text(folder / f"{self.name}.yaml", head + text, root=folder)

    def _turn_chains(self, mech, q) -> bool:
        """Turn each spherical chain's joint frame to its assembled start (module docstring): the
        new rpy is the old one times the chain's rotation Rx(q1) Ry(q2) Rz(q3), and the chain's
        guesses become 0, the same start in coordinates 90 deg from the lock. True if any turned."""
        model, turned = mech.model, False
        for specs in self.chains.values():
            angles = [float(q[model.joints[model.getJointId(s["name"])].idx_q]) for s in specs]
            if max(abs(a) for a in angles) < 1e-12:
                continue
            R = _rotation(specs[0]["rpy"])
            for s, a in zip(specs, angles):
                R = R @ _axis_rotation(s["axis"], a)
            specs[0]["rpy"] = _rpy(R)
            for s in specs:
                self.q[s["name"]] = 0.0
            turned = True
        return turned

    def write(self, folder, head="# written by pinclear.builder\n"):
        """Write ``folder``/NAME.urdf and NAME.yaml, then load them (every key checked by the
        loader) and assemble at t = 0 with every clearance active: returns the ideal Mechanism.
        A spherical joint's frame is turned to the assembled start first (module docstring).
        A mistake raises the loader's error naming the file and the key.

        Parameters
        ----------
        folder : str or Path
            The folder the two files are written into (created if missing); the files are
            names inside it, never paths through it.
        head : str
            Text put verbatim before the YAML (comment lines starting with ``#``).

        Returns
        -------
        Mechanism
            The ideal mechanism (no clearance active unless declared ``active``), as
            ``pinclear.load(folder/NAME.yaml)`` gives it.
        """
        from pinclear.io.sidecar import load
        from pinclear.model import kinematics

        folder = Path(folder)
        path = self._write_files(folder, head)
        mech = load(path)
        q = kinematics.assemble(mech)
        if self.chains and self._turn_chains(mech, q):
            path = self._write_files(folder, head)
            mech = load(path)
            kinematics.assemble(mech)
        names = [c["name"] for c in self.clearances]
        if names:
            free = load(path, clearances=names)
            kinematics.start_state(free, "ideal")
        return mech
