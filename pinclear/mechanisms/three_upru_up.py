"""3-UPRU+UP optical polishing robot of paper 003 (Zhu et al. 2025), ideal joints.

Spanning tree
    Limb 1 (U - P - R - U) carries the moving platform. Limbs 2 and 3 are U - P - R branches
    closed at the platform by ``universal`` closures U6, U7. The central UP branch is a base
    U joint carrying the guide rail; the platform's slider is closed to it by the
    ``prismatic`` closure ``P_UP`` (the joint paper 003 gives a clearance). The actuated
    prismatic joints are tree joints whose coordinate is the limb length |U_i U_{i+4}|.

Joint axes (reconstructed; the paper's figures are lost)
    base U_i: first axis tangent to the r_s circle (fixed in the base), second radial;
    R: along the limb (the rotating rod c_i spins about the telescopic rod's axis);
    platform U_{i+4}: first axis radial (fixed in c_i), second tangent (fixed in the platform).
    The R axis passes through U_{i+4}, so R and the platform U are three concurrent axes:
    each UPRU limb is kinematically a UPS limb (6 independent screws, no constraint, no idle
    freedom). The UP branch alone leaves the platform 3 freedoms (two tilts about the base
    centre and the slide along the branch), so the mobility is 3 and the three drives fix it.
    Along the circle law the Jacobian of closures + drives stays well conditioned (tests).

Frames: world z up, base plane z = 0, x from S0 to U3, y parallel to U1 -> U2 (paper 003,
sec. 2); the moving platform frame is at M0 with x0 toward U7, y0 parallel to U5 -> U6.
"""
from __future__ import annotations

import math
from functools import lru_cache
from pathlib import Path

import numpy as np
import pinocchio as pin

from pinclear.core.jit import njit
from pinclear.io.urdf_write import urdf_joint, urdf_link
from pinclear.mechanisms._common import (
    ALUMINIUM,
    STEEL,
    URDF_DIR,
    ClosedChain,
    config_vector,
    cross_inertia,
    solve_lengths,
    u_angles,
    write_sidecar_yaml,
)

G = 9.81
# ------------------------------------------------------------------ paper 003, Table 2
M_M, J_M = 138.239, (35.509, 35.478, 1.452)      # platform + UP branch
R_S, R_M = 0.4, 0.15                              # U joint circles, base / platform
L_A, M_A, J_A = 0.6, 70.8, (14.264, 14.598, 0.203)
L_B, M_B, J_B = 1.2, 29.85, (5.94, 5.94, 0.02)
L_C, M_C, J_C = 0.09, 1.3, (0.004, 0.004, 0.004)
M_LOAD = 118.5
# ------------------------------------------------------------------ motion law (paper 003, sec. 4)
RADIUS, SPEED = 0.2, 0.05
# reconstructed: centre 0.1 m off the branch axis so that the UP slider really slides
# (|p| varies by ~26 mm per turn); height puts every limb near mid-stroke.
XC, YC, Z0, THETA0 = 0.1, 0.0, 1.5, 0.0
OMEGA = SPEED / RADIUS
PERIOD = 2 * math.pi / OMEGA

# ------------------------------------------------------------------ reconstructed parts
GUIDE_LEN, GUIDE_W, GUIDE_H, GUIDE_WALL, GUIDE_Z0 = 0.40, 0.10, 0.08, 0.010, 0.10   # aluminium
SLIDER_A, SLIDER_B = GUIDE_W - 2 * GUIDE_WALL, GUIDE_H - 2 * GUIDE_WALL   # slider section = guide bore
PIN_D, PIN_L = 0.030, 0.100                                                # U-joint crosses, steel

# limb i joins U_i (base) to U_{i+4} (platform); angles of the joints on their circles
ANGLES = {1: math.radians(240.0), 2: math.radians(120.0), 3: 0.0}
LIMBS = (1, 2, 3)
SIDECAR_NAME = "three_upru_up"


# ================================================================== geometry
def radial(i):
    th = ANGLES[i]
    return np.array([math.cos(th), math.sin(th), 0.0])


def tangent(i):
    th = ANGLES[i]
    return np.array([-math.sin(th), math.cos(th), 0.0])


def base_point(i):
    return R_S * radial(i)


def platform_point(i):
    return R_M * radial(i)


def limb_frame(i):
    """Columns (radial, tangent, z): the paper's limb-local axes (x radial, z along the limb)."""
    return np.column_stack([radial(i), tangent(i), [0.0, 0.0, 1.0]])


# ================================================================== mass properties
def box_tube_inertia(rho, length, w, h, wall):
    """Rectangular hollow section along local z: mass and central inertia."""
    def solid(a, b):
        m = rho * a * b * length
        return m, np.diag([m * (b * b + length**2) / 12, m * (a * a + length**2) / 12, m * (a * a + b * b) / 12])
    mo, Io = solid(w, h)
    mi, Ii = solid(w - 2 * wall, h - 2 * wall)
    return mo - mi, Io - Ii


def body_inertias():
    """Mass, centre of mass (body frame) and central inertia of each body. Table 2 values where
    the paper gives them (central inertias in the limb-local axes: z along the limb, x radial);
    the guide rail and the U-joint crosses from reconstructed dimensions and densities.

    Body frames (world-aligned in the zero configuration, limbs along z): cylinder a_i at U_i;
    rod b_i at U_{i+4} (tip of the limb); rotating rod c_i at the R joint; platform at M0.
    """
    out = {}
    for i in LIMBS:
        F = limb_frame(i)
        out[f"cyl{i}"] = (M_A, np.array([0, 0, L_A / 2]), F @ np.diag(J_A) @ F.T)
        out[f"rod{i}"] = (M_B, np.array([0, 0, -L_C - L_B / 2]), F @ np.diag(J_B) @ F.T)
        out[f"rot{i}"] = (M_C, np.array([0, 0, L_C / 2]), F @ np.diag(J_C) @ F.T)
        m, I = cross_inertia(tangent(i), radial(i), STEEL, PIN_D, PIN_L)
        out[f"cross{i}_base"] = (m, np.zeros(3), I)
    m, I = cross_inertia(radial(1), tangent(1), STEEL, PIN_D, PIN_L)
    out["cross1_top"] = (m, np.zeros(3), I)
    m, I = cross_inertia(np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), STEEL, PIN_D, PIN_L)
    out["up_cross"] = (m, np.zeros(3), I)
    m, I = box_tube_inertia(ALUMINIUM, GUIDE_LEN, GUIDE_W, GUIDE_H, GUIDE_WALL)
    out["guide_rail"] = (m, np.array([0, 0, GUIDE_Z0 + GUIDE_LEN / 2]), I)
    # the moving platform link's frame is at U5 (end of limb 1); its centre of mass is M0
    out["moving_platform"] = (M_M, -platform_point(1), np.diag(J_M))
    out["external_load"] = (M_LOAD, np.zeros(3), np.zeros((3, 3)))
    return out


def parameters():
    b = body_inertias()
    P = [
        ("m_m", M_M, "kg", "paper 003, Table 2"),
        ("J_m", list(J_M), "kg m^2", "paper 003, Table 2"),
        ("r_s", R_S, "m", "paper 003, Table 2"),
        ("r_m", R_M, "m", "paper 003, Table 2"),
        ("L_a", L_A, "m", "paper 003, Table 2"),
        ("m_a", M_A, "kg", "paper 003, Table 2"),
        ("J_a", list(J_A), "kg m^2", "paper 003, Table 2 (axes: x radial, z along the limb: reconstructed)"),
        ("L_b", L_B, "m", "paper 003, Table 2"),
        ("m_b", M_B, "kg", "paper 003, Table 2"),
        ("J_b", list(J_B), "kg m^2", "paper 003, Table 2 (printed as J_c: typo)"),
        ("L_c", L_C, "m", "paper 003, Table 2"),
        ("m_c", M_C, "kg", "paper 003, Table 2"),
        ("J_c", list(J_C), "kg m^2", "paper 003, Table 2"),
        ("external_load", M_LOAD, "kg",
         "paper 003, Table 2; location reconstructed: point mass at the platform centre M0"),
        ("circle_radius", RADIUS, "m", "paper 003, sec. 4"),
        ("speed", SPEED, "m/s", "paper 003, sec. 4"),
        ("circle_centre", [XC, YC, Z0], "m",
         "reconstructed: 0.1 m off the UP axis so the slider slides; Z0 puts limbs near mid-stroke"),
        ("theta0", THETA0, "rad", "reconstructed: start on the +x side of the circle"),
        ("joint_angles", "U1/U5 240, U2/U6 120, U3/U7 0", "deg",
         "paper 003, sec. 2 (x along S0U3, y along U1U2; x0 along M0U7, y0 along U5U6)"),
        ("R_axis", "along the limb", "-",
         "reconstructed: rotating rod spins about the telescopic rod, R + U = spherical (non-singular)"),
        ("com_positions", "mid-length of each rod; platform at M0", "-",
         "reconstructed: paper puts body frames at the centres of mass, assumed geometric centres"),
        ("guide_rail", f"{GUIDE_LEN} x {GUIDE_W} x {GUIDE_H}, wall {GUIDE_WALL}, from {GUIDE_Z0} m", "m",
         "reconstructed: aluminium box section on the UP U joint; paper lumps it into m_m"),
        ("slider_section", [SLIDER_A, SLIDER_B], "m",
         "reconstructed: slider fills the guide bore (clearance added by the clearance model)"),
        ("m_guide_rail", b["guide_rail"][0], "kg", "reconstructed: derived by body_inertias() from the section"),
        ("u_cross_pins", f"D {PIN_D} x {PIN_L}", "m", "reconstructed: two crossed steel pins per U joint"),
        ("m_u_cross", b["up_cross"][0], "kg", "reconstructed: derived by body_inertias() from the pins"),
        ("rho_steel", STEEL, "kg/m^3", "reconstructed: structural steel"),
        ("rho_aluminium", ALUMINIUM, "kg/m^3", "reconstructed: aluminium alloy"),
    ]
    out = []
    for name, value, unit, source in P:
        if isinstance(value, (float, np.floating)):
            value = float(round(value, 6))
        out.append({"name": name, "value": value, "unit": unit, "source": source})
    return out


# ================================================================== exact derivatives
# A "jet" is (f, f', f'') along time; the products and quotients below are the Leibniz
# rules, so the drive laws get exact first and second derivatives. Compiled (numba): the drives
# evaluate the inverse kinematics at every right-hand side of a run. Jets hold floats (scalar
# jets) or 3-vectors as float triples (vector jets): tuples, not arrays, so an evaluation
# allocates nothing (with arrays the drive law cost 2.3 us of 3-UPRU+UP's 27 us evaluation).
@njit(cache=True)
def _mul(a, b):
    return (a[0] * b[0], a[1] * b[0] + a[0] * b[1], a[2] * b[0] + 2 * a[1] * b[1] + a[0] * b[2])


@njit(cache=True)
def _inv(b):
    r = 1.0 / b[0]
    return (r, -b[1] * r * r, -b[2] * r * r + 2 * b[1] ** 2 * r**3)


@njit(cache=True)
def _sqrt(a):
    s = np.sqrt(a[0])
    return (s, a[1] / (2 * s), a[2] / (2 * s) - a[1] ** 2 / (4 * s**3))


@njit(cache=True)
def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


@njit(cache=True)
def _scale(a, k):
    return (a[0] * k, a[1] * k, a[2] * k)


@njit(cache=True)
def _comp(v, k):
    return (v[0][k], v[1][k], v[2][k])


@njit(cache=True)
def _dot(u, w):
    return _add(_add(_mul(_comp(u, 0), _comp(w, 0)), _mul(_comp(u, 1), _comp(w, 1))), _mul(_comp(u, 2), _comp(w, 2)))


@njit(cache=True)
def _vec(x, y, z):
    return ((x[0], y[0], z[0]), (x[1], y[1], z[1]), (x[2], y[2], z[2]))


@njit(cache=True)
def _vadd(u, w):
    """sum of vector jets (_add and _scale act on a float triple as on a scalar jet)"""
    return (_add(u[0], w[0]), _add(u[1], w[1]), _add(u[2], w[2]))


@njit(cache=True)
def _vmul(u, k):
    """vector jet times a constant"""
    return (_scale(u[0], k), _scale(u[1], k), _scale(u[2], k))


@njit(cache=True)
def _cross_c(u, w, i, j):
    return _add(_mul(_comp(u, i), _comp(w, j)), _scale(_mul(_comp(u, j), _comp(w, i)), -1.0))


@njit(cache=True)
def _cross(u, w):
    return _vec(_cross_c(u, w, 1, 2), _cross_c(u, w, 2, 0), _cross_c(u, w, 0, 1))


@njit(cache=True)
def _vscale(v, s):
    """vector jet times scalar jet"""
    return (_scale(v[0], s[0]), _add(_scale(v[1], s[0]), _scale(v[0], s[1])),
            _add(_add(_scale(v[2], s[0]), _scale(v[1], 2 * s[1])), _scale(v[0], s[2])))


@njit(cache=True)
def _circle(t, xc, yc, z0, radius, th0, w):
    ph = th0 + w * t
    c, s = math.cos(ph), math.sin(ph)
    return ((xc + radius * c, yc + radius * s, z0),
            (-radius * w * s, radius * w * c, 0.0),
            (-radius * w * w * c, -radius * w * w * s, 0.0))


def platform_position(t):
    """Platform centre on the circle (paper 003, sec. 4): position, velocity, acceleration."""
    return tuple(np.array(x) for x in _circle(float(t), XC, YC, Z0, RADIUS, THETA0, OMEGA))


@njit(cache=True)
def _pose_jet_of(p):
    """Jets of the platform rotation columns from the position jet p. The UP branch fixes the
    orientation from the position: R = Rx(a) Ry(b) with R e_z = p/|p| (base U axes x, then y)."""
    s = _sqrt(_dot(p, p))
    n = _vscale(p, _inv(s))
    ny, nz = _comp(n, 1), _comp(n, 2)
    cb_inv = _inv(_sqrt(_add(_mul(ny, ny), _mul(nz, nz))))
    zero = (0.0, 0.0, 0.0)
    c2 = _vec(zero, _mul(nz, cb_inv), _scale(_mul(ny, cb_inv), -1.0))
    c1 = _cross(c2, n)
    return (c1, c2, n), s


def _pose_jet(t):
    cols, s = _pose_jet_of(_circle(float(t), XC, YC, Z0, RADIUS, THETA0, OMEGA))
    return platform_position(t), tuple(tuple(np.array(x) for x in c) for c in cols), s


def platform_pose(t):
    """World pose of frame ``platform`` (M0) at time t."""
    p, cols, _ = _pose_jet(t)
    return pin.SE3(np.column_stack([c[0] for c in cols]), p[0].copy())


# platform joint points in the platform's (c1, c2) axes (they lie in its plane, z = 0)
_PLATFORM_XY = np.array([platform_point(i)[:2] for i in LIMBS])
_BASE = np.array([base_point(i) for i in LIMBS])


def limb_lengths(t):
    """Exact lengths |U_i U_{i+4}| of limbs 1..3 and their first two time derivatives."""
    return _limb_lengths(_circle(float(t), XC, YC, Z0, RADIUS, THETA0, OMEGA), _PLATFORM_XY, _BASE)


@njit(cache=True)
def _limb_lengths(p, plat_xy, base):
    out = np.empty((3, plat_xy.shape[0]))
    _limb_lengths_into(p, plat_xy, base, out)
    return out[0], out[1], out[2]


@njit(cache=True)
def _limb_lengths_into(p, plat_xy, base, out):
    cols, _ = _pose_jet_of(p)
    c1, c2 = cols[0], cols[1]
    for k in range(plat_xy.shape[0]):
        B = _vadd(_vadd(p, _vmul(c1, plat_xy[k, 0])), _vmul(c2, plat_xy[k, 1]))
        d = ((B[0][0] - base[k, 0], B[0][1] - base[k, 1], B[0][2] - base[k, 2]), B[1], B[2])
        L = _sqrt(_dot(d, d))
        out[0, k], out[1, k], out[2, k] = L[0], L[1], L[2]


@njit(cache=True)
def _limb_lengths_at(t, xc, yc, z0, radius, th0, w, plat_xy, base, out):
    # the circle and the lengths in one compiled call: this runs at every new time of a run
    _limb_lengths_into(_circle(t, xc, yc, z0, radius, th0, w), plat_xy, base, out)


def _limb_lengths_kernel():
    """(kernel, args): kernel(t, *args, out) writes limb_lengths(t) into out (3, 3) in compiled
    code (timelaws.Callable: the drives' compiled path, and the compiled integration loop)."""
    return _limb_lengths_at, (XC, YC, Z0, RADIUS, THETA0, OMEGA, _PLATFORM_XY, _BASE)


def _limb_lengths_fill(t, out):
    """limb_lengths(t) written into out (3, 3)."""
    if out.shape != (3, _BASE.shape[0]):
        raise ValueError(f"limb_lengths fills (3, {_BASE.shape[0]}) values, got an array of shape {out.shape}")
    kernel, args = _limb_lengths_kernel()
    kernel(float(t), *args, out)


limb_lengths.into = _limb_lengths_fill
limb_lengths.kernel = _limb_lengths_kernel


def limb_law(t, limb):
    """Drive law of limb ``limb`` alone: (L, dL/dt, d2L/dt2). The sidecar's drives use
    limb_lengths with ``index`` instead, so one inverse kinematics serves all limbs per time."""
    L, Ld, Ldd = limb_lengths(t)
    k = int(limb) - 1
    return float(L[k]), float(Ld[k]), float(Ldd[k])


def ik_configuration(t):
    """Exact tree configuration (dict joint -> value) of the ideal mechanism at time t."""
    from scipy.spatial.transform import Rotation
    M = platform_pose(t)
    R, p = M.rotation, M.translation
    out = {"UP_1": math.atan2(R[2, 1], R[1, 1]), "UP_2": math.atan2(R[0, 2], R[0, 0])}
    z = np.array([0.0, 0, 1])
    for i in LIMBS:
        d = p + R @ platform_point(i) - base_point(i)
        L = float(np.linalg.norm(d))
        a, b = u_angles(d / L, tangent(i), radial(i), z)
        out[f"U{i}_1"], out[f"U{i}_2"], out[f"P{i}"] = a, b, L
        Rab = pin.AngleAxis(a, tangent(i)).matrix() @ pin.AngleAxis(b, radial(i)).matrix()
        F = limb_frame(i)
        # Rz(phi) Rx(psi1) Ry(psi2) in the (radial, tangent, z) basis = the R + U chain
        phi, psi1, psi2 = Rotation.from_matrix(F.T @ Rab.T @ R @ F).as_euler("ZXY")
        out[f"R{i}"] = phi
        if i == 1:
            out["U1_3"], out["U1_4"] = psi1, psi2
    return out


# ================================================================== URDF
ANGLE_LIMITS = (-math.pi, math.pi)
STROKE = (L_B + L_C + 0.05, L_A + L_B + L_C - 0.05)   # rod end stays inside the 0.6 m cylinder


def _frame_rpy(z_axis, i):
    """rpy of a frame whose z axis is radial(i) or tangent(i) (right-handed with the others)."""
    r, t, z = radial(i), tangent(i), np.array([0.0, 0, 1])
    cols = {"radial": (t, z, r), "tangent": (z, r, t)}[z_axis]
    return pin.rpy.matrixToRpy(np.column_stack(cols))


def urdf_text():
    bodies = body_inertias()
    zdir = np.array([0.0, 0, 1])
    s = '<?xml version="1.0"?>\n<!-- generated by pinclear.mechanisms.three_upru_up.write_urdf: do not edit -->\n'
    s += '<robot name="three_upru_up">\n' + urdf_link("world")
    for i in LIMBS:
        cr, a, b, c = f"cross{i}_base", f"cyl{i}", f"rod{i}", f"rot{i}"
        s += "".join(urdf_link(n, bodies[n]) for n in (cr, a, b, c))
        s += urdf_joint(f"U{i}_1", "revolute", "world", cr, base_point(i), tangent(i), ANGLE_LIMITS)
        s += urdf_joint(f"U{i}_2", "revolute", cr, a, (0, 0, 0), radial(i), ANGLE_LIMITS)
        s += urdf_joint(f"P{i}", "prismatic", a, b, (0, 0, 0), zdir, STROKE)
        s += urdf_joint(f"R{i}", "revolute", b, c, (0, 0, -L_C), zdir, ANGLE_LIMITS)
        if i != 1:
            # U_{i+4}: first axis (radial) on the rotating rod, second (tangent) on the platform
            s += urdf_link(f"U{i + 4}_rod")
            s += urdf_joint(f"U{i + 4}_rod_joint", "fixed", c, f"U{i + 4}_rod", (0, 0, L_C), rpy=_frame_rpy("radial", i))
    s += urdf_link("cross1_top", bodies["cross1_top"]) + urdf_link("moving_platform", bodies["moving_platform"])
    s += urdf_joint("U1_3", "revolute", "rot1", "cross1_top", (0, 0, L_C), radial(1), ANGLE_LIMITS)
    s += urdf_joint("U1_4", "revolute", "cross1_top", "moving_platform", (0, 0, 0), tangent(1), ANGLE_LIMITS)
    # the platform body's frame is at U5; M0 and the joints on the platform are fixed frames
    s += urdf_link("platform")
    s += urdf_joint("platform_M0", "fixed", "moving_platform", "platform", -platform_point(1))
    s += urdf_link("external_load", bodies["external_load"])
    s += urdf_joint("external_load_joint", "fixed", "platform", "external_load")
    for i in (2, 3):
        s += urdf_link(f"U{i + 4}_platform")
        s += urdf_joint(f"U{i + 4}_platform_joint", "fixed", "platform", f"U{i + 4}_platform",
                        platform_point(i), rpy=_frame_rpy("tangent", i))
    # central UP branch: base U (x then y) carrying the guide rail
    s += urdf_link("up_cross", bodies["up_cross"]) + urdf_link("guide_rail", bodies["guide_rail"])
    s += urdf_joint("UP_1", "revolute", "world", "up_cross", (0, 0, 0), (1, 0, 0), ANGLE_LIMITS)
    s += urdf_joint("UP_2", "revolute", "up_cross", "guide_rail", (0, 0, 0), (0, 1, 0), ANGLE_LIMITS)
    zg = GUIDE_Z0 + GUIDE_LEN / 2
    s += urdf_link("guide_centre") + urdf_joint("guide_centre_joint", "fixed", "guide_rail", "guide_centre", (0, 0, zg))
    # slider frame on the platform: on the branch axis, at the guide centre at t = 0
    s += urdf_link("slider_centre")
    s += urdf_joint("slider_centre_joint", "fixed", "platform", "slider_centre", (0, 0, zg - slide_length(0.0)))
    return s + "</robot>\n"


def slide_length(t):
    """Distance from the base centre to M0 along the UP branch."""
    return float(np.linalg.norm(platform_position(t)[0]))


def write_urdf(path):
    Path(path).write_text(urdf_text())


# ================================================================== sidecar
CLOSURES = ([{"name": f"U{i + 4}", "type": "universal", "frame1": f"U{i + 4}_rod", "frame2": f"U{i + 4}_platform"}
             for i in (2, 3)]
            + [{"name": "P_UP", "type": "prismatic", "frame1": "guide_centre", "frame2": "slider_centre"}])
DRIVES = [f"drive{i}" for i in LIMBS]


def sidecar_dict():
    q0 = ik_configuration(0.0)
    return {
        "name": SIDECAR_NAME,
        "urdf": f"{SIDECAR_NAME}.urdf",
        "description": "3-UPRU+UP polishing robot (paper 003), ideal joints, 3 prismatic drives, circle law",
        "gravity": [0.0, 0.0, -G],
        # paper 003, eq. 20 and Table 3: alpha_b = 5, beta_b = 1
        "baumgarte": {"alpha": 5.0, "beta": 1.0},
        "initial": {"q": {k: float(round(v, 12)) + 0.0 for k, v in q0.items()}},   # + 0.0: no -0.0
        "closures": CLOSURES,
        "drives": [{"name": f"drive{i}", "joint": f"P{i}",
                    "law": {"type": "python", "function": "pinclear.mechanisms.three_upru_up:limb_lengths",
                            "index": k}} for k, i in enumerate(LIMBS)],
        "platform": {"frame": "platform",
                     "motion": {"function": "pinclear.mechanisms.three_upru_up:platform_pose", "args": {}}},
        "nonphysical_inertia": {f"U{i}_2": "paper 003, Table 2 prints J_a = (14.264, 14.598, 0.203) kg m^2, which "
                                "breaks the triangle inequality (0.203 + 14.264 < 14.598); kept as printed to "
                                "reproduce the paper" for i in LIMBS},
        "parameters": parameters(),
    }


def write_sidecar(path):
    """Write the sidecar; a ``clearances:`` block already in the file is kept."""
    write_sidecar_yaml(path, sidecar_dict(),
                       "# 3-UPRU+UP of paper 003. Generated by pinclear.mechanisms.three_upru_up.write_sidecar.\n"
                       "# World z up, base plane z = 0; the platform moves on a circle of r = 0.2 m at 0.05 m/s.\n")


def default_urdf_path():
    return URDF_DIR / f"{SIDECAR_NAME}.urdf"


@lru_cache(maxsize=4)
def _model(path=None):
    return pin.buildModelFromUrdf(str(path or default_urdf_path()))


def chain(model=None):
    model = model or _model()
    return ClosedChain(model, CLOSURES, [f"P{i}" for i in LIMBS])


def forward_kinematics(lengths, guess=None, model=None):
    """Forward position analysis: the closed-chain configuration with limb lengths
    ``lengths`` (limbs 1..3), by Newton from ``guess`` (default: the IK pose at t = 0).
    Returns (q, pose of frame ``platform``)."""
    model = model or _model()
    q0 = config_vector(model, ik_configuration(0.0)) if guess is None else guess
    return solve_lengths(model, CLOSURES, [f"P{i}" for i in LIMBS], lengths, q0)