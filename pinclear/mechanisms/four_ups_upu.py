"""4UPS-UPU spatial parallel mechanism of paper 000 (Chen & Cui 2021), ideal joints.

Spanning tree
    The UPU limb (limb 1: U - P - U, five 1-DoF joints) carries the moving platform.
    The four UPS limbs (2..5) are U - P branches from the ground; each is closed at the
    platform by a ``spherical`` closure S2..S5 (S2 is the one paper 000 gives a clearance).
    Every actuated prismatic joint is a tree joint whose coordinate IS the limb length
    (distance from the base U centre to the platform-side joint centre).

U joints
    A U joint is two revolute joints; URDF needs a link between them. That link is the
    physical cross-piece (spider) of the joint, with the mass and inertia of two crossed steel
    pins (``cross_inertia``) -- small but positive, so no body of the tree is massless.

Frames and axes (paper 000, sec. 3.1): world X is normal to the fixed platform, the
fixed platform is the plane X = 0, the moving platform is parallel to it at X ~ 1.1 m.
Gravity is along +X: paper 000 (sec. 3.1) puts every rod's local x axis "downward along the
rod", and the rods run from the fixed platform (X = 0) to the moving one (X ~ 1.1 m), so the
fixed platform is on top and the moving platform hangs below it. The paper's S2 force band
(sec. 4.2, Figs. 5-7: min/max 0.71-0.84) agrees with this reading (+X: 0.83) and not with
the other (-X: 0.08); docs/papers.md gives the measurements.

UPU axis arrangement: base U = (e1 fixed in the ground, then e2), platform U = (e2, then e1
fixed in the platform), e1 = tangent of the limb-1 circle, e2 = its radial direction, both
normal to X. The platform orientation is then Rot(e1,a)Rot(e2,b+c)Rot(e1,d); R = I is
reachable at every position (c = -b, d = -a). The limb's one constraint is a couple normal
to its four U axes, i.e. about the platform normal X near R = I: alpha of the paper becomes
a function of the other five coordinates (zero whenever beta = gamma = 0) -- mobility 5:
X, Y, Z, beta, gamma.
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
    cylinder_inertia,
    solve_lengths,
    u_angles,
    write_sidecar_yaml,
)
from pinclear.mechanisms._common import cross_inertia as _cross_inertia

G = 9.81

# ------------------------------------------------------------------ geometry (paper 000)
R_BASE = 0.65         # fixed-platform radius of U joints 2..5       (paper 000, sec. 3.1)
R_BASE_UPU = 0.71     # distance of U joint 1 from the base centre    (paper 000, sec. 3.1)
R_PLATFORM = 0.202    # moving-platform radius                       (paper 000, sec. 3.1)
# U joints 2..5 evenly spaced, U joint 1 at the middle angle between 2 and 3 (sec. 3.1)
ANGLES = {1: math.pi / 4, 2: 0.0, 3: math.pi / 2, 4: math.pi, 5: 1.5 * math.pi}
# Moving platform: the five joints evenly spaced (72 deg, sec. 3.1 "evenly distributed"), in
# the base's cyclic order 2, 1, 3, 4, 5, joint 1 on the UPU limb's radial plane (45 deg).
# Reconstructed. Using the base angles instead would make the platform circle homothetic to
# the base circle: all four UPS lines would meet in one point, a singular design.
PLATFORM_ANGLES = {i: math.radians(45.0 + 72.0 * k) for k, i in enumerate((1, 3, 4, 5, 2))}
LIMBS = (1, 2, 3, 4, 5)
UPS_LIMBS = (2, 3, 4, 5)

# ------------------------------------------------------------------ motion law (paper 000, sec. 4)
X0 = 1.1
AMPLITUDE = 0.05
OMEGA = math.pi
PERIOD = 2 * math.pi / OMEGA

# ------------------------------------------------------------------ reconstructed dimensions
LOWER_LEN, LOWER_OD, LOWER_ID = 0.60, 0.070, 0.050   # swing rods 6..10: steel tube
UPPER_LEN, UPPER_D = 0.70, 0.035                     # driving rods 1..5: solid steel
PLATE_R, PLATE_T = 0.25, 0.030                       # moving platform: aluminium disc
PIN_D, PIN_L = 0.025, 0.080                          # U-joint cross: two steel pins

SIDECAR_NAME = "four_ups_upu"


# ================================================================== mass properties
def cross_inertia(axis1, axis2, rho=STEEL, d=PIN_D, length=PIN_L):
    """U-joint spider of paper 000's size (see _common.cross_inertia)."""
    return _cross_inertia(axis1, axis2, rho, d, length)


def body_inertias():
    """Mass, centre of mass (body frame) and central inertia of every body, from the
    reconstructed dimensions and densities (paper 000's Table 1 is lost).

    Body frames: lower rod at the base U centre, upper rod at its tip (the S / U centre),
    moving platform at the U1 centre; all world-aligned in the zero configuration.
    """
    out = {}
    m, I = cylinder_inertia(STEEL, LOWER_LEN, LOWER_OD / 2, LOWER_ID / 2)
    for i in LIMBS:
        out[f"rod{i}_lower"] = (m, np.array([LOWER_LEN / 2, 0, 0]), I)
    m, I = cylinder_inertia(STEEL, UPPER_LEN, UPPER_D / 2)
    for i in LIMBS:
        out[f"rod{i}_upper"] = (m, np.array([-UPPER_LEN / 2, 0, 0]), I)
    for i in LIMBS:
        m, I = cross_inertia(*u_axes(i))
        out[f"cross{i}_base"] = (m, np.zeros(3), I)
    m, I = cross_inertia(*u_axes(1))
    out["cross1_top"] = (m, np.zeros(3), I)
    m, I = cylinder_inertia(ALUMINIUM, PLATE_T, PLATE_R)
    out["moving_platform"] = (m, -platform_point(1), I)
    return out


def parameters():
    """The sidecar's parameter table (name, value, unit, source)."""
    b = body_inertias()
    P = [
        ("r_base", R_BASE, "m", "paper 000, sec. 3.1"),
        ("r_base_upu", R_BASE_UPU, "m", "paper 000, sec. 3.1"),
        ("r_platform", R_PLATFORM, "m", "paper 000, sec. 3.1"),
        ("angles_U2_U5", "0, 90, 180, 270", "deg", "paper 000, sec. 3.1 (evenly spaced)"),
        ("angle_U1", 45.0, "deg", "paper 000, sec. 3.1 (middle angle between U2 and U3)"),
        ("angles_platform", "U1 45, S3 117, S4 189, S5 261, S2 333", "deg",
         "reconstructed: 'evenly distributed' (72 deg) in the base's cyclic order; base angles would be singular"),
        ("X0", X0, "m", "paper 000, sec. 4 (platform law)"),
        ("amplitude_YZ", AMPLITUDE, "m", "paper 000, sec. 4"),
        ("omega", OMEGA, "rad/s", "paper 000, sec. 4"),
        ("gravity_direction", "+X", "-",
         "paper 000, sec. 3.1: each rod's x axis points 'downward along the rod', from the fixed "
         "platform (X = 0) to the moving one (X = 1.1 m)"),
        ("lower_rod", f"{LOWER_LEN} x OD {LOWER_OD} / ID {LOWER_ID}", "m",
         "reconstructed: steel cylinder tube, long enough to hold the piston over the stroke"),
        ("upper_rod", f"{UPPER_LEN} x D {UPPER_D}", "m",
         "reconstructed: solid steel piston rod, 0.1 m overlap with the tube at the shortest limb"),
        ("platform_plate", f"R {PLATE_R} x t {PLATE_T}", "m",
         "reconstructed: aluminium disc enclosing the 0.202 m joint circle"),
        ("u_cross_pins", f"D {PIN_D} x {PIN_L}", "m", "reconstructed: two crossed steel pins per U joint"),
        ("rho_steel", STEEL, "kg/m^3", "reconstructed: structural steel"),
        ("rho_aluminium", ALUMINIUM, "kg/m^3", "reconstructed: aluminium alloy"),
        ("m_lower_rod", b["rod2_lower"][0], "kg", "reconstructed: derived by body_inertias() from the tube"),
        ("m_upper_rod", b["rod2_upper"][0], "kg", "reconstructed: derived by body_inertias() from the rod"),
        ("m_platform", b["moving_platform"][0], "kg", "reconstructed: derived by body_inertias() from the disc"),
        ("m_u_cross", b["cross2_base"][0], "kg", "reconstructed: derived by body_inertias() from the pins"),
    ]
    out = []
    for name, value, unit, source in P:
        if isinstance(value, (float, np.floating)):
            value = float(round(value, 6))
        out.append({"name": name, "value": value, "unit": unit, "source": source})
    return out


# ================================================================== geometry helpers
def base_point(i):
    r = R_BASE_UPU if i == 1 else R_BASE
    th = ANGLES[i]
    return np.array([0.0, r * math.cos(th), r * math.sin(th)])


def platform_point(i):
    """Joint centre b_i in the platform frame (centre of the platform)."""
    th = PLATFORM_ANGLES[i]
    return np.array([0.0, R_PLATFORM * math.cos(th), R_PLATFORM * math.sin(th)])


def u_axes(i):
    """(e1, e2) of limb i's base U: e1 tangent to the joint circle (fixed in the ground),
    e2 radial (fixed in the lower rod); both normal to the limb's zero direction X."""
    th = ANGLES[i]
    e1 = np.array([0.0, -math.sin(th), math.cos(th)])
    e2 = np.array([0.0, math.cos(th), math.sin(th)])
    return e1, e2


_OFFSETS = np.array([platform_point(i) - base_point(i) for i in LIMBS])     # a_i -> b_i


# ================================================================== motion law and IK
def platform_position(t):
    """Platform centre position, velocity, acceleration (paper 000, sec. 4)."""
    w = OMEGA
    s, c = math.sin(w * t), math.cos(w * t)
    p = np.array([X0, AMPLITUDE * s, AMPLITUDE * c])
    v = np.array([0.0, AMPLITUDE * w * c, -AMPLITUDE * w * s])
    a = np.array([0.0, -AMPLITUDE * w * w * s, -AMPLITUDE * w * w * c])
    return p, v, a


def platform_pose(t):
    """World pose of frame ``platform`` (platform centre) at time t; beta = gamma = 0 and
    alpha = 0 (alpha is not free: the UPU limb keeps it at zero)."""
    return pin.SE3(np.eye(3), platform_position(t)[0])


def limb_lengths(t):
    """Exact limb lengths L_i = |p + b_i - a_i| and their first two time derivatives
    (the platform only translates), arrays indexed like ``LIMBS``. Compiled: the drives ask for
    it at every right-hand side of a run."""
    return _limb_lengths(float(t), _OFFSETS, X0, AMPLITUDE, OMEGA)


@njit(cache=True)
def _limb_lengths(t, offsets, x0, amp, w):
    out = np.empty((3, offsets.shape[0]))
    _limb_lengths_into(t, offsets, x0, amp, w, out)
    return out[0], out[1], out[2]


@njit(cache=True)
def _limb_lengths_into(t, offsets, x0, amp, w, out):
    s, c = math.sin(w * t), math.cos(w * t)
    p = (x0, amp * s, amp * c)              # platform_position(t)
    v = (0.0, amp * w * c, -amp * w * s)
    a = (0.0, -amp * w * w * s, -amp * w * w * c)
    vv = v[1] * v[1] + v[2] * v[2]
    for i in range(offsets.shape[0]):
        d0, d1, d2 = p[0] + offsets[i, 0], p[1] + offsets[i, 1], p[2] + offsets[i, 2]
        li = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        dv = d1 * v[1] + d2 * v[2]
        da = d1 * a[1] + d2 * a[2]
        out[0, i], out[1, i], out[2, i] = li, dv / li, (vv + da) / li - dv * dv / li**3


def _limb_lengths_kernel():
    """(kernel, args): kernel(t, *args, out) writes limb_lengths(t) into out (3, 5) in compiled
    code (timelaws.Callable: the drives' compiled path, and the compiled integration loop)."""
    return _limb_lengths_into, (_OFFSETS, X0, AMPLITUDE, OMEGA)


def _limb_lengths_fill(t, out):
    """limb_lengths(t) written into out (3, 5)."""
    if out.shape != (3, _OFFSETS.shape[0]):
        raise ValueError(f"limb_lengths fills (3, {_OFFSETS.shape[0]}) values, got an array of shape {out.shape}")
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
    p = platform_position(t)[0]
    out = {}
    for i in LIMBS:
        e1, e2 = u_axes(i)
        d = p + platform_point(i) - base_point(i)
        L = float(np.linalg.norm(d))
        a, b = u_angles(d / L, e1, e2, np.array([1.0, 0, 0]))
        out[f"U{i}_1"], out[f"U{i}_2"], out[f"P{i}"] = a, b, L
        if i == 1:
            out["U1_3"], out["U1_4"] = -b, -a     # platform stays parallel (R = I)
    return out


# ================================================================== URDF
ANGLE_LIMITS = (-math.pi, math.pi)
STROKE = (LOWER_LEN / 2 + 0.35, LOWER_LEN + UPPER_LEN)   # piston inside the tube, rod not out


def urdf_text():
    bodies = body_inertias()
    X = np.array([1.0, 0, 0])
    s = '<?xml version="1.0"?>\n<!-- generated by pinclear.mechanisms.four_ups_upu.write_urdf: do not edit -->\n'
    s += '<robot name="four_ups_upu">\n'
    s += urdf_link("world")
    for i in LIMBS:
        e1, e2 = u_axes(i)
        cr, lo, up = f"cross{i}_base", f"rod{i}_lower", f"rod{i}_upper"
        s += urdf_link(cr, bodies[cr]) + urdf_link(lo, bodies[lo]) + urdf_link(up, bodies[up])
        s += urdf_joint(f"U{i}_1", "revolute", "world", cr, base_point(i), e1, ANGLE_LIMITS)
        s += urdf_joint(f"U{i}_2", "revolute", cr, lo, (0, 0, 0), e2, ANGLE_LIMITS)
        s += urdf_joint(f"P{i}", "prismatic", lo, up, (0, 0, 0), X, STROKE)
        if i != 1:
            # socket of S_i: centre of the spherical joint on the driving rod
            s += urdf_link(f"S{i}_socket")
            s += urdf_joint(f"S{i}_socket_joint", "fixed", up, f"S{i}_socket")
    e1, e2 = u_axes(1)
    s += urdf_link("cross1_top", bodies["cross1_top"]) + urdf_link("moving_platform", bodies["moving_platform"])
    s += urdf_joint("U1_3", "revolute", "rod1_upper", "cross1_top", (0, 0, 0), e2, ANGLE_LIMITS)
    s += urdf_joint("U1_4", "revolute", "cross1_top", "moving_platform", (0, 0, 0), e1, ANGLE_LIMITS)
    s += urdf_link("platform")
    s += urdf_joint("platform_centre", "fixed", "moving_platform", "platform", -platform_point(1))
    for i in UPS_LIMBS:
        s += urdf_link(f"S{i}_ball")
        s += urdf_joint(f"S{i}_ball_joint", "fixed", "moving_platform", f"S{i}_ball",
                        platform_point(i) - platform_point(1))
    return s + "</robot>\n"


def write_urdf(path):
    Path(path).write_text(urdf_text())


# ================================================================== sidecar
CLOSURES = [{"name": f"S{i}", "type": "spherical", "frame1": f"S{i}_socket", "frame2": f"S{i}_ball"}
            for i in UPS_LIMBS]
DRIVES = [f"drive{i}" for i in LIMBS]


def sidecar_dict():
    q0 = ik_configuration(0.0)
    return {
        "name": SIDECAR_NAME,
        "urdf": f"{SIDECAR_NAME}.urdf",
        "description": "4UPS-UPU spatial parallel mechanism (paper 000), ideal joints, 5 prismatic drives",
        "gravity": [G, 0.0, 0.0],
        # paper 000, eq. 31: correction factors zeta = xi = 5
        "baumgarte": {"alpha": 5.0, "beta": 5.0},
        "initial": {"q": {k: float(round(v, 12)) + 0.0 for k, v in q0.items()}},   # + 0.0: no -0.0
        "closures": CLOSURES,
        "drives": [{"name": f"drive{i}", "joint": f"P{i}",
                    "law": {"type": "python", "function": "pinclear.mechanisms.four_ups_upu:limb_lengths",
                            "index": k}} for k, i in enumerate(LIMBS)],
        "platform": {"frame": "platform",
                     "motion": {"function": "pinclear.mechanisms.four_ups_upu:platform_pose", "args": {}}},
        "parameters": parameters(),
    }


def write_sidecar(path):
    """Write the sidecar; a ``clearances:`` block already in the file is kept."""
    write_sidecar_yaml(path, sidecar_dict(),
                       "# 4UPS-UPU of paper 000. Generated by pinclear.mechanisms.four_ups_upu.write_sidecar;\n"
                       "# the X axis is normal to the fixed platform (paper's convention), gravity along +X (down).\n")


def default_urdf_path():
    return URDF_DIR / f"{SIDECAR_NAME}.urdf"


# ================================================================== closed-chain position analysis
@lru_cache(maxsize=4)
def _model(path=None):
    return pin.buildModelFromUrdf(str(path or default_urdf_path()))


def chain(model=None):
    model = model or _model()
    return ClosedChain(model, CLOSURES, [f"P{i}" for i in LIMBS])


def forward_kinematics(lengths, guess=None, model=None):
    """Forward position analysis: the closed-chain configuration with limb lengths
    ``lengths`` (limbs 1..5), by Newton from ``guess`` (default: the IK pose at t = 0).
    Returns (q, pose of frame ``platform``)."""
    model = model or _model()
    q0 = config_vector(model, ik_configuration(0.0)) if guess is None else guess
    return solve_lengths(model, CLOSURES, [f"P{i}" for i in LIMBS], lengths, q0)