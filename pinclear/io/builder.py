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
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from pinclear.core import safeio
from pinclear.core.errors import InputError
from pinclear.io.urdf_write import thin_rod as rod  # noqa: F401  (re-exported: a bar's central inertia)
from pinclear.io.urdf_write import urdf_joint, urdf_link

#: URDF joint types the builder writes (pinclear's loader accepts what Pinocchio parses)
JOINT_TYPES = ("revolute", "prismatic", "continuous", "fixed")
#: revolute and prismatic joints get these limits: none in effect (the closures bound the motion)
_NO_LIMITS = (-1e9, 1e9)


def plate(mass, radius):
    """Central inertia of a thin disc of ``radius`` in the local x-y plane (a plate in planar motion)."""
    i = mass * radius * radius / 4.0
    return np.diag([i, i, 2 * i])


def sines(offset, amp, omega, phase=0.0):
    """A drive law offset + amp sin(omega t + phase) [rad or m; rad/s; rad] (pinclear.model.timelaws.Sines)."""
    return {"type": "sines", "offset": float(offset),
            "terms": [{"amp": float(amp), "omega": float(omega), "phase": float(phase)}]}


class Builder:
    """Collects a mechanism and writes NAME.urdf + NAME.yaml (see the module docstring)."""

    def __init__(self, name, gravity=(0.0, 0.0, -9.81), description=None, ground="ground"):
        self.name, self.ground = str(name), str(ground)
        self.sidecar = {"name": self.name, "urdf": f"{self.name}.urdf"}
        if description:
            self.sidecar["description"] = str(description)
        self.sidecar["gravity"] = [float(g) for g in gravity]
        self.links = {self.ground: None}
        self.joints, self.q, self.v = [], {}, {}
        self.closures, self.drives, self.clearances, self.parameters = [], [], [], []

    def body(self, name, mass, com=(0.0, 0.0, 0.0), inertia=None):
        """A rigid body: mass [kg], centre of mass [m] and central inertia [kg m^2] in its frame
        (3 principal moments or a 3x3 matrix; default: a point-like token inertia)."""
        if name in self.links:
            raise InputError(f"builder {self.name}: body {name!r} defined twice", key="body")
        inertia = np.eye(3) * 1e-7 if inertia is None else np.asarray(inertia, float)
        inertia = np.diag(inertia) if inertia.ndim == 1 else inertia
        self.links[name] = (float(mass), tuple(float(c) for c in com), inertia)
        return self

    def joint(self, name, type, parent, child, xyz=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0), rpy=(0.0, 0.0, 0.0),
              q=None, v=None):
        """A tree joint from ``parent`` to ``child`` at ``xyz``/``rpy`` in the parent's frame; q, v:
        its initial guess (rad or m; rad/s or m/s) for the sidecar's ``initial:``."""
        if type not in JOINT_TYPES:
            raise InputError(f"builder {self.name}: joint {name!r}: unknown type {type!r}", key="joint",
                             choices=JOINT_TYPES)
        for body in (parent, child):
            if body not in self.links:
                raise InputError(f"builder {self.name}: joint {name!r}: no body {body!r} (define it with body() "
                                 "first)", key="joint", choices=sorted(self.links))
        limits = _NO_LIMITS if type in ("revolute", "prismatic") else None
        self.joints.append(urdf_joint(name, type, parent, child, xyz, None if type == "fixed" else axis, limits, rpy))
        if q is not None:
            self.q[name] = float(q)
        if v is not None:
            self.v[name] = float(v)
        return self

    def closure(self, name, type, frame1, frame2, **keys):
        """A cut joint closing a loop: ``frame1``/``frame2`` are (body, xyz) or (body, xyz, rpy)
        (pinclear.model.closures: planar_point, revolute, spherical, ...); ``keys``: e.g. normal."""
        entry = {"name": name, "type": type}
        for key, fr in (("frame1", frame1), ("frame2", frame2)):
            entry[key] = {"parent": fr[0], "xyz": [float(x) for x in fr[1]]}
            if len(fr) > 2:
                entry[key]["rpy"] = [float(x) for x in fr[2]]
        entry.update(keys)
        self.closures.append(entry)
        return self

    def drive(self, joint, law, name=None):
        """A rheonomic drive of a tree joint (``law``: a sidecar law mapping, e.g. :func:`sines`)."""
        self.drives.append({"name": name or f"{joint}_drive", "joint": joint, "law": law})
        return self

    def clearance(self, closure, type="planar_revolute", name=None, active=False, **keys):
        """A clearance joint replacing the closure ``closure`` (inactive unless ``active``: turned
        on by ``--clearance NAME`` / load(..., clearances=[NAME])); ``keys``: clearance [m],
        radius [m], length [m], material, ce, mu, friction_law... (docs/inputs.md)."""
        self.clearances.append({"name": name or closure, "type": type, "closure": closure, "active": bool(active),
                                **keys})
        return self

    def platform(self, body, xyz=None, name=None):
        """The frame whose motion the platform figure plots (the sidecar's ``platform: frame:``):
        ``body``'s own frame, or a new frame ``name`` at ``xyz`` [m] in it (e.g. the centre)."""
        frame = str(body) if xyz is None else {"parent": str(body), "xyz": [float(x) for x in xyz],
                                               "name": name or f"{body}_centre"}
        self.sidecar["platform"] = {"frame": frame}
        return self

    def parameter(self, name, value, unit, source):
        """A row of the sidecar's parameter table (every number of a model with its source)."""
        self.parameters.append({"name": name, "value": value, "unit": unit, "source": source})
        return self

    def urdf_text(self):
        links = "".join(urdf_link(n, None if p is None else (p[0], p[1], p[2])) for n, p in self.links.items())
        return (f'<?xml version="1.0"?>\n<!-- written by pinclear.builder -->\n<robot name="{self.name}">\n'
                + links + "".join(self.joints) + "</robot>\n")

    def sidecar_dict(self):
        d = dict(self.sidecar)
        init = {k: v for k, v in (("q", self.q), ("v", self.v)) if v}
        for key, val in (("initial", init), ("closures", self.closures), ("drives", self.drives),
                         ("clearances", self.clearances), ("parameters", self.parameters)):
            if val:
                d[key] = val
        return d

    def write(self, folder, head="# written by pinclear.builder\n"):
        """Write ``folder``/NAME.urdf and NAME.yaml, then load them (every key checked by the
        loader) and assemble at t = 0 with every clearance active: returns the ideal Mechanism.
        A mistake raises the loader's error naming the file and the key."""
        import yaml

        from pinclear.io.sidecar import load
        from pinclear.model import kinematics

        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        safeio.write_text(folder / f"{self.name}.urdf", self.urdf_text())
        path = folder / f"{self.name}.yaml"
        text = yaml.safe_dump(self.sidecar_dict(), sort_keys=False, default_flow_style=None, width=110)
        safeio.write_text(path, head + text)
        mech = load(path)
        kinematics.assemble(mech)
        names = [c["name"] for c in self.clearances]
        if names:
            free = load(path, clearances=names)
            kinematics.start_state(free, "ideal")
        return mech
