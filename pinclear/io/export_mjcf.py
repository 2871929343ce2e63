"""``pinclear export FILE --mjcf OUT.xml``: a pinclear mechanism as MuJoCo's MJCF.

The translation (moved here from the MuJoCo peer, benchmarks/peers/mujoco_peer.py, which now
calls it) works from ``pinclear.load(path).model``, not from MuJoCo's URDF importer, so that the
tree, the merged inertias and the joint placements are the ones pinclear integrates:

* one MJCF body per Pinocchio joint at ``model.jointPlacements[j]`` in its parent's body, with
  ``model.inertias[j]`` (mass, centre of mass, full inertia); revolute -> hinge, prismatic ->
  slide, spherical -> ball, free-flyer -> free (names kept); a massless body with one child is
  merged into it, its joint first (MuJoCo refuses massless moving bodies; _tree_xml);
* closures -> equality constraints between sites at the closure frames: spherical -> connect,
  weld -> weld, revolute -> two connects (the frames' origins and points one unit along the common
  z axis: 6 rows for 5), planar_point -> a connect whose second site is shifted along the normal
  by the initial out-of-plane offset, coupling -> a joint equality (polycoef = offset, ratio).
  Other closure types (universal, prismatic, cylindrical, distance) have no MuJoCo equality: they
  are left out, named in an XML comment and in the command's output;
* ``joint_spring`` force elements -> the joint's stiffness, springref and damping attributes
  (MuJoCo's passive joint forces are the same law); other force elements are named, not written;
* drives: ``drives="clock"`` (the peer): a joint equality on a clock joint whose polynomial the
  peer refreshes every step (exact prescribed motion, needs a Python loop); ``drives="position"``
  (the export): a position actuator per drive, critically damped at the drive's reflected inertia
  (a MuJoCo user sets its ctrl to f + 2 tc f', the law kept in the annotation), which is the
  nearest form MuJoCo offers without a loop;
* gravity; contacts disabled (ideal joints only).

The mechanism's own description is kept in ``<custom><text name="pinclear:sidecar" data=.../>``
(JSON of the sidecar mapping): MuJoCo ignores it and an import reads it back.
"""
from __future__ import annotations

import json
from xml.sax.saxutils import quoteattr

import numpy as np
import pinocchio as pin

from pinclear.core.errors import InputError

SUPPORTED_CLOSURES = ("spherical", "weld", "revolute", "planar_point", "coupling")
DMAX = 0.9999            # MuJoCo's largest impedance (mjMAXIMP)
CLOCK_ARMATURE = 1e10    # kg: the clock's reaction acceleration |F p'(s)| / 1e10 is negligible
ANNOTATION = "pinclear:sidecar"
LINK = "pinclear:link:"  # <custom><text name="pinclear:link:JOINT" data="LINK">: the link a merged joint moves


def _comment(text) -> str:
    """A note as an XML comment's body: one line, no ``--`` (which would end the comment early or
    make the file malformed, whatever a joint or closure name holds)."""
    text = " ".join(str(text).split())
    while "--" in text:
        text = text.replace("--", "- -")
    return text + " " if text.endswith("-") else text


def vec(x):
    return " ".join(f"{float(v):.17g}" for v in np.asarray(x, float).ravel())


def quat_wxyz(R):
    q = pin.Quaternion(np.asarray(R, float))
    q.normalize()
    return np.array([q.w, q.x, q.y, q.z])


def axis_joint(model, j):
    """(MJCF type, axis in the joint's frame) of a 1-dof Pinocchio joint, or None."""
    short = model.joints[j].shortname()
    axes = {"X": (1.0, 0, 0), "Y": (0, 1.0, 0), "Z": (0, 0, 1.0)}
    for kind, letter in (("hinge", "R"), ("slide", "P")):
        if short in tuple(f"JointModel{letter}{a}" for a in "XYZ"):
            return kind, np.array(axes[short[-1]])
        if short == f"JointModel{'Revolute' if letter == 'R' else 'Prismatic'}Unaligned":
            return kind, np.asarray(model.joints[j].extract().axis, float)
    return None


def joint_xml(model, j, name, extra="", frame=None):
    """MJCF joint element for Pinocchio joint j, and its kind for the q mapping. ``frame``: the
    joint's frame in the MuJoCo body's frame (a massless body merged into its child, _tree_xml),
    which sets the joint's ``pos`` and turns its axis."""
    jm = model.joints[j]
    short = jm.shortname()
    one = axis_joint(model, j)
    if one is not None:
        kind, axis = one
        pos = ""
        if frame is not None:
            axis = frame.rotation @ axis
            pos = f' pos="{vec(frame.translation)}"'
        return f'<joint name="{name}" type="{kind}"{pos} axis="{vec(axis)}"{extra}/>', "1"
    if short == "JointModelSpherical":
        return f'<joint name="{name}" type="ball"/>', "ball"
    if short == "JointModelFreeFlyer":
        if model.parents[j] != 0:
            raise InputError(f"MJCF export: free-flyer joint {model.names[j]!r} must hang from the universe "
                             "(MuJoCo's free joints are top-level)")
        return f'<joint name="{name}" type="free"/>', "free"
    raise InputError(f"MJCF export: joint {model.names[j]!r} of type {short} has no MuJoCo translation; "
                     "supported: revolute (RX, RY, RZ, unaligned), prismatic (PX, PY, PZ, unaligned), "
                     "spherical, free-flyer")


def _joint_extras(mech):
    """{joint index: MJCF attributes} from the joint_spring elements; the names of the others."""
    from pinclear.model.joint_spring import JointSpring

    extra, skipped = {}, []
    for f in mech.forces:
        if isinstance(f, JointSpring):
            j = next(j for j in range(1, mech.model.njoints) if mech.model.joints[j].idx_v == f.idx_v)
            extra[j] = f' stiffness="{f.k:.17g}" springref="{f.reference:.17g}" damping="{f.c:.17g}"'
        else:
            skipped.append(f"force element {f.name!r} ({f.describe().get('type')}): no MJCF translation")
    return extra, skipped


def mjcf(mech, q0, h, tc, integrator="RK4", drives="clock", strict=True, annotation=None):
    """(MJCF text, {joint index: name}, {joint index: kind}, notes) of ``mech`` with closures
    assembled at ``q0``, step ``h`` and constraint time constant ``tc``. ``strict``: refuse
    closures and force elements MuJoCo cannot express (the peer) instead of naming them.
    ``annotation``: text kept in ``<custom><text name="pinclear:sidecar">``."""
    model = mech.model
    names = {j: model.names[j] for j in range(1, model.njoints)}
    kinds, notes = {}, []
    sites = {j: [] for j in range(model.njoints)}
    equality = []
    solref = f'solref="{tc:.17g} 1" solimp="{DMAX} {DMAX} 0.001 0.5 2"'
    pdata = model.createData()
    pin.framesForwardKinematics(model, pdata, q0)
    extras, skipped = _joint_extras(mech) if not (strict and mech.forces) else ({}, [])
    if strict and mech.forces:
        raise InputError(f"MuJoCo peer: {mech.name} has force elements {[f.name for f in mech.forces]}; "
                         "the translation covers ideal joints, closures, drives and gravity only")
    notes += skipped

    def add_site(fid, offset=np.zeros(3), label=""):
        F = model.frames[fid]
        name = f"site_{len([s for v in sites.values() for s in v])}_{F.name}{label}"
        pos = F.placement.translation + F.placement.rotation @ offset
        sites[F.parentJoint].append(f'<site name="{name}" pos="{vec(pos)}" '
                                    f'quat="{vec(quat_wxyz(F.placement.rotation))}"/>')
        return name

    for c in mech.closures:
        if c.type not in SUPPORTED_CLOSURES:
            if strict:
                raise InputError(f"MuJoCo peer: closure {c.name!r} of type {c.type!r} has no MuJoCo equality; "
                                 f"supported: {list(SUPPORTED_CLOSURES)}")
            notes.append(f"closure {c.name!r} ({c.type}): MuJoCo has no equality of this kind; not written "
                         "(kept in the pinclear annotation)")
            continue
        equality += _equality(c, add_site, pdata, model, solref)

    world, links = _tree_xml(model, names, sites, extras, kinds, notes)
    g = model.gravity.linear
    more, eqs, actuators = _drives_xml(mech, g, tc, solref, drives, notes, q0)
    world += more
    equality += eqs
    # the links of the merged massless bodies, by joint, so that an import names them again
    texts = [f"<text name={quoteattr(LINK + names[j])} data={quoteattr(link)}/>" for j, link in links.items()]
    if annotation is not None:
        texts.append(f"<text name={quoteattr(ANNOTATION)} data={quoteattr(annotation)}/>")
    xml = "\n".join([
        f'<mujoco model="{mech.name}">',
        *[f"  <!-- pinclear: {_comment(n)} -->" for n in notes],
        '  <compiler angle="radian" autolimits="true" inertiafromgeom="false"/>',
        f'  <option timestep="{h:.17g}" integrator="{integrator}" gravity="{vec(g)}" solver="Newton" '
        'iterations="50" tolerance="1e-12" jacobian="dense">',
        '    <flag contact="disable"' + (' refsafe="disable"' if tc < 2 * h else "") + "/>",
        "  </option>",
        "  <worldbody>", *world, "  </worldbody>",
        *(["  <equality>", *[f"    {e}" for e in equality], "  </equality>"] if equality else []),
        *(["  <actuator>", *[f"    {a}" for a in actuators], "  </actuator>"] if actuators else []),
        *(["  <custom>", *[f"    {t}" for t in texts], "  </custom>"] if texts else []),
        "</mujoco>"])
    return xml, names, kinds, notes


def accepted_inertia(Y) -> bool:
    """Whether MuJoCo takes a moving body's inertia: positive mass, positive-definite inertia."""
    return Y.mass > 0 and np.linalg.eigvalsh(Y.inertia).min() > 0


def massless(Y) -> bool:
    """Whether a body carries no mass and no rotational inertia at all."""
    return not Y.mass > 0 and not np.abs(Y.inertia).max() > 0


def _tree_xml(model, names, sites, extras, kinds, notes):
    """(the worldbody's lines, {joint: link} of the merged bodies): one body per joint (named
    after the link it moves), its joint, inertial and sites; every other link of the tree (merged
    into a body, the root) as a site ``pinclear:frame:NAME`` so that an import gets its frames back.

    MuJoCo refuses a moving body without mass or inertia (mjMINVAL), which pinclear's clearance
    scenes use for the massless links between their six free coordinates. Such a body, when it
    has one child and no site, is merged into that child: MuJoCo gives a body several joints and
    applies them in order, each about its axis through its ``pos`` in the body's frame as moved by
    the joints before it (mj_kinematics), which is Pinocchio's chain joint after joint. So the
    child's body sits at the composed placement B and each merged joint gets pos and axis from
    its own frame S in B's axes (B^-1 S): the kinematics are the same map of q, and the massless
    body adds nothing to the mass matrix or the bias forces, so the dynamics are unchanged
    (tests/io/test_export_mjcf.py compares MuJoCo's M and bias with Pinocchio's)."""
    children = {j: [] for j in range(model.njoints)}
    for j in range(1, model.njoints):
        children[model.parents[j]].append(j)
    body_name = {j: f"b{j}_{names[j]}" for j in range(1, model.njoints)}
    named = set()
    for f in model.frames:
        if f.type == pin.FrameType.BODY:
            if f.parentJoint > 0 and f.placement.isIdentity(0.0) and f.parentJoint not in named:
                body_name[f.parentJoint] = f.name          # the link the joint moves
                named.add(f.parentJoint)
            else:                                          # a link merged into its parent, or the root
                sites[f.parentJoint].append(f'<site name="pinclear:frame:{f.name}" '
                                            f'pos="{vec(f.placement.translation)}" '
                                            f'quat="{vec(quat_wxyz(f.placement.rotation))}"/>')

    merged = {j: body_name[j] for j in range(1, model.njoints) if massless(model.inertias[j])
              and len(children[j]) == 1 and not sites[j] and axis_joint(model, j) is not None}
    notes += [f"body of joint {names[j]!r} has no mass and cannot be merged into a single child: MuJoCo refuses "
              "a massless moving body (give it one in the URDF to run the file in MuJoCo)"
              for j in range(1, model.njoints) if j not in merged and not accepted_inertia(model.inertias[j])]

    def body(j, indent, pending=(), S=pin.SE3.Identity()):
        S = S * model.jointPlacements[j]                  # joint j's frame in the MuJoCo parent body
        if j in merged:
            return body(children[j][0], indent, pending + ((j, S),), S)
        Y = model.inertias[j]
        pad = " " * indent
        out = [f'{pad}<body name="{body_name[j]}" pos="{vec(S.translation)}" quat="{vec(quat_wxyz(S.rotation))}">']
        for i, Si in pending:
            jx, kinds[i] = joint_xml(model, i, names[i], extras.get(i, ""), S.actInv(Si))
            out.append(f"{pad}  {jx}")
        jx, kinds[j] = joint_xml(model, j, names[j], extras.get(j, ""))
        I = Y.inertia
        out += [f'{pad}  {jx}', f'{pad}  <inertial pos="{vec(Y.lever)}" mass="{Y.mass:.17g}" fullinertia="'
                f'{vec([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]])}"/>']
        out += [f"{pad}  {s}" for s in sites[j]]
        for k in children[j]:
            out += body(k, indent + 2)
        out.append(f"{pad}</body>")
        return out

    world = [f"    {s}" for s in sites[0]]
    for j in children[0]:
        world += body(j, 4)
    return world, merged


def drive_inertias(mech, q):
    """The inertia each drive's joint reflects at q with the closures held and the other drives
    free: 1 / (e_i^T P e_i), P = M^-1 - M^-1 J^T S^+ J M^-1 the constrained inverse mass matrix
    (J: the closure rows at q, S = J M^-1 J^T, its pseudo-inverse for redundant rows)."""
    from pinclear.model import kinematics

    data = mech.model.createData()
    M = pin.crba(mech.model, data, q)
    Minv = np.linalg.inv(np.triu(M) + np.triu(M, 1).T)
    J = kinematics.jacobian(mech, mech.workspace(), q)
    Y = J @ Minv
    P = Minv - Y.T @ np.linalg.pinv(Y @ J.T, rcond=1e-12, hermitian=True) @ Y
    g = np.array([P[d.idx_v, d.idx_v] for d in mech.drives])
    bad = [d.name for d, x in zip(mech.drives, g) if not x > 1e-12 * np.abs(Minv).max()]
    if bad:
        raise InputError(f"MJCF export: drive {bad[0]!r} cannot move its joint with the closures held (the loop "
                         "locks it): no servo gain")
    return 1.0 / g


def _drives_xml(mech, g, tc, solref, drives, notes, q0):
    """(worldbody lines, equality lines, actuator lines) of the drives: a clock joint and joint
    equalities (the peer), or position servos (the export; named in ``notes``).

    A servo's force is kp (ctrl - q) - kv q'; with kp = m / tc^2 and kv = 2 m / tc, m the
    drive's reflected inertia (drive_inertias), the error e = q - ctrl of a servo tracking
    ctrl = f(t) obeys m (e'' + 2 e'/tc + e/tc^2) = -m f'' - 2 m f'/tc - (the load it carries): a
    critically damped lag of time constant tc, e -> -2 tc f' + O(tc^2), first order in MuJoCo's
    step (tc = 2 h). ctrl = f + 2 tc f' (kp 2 tc f' = kv f') leaves the O(tc^2) part only, and
    taken at the step's midpoint (MuJoCo holds ctrl over a step) no O(h) hold error either: the
    run then converges to the prescribed motion at second order (tests/io/test_export_mjcf.py)."""
    world, equality = [], []
    actuators = []
    if mech.drives and drives == "clock":
        # the clock's slide axis is normal to gravity: no generalized gravity force on it
        a = np.eye(3)[np.argmin(np.abs(g))] if np.linalg.norm(g) else np.array([1.0, 0, 0])
        axis = a - g * (g @ a) / max(g @ g, 1e-300)
        world.append(f'    <body name="pinclear_clock_body"><joint name="pinclear_clock" type="slide" '
                     f'axis="{vec(axis / np.linalg.norm(axis))}" armature="{CLOCK_ARMATURE:g}"/>'
                     '<inertial pos="0 0 0" mass="1" diaginertia="1 1 1"/></body>')
        for d in mech.drives:
            equality.append(f'<joint name="drive_{d.name}" joint1="{d.joint}" joint2="pinclear_clock" '
                            f'polycoef="0 0 0 0 0" {solref}/>')
    elif mech.drives:
        for d, m in zip(mech.drives, drive_inertias(mech, q0)):
            actuators.append(f'<position name="drive_{d.name}" joint="{d.joint}" kp="{m / tc ** 2:.17g}" '
                             f'kv="{2.0 * m / tc:.17g}"/>')
            notes.append(f"drive {d.name!r}: a position servo, critically damped with time constant tc = {tc:g} s "
                         f"(kp = m/tc^2, kv = 2m/tc, m = {m:.6g} the joint's reflected inertia); MuJoCo has no time "
                         "law: set its ctrl every step to f + 2 tc f' at the step's midpoint, f the law "
                         f"{d.law.describe()} (ctrl = f alone lags the law by 2 tc f')")
    return world, equality, actuators


def _equality(c, add_site, pdata, model, solref):
    """MJCF equality element(s) of one closure."""
    if c.type == "spherical":
        return [f'<connect name="{c.name}" site1="{add_site(c.f1)}" site2="{add_site(c.f2)}" {solref}/>']
    if c.type == "weld":
        return [f'<weld name="{c.name}" site1="{add_site(c.f1)}" site2="{add_site(c.f2)}" {solref}/>']
    if c.type == "revolute":
        ez = np.array([0.0, 0.0, 1.0])
        return [f'<connect name="{c.name}" site1="{add_site(c.f1)}" site2="{add_site(c.f2)}" {solref}/>',
                f'<connect name="{c.name}_axis" site1="{add_site(c.f1, ez, "_z")}" '
                f'site2="{add_site(c.f2, ez, "_z")}" {solref}/>']
    if c.type == "coupling":
        # MuJoCo: joint1 - joint1_0 = poly(joint2 - joint2_0), qpos0 = 0 here: q2 = offset + ratio q1
        iq1, _, iq2, _, ratio, offset = c.coupling
        j1 = next(j for j in range(1, model.njoints) if model.joints[j].idx_q == iq1)
        j2 = next(j for j in range(1, model.njoints) if model.joints[j].idx_q == iq2)
        return [f'<joint name="{c.name}" joint1="{model.names[j2]}" joint2="{model.names[j1]}" '
                f'polycoef="{offset:.17g} {ratio:.17g} 0 0 0" {solref}/>']
    # planar_point: shift point 2 along n by the initial out-of-plane offset
    n = np.asarray(c.normal, float) / np.linalg.norm(c.normal)
    p1, p2 = pdata.oMf[c.f1].translation, pdata.oMf[c.f2].translation
    R2 = pdata.oMf[c.f2].rotation
    off_world = n * float(n @ (p1 - p2))
    return [f'<connect name="{c.name}" site1="{add_site(c.f1)}" site2="{add_site(c.f2, R2.T @ off_world)}" {solref}/>']


def export_mjcf(mech, h=1e-3, tc_factor=2.0) -> tuple[str, list]:
    """(MJCF text with the pinclear annotation, notes) of a loaded mechanism, assembled."""
    from pinclear.model import kinematics

    q0 = kinematics.assemble(mech, mech.q0, t=0.0)
    ann = json.dumps(mech.sidecar, sort_keys=True, default=str)
    xml, _, _, notes = mjcf(mech, q0, h, tc_factor * h, "RK4", drives="position", strict=False, annotation=ann)
    return xml, notes
