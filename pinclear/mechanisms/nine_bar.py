"""Planar 2-DOF nine-bar linkage with a slider (paper 002: Chen & Pan 2021, JHIT 28(2) 82-96).

Topology, read from the paper's constraint equations n1..n22 (eq. 15); body numbers are the
paper's, the frame is body 5 (its length L5 is the distance between the crank pivots):

* crank 1 turns about O1 = (0, 0) (n1, n2); its tip A carries coupler 2 (n3, n4);
* crank 4 turns about O4 = (L5, 0) (n5, n6); its tip B carries link 3 (n11, n12);
* coupler 2, link 3 and link 6 meet at one point C (n7..n10): a five-bar O1-A-C-B-O4;
* link 6 drives the triangular plate 7 at its vertex D (n13, n14); plate 7 is hinged to the
  frame at H = (Hx, Hy) (n15, n16); its third vertex E (|HE| = L72, angle beta from HD)
  carries link 8 (n17, n18), whose other end F is the pin of slider 9 (n19, n20);
* slider 9 runs in a fixed guide along the horizontal line y = Hy through H (n21, n22).

Cranks 1 and 4 are driven (n23, n24): theta1 = omega1 t + 146.9 deg, theta4 = omega4 t + 28 deg,
omega1 = 2 pi, omega4 = -2 pi rad/s. The paper's Tables 1-4 (dimensions, masses) were lost, so
every dimension below is reconstructed (see ``PARAMETER_SOURCES``): chosen so that the five-bar
stays fully rotatable (L2 + L3 > L5 + L1 + L4 and |L2 - L3| < L5 - L1 - L4), that along the
paper's drive law no dyad comes within 27 deg of a stretched or folded position (transmission
sines >= 0.45; every other pair of crank angles assembles too), and that the ideal slider hits
the peaks sec. 3.2 prints: L1, L4, Hx, Hy are fitted to them (pinclear.studies.reproduce.linkage002,
which also gives the family of linkages that hit them as well).

Motion is in the x-y plane, every revolute axis is z, gravity acts along -y.

Pinocchio spanning tree (nq = nv = 8): ground -> crank 1 (joint ``O1``), ground -> crank 4
(``O4``), ground -> plate 7 (``H``) -> link 6 (``D``) -> link 3 (``C63``) -> coupler 2 (``C32``),
plate 7 -> link 8 (``E``), ground -> slider 9 (prismatic ``guide``). The revolute joints A
(crank 1 - coupler 2) and B (crank 4 - link 3), whose clearances the paper studies, and the
slider pin F (link 8 - slider 9) are cut as ``planar_point`` closures (2 rows each): 6 rows,
mobility 8 - 6 = 2.

``positions`` is a closed-form position analysis written from eq. 15 alone (no Pinocchio);
``paper_constraints`` evaluates n1..n24 literally. Both serve as the second method in tests.

Run ``python -m pinclear.mechanisms.nine_bar`` to regenerate ``urdf/nine_bar.urdf`` and
``urdf/nine_bar.yaml``.
"""
from __future__ import annotations

import math
import sys
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from pinclear.mechanisms._common import URDF_DIR

RHO_STEEL = 7850.0          # kg/m^3
GRAVITY = 9.81              # m/s^2, along -y
THETA1_0 = math.radians(146.9)
THETA4_0 = math.radians(28.0)
OMEGA1 = 2.0 * math.pi
OMEGA4 = -2.0 * math.pi

#: paper body numbers in the order used by ``positions`` (5 is the frame)
BODIES = (1, 2, 3, 4, 6, 7, 8, 9)
#: URDF link name of each paper body
LINKS = {1: "crank1", 2: "coupler2", 3: "link3", 4: "crank4", 6: "link6", 7: "plate7",
         8: "link8", 9: "slider9"}
#: tree joints (Pinocchio orders them depth-first: use ``tree_configuration``)
JOINTS = ("O1", "O4", "H", "D", "C63", "C32", "E", "guide")
#: the tree joint that carries each link
_JOINT_OF = {"crank1": "O1", "crank4": "O4", "plate7": "H", "link6": "D", "link3": "C63",
             "coupler2": "C32", "link8": "E", "slider9": "guide"}
DRIVES = {"crank1_drive": "O1", "crank4_drive": "O4"}


@dataclass(frozen=True)
class Dimensions:
    """Pin-to-pin lengths (m), angles (rad) and cross-sections of the reconstructed linkage."""

    L1: float = 0.1013478   # crank 1, O1-A (= 2 Ls1)
    L2: float = 0.285       # coupler 2, A-C (= 2 Ls2)
    L3: float = 0.420       # link 3, B-C (= 2 Ls3)
    L4: float = 0.1247286   # crank 4, O4-B (= 2 Ls4)
    L5: float = 0.440       # frame, O1-O4
    L6: float = 0.380       # link 6, D-C (= 2 Ls6)
    L71: float = 0.315      # plate 7, H-D
    L72: float = 0.280      # plate 7, H-E
    beta: float = math.radians(95.0)    # plate 7, angle D-H-E
    L8: float = 0.440       # link 8, E-F (= 2 Ls8)
    Hx: float = 0.5773995   # plate pivot H and slider guide line y = Hy
    Hy: float = 0.3910211
    bar_width: float = 0.025      # in-plane width of every bar
    thickness: float = 0.010      # out-of-plane thickness of bars and plate
    slider: tuple = (0.060, 0.040, 0.030)   # slider block along x, y, z
    branch_C: int = 1       # C to the left of A->B (above the cranks)
    branch_D: int = 1       # D to the left of H->C


DIMS = Dimensions()

_FITTED = ("fitted: with L1, L4, Hx, Hy to paper 002's printed ideal slider peaks (sec. 3.2: 0.115 m at "
           "0.616 s, 0.653 m/s at 0.512 s; pinclear.studies.reproduce.linkage002)")
_FAMILY = "reconstructed: spans the family of linkages that hit the printed peaks (pinclear.studies.reproduce.linkage002)"
PARAMETER_SOURCES = {
    "L1": _FITTED + "; crank O1-A",
    "L4": _FITTED + "; crank O4-B (the five-bar's asymmetry sets the peaks' instants)",
    "L2": "reconstructed: coupler A-C; L2+L3 = 0.705 > L5+L1+L4 = 0.666, so A-C-B never stretches",
    "L3": "reconstructed: link B-C; |L2-L3| = 0.135 < L5-L1-L4 = 0.214, so it never folds",
    "L5": "reconstructed: pivot distance O1-O4",
    "L6": _FAMILY + "; link D-C, 0.30-0.46 m",
    "L71": "reconstructed: plate side H-D (eq. 15 uses only the derived Ls71, Ls72, beta1, beta2)",
    "L72": "reconstructed: plate side H-E (named in n19, n20); sets the stroke with Hx, Hy",
    "beta": "reconstructed: plate angle D-H-E (n17..n20)",
    "L8": _FAMILY + "; link E-F, 0.40-0.48 m",
    "Hx": _FITTED + "; plate pivot H",
    "Hy": _FITTED + "; height of H and of the slider guide (n16, n21: guide passes through H)",
    "bar_width": "reconstructed: steel flat bar 25 mm x 10 mm (paper: 'each rod is a homogeneous rod')",
    "thickness": "reconstructed: 10 mm steel plate and bars",
    "slider": "reconstructed: steel block 60 x 40 x 30 mm",
    "rho": "reconstructed: structural steel",
}


# ----------------------------------------------------------------------------- geometry
def _e(a):
    return np.array([math.cos(a), math.sin(a)])


def plate_geometry(d: Dimensions = DIMS) -> dict:
    """Plate 7 in its own frame (origin H, x along H->D) and the paper's derived quantities.

    The centroid of a homogeneous triangle is the mean of its vertices; Ls71, beta1, Ls72,
    beta2, Ls73, beta3 are then defined by n15..n18 of eq. 15:
    G = H + Ls71 e(th7 + beta1), D = G + Ls72 e(th7 - beta2), E = G + Ls73 e(th7 + beta + beta3).
    """
    Hl = np.zeros(2)
    Dl = np.array([d.L71, 0.0])
    El = d.L72 * _e(d.beta)
    Gl = (Hl + Dl + El) / 3.0
    gd, ge = Dl - Gl, El - Gl
    return {
        "H": Hl, "D": Dl, "E": El, "G": Gl,
        "Ls71": float(np.hypot(*Gl)), "beta1": float(math.atan2(Gl[1], Gl[0])),
        "Ls72": float(np.hypot(*gd)), "beta2": float(-math.atan2(gd[1], gd[0])),
        "Ls73": float(np.hypot(*ge)), "beta3": float(math.atan2(ge[1], ge[0]) - d.beta),
        "area": 0.5 * d.L71 * d.L72 * math.sin(d.beta),
    }


def paper_parameters(d: Dimensions = DIMS) -> dict:
    """The dimensions under the names eq. 15 uses (Ls* are centroid-to-pin half lengths)."""
    g = plate_geometry(d)
    return {"Ls1": d.L1 / 2, "Ls2": d.L2 / 2, "Ls3": d.L3 / 2, "Ls4": d.L4 / 2, "L5": d.L5,
            "Ls6": d.L6 / 2, "Ls71": g["Ls71"], "Ls72": g["Ls72"], "Ls73": g["Ls73"],
            "L72": d.L72, "L8": d.L8, "Ls8": d.L8 / 2, "Hx": d.Hx, "Hy": d.Hy, "beta": d.beta,
            "beta1": g["beta1"], "beta2": g["beta2"], "beta3": g["beta3"]}


def _circle_intersection(P, r1, Q, r2, side):
    """Point X with |X-P| = r1, |X-Q| = r2 on the given side (+1 left) of P->Q, and the sine
    of the angle between X-P and X-Q (0 at a stretched or folded dyad)."""
    d = Q - P
    dd = math.hypot(d[0], d[1])
    a = (r1 * r1 - r2 * r2 + dd * dd) / (2.0 * dd)
    h2 = r1 * r1 - a * a
    if h2 < 0.0:
        raise ValueError(f"dyad cannot close: |PQ| = {dd:.6g} m, arms {r1:.6g} m and {r2:.6g} m")
    h = math.sqrt(h2)
    u = d / dd
    X = P + a * u + side * h * np.array([-u[1], u[0]])
    # sin(angle PXQ) = dd * h / (r1 r2) from the triangle's area
    return X, dd * h / (r1 * r2)


def positions(theta1: float, theta4: float, d: Dimensions = DIMS) -> dict:
    """Closed-form position analysis of the linkage from the two crank angles (eq. 15).

    Returns ``x`` (8, 3): the paper's generalized coordinates (x_i, y_i, theta_i) of the
    centroids of bodies ``BODIES`` = 1, 2, 3, 4, 6, 7, 8, 9 (theta_i as eq. 15 defines it),
    ``points`` (A, B, C, D, E, F, H, O1, O4 in the plane), ``sines`` (sine of the transmission
    angle of the three dyads A-C-B, C-D-H and E-F-guide; 0 means singular) and ``tree``
    (the URDF joint coordinates, joint name -> value; see ``tree_configuration``).
    Raises ValueError if a dyad cannot close.
    """
    g = plate_geometry(d)
    O1 = np.zeros(2)
    O4 = np.array([d.L5, 0.0])
    H = np.array([d.Hx, d.Hy])
    A = O1 + d.L1 * _e(theta1)
    B = O4 + d.L4 * _e(theta4)
    C, s_c = _circle_intersection(A, d.L2, B, d.L3, d.branch_C)
    D, s_d = _circle_intersection(H, d.L71, C, d.L6, d.branch_D)
    th7 = math.atan2(D[1] - H[1], D[0] - H[0])          # plate frame x axis = H->D
    E = H + d.L72 * _e(th7 + d.beta)
    dy = d.Hy - E[1]
    if abs(dy) >= d.L8:
        raise ValueError(f"link 8 cannot reach the guide: |E_y - Hy| = {abs(dy):.6g} m >= L8")
    cos8 = math.sqrt(1.0 - (dy / d.L8) ** 2)
    F = np.array([E[0] + d.L8 * cos8, d.Hy])            # slider to the right of E
    th2 = math.atan2(C[1] - A[1], C[0] - A[0])          # n3..n8: A = x2 - Ls2 e2, C = x2 + Ls2 e2
    th3 = math.atan2(C[1] - B[1], C[0] - B[0])          # n9..n12: B = x3 - Ls3 e3
    th6 = math.atan2(C[1] - D[1], C[0] - D[0])          # n7, n13: D = x6 - Ls6 e6
    th8 = math.atan2(F[1] - E[1], F[0] - E[0])          # n17..n20: E = x8 - Ls8 e8
    G7 = H + g["Ls71"] * _e(th7 + g["beta1"])
    x = np.array([
        [*(A / 2), theta1],
        [*((A + C) / 2), th2],
        [*((B + C) / 2), th3],
        [*((O4 + B) / 2), theta4],
        [*((D + C) / 2), th6],
        [*G7, th7],
        [*((E + F) / 2), th8],
        [*F, 0.0],
    ])
    # tree joints: relative angles between the link frames (frame x axis from the joint to
    # the far pin: link 3 points C->B, coupler 2 points C->A, so both are turned by pi)
    rel = np.array([th7, th6 - th7, (th3 + math.pi) - th6, th2 - th3, th8 - th7])
    rel = (rel + math.pi) % (2 * math.pi) - math.pi
    tree = dict(zip(JOINTS, (theta1, theta4, *rel.tolist(), float(F[0]))))
    return {"x": x, "points": {"A": A, "B": B, "C": C, "D": D, "E": E, "F": F, "H": H,
                               "O1": O1, "O4": O4},
            "sines": np.array([s_c, s_d, cos8]), "tree": tree}


def _meet(P, r1, Q, r2, side):
    """Vectorised ``_circle_intersection`` over rows of P, Q (n, 2): the points X (n, 2) and the
    sines of the dyads' transmission angles (n,); NaN where a dyad cannot close."""
    d = Q - P
    dd = np.hypot(d[:, 0], d[:, 1])
    a = (r1 * r1 - r2 * r2 + dd * dd) / (2.0 * dd)
    h2 = r1 * r1 - a * a
    h = np.sqrt(np.where(h2 >= 0.0, h2, np.nan))
    u = d / dd[:, None]
    X = P + a[:, None] * u + side * h[:, None] * np.stack([-u[:, 1], u[:, 0]], axis=1)
    return X, dd * h / (r1 * r2)


def slider_positions(theta1, theta4, d: Dimensions = DIMS):
    """Slider 9's x (the pin F) and the smallest of the three dyad sines, for arrays of crank
    angles: ``positions``'s chain A, B -> C -> D -> E -> F for many instants at once (the fit
    of pinclear.studies.reproduce.linkage002 evaluates it thousands of times). NaN where a
    dyad cannot close."""
    th1, th4 = np.atleast_1d(np.asarray(theta1, float)), np.atleast_1d(np.asarray(theta4, float))
    A = d.L1 * np.stack([np.cos(th1), np.sin(th1)], axis=1)
    B = np.array([d.L5, 0.0]) + d.L4 * np.stack([np.cos(th4), np.sin(th4)], axis=1)
    C, s_c = _meet(A, d.L2, B, d.L3, d.branch_C)
    H = np.broadcast_to(np.array([d.Hx, d.Hy]), C.shape)
    D, s_d = _meet(H, d.L71, C, d.L6, d.branch_D)
    th7 = np.arctan2(D[:, 1] - d.Hy, D[:, 0] - d.Hx)
    Ex, Ey = d.Hx + d.L72 * np.cos(th7 + d.beta), d.Hy + d.L72 * np.sin(th7 + d.beta)
    r = (d.Hy - Ey) / d.L8
    cos8 = np.sqrt(np.where(np.abs(r) < 1.0, 1.0 - r * r, np.nan))
    return Ex + d.L8 * cos8, np.minimum(np.minimum(s_c, s_d), cos8)


def paper_constraints(x: np.ndarray, t: float, d: Dimensions = DIMS,
                      omega1: float = OMEGA1, omega4: float = OMEGA4) -> np.ndarray:
    """n1..n24 of eq. 15, written out literally; ``x`` is (8, 3) as returned by ``positions``."""
    p = paper_parameters(d)
    (x1, y1, t1), (x2, y2, t2), (x3, y3, t3), (x4, y4, t4), (x6, y6, t6), (x7, y7, t7), \
        (x8, y8, t8), (x9, y9, t9) = x
    c, s = math.cos, math.sin
    b, b1, b2, b3 = p["beta"], p["beta1"], p["beta2"], p["beta3"]
    return np.array([
        x1 - p["Ls1"] * c(t1), y1 - p["Ls1"] * s(t1),
        x1 + p["Ls1"] * c(t1) - x2 + p["Ls2"] * c(t2), y1 + p["Ls1"] * s(t1) - y2 + p["Ls2"] * s(t2),
        x4 - p["Ls4"] * c(t4) - p["L5"], y4 - p["Ls4"] * s(t4),
        x6 + p["Ls6"] * c(t6) - x2 - p["Ls2"] * c(t2), y6 + p["Ls6"] * s(t6) - y2 - p["Ls2"] * s(t2),
        x6 + p["Ls6"] * c(t6) - x3 - p["Ls3"] * c(t3), y6 + p["Ls6"] * s(t6) - y3 - p["Ls3"] * s(t3),
        x3 - p["Ls3"] * c(t3) - x4 - p["Ls4"] * c(t4), y3 - p["Ls3"] * s(t3) - y4 - p["Ls4"] * s(t4),
        x7 + p["Ls72"] * c(t7 - b2) - x6 + p["Ls6"] * c(t6),
        y7 + p["Ls72"] * s(t7 - b2) - y6 + p["Ls6"] * s(t6),
        x7 - p["Ls71"] * c(t7 + b1) - p["Hx"], y7 - p["Ls71"] * s(t7 + b1) - p["Hy"],
        x7 + p["Ls73"] * c(t7 + b + b3) - x8 + p["Ls8"] * c(t8),
        y7 + p["Ls73"] * s(t7 + b + b3) - y8 + p["Ls8"] * s(t8),
        x9 - p["Hx"] - p["L72"] * c(t7 + b) - p["L8"] * c(t8),
        y9 - p["Hy"] - p["L72"] * s(t7 + b) - p["L8"] * s(t8),
        y9 - p["Hy"], t9,
        t1 - omega1 * t - THETA1_0, t4 - omega4 * t - THETA4_0,
    ])


# ----------------------------------------------------------------------------- mass properties
def _box_inertia(m, a, b, c):
    """Inertia of a homogeneous box with edges a, b, c along x, y, z, about its centroid."""
    return np.diag([m * (b * b + c * c), m * (a * a + c * c), m * (a * a + b * b)]) / 12.0


def mass_properties(d: Dimensions = DIMS, rho: float = RHO_STEEL) -> dict:
    """Mass (kg), centroid (m, link frame) and inertia about the centroid (kg m^2, link frame)
    of every moving body, from the dimensions: bars are steel flats of ``bar_width`` x
    ``thickness`` section and pin-to-pin length (homogeneous rods, centroid mid-way, as eq. 15
    assumes); plate 7 is a steel triangle H-D-E of ``thickness``; slider 9 a steel block.
    Link frames have their origin at the body's tree joint, x axis towards the far pin.
    """
    w, t = d.bar_width, d.thickness
    out = {}
    for body, L in ((1, d.L1), (2, d.L2), (3, d.L3), (4, d.L4), (6, d.L6), (8, d.L8)):
        m = rho * w * t * L
        out[body] = (m, np.array([L / 2, 0.0, 0.0]), _box_inertia(m, L, w, t))
    g = plate_geometry(d)
    m7 = rho * t * g["area"]
    # second moment of area of a triangle about its centroid: (A/12) sum_i r_i r_i^T over the
    # vertices r_i measured from the centroid (exact for a homogeneous triangle)
    R = np.array([g["H"], g["D"], g["E"]]) - g["G"]
    S = g["area"] / 12.0 * R.T @ R
    I7 = np.zeros((3, 3))
    I7[0, 0] = rho * t * S[1, 1] + m7 * t * t / 12.0
    I7[1, 1] = rho * t * S[0, 0] + m7 * t * t / 12.0
    I7[2, 2] = rho * t * (S[0, 0] + S[1, 1])
    I7[0, 1] = I7[1, 0] = -rho * t * S[0, 1]
    out[7] = (m7, np.array([*g["G"], 0.0]), I7)
    a, b, c = d.slider
    m9 = rho * a * b * c
    out[9] = (m9, np.zeros(3), _box_inertia(m9, a, b, c))
    return out


def potential_energy(theta1: float, theta4: float, d: Dimensions = DIMS,
                     gravity: float = GRAVITY) -> float:
    """Gravitational potential (J) on the closed-loop manifold, gravity along -y."""
    x = positions(theta1, theta4, d)["x"]
    mp = mass_properties(d)
    return gravity * sum(mp[b][0] * x[i, 1] for i, b in enumerate(BODIES))


def static_crank_torques(theta1: float, theta4: float, d: Dimensions = DIMS,
                         gravity: float = GRAVITY, h: float = 1e-5) -> np.ndarray:
    """Crank torques (N m) that hold the linkage still against gravity, by virtual work:
    tau_k = dV/dtheta_k on the manifold parametrised by the crank angles (central differences)."""
    def V(a, b):
        return potential_energy(a, b, d, gravity)
    return np.array([(V(theta1 + h, theta4) - V(theta1 - h, theta4)) / (2 * h),
                     (V(theta1, theta4 + h) - V(theta1, theta4 - h)) / (2 * h)])


# ----------------------------------------------------------------------------- model files
def _f(v) -> str:
    return repr(float(v))


def _vec(v) -> str:
    return " ".join(_f(c) for c in v)


def urdf_text(d: Dimensions = DIMS) -> str:
    """The URDF of the spanning tree (see the module docstring)."""
    g = plate_geometry(d)
    mp = mass_properties(d)
    lines = ['<?xml version="1.0"?>',
             "<!-- Generated by pinclear.mechanisms.nine_bar.write_urdf; do not edit by hand. -->",
             "<!-- Paper 002 nine-bar linkage: planar (x-y), revolute axes z, gravity -y. -->",
             '<robot name="nine_bar">', '  <link name="world"/>']

    def link(body, visual):
        m, c, I = mp[body]
        lines.extend([
            f'  <link name="{LINKS[body]}">',
            "    <inertial>",
            f'      <origin xyz="{_vec(c)}" rpy="0 0 0"/>',
            f'      <mass value="{_f(m)}"/>',
            f'      <inertia ixx="{_f(I[0, 0])}" ixy="{_f(I[0, 1])}" ixz="{_f(I[0, 2])}" '
            f'iyy="{_f(I[1, 1])}" iyz="{_f(I[1, 2])}" izz="{_f(I[2, 2])}"/>',
            "    </inertial>", *visual, "  </link>"])

    def bar(L):
        return ["    <visual>", f'      <origin xyz="{_f(L / 2)} 0 0" rpy="0 0 0"/>',
                f'      <geometry><box size="{_f(L)} {_f(d.bar_width)} {_f(d.thickness)}"/></geometry>',
                "    </visual>"]

    def joint(name, kind, parent, child, xyz, axis="0 0 1"):
        lim = ('    <limit lower="-1e3" upper="1e3" effort="1e6" velocity="1e3"/>'
               if kind == "prismatic" else '    <limit effort="1e6" velocity="1e3"/>')
        lines.extend([f'  <joint name="{name}" type="{kind}">',
                      f'    <parent link="{parent}"/>', f'    <child link="{child}"/>',
                      f'    <origin xyz="{_vec(xyz)}" rpy="0 0 0"/>', f'    <axis xyz="{axis}"/>',
                      lim, "  </joint>"])

    L = {1: d.L1, 2: d.L2, 3: d.L3, 4: d.L4, 6: d.L6, 8: d.L8}
    for b in (1, 2, 3, 4, 6, 8):
        link(b, bar(L[b]))
    # plate 7 drawn as a prism would need a mesh; a box over its bounding rectangle would
    # misstate its shape, so it is drawn as its three sides
    plate_vis = []
    for P, Q in ((g["H"], g["D"]), (g["D"], g["E"]), (g["E"], g["H"])):
        mid, dv = (P + Q) / 2, Q - P
        plate_vis += ["    <visual>",
                      f'      <origin xyz="{_f(mid[0])} {_f(mid[1])} 0" '
                      f'rpy="0 0 {_f(math.atan2(dv[1], dv[0]))}"/>',
                      f'      <geometry><box size="{_f(np.hypot(*dv))} {_f(d.bar_width)} '
                      f'{_f(d.thickness)}"/></geometry>', "    </visual>"]
    link(7, plate_vis)
    link(9, ["    <visual>", '      <origin xyz="0 0 0" rpy="0 0 0"/>',
             f'      <geometry><box size="{_vec(d.slider)}"/></geometry>', "    </visual>"])
    joint("O1", "revolute", "world", "crank1", (0, 0, 0))
    joint("O4", "revolute", "world", "crank4", (d.L5, 0, 0))
    joint("H", "revolute", "world", "plate7", (d.Hx, d.Hy, 0))
    joint("D", "revolute", "plate7", "link6", (d.L71, 0, 0))
    joint("C63", "revolute", "link6", "link3", (d.L6, 0, 0))
    joint("C32", "revolute", "link3", "coupler2", (0, 0, 0))
    joint("E", "revolute", "plate7", "link8", (*g["E"], 0))
    joint("guide", "prismatic", "world", "slider9", (0, d.Hy, 0), axis="1 0 0")
    lines.append("</robot>")
    return "\n".join(lines) + "\n"


def write_urdf(path, d: Dimensions = DIMS) -> Path:
    path = Path(path)
    path.write_text(urdf_text(d))
    return path


def journal_clearance(name: str) -> dict:
    """Clearance joint A or B of paper 002 (sidecar ``clearances:`` entry, inactive by default)."""
    return {"name": name, "type": "planar_revolute", "closure": name, "active": False, "clearance": 5.0e-4,
            "radius": 0.01, "length": 0.02, "material": "steel", "stiffness": "printed",
            "normal_law": "lankarani_nikravesh", "ce": 0.9, "mu": 0.1,
            "friction_law": {"type": "modified_coulomb", "v0": 1.0e-4, "v1": 1.0e-3},
            "notes": "paper 002: c = 0.5 mm (sec. 3), L-N law eqs. 8-9 with K as printed, modified Coulomb "
                     "eq. 10; reconstructed (Table 3 lost): journal radius 10 mm, length 20 mm, steel, ce 0.9, "
                     "mu 0.1, v0 = 0.1 mm/s, v1 = 1 mm/s"}


def sidecar_text(d: Dimensions = DIMS, urdf: str = "nine_bar.urdf") -> str:
    """The sidecar YAML (closures A, B, F; crank drives; parameter table)."""
    import yaml

    tree = positions(THETA1_0, THETA4_0, d)["tree"]
    params = []
    for k, v in asdict(d).items():
        if k.startswith("branch"):
            continue
        if k == "slider":
            for axis, c in zip("xyz", v):
                params.append({"name": f"slider_{axis}", "value": float(c), "unit": "m",
                               "source": PARAMETER_SOURCES[k]})
            continue
        params.append({"name": k, "value": float(v), "unit": "rad" if k == "beta" else "m",
                       "source": PARAMETER_SOURCES[k]})
    params.append({"name": "rho", "value": RHO_STEEL, "unit": "kg/m^3",
                   "source": PARAMETER_SOURCES["rho"]})
    for k, v in paper_parameters(d).items():
        if k in ("Ls71", "Ls72", "Ls73", "beta1", "beta2", "beta3"):
            params.append({"name": k, "value": float(f"{v:.12g}"), "unit": "rad" if k.startswith("beta") else "m",
                           "source": "reconstructed: eq. 15 name, derived from L71, L72, beta "
                                     "(centroid of the homogeneous triangle)"})
    for b, (m, _, I) in sorted(mass_properties(d).items()):
        params.append({"name": f"m{b}", "value": round(float(m), 6), "unit": "kg",
                       "source": "reconstructed: steel, from dimensions (nine_bar.mass_properties)"})
        params.append({"name": f"Izz{b}", "value": float(f"{I[2, 2]:.6g}"), "unit": "kg m^2",
                       "source": "reconstructed: about the centroid, from dimensions (nine_bar.mass_properties)"})
    for k, v, src in (("theta1_0", THETA1_0, "paper 002, eq. 15 (n23): 146.9 deg"),
                      ("theta4_0", THETA4_0, "paper 002, eq. 15 (n24): 28 deg"),
                      ("omega1", OMEGA1, "paper 002, sec. 2.2: 2 pi rad/s"),
                      ("omega4", OMEGA4, "paper 002, sec. 2.2: -2 pi rad/s")):
        params.append({"name": k, "value": float(v), "unit": "rad/s" if k.startswith("omega") else "rad",
                       "source": src})
    doc = {
        "name": "nine_bar",
        "urdf": urdf,
        "description": "Paper 002 planar 2-DOF nine-bar with slider; x-y plane, axes z, gravity -y",
        "gravity": [0.0, -GRAVITY, 0.0],
        # paper 002, the equation after eq. 19: "alpha and beta are selected as 20"
        "baumgarte": {"alpha": 20.0, "beta": 20.0},
        "initial": {"q": {j: float(v) for j, v in tree.items()},
                    "v": {"O1": OMEGA1, "O4": OMEGA4}},
        "closures": [
            {"name": "A", "type": "planar_point",
             "frame1": {"parent": "crank1", "xyz": [d.L1, 0.0, 0.0], "rpy": [0.0, 0.0, 0.0]},
             "frame2": {"parent": "coupler2", "xyz": [d.L2, 0.0, 0.0], "rpy": [0.0, 0.0, 0.0]},
             "normal": [0.0, 0.0, 1.0]},
            {"name": "B", "type": "planar_point",
             "frame1": {"parent": "crank4", "xyz": [d.L4, 0.0, 0.0], "rpy": [0.0, 0.0, 0.0]},
             "frame2": {"parent": "link3", "xyz": [d.L3, 0.0, 0.0], "rpy": [0.0, 0.0, 0.0]},
             "normal": [0.0, 0.0, 1.0]},
            {"name": "F", "type": "planar_point",
             "frame1": {"parent": "link8", "xyz": [d.L8, 0.0, 0.0], "rpy": [0.0, 0.0, 0.0]},
             "frame2": {"parent": "slider9", "xyz": [0.0, 0.0, 0.0], "rpy": [0.0, 0.0, 0.0]},
             "normal": [0.0, 0.0, 1.0]},
        ],
        "drives": [
            {"name": "crank1_drive", "joint": "O1",
             "law": {"type": "polynomial", "coeffs": [THETA1_0, OMEGA1]}},
            {"name": "crank4_drive", "joint": "O4",
             "law": {"type": "polynomial", "coeffs": [THETA4_0, OMEGA4]}},
        ],
        "platform": {"frame": "slider9"},
        "clearances": [journal_clearance("A"), journal_clearance("B")],
        "parameters": params,
    }
    head = ("# Generated by pinclear.mechanisms.nine_bar (python -m pinclear.mechanisms.nine_bar);\n"
            "# edit the Dimensions there, not this file. Paper 002 Tables 1-4 are lost: every\n"
            "# dimension is reconstructed. Cut joints A, B (the paper's clearance joints) and\n"
            "# F (slider pin) are planar_point closures; plane x-y, gravity -y.\n")
    return head + yaml.safe_dump(doc, sort_keys=False, default_flow_style=None, width=110)


def write_sidecar(path, d: Dimensions = DIMS) -> Path:
    path = Path(path)
    path.write_text(sidecar_text(d))
    return path


# ----------------------------------------------------------------------------- checks on the tree
def tree_configuration(model, tree: dict) -> np.ndarray:
    """Pinocchio configuration vector from joint name -> value (Pinocchio orders the joints
    depth-first, not as ``JOINTS``)."""
    q = np.zeros(model.nq)
    for name, value in tree.items():
        q[model.joints[model.getJointId(name)].idx_q] = value
    return q


def tree_positions(model, data, q) -> np.ndarray:
    """The paper's (x_i, y_i, theta_i) of every body from a Pinocchio configuration of the
    nine-bar URDF (frame x axes of link 3 and coupler 2 point away from C: angle - pi)."""
    pin.forwardKinematics(model, data, q)
    out = np.zeros((len(BODIES), 3))
    for i, b in enumerate(BODIES):
        jid = model.getJointId(_JOINT_OF[LINKS[b]])
        M = data.oMi[jid]
        c = M.act(model.inertias[jid].lever)
        ang = math.atan2(M.rotation[1, 0], M.rotation[0, 0]) + (math.pi if b in (2, 3) else 0.0)
        out[i] = c[0], c[1], (ang + math.pi) % (2 * math.pi) - math.pi
    return out


def sweep(n_cycles: int = 3, samples_per_cycle: int = 720, d: Dimensions = DIMS) -> dict:
    """Sweep the paper's drive law over ``n_cycles`` periods (1 s each) with the closed-form
    analysis; report the smallest dyad sine and the extreme singular values of the closure
    Jacobian of the Pinocchio tree (points A, B, F; x-y rows) restricted to the six undriven
    coordinates. A zero smallest singular value would be a singular (locking or branching)
    configuration."""
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        model = pin.buildModelFromUrdf(str(write_urdf(Path(tmp) / "nine_bar.urdf", d)))
    data = model.createData()
    free = [model.joints[model.getJointId(j)].idx_v for j in JOINTS if j not in DRIVES.values()]
    pairs = [("crank1", (d.L1, 0, 0), "coupler2", (d.L2, 0, 0)),
             ("crank4", (d.L4, 0, 0), "link3", (d.L3, 0, 0)),
             ("link8", (d.L8, 0, 0), "slider9", (0, 0, 0))]
    pts = [(model.getJointId(_JOINT_OF[a]), np.array(pa, float), model.getJointId(_JOINT_OF[b]),
            np.array(pb, float)) for a, pa, b, pb in pairs]
    smin, smax, sines_min, t_at = np.inf, 0.0, np.full(3, np.inf), 0.0
    J = np.zeros((6, model.nv))
    for t in np.linspace(0.0, float(n_cycles), n_cycles * samples_per_cycle + 1):
        r = positions(OMEGA1 * t + THETA1_0, OMEGA4 * t + THETA4_0, d)
        sines_min = np.minimum(sines_min, r["sines"])
        q = tree_configuration(model, r["tree"])
        pin.computeJointJacobians(model, data, q)
        for k, (j1, p1, j2, p2) in enumerate(pts):
            J[2 * k:2 * k + 2] = (_point_jac(model, data, j1, p1) - _point_jac(model, data, j2, p2))[:2]
        sv = np.linalg.svd(J[:, free], compute_uv=False)
        smax = max(smax, sv[0])
        if sv[-1] < smin:
            smin, t_at = sv[-1], t
    # the law has period 1 s, so every cycle repeats: report the time within the period
    return {"min_singular_value": float(smin), "t_min": float(t_at % 1.0), "max_singular_value": float(smax),
            "min_sines": sines_min, "cycles": n_cycles}

def _point_jac(model, data, jid, p_local):
    """World-frame linear Jacobian (3 x nv) of a point fixed on joint ``jid``'s body."""
    Jj = pin.getJointJacobian(model, data, jid, pin.LOCAL_WORLD_ALIGNED)
    r = data.oMi[jid].rotation @ p_local
    return Jj[:3] + np.cross(Jj[3:].T, r).T          # v_p = v_o + w x r


def main(argv=None) -> int:
    """Regenerate urdf/nine_bar.urdf and urdf/nine_bar.yaml (default: the repository's urdf/),
    then print the singularity sweep over three periods of the paper's drive law."""
    argv = sys.argv[1:] if argv is None else argv
    out = Path(argv[0]) if argv else URDF_DIR
    write_urdf(out / "nine_bar.urdf")
    write_sidecar(out / "nine_bar.yaml")
    print(f"wrote {out / 'nine_bar.urdf'} and {out / 'nine_bar.yaml'}")
    s = sweep(3)
    print(f"sweep over {s['cycles']} periods: restricted closure Jacobian singular values in "
          f"[{s['min_singular_value']:.4g}, {s['max_singular_value']:.4g}] m (min at t = {s['t_min']:.4g} s of each period); "
          f"dyad transmission sines >= {np.round(s['min_sines'], 3).tolist()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
