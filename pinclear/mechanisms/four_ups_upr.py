"""4-UPS/UPR vehicle motion simulator of paper 004 (Geng et al. 2014): geometry, parameter table,
coupled motion, inverse and forward kinematics, the URDF generator and the sidecar hook.

Spanning tree (no quaternion joints):

* constraint limb UPR: ``upr_u1`` (revolute about base x at the origin) -> ``upr_u2`` (revolute
  about the rotated y) -> swing rod -> ``upr_p`` (prismatic along the rod, coordinate = distance
  from the U centre to the platform origin) -> telescopic rod -> ``upr_r`` (revolute about the
  platform's y_p axis at the platform origin) -> ``platform``. This chain alone gives the
  platform its four freedoms (paper 004, sec. 1.2);
* four UPS limbs ``ups{i}_u1``, ``ups{i}_u2``, ``ups{i}_p`` from a_i, the prismatic coordinate
  being the limb length |b_i - a_i| (the telescopic rod's frame sits at the S centre); each is
  closed on the platform by a ``spherical`` closure ``S{i}`` between ``ups{i}_rod`` and
  ``platform_b{i}``.

What the screw method (:mod:`pinclear.dynamics.screw`) needs is declared in the sidecar's ``screw:``
section written by :func:`screw_section`: the limbs, paper 004's virtual joints of the UPR limb
(the generic ``line_normal`` rule), the analytic IK :func:`tree_configuration_ik` and the two
motion laws :func:`platform_motion` with their periods.

Screw conventions follow the paper: twist V = (omega; v_o), v_o the velocity of the body point at
the fixed origin; acceleration A = (domega; a_o) its time derivative (paper 004, eq. 6).
Pinocchio's Motion is (v; omega); the converters below go between the two.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pinocchio as pin

from pinclear.core.errors import InputError
from pinclear.mechanisms._common import URDF_DIR
from pinclear.mechanisms.four_ups_upr_kinematics import _coupled_accel, _limb_kinematics, _limb_lengths_into

#: initial platform height (paper 004, sec. 4)
H0 = 0.38

#: base hinge points a_i in the fixed frame (paper 004, Table 1)
BASE_POINTS = np.array([[0.40, 0.37, 0.0], [-0.40, 0.37, 0.0], [-0.40, -0.37, 0.0], [0.40, -0.37, 0.0]])

#: platform hinge points b_i0 in the platform frame for the six layouts of the paper's Fig. 2.
#: (f) is Table 1; (a)-(e) are reconstructed to have exactly the line geometry the paper names,
#: on the same base (the figure itself was lost in extraction).
LAYOUTS = {
    # (a) four actuation lines parallel (vertical)
    "a": np.array([[0.40, 0.37, 0.0], [-0.40, 0.37, 0.0], [-0.40, -0.37, 0.0], [0.40, -0.37, 0.0]]),
    # (b) concurrent: b_i = a_i / 2 puts all four lines through (0, 0, 2 H)
    "b": np.array([[0.20, 0.185, 0.0], [-0.20, 0.185, 0.0], [-0.20, -0.185, 0.0], [0.20, -0.185, 0.0]]),
    # (c) one common transversal L: every line lies in a plane x = +-0.4 and meets the x axis
    #     at height 2 H perpendicularly
    "c": np.array([[0.40, 0.185, 0.0], [-0.40, 0.185, 0.0], [-0.40, -0.185, 0.0], [0.40, -0.185, 0.0]]),
    # (d) rectangle scaled differently in x and y: two transversals (one parallel to x, one to y)
    "d": np.array([[0.20, 0.20, 0.0], [-0.20, 0.20, 0.0], [-0.20, -0.20, 0.0], [0.20, -0.20, 0.0]]),
    # (e) trapezoid symmetric about the x axis
    "e": np.array([[0.20, 0.20, 0.0], [-0.20, 0.15, 0.0], [-0.20, -0.15, 0.0], [0.20, -0.20, 0.0]]),
    # (f) trapezoid symmetric about the y axis: paper 004, Table 1
    "f": np.array([[0.20, 0.20, 0.0], [-0.20, 0.20, 0.0], [-0.15, -0.20, 0.0], [0.15, -0.20, 0.0]]),
}

# masses and central inertias (paper 004, sec. 4.2); rods: z along the rod
M_PLATFORM, I_PLATFORM = 53.45, (1.41, 4.41, 2.82)
M_UPS_SWING, I_UPS_SWING = 6.71, (0.064, 0.064, 0.002)
M_UPS_ROD, I_UPS_ROD = 2.27, (0.023, 0.023, 0.0003)
M_UPR_SWING, I_UPR_SWING = 3.44, (0.013, 0.014, 0.002)
M_UPR_ROD, I_UPR_ROD = 3.54, (0.032, 0.032, 0.0004)


def _slender_length(m, i_transverse):
    # a uniform slender rod has I = m L^2 / 12 about its centre
    return math.sqrt(12.0 * i_transverse / m)


L_UPS_SWING = _slender_length(M_UPS_SWING, I_UPS_SWING[0])
L_UPS_ROD = _slender_length(M_UPS_ROD, I_UPS_ROD[0])
L_UPR_SWING = _slender_length(M_UPR_SWING, 0.5 * (I_UPR_SWING[0] + I_UPR_SWING[1]))
L_UPR_ROD = _slender_length(M_UPR_ROD, I_UPR_ROD[0])

#: motion laws (paper 004, eqs. 27 and 28): amplitude, angular frequency of
#: (alpha, beta, dx, dz) = amp * sin(omega t)
LAWS = {
    "low": (np.array([0.2, 0.2, 0.1, 0.2]), np.array([3.0, 2.0, 1.0, 2.0])),
    "high": (np.array([0.2, 0.2, 0.1, 0.2]), np.array([15.0, 10.0, 5.0, 10.0])),
}
#: full period of each law (common period of its four sines)
PERIODS = {"low": 2.0 * math.pi, "high": 2.0 * math.pi / 5.0}

OPTIONS = {
    "law": {"default": "high", "choices": ["low", "high"],
            "doc": "paper 004 motion law (eq. 27 low, eq. 28 high); 'low' via four_ups_upr.load(law='low')"},
    "limbs": {"default": True, "choices": [True, False], "doc": "limb inertia on/off (off: platform only)"},
    "layout": {"default": "f", "choices": list("abcdef"),
               "doc": "hinge layout of the paper's Fig. 2 (a-e singular, f regular: Table 1)"},
}

UPS_JOINTS = [[f"ups{i}_u1", f"ups{i}_u2", f"ups{i}_p"] for i in range(1, 5)]
UPR_JOINTS = ["upr_u1", "upr_u2", "upr_p", "upr_r"]
DRIVE_JOINTS = [f"ups{i}_p" for i in range(1, 5)]
LIMB_BODY_JOINTS = [j for js in UPS_JOINTS for j in js] + UPR_JOINTS[:3]


def parameters():
    """The parameter table of the model: name, value, unit, source."""
    t1 = "paper 004, Table 1"
    s42 = "paper 004, sec. 4.2"
    rows = [{"name": "H", "value": H0, "unit": "m", "source": "paper 004, sec. 4"}]
    for i in range(4):
        rows.append({"name": f"a{i + 1}", "value": BASE_POINTS[i].tolist(), "unit": "m", "source": t1})
    for i in range(4):
        rows.append({"name": f"b{i + 1}0", "value": LAYOUTS["f"][i].tolist(), "unit": "m", "source": t1})
    rows += [
        {"name": "m_platform", "value": M_PLATFORM, "unit": "kg", "source": s42},
        {"name": "I_platform", "value": list(I_PLATFORM), "unit": "kg m^2", "source": s42},
        {"name": "m_ups_swing", "value": M_UPS_SWING, "unit": "kg", "source": s42},
        {"name": "I_ups_swing", "value": list(I_UPS_SWING), "unit": "kg m^2", "source": s42},
        {"name": "m_ups_rod", "value": M_UPS_ROD, "unit": "kg", "source": s42},
        {"name": "I_ups_rod", "value": list(I_UPS_ROD), "unit": "kg m^2", "source": s42},
        {"name": "m_upr_swing", "value": M_UPR_SWING, "unit": "kg", "source": s42},
        {"name": "I_upr_swing", "value": list(I_UPR_SWING), "unit": "kg m^2", "source": s42},
        {"name": "m_upr_rod", "value": M_UPR_ROD, "unit": "kg", "source": s42},
        {"name": "I_upr_rod", "value": list(I_UPR_ROD), "unit": "kg m^2", "source": s42},
    ]
    rec = "reconstructed: uniform slender rod, L = sqrt(12 I_transverse / m) from the paper's inertia"
    rows += [
        {"name": "L_ups_swing", "value": round(L_UPS_SWING, 4), "unit": "m", "source": rec},
        {"name": "c_ups_swing", "value": round(L_UPS_SWING / 2, 4), "unit": "m",
         "source": "reconstructed: centre of mass at mid-rod, measured from the U centre"},
        {"name": "L_ups_rod", "value": round(L_UPS_ROD, 4), "unit": "m", "source": rec},
        {"name": "c_ups_rod", "value": round(L_UPS_ROD / 2, 4), "unit": "m",
         "source": "reconstructed: centre of mass at mid-rod, measured back from the S centre"},
        {"name": "L_upr_swing", "value": round(L_UPR_SWING, 4), "unit": "m",
         "source": rec + " (mean of its two transverse values)"},
        {"name": "c_upr_swing", "value": round(L_UPR_SWING / 2, 4), "unit": "m",
         "source": "reconstructed: centre of mass at mid-rod, measured from the U centre"},
        {"name": "L_upr_rod", "value": round(L_UPR_ROD, 4), "unit": "m", "source": rec},
        {"name": "c_upr_rod", "value": round(L_UPR_ROD / 2, 4), "unit": "m",
         "source": "reconstructed: centre of mass at mid-rod, measured back from the R joint"},
        {"name": "c_platform", "value": [0.0, 0.0, 0.0], "unit": "m",
         "source": "reconstructed: platform centre of mass at the platform frame origin (eq. 19 uses no offset)"},
    ]
    return rows


def _check_layout(layout):
    if layout not in LAYOUTS:
        raise InputError(f"four_ups_upr: unknown layout {layout!r} (valid: {', '.join(LAYOUTS)})")
    return LAYOUTS[layout]


def _check_law(law):
    if law not in LAWS:
        raise InputError(f"four_ups_upr: unknown motion law {law!r} (valid: {', '.join(LAWS)})")
    return LAWS[law]


# --------------------------------------------------------------------------- coupled motion
def _cross(a, b):
    # explicit components: np.cross's axis handling dominates these 3-vector evaluations
    return np.array([a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]])


def _rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _ry(b):
    c, s = math.cos(b), math.sin(b)
    return np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])


def motion_law(t, law="high"):
    """(x, xd, xdd) of x = (alpha, beta, dx, dz) for the paper's law 'low' (eq. 27) or 'high' (eq. 28)."""
    amp, w = _check_law(law)
    s, c = np.sin(w * t), np.cos(w * t)
    return amp * s, amp * w * c, -amp * w * w * s


def coupled_pose(alpha, beta, dx, dz, H=H0):
    """Platform pose: p = [0,0,H] + [dx,0,dz], p' = R p, R = R(x, alpha) R(y', beta) (paper 004, eq. 3)."""
    R = _rx(alpha) @ _ry(beta)
    p = np.array([dx, 0.0, H + dz])
    return pin.SE3(R, R @ p)


def coupled_twist(x, xd, H=H0):
    """Platform twist V = (omega; v_o) from (alpha, beta, dx, dz) and rates (paper 004, eqs. 4, 6)."""
    return coupled_accel(x, xd, np.zeros(4), H)[0]


def coupled_accel(x, xd, xdd, H=H0):
    """(V, A): twist (omega; v_o) and its derivative (domega; a_o) (paper 004, eqs. 4-6)."""
    out = np.empty((2, 6))
    _coupled_accel(np.asarray(x, float), np.asarray(xd, float), np.asarray(xdd, float), float(H), np.empty((3, 3)),
                   out)
    return out[0].copy(), out[1].copy()


def platform_motion(t, law="high", H=H0):
    """(pin.SE3, V, A) of the platform at time t under the paper's law, screws in the paper's order."""
    x, xd, xdd = motion_law(t, law)
    V, A = coupled_accel(x, xd, xdd, H)
    return coupled_pose(*x, H=H), V, A


def platform_pose(t, law="high", H=H0):
    """World pose of the ``platform`` frame at t (the sidecar's platform.motion function)."""
    return coupled_pose(*motion_law(t, law)[0], H=H)


# ------------------------------------------------------------- convention converters
_REFS = ("WORLD", "LOCAL_WORLD_ALIGNED", "LOCAL")


def _ref(reference):
    name = reference.name if hasattr(reference, "name") else str(reference)
    if name not in _REFS:
        raise InputError(f"reference frame {reference!r} (valid: {', '.join(_REFS)})")
    return name


def twist_to_pin(V, pose=None, reference="WORLD"):
    """Paper twist (omega; v_o) -> pin.Motion in Pinocchio's WORLD, LOCAL_WORLD_ALIGNED or LOCAL
    convention (the last two need the body pose: point p' and rotation)."""
    V = np.asarray(V, float)
    w, vo = V[:3], V[3:]
    ref = _ref(reference)
    if ref == "WORLD":
        return pin.Motion(vo, w)
    vp = vo + _cross(w, pose.translation)
    if ref == "LOCAL_WORLD_ALIGNED":
        return pin.Motion(vp, w)
    Rt = pose.rotation.T
    return pin.Motion(Rt @ vp, Rt @ w)


def twist_from_pin(m, pose=None, reference="WORLD"):
    """Inverse of :func:`twist_to_pin`: pin.Motion -> paper twist (omega; v_o)."""
    ref = _ref(reference)
    v, w = np.array(m.linear), np.array(m.angular)
    if ref == "LOCAL":
        R = pose.rotation
        v, w = R @ v, R @ w
    if ref != "WORLD":
        v = v - _cross(w, pose.translation)
    return np.concatenate([w, v])


def accel_to_pin(A, V=None, pose=None, reference="WORLD", classical=False):
    """Paper acceleration (domega; a_o) -> pin.Motion. Spatial accelerations transform like twists;
    ``classical=True`` (LOCAL_WORLD_ALIGNED only) returns the frame origin's ordinary acceleration
    p'' = a_o + domega x p' + omega x v_p, as pin.getFrameClassicalAcceleration does."""
    m = twist_to_pin(A, pose, reference)
    if classical:
        if _ref(reference) != "LOCAL_WORLD_ALIGNED":
            raise InputError("classical acceleration is defined here for LOCAL_WORLD_ALIGNED only")
        vp = twist_to_pin(V, pose, "LOCAL_WORLD_ALIGNED")
        m = pin.Motion(m.linear + _cross(vp.angular, vp.linear), m.angular)
    return m


def accel_from_pin(m, V=None, pose=None, reference="WORLD", classical=False):
    """Inverse of :func:`accel_to_pin`."""
    if classical:
        if _ref(reference) != "LOCAL_WORLD_ALIGNED":
            raise InputError("classical acceleration is defined here for LOCAL_WORLD_ALIGNED only")
        vp = twist_to_pin(V, pose, "LOCAL_WORLD_ALIGNED")
        m = pin.Motion(np.array(m.linear) - _cross(vp.angular, vp.linear), np.array(m.angular))
    return twist_from_pin(m, pose, reference)


# ------------------------------------------------------------------ inverse kinematics
def limb_kinematics(pose, V=None, A=None, layout="f"):
    """Limb lengths l_i, rates and accelerations (4,) each, for a platform pose, twist and
    acceleration (paper order). Analytic: l = |b - a|, l' = n.b', l'' = n.b'' + (|b'|^2 - l'^2)/l."""
    bl = _check_layout(layout)
    out = np.empty((3, 4))
    zero = np.zeros(6)
    _limb_kinematics(np.ascontiguousarray(pose.rotation), np.ascontiguousarray(pose.translation),
                     zero if V is None else np.asarray(V, float), zero if A is None else np.asarray(A, float),
                     bl, BASE_POINTS, out)
    return out[0], (None if V is None else out[1]), (None if A is None else out[2])


def _limb_lengths_kernel(law="high", layout="f"):
    """(kernel, args): kernel(t, *args, out) writes limb_lengths(t, law, layout) into out (3, 4)
    in compiled code (timelaws.Callable: the drives' compiled path, and the compiled loop)."""
    amp, w = _check_law(law)
    return _limb_lengths_into, (amp, w, H0, _check_layout(layout), BASE_POINTS)


def _limb_lengths_fill(t, out, law="high", layout="f"):
    """limb_lengths(t, law, layout) written into out (3, 4)."""
    kernel, args = _limb_lengths_kernel(law, layout)
    if out.shape != (3, 4):
        raise ValueError(f"limb_lengths fills (3, 4) values, got an array of shape {out.shape}")
    kernel(float(t), *args, out)


def limb_lengths(t, law="high", layout="f"):
    """Lengths of the four UPS limbs and their first two time derivatives from the analytic IK of
    the coupled motion (three arrays). The sidecar's drives take one component each (``index``),
    so the IK runs once per time for all four, the cache in the run's workspace."""
    out = np.empty((3, 4))
    _limb_lengths_fill(t, out, law, layout)
    return out[0], out[1], out[2]


limb_lengths.into = _limb_lengths_fill
limb_lengths.kernel = _limb_lengths_kernel


def limb_law(t, limb, law="high", layout="f"):
    """Drive law of UPS limb ``limb`` (1..4) alone: (l, l', l'')."""
    if limb not in (1, 2, 3, 4):
        raise InputError(f"four_ups_upr.limb_law: limb must be 1..4, got {limb!r}")
    ell, ld, ldd = limb_lengths(t, law, layout)
    k = limb - 1
    return float(ell[k]), float(ld[k]), float(ldd[k])


def pose_to_coordinates(pose, H=H0):
    """(alpha, beta, dx, dz) of a reachable platform pose (inverse of :func:`coupled_pose`)."""
    R = pose.rotation
    # R = Rx(a) Ry(b): R[1,2] = -sin a cos b, R[2,2] = cos a cos b, R[0,2] = sin b
    a = math.atan2(-R[1, 2], R[2, 2])
    b = math.atan2(R[0, 2], math.hypot(R[0, 0], R[0, 1]))
    p = R.T @ pose.translation
    return np.array([a, b, p[0], p[2] - H])


def tree_configuration(model, pose, layout="f"):
    """Analytic IK of every tree joint for a platform pose (positions), q (nq,)."""
    bl = _check_layout(layout)
    R, pp = pose.rotation, pose.translation
    q = pin.neutral(model)

    def put(name, value):
        q[model.joints[model.getJointId(name)].idx_q] = value

    # UPR: Rx(u1) Ry(u2) [0,0,d] = p'  and  Rx(u1) Ry(u2 + r) = R
    d = float(np.linalg.norm(pp))
    n = pp / d
    u2 = math.asin(max(-1.0, min(1.0, n[0])))
    u1 = math.atan2(-n[1], n[2])
    b = pose_to_coordinates(pose)[1]
    put("upr_u1", u1)
    put("upr_u2", u2)
    put("upr_p", d)
    put("upr_r", b - u2)
    bw = pp + bl @ R.T
    for i in range(4):
        dv = bw[i] - BASE_POINTS[i]
        ell = float(np.linalg.norm(dv))
        n = dv / ell
        # direction of Rx(t1) Ry(t2) e3 = (sin t2, -sin t1 cos t2, cos t1 cos t2)
        put(f"ups{i + 1}_u1", math.atan2(-n[1], n[2]))
        put(f"ups{i + 1}_u2", math.asin(max(-1.0, min(1.0, n[0]))))
        put(f"ups{i + 1}_p", ell)
    return q


def tree_configuration_ik(mech, pose, q_prev=None):
    """The sidecar's ``screw: ik:``: :func:`tree_configuration` in the loaded mechanism's hinge
    layout (closed form, so the previous configuration is not needed)."""
    return tree_configuration(mech.model, pose, mech.options.get("layout", SIDECAR_LAYOUT))


def forward_kinematics(lengths, layout="f", guess=None, tol=1e-13, max_iter=50):
    """Forward position analysis: the coordinates (alpha, beta, dx, dz) whose IK limb lengths equal
    ``lengths`` (Newton with a central-difference Jacobian of the analytic IK)."""
    lengths = np.asarray(lengths, float)
    x = np.zeros(4) if guess is None else np.array(guess, float)

    def f(x):
        return limb_kinematics(coupled_pose(*x), layout=layout)[0] - lengths

    h = 1e-7
    for _ in range(max_iter):
        r = f(x)
        if np.max(np.abs(r)) < tol:
            return x
        J = np.empty((4, 4))
        for k in range(4):
            e = np.zeros(4)
            e[k] = h
            J[:, k] = (f(x + e) - f(x - e)) / (2 * h)
        x = x - np.linalg.solve(J, r)
    r = f(x)
    if np.max(np.abs(r)) > 1e-10:
        raise InputError(f"four_ups_upr.forward_kinematics: no convergence (residual {np.max(np.abs(r)):.2e})")
    return x


# ------------------------------------------------------------------------- model files
def _inertial(m, com, I):
    return (f'    <inertial>\n      <origin xyz="{com[0]:.12g} {com[1]:.12g} {com[2]:.12g}" rpy="0 0 0"/>\n'
            f'      <mass value="{m:.12g}"/>\n'
            f'      <inertia ixx="{I[0]:.12g}" ixy="0" ixz="0" iyy="{I[1]:.12g}" iyz="0" izz="{I[2]:.12g}"/>\n'
            "    </inertial>\n")


def _cyl(length, radius, z0):
    return (f'    <visual>\n      <origin xyz="0 0 {z0:.12g}" rpy="0 0 0"/>\n'
            f'      <geometry><cylinder radius="{radius}" length="{length:.12g}"/></geometry>\n    </visual>\n')


def _joint(name, kind, parent, child, xyz=(0, 0, 0), axis=(1, 0, 0), lower=None, upper=None):
    s = f'  <joint name="{name}" type="{kind}">\n    <parent link="{parent}"/>\n    <child link="{child}"/>\n'
    s += f'    <origin xyz="{xyz[0]:.12g} {xyz[1]:.12g} {xyz[2]:.12g}" rpy="0 0 0"/>\n'
    if kind != "fixed":
        s += f'    <axis xyz="{axis[0]} {axis[1]} {axis[2]}"/>\n'
        lo, up = (-math.pi, math.pi) if lower is None else (lower, upper)
        s += f'    <limit lower="{lo:.12g}" upper="{up:.12g}" effort="1e5" velocity="100"/>\n'
    return s + "  </joint>\n"


def urdf_text(layout="f"):
    """URDF of the spanning tree (see the module docstring)."""
    bl = _check_layout(layout)
    out = ['<?xml version="1.0"?>\n',
           "<!-- generated by pinclear.mechanisms.four_ups_upr.write_urdf: do not edit -->\n",
           '<robot name="four_ups_upr">\n', '  <link name="world"/>\n']
    X, Y, Z = (1, 0, 0), (0, 1, 0), (0, 0, 1)
    # constraint limb UPR
    out.append('  <link name="upr_cross"/>\n')
    out.append('  <link name="upr_swing">\n' + _inertial(M_UPR_SWING, (0, 0, L_UPR_SWING / 2), I_UPR_SWING)
               + _cyl(L_UPR_SWING, 0.03, L_UPR_SWING / 2) + "  </link>\n")
    out.append('  <link name="upr_rod">\n' + _inertial(M_UPR_ROD, (0, 0, -L_UPR_ROD / 2), I_UPR_ROD)
               + _cyl(L_UPR_ROD, 0.02, -L_UPR_ROD / 2) + "  </link>\n")
    out.append('  <link name="platform">\n' + _inertial(M_PLATFORM, (0, 0, 0), I_PLATFORM)
               + '    <visual>\n      <origin xyz="0 0 0" rpy="0 0 0"/>\n'
               '      <geometry><box size="0.5 0.5 0.03"/></geometry>\n    </visual>\n  </link>\n')
    out.append(_joint("upr_u1", "revolute", "world", "upr_cross", axis=X))
    out.append(_joint("upr_u2", "revolute", "upr_cross", "upr_swing", axis=Y))
    out.append(_joint("upr_p", "prismatic", "upr_swing", "upr_rod", axis=Z, lower=0.05, upper=1.2))
    out.append(_joint("upr_r", "revolute", "upr_rod", "platform", axis=Y))
    for i in range(4):
        k = i + 1
        out.append(f'  <link name="platform_b{k}"/>\n')
        out.append(_joint(f"platform_b{k}_joint", "fixed", "platform", f"platform_b{k}", xyz=bl[i]))
    for i in range(4):
        k = i + 1
        out.append(f'  <link name="ups{k}_cross"/>\n')
        out.append(f'  <link name="ups{k}_swing">\n' + _inertial(M_UPS_SWING, (0, 0, L_UPS_SWING / 2), I_UPS_SWING)
                   + _cyl(L_UPS_SWING, 0.03, L_UPS_SWING / 2) + "  </link>\n")
        out.append(f'  <link name="ups{k}_rod">\n' + _inertial(M_UPS_ROD, (0, 0, -L_UPS_ROD / 2), I_UPS_ROD)
                   + _cyl(L_UPS_ROD, 0.02, -L_UPS_ROD / 2) + "  </link>\n")
        out.append(_joint(f"ups{k}_u1", "revolute", "world", f"ups{k}_cross", xyz=BASE_POINTS[i], axis=X))
        out.append(_joint(f"ups{k}_u2", "revolute", f"ups{k}_cross", f"ups{k}_swing", axis=Y))
        out.append(_joint(f"ups{k}_p", "prismatic", f"ups{k}_swing", f"ups{k}_rod", axis=Z, lower=0.1, upper=1.2))
    out.append("</robot>\n")
    return "".join(out)


def write_urdf(path):
    """Write the URDF (layout f; other layouts are applied by :func:`apply_options`)."""
    Path(path).write_text(urdf_text("f"))
    return Path(path)


#: fraction of the limb inertia kept when ``limbs: false``
LIMB_RESIDUE = 1e-5


def apply_options(model, options):
    """Hook body: ``layout`` moves the platform hinge frames, ``limbs: false`` removes the limb
    inertia.

    Removing it exactly would leave the KKT matrix regular (every closed-chain freedom moves the
    platform, so M is positive definite on ker J) but M itself singular, and the Schur-complement
    formulations factor M. The limb inertias are therefore scaled by :data:`LIMB_RESIDUE` (1e-5):
    M stays positive definite and the drive forces differ from the platform-only ones by about
    1e-5 x (limb share of the force, ~20 %), i.e. ~2e-6 relative. Smaller residues cost accuracy
    elsewhere: the Schur complement's round-off grows as 1/residue (open-loop tracking error over
    1 s of the high law: 1.3e-7 rad at 1e-5, 9e-7 at 1e-6; at 1e-8 the integrator stalls).
    :func:`pinclear.dynamics.screw.inverse_dynamics` with ``limbs=False``
    removes the limbs exactly."""
    options = dict(options or {})
    if "layout" in options:
        _move_hinges(model, options["layout"])
    limbs = options.get("limbs", True)
    if isinstance(limbs, str):
        limbs = limbs.lower() in ("true", "on", "yes", "1")
    if not limbs:
        for j in LIMB_BODY_JOINTS:
            Y = model.inertias[model.getJointId(j)]
            model.inertias[model.getJointId(j)] = pin.Inertia(LIMB_RESIDUE * Y.mass, Y.lever,
                                                              LIMB_RESIDUE * Y.inertia)
    return None


def _move_hinges(model, layout):
    bl = _check_layout(layout)
    for k in range(4):
        name = f"platform_b{k + 1}"
        for fname in (name, f"{name}_joint"):
            if model.existFrame(fname):
                f = model.frames[model.getFrameId(fname)]
                f.placement = pin.SE3(np.eye(3), bl[k].copy())
                model.frames[model.getFrameId(fname)] = f


#: law and layout the generated sidecar's drive laws are written for
SIDECAR_LAW, SIDECAR_LAYOUT = "high", "f"


def sidecar_hook(model, options):
    """The sidecar's hook: ``layout`` moves the platform hinges, ``limbs`` sets the limb inertia.
    The drive laws and platform motion follow ``law``/``layout`` through the sidecar's "$law" and
    "$layout" arguments (substituted by pinclear.load)."""
    options = dict(options or {})
    _check_law(options.get("law", SIDECAR_LAW))
    apply_options(model, {"layout": options.get("layout", SIDECAR_LAYOUT), "limbs": options.get("limbs", True)})


def build_model(layout="f", limbs=True, gravity=True):
    """The Pinocchio model straight from the generated URDF text (no sidecar)."""
    model = pin.buildModelFromXML(urdf_text("f"))
    apply_options(model, {"layout": layout, "limbs": limbs})
    if not gravity:
        model.gravity = pin.Motion.Zero()
    return model


def sidecar_dict(law="high"):
    """The sidecar mapping (see docs/design.md) written by :func:`write_sidecar`."""
    model = build_model()
    q0 = tree_configuration(model, coupled_pose(0.0, 0.0, 0.0, 0.0))
    init = {model.names[j]: round(float(q0[model.joints[j].idx_q]), 12) for j in range(1, model.njoints)}
    fn = "pinclear.mechanisms.four_ups_upr"
    return {
        "name": "four_ups_upr",
        "urdf": "four_ups_upr.urdf",
        "description": "4-UPS/UPR vehicle motion simulator (paper 004): UPR constraint limb carries the "
                       "platform, four UPS limbs closed by spherical joints, driven by their prismatic joints",
        "gravity": [0.0, 0.0, -9.81],
        "initial": {"q": init},
        "closures": [{"name": f"S{k}", "type": "spherical", "frame1": f"ups{k}_rod", "frame2": f"platform_b{k}"}
                     for k in range(1, 5)],
        "drives": [{"name": f"P{k}", "joint": f"ups{k}_p",
                    "law": {"type": "python", "function": f"{fn}:limb_lengths",
                            "args": {"law": "$law", "layout": "$layout"}, "index": k - 1}} for k in range(1, 5)],
        "platform": {"frame": "platform", "motion": {"function": f"{fn}:platform_pose", "args": {"law": "$law"}}},
        "options": {k: dict(v) for k, v in OPTIONS.items()},
        "hook": f"{fn}:sidecar_hook",
        "screw": screw_section(),
        "nonphysical_inertia": {"upr_r": "paper 004, sec. 4 prints the platform inertia (1.41, 4.41, 2.82) kg m^2, "
                                "which breaks the triangle inequality (1.41 + 2.82 < 4.41); kept as printed to "
                                "reproduce the paper's drive forces"},
        "parameters": parameters(),
    }


def screw_section():
    """The sidecar's ``screw:`` section (format in :mod:`pinclear.dynamics.screw`): the five limbs, the
    UPR limb completed by paper 004's virtual joints (sec. 2.1: the ``line_normal`` rule), the
    analytic IK, and the two motion laws with their periods."""
    fn = "pinclear.mechanisms.four_ups_upr"
    return {
        "limbs": [{"name": f"UPS{k}", "joints": UPS_JOINTS[k - 1], "closure": f"S{k}"} for k in range(1, 5)]
        + [{"name": "UPR", "joints": UPR_JOINTS, "closure": None}],
        "virtual": {"UPR": "line_normal"},
        "ik": f"{fn}:tree_configuration_ik",
        "motions": {law: {"function": f"{fn}:platform_motion", "args": {"law": law}, "period": PERIODS[law]}
                    for law in LAWS},
    }


def write_sidecar(path, law="high"):
    """Write the YAML sidecar (the generated URDF's companion)."""
    import yaml

    text = ("# generated by pinclear.mechanisms.four_ups_upr.write_sidecar: edit the generator, not this file.\n"
            "# The drive laws and platform motion use the 'law' named below; pinclear.mechanisms.four_ups_upr.load()\n"
            "# switches law/limbs/layout together (the sidecar's law args are static).\n")
    text += yaml.safe_dump(sidecar_dict(law), sort_keys=False, default_flow_style=None, width=110)
    Path(path).write_text(text)
    return Path(path)


def load(path=None, law=None, limbs=None, layout=None, **kw):
    """pinclear.load of the sidecar with the scene options set (law, limbs, layout), assembled from
    the configuration of the chosen layout."""
    from pinclear.io import sidecar as _sidecar

    path = Path(path) if path else URDF_DIR / "four_ups_upr.yaml"
    options = dict(kw.pop("options", None) or {})
    for k, v in (("law", law), ("limbs", limbs), ("layout", layout)):
        if v is not None:
            options[k] = v
    _check_law(options.get("law", SIDECAR_LAW))
    layout_ = options.get("layout", SIDECAR_LAYOUT)
    _check_layout(layout_)
    mech = _sidecar.load(path, options=options, **kw)
    return mech.replace(q0=tree_configuration(mech.model, coupled_pose(0.0, 0.0, 0.0, 0.0), layout_))