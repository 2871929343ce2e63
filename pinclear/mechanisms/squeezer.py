"""Andrews' squeezing mechanism ("seven-body mechanism") as URDF + sidecar, with its references.

Sources: E. Hairer, G. Wanner, *Solving Ordinary Differential Equations II*, 2nd ed., Springer
1996, sec. VII.7 (the problem as formulated by W. Schiehlen, *Multibody Systems Handbook*,
Springer 1990, after G. Giles / M. Andrews); the "Test Set for IVP Solvers" (F. Mazzia,
C. Magherini, Univ. Bari; problem ``andrews``, Fortran source ``andrews.f``) gives every parameter,
the consistent initial values and a reference solution at t = 0.03 s (computed by its authors
with PSIDE at rtol = atol = 1e-14). Planar, no gravity, initially at rest; a constant torque
``mom`` on the crank (body 1) and a spring between point D of body 3 and the fixed point C.

Coordinates. The Test Set's seven angles (Hairer's fig. VII.7.1) are

====== ====== ======================================================================
angle  body   meaning
====== ====== ======================================================================
beta   1      crank about the fixed point O = (0, 0)
Theta  2      body 2 relative to body 1, about the crank's tip at distance rr from O
gamma  3      body 3 about the fixed point B = (xb, yb)
Phi    4      body 4 relative to body 5, about the point of body 5 at distance zt from A
delta  5      body 5 about the fixed point A = (xa, ya)
Omega  6      body 6 relative to body 7, about the point of body 7 at distance u from A
epsilon 7     body 7 about A
====== ====== ======================================================================

The far end of body 2 (distance d from its joint) is pinned to the ends of bodies 3, 4 and 6;
the Test Set's six constraints ``g(q) = 0`` state that the one point, reached along the three
branches, coincides:

    E = R(beta) (rr, 0) + R(beta + Theta) (-d, 0)
      = B + R(gamma) (0, -ss)
      = A + R(delta) (zt, 0) + R(delta + Phi) (0, -e)
      = A + R(epsilon) (0, -u) + R(epsilon + Omega) (zf, 0)

(R(a) the planar rotation by a; each line is one pair of rows of ``andrews.f``'s g). The URDF
is the spanning tree O -> body1 -> body2, B -> body3, A -> body5 -> body4, A -> body7 -> body6
of revolute joints about z, one joint per angle, named after it; every link frame is the
Test Set's body frame, rotated by the joint's own angle, so **each Pinocchio joint coordinate
is the Test Set's angle of the same name** (no offsets, no sign changes; only the order in q
differs, Pinocchio ordering parents before children: see :func:`q_from_angles`). The pins of
body 2 with bodies 3, 4 and 6 are cut as ``planar_point`` closures ``E3``, ``E4``, ``E6``
(2 rows each: the scene is planar), so nv = 7, 6 rows, mobility 1.

Mass properties. The mass matrix of ``andrews.f`` fixes the centres of mass: body 2's lies on
the line from its joint to E at distance da, body 4's at e - ea from its joint towards E, body
6's at zf - fa from its joint towards E (the cross terms m2 da rr cos Theta, m4 zt (e - ea)
sin Phi and m6 u (zf - fa) sin Omega fix both distance and direction). Bodies 1, 3, 5 and 7
turn about fixed points without gravity, so only the distance of their centre from the pivot
enters (m1 ra^2, m3 (sa^2 + sb^2), m5 (ta^2 + tb^2), m7 (ua^2 + ub^2)); the published
components are placed along the body frame's (x, y) axes, a choice that changes no motion.
The inertias I1..I7 are about the centres of mass, about z; the two in-plane moments, which a
planar motion never excites, are those of a thin plate (Ixx = Iyy = Izz / 2) so the tensor is
physical.

Run ``python -m pinclear.mechanisms.squeezer`` to regenerate urdf/squeezer.urdf and .yaml.
"""
from __future__ import annotations

import math
from pathlib import Path
from types import MappingProxyType

import numpy as np

from pinclear.mechanisms._common import URDF_DIR

NAME = "squeezer"
SOURCE = "Test Set for IVP Solvers (Mazzia, Magherini), problem andrews, andrews.f"
HW = "Hairer & Wanner, Solving ODEs II, sec. VII.7"

#: the Test Set's 42 parameters (SI: kg, m, kg m^2, N/m, N m), in andrews.f's order
P = MappingProxyType({
    "m1": 0.04325, "m2": 0.00365, "m3": 0.02373, "m4": 0.00706, "m5": 0.07050, "m6": 0.00706, "m7": 0.05498,
    "xa": -0.06934, "ya": -0.00227, "xb": -0.03635, "yb": 0.03273, "xc": 0.014, "yc": 0.072,
    "c0": 4530.0,
    "i1": 2.194e-6, "i2": 4.410e-7, "i3": 5.255e-6, "i4": 5.667e-7, "i5": 1.169e-5, "i6": 5.667e-7, "i7": 1.912e-5,
    "d": 28e-3, "da": 115e-4, "e": 2e-2, "ea": 1421e-5, "rr": 7e-3, "ra": 92e-5, "l0": 7785e-5,
    "ss": 35e-3, "sa": 1874e-5, "sb": 1043e-5, "sc": 18e-3, "sd": 2e-2, "ta": 2308e-5, "tb": 916e-5,
    "u": 4e-2, "ua": 1228e-5, "ub": 449e-5, "zf": 2e-2, "zt": 4e-2, "fa": 1421e-5, "mom": 33e-3,
})
UNITS = {**{f"m{k}": "kg" for k in range(1, 8)}, **{f"i{k}": "kg m^2" for k in range(1, 8)},
         "c0": "N/m", "mom": "N m"}
MEANING = {
    "m1": "mass of body 1 (crank)", "m2": "mass of body 2", "m3": "mass of body 3", "m4": "mass of body 4",
    "m5": "mass of body 5", "m6": "mass of body 6", "m7": "mass of body 7",
    "xa": "x of the fixed point A", "ya": "y of A", "xb": "x of the fixed point B", "yb": "y of B",
    "xc": "x of the fixed point C (spring anchor)", "yc": "y of C", "c0": "spring stiffness",
    "i1": "inertia of body 1 about its centre", "i2": "inertia of body 2 about its centre",
    "i3": "inertia of body 3 about its centre", "i4": "inertia of body 4 about its centre",
    "i5": "inertia of body 5 about its centre", "i6": "inertia of body 6 about its centre",
    "i7": "inertia of body 7 about its centre",
    "d": "body 2: joint to the pin E", "da": "body 2: joint to its centre (towards E)",
    "e": "body 4: joint to the pin E", "ea": "body 4: pin E to its centre",
    "rr": "body 1: O to the joint of body 2", "ra": "body 1: O to its centre", "l0": "spring free length",
    "ss": "body 3: B to the pin E", "sa": "body 3: centre, first component", "sb": "body 3: centre, second component",
    "sc": "body 3: spring point D, component along -y of the body frame", "sd": "body 3: spring point D, along x",
    "ta": "body 5: centre, first component", "tb": "body 5: centre, second component",
    "u": "body 7: A to the joint of body 6", "ua": "body 7: centre, first component",
    "ub": "body 7: centre, second component", "zf": "body 6: joint to the pin E",
    "zt": "body 5: A to the joint of body 4", "fa": "body 6: pin E to its centre",
    "mom": "constant driving torque on body 1",
}

#: the Test Set's angles in its order y(1..7), and the joint of each (same name)
ANGLES = ("beta", "Theta", "gamma", "Phi", "delta", "Omega", "epsilon")
#: consistent initial angles (andrews.f, subroutine init; at rest, t = 0)
ANGLES0 = MappingProxyType({
    "beta": -0.0617138900142764496358948458001, "Theta": 0.0,
    "gamma": 0.455279819163070380255912382449, "Phi": 0.222668390165885884674473185609,
    "delta": 0.487364979543842550225598953530, "Omega": -0.222668390165885884674473185609,
    "epsilon": 1.23054744454982119249735015568,
})
#: consistent initial accelerations (andrews.f, init; y(15), y(16), the others 0) [rad/s^2]
ACCEL0 = MappingProxyType({"beta": 14222.4439199541138705911625887, "Theta": -10666.8329399655854029433719415,
                           "gamma": 0.0, "Phi": 0.0, "delta": 0.0, "Omega": 0.0, "epsilon": 0.0})
#: reference solution at t = 0.03 s (andrews.f, subroutine solut: PSIDE, rtol = atol = 1e-14,
#: Cray C90 double precision): angles [rad] and rates [rad/s]
T_REF = 0.03
ANGLES_REF = MappingProxyType({
    "beta": 0.1581077119629904e+2, "Theta": -0.1575637105984298e+2, "gamma": 0.4082224013073101e-1,
    "Phi": -0.5347301163226948e+0, "delta": 0.5244099658805304e+0, "Omega": 0.5347301163226948e+0,
    "epsilon": 0.1048080741042263e+1,
})
RATES_REF = MappingProxyType({
    "beta": 0.1139920302151208e+4, "Theta": -0.1424379294994111e+4, "gamma": 0.1103291221937134e+2,
    "Phi": 0.1929337464421385e+2, "delta": 0.5735699284790808e+0, "Omega": -0.1929337464421385e+2,
    "epsilon": 0.3231791658026955e+0,
})

_LIMIT = '<limit lower="-1e9" upper="1e9" effort="1e9" velocity="1e9"/>'


def _fmt(v):
    return " ".join(repr(float(x)) for x in v)


def _plate_inertia(izz):
    """A planar body's central inertia: Izz as published, Ixx = Iyy = Izz / 2 (thin plate in x-y,
    the perpendicular-axis theorem), which the planar motion never excites."""
    return np.diag([izz / 2.0, izz / 2.0, izz])


def _link(name, m=None, com=(0.0, 0.0, 0.0), izz=None):
    if m is None:
        return f'  <link name="{name}"/>\n'
    I = [float(x) for x in np.diag(_plate_inertia(izz))]
    return (f'  <link name="{name}">\n    <inertial>\n      <origin xyz="{_fmt(com)}" rpy="0 0 0"/>\n'
            f'      <mass value="{float(m)!r}"/>\n'
            f'      <inertia ixx="{I[0]!r}" ixy="0.0" ixz="0.0" iyy="{I[1]!r}" iyz="0.0" izz="{I[2]!r}"/>\n'
            f'    </inertial>\n  </link>\n')


def _joint(name, parent, child, xyz):
    return (f'  <joint name="{name}" type="revolute">\n    <parent link="{parent}"/><child link="{child}"/>\n'
            f'    <origin xyz="{_fmt(xyz)}" rpy="0 0 0"/><axis xyz="0.0 0.0 1.0"/>{_LIMIT}\n  </joint>\n')


def body_points(p=P):
    """Points fixed to each body in its own frame (the frame turned by the body's absolute angle,
    origin at its joint), as the Test Set's g(q) and mass matrix place them: centres of mass
    ``com{k}``, the pin E on bodies 2, 3, 4, 6, the spring point D on body 3, and the joints of
    the child bodies 2, 4, 6 on their parents 1, 5, 7."""
    return {
        "com1": (p["ra"], 0.0), "com2": (-p["da"], 0.0), "com3": (p["sa"], p["sb"]),
        "com4": (0.0, -(p["e"] - p["ea"])), "com5": (p["ta"], p["tb"]), "com6": (p["zf"] - p["fa"], 0.0),
        "com7": (p["ua"], p["ub"]),
        "E2": (-p["d"], 0.0), "E3": (0.0, -p["ss"]), "E4": (0.0, -p["e"]), "E6": (p["zf"], 0.0),
        "D3": (p["sd"], -p["sc"]),
        "joint2": (p["rr"], 0.0), "joint4": (p["zt"], 0.0), "joint6": (0.0, -p["u"]),
    }


def urdf_text(p=P):
    b = body_points(p)

    def xyz(key):
        return (*b[key], 0.0)

    body = _link("ground")
    for k in range(1, 8):
        body += _link(f"body{k}", p[f"m{k}"], xyz(f"com{k}"), p[f"i{k}"])
    body += _joint("beta", "ground", "body1", (0.0, 0.0, 0.0))
    body += _joint("Theta", "body1", "body2", xyz("joint2"))
    body += _joint("gamma", "ground", "body3", (p["xb"], p["yb"], 0.0))
    body += _joint("delta", "ground", "body5", (p["xa"], p["ya"], 0.0))
    body += _joint("Phi", "body5", "body4", xyz("joint4"))
    body += _joint("epsilon", "ground", "body7", (p["xa"], p["ya"], 0.0))
    body += _joint("Omega", "body7", "body6", xyz("joint6"))
    return (f'<?xml version="1.0"?>\n<!-- generated by pinclear.mechanisms.squeezer.urdf_text; edit the '
            f'generator, not this file -->\n<robot name="{NAME}">\n{body}</robot>\n')


def _param(name, value, unit, source):
    return {"name": name, "value": value, "unit": unit, "source": source}


def sidecar(p=P):
    b = body_points(p)

    def at(parent, key):
        return {"parent": parent, "xyz": [*b[key], 0.0]}

    closures = [{"name": f"E{k}", "type": "planar_point", "frame1": at("body2", "E2"),
                 "frame2": at(f"body{k}", f"E{k}"), "normal": [0.0, 0.0, 1.0]} for k in (3, 4, 6)]
    params = [_param(k, v, UNITS.get(k, "m"), f"{SOURCE}: {MEANING[k]}") for k, v in p.items()]
    params += [_param(f"{a}0", ANGLES0[a], "rad", f"{SOURCE}, subroutine init: consistent initial value "
                      f"({HW}, fig. 7.1)") for a in ANGLES]
    params += [
        _param("v0", 0.0, "rad/s", f"{SOURCE}, init: the mechanism starts at rest"),
        _param("gravity", 0.0, "m/s^2", f"{HW}: no gravity in the problem"),
        _param("t_end", T_REF, "s", f"{SOURCE}: integration interval [0, 0.03] s"),
        _param("in_plane_inertia", 0.5, "-", "reconstructed: Ixx = Iyy = Izz/2 (thin plate); planar motion "
               "never excites them"),
        _param("com_directions", 0.0, "rad", "reconstructed: the centres of bodies 1, 3, 5, 7 lie at (ra, 0), "
               "(sa, sb), (ta, tb), (ua, ub) in their body frames; about a fixed pivot without gravity only "
               "the distance enters the motion"),
    ]
    params += [_param(f"{a}_ref", ANGLES_REF[a], "rad", f"{SOURCE}, subroutine solut: angle at t = 0.03 s "
                      "(PSIDE, rtol = atol = 1e-14)") for a in ANGLES]
    return {
        "name": NAME,
        "urdf": f"{NAME}.urdf",
        "description": ("Andrews' squeezing mechanism (Hairer & Wanner VII.7, Test Set 'andrews'): 7 bodies, 3 loop "
                        "closures, a spring and a constant torque; planar, no gravity, 0.03 s from rest"),
        "gravity": [0.0, 0.0, 0.0],
        "initial": {"q": {a: ANGLES0[a] for a in ANGLES}, "v": {a: 0.0 for a in ANGLES}},
        "closures": closures,
        "forces": [
            {"name": "spring", "type": "spring_damper", "frame1": at("body3", "D3"),
             "frame2": {"parent": "ground", "xyz": [p["xc"], p["yc"], 0.0]},
             "k": p["c0"], "c": 0.0, "free_length": p["l0"]},
            {"name": "motor", "type": "joint_force", "joint": "beta", "law": {"type": "constant", "value": p["mom"]}},
        ],
        "parameters": params,
    }


def write(folder=URDF_DIR):
    from pinclear.mechanisms.benchmarks import _write_sidecar

    folder = Path(folder)
    (folder / f"{NAME}.urdf").write_text(urdf_text())
    head = ("# Generated by pinclear.mechanisms.squeezer (python -m pinclear.mechanisms.squeezer).\n"
            "# Andrews' squeezing mechanism; each joint coordinate is the Test Set's angle of the same name.\n"
            "# Pins E3, E4, E6 (body 2 with bodies 3, 4, 6) are planar_point closures; plane x-y, axes z.\n")
    _write_sidecar(folder / f"{NAME}.yaml", sidecar(), head)


# ----------------------------------------------------------------------------- coordinates
def q_from_angles(model, angles):
    """Pinocchio q (or v, same layout: revolute joints) from a mapping angle name -> value."""
    q = np.zeros(model.nq)
    for a in ANGLES:
        q[model.joints[model.getJointId(a)].idx_q] = angles[a]
    return q


def angles_from_q(model, q):
    """The Test Set's angle vector y(1..7) (order ANGLES) from a Pinocchio q (or v)."""
    return np.array([q[model.joints[model.getJointId(a)].idx_q] for a in ANGLES])


# ----------------------------------------------------------------------------- Hairer's form
def testset_terms(y, yp, p=P):
    """The problem as Hairer & Wanner (VII.7) and andrews.f write it, in the Test Set's angles
    y = (beta, Theta, gamma, Phi, delta, Omega, epsilon) and rates yp: returns (M, f, G, g, c) of

        M(y) y'' = f(y, y') - G(y)^T lam,    g(y) = 0,   G = dg/dy,

    and c = (dG/dt) y', the velocity part of d^2 g / dt^2 = G y'' + c (index-1 form: G y'' = -c).

    Written here from the published equations, independently of Pinocchio: the tests compare
    pinclear's mass matrix, forces and closure rows with it."""
    be, th, ga, ph, de, om, ep = y
    bep, thp, _, php, dep, omp, epp = yp
    m1, m2, m3, m4, m5, m6, m7 = (p[f"m{k}"] for k in range(1, 8))
    i1, i2, i3, i4, i5, i6, i7 = (p[f"i{k}"] for k in range(1, 8))
    rr, d, da, ra, e, ea, zt = p["rr"], p["d"], p["da"], p["ra"], p["e"], p["ea"], p["zt"]
    u, zf, fa, ss = p["u"], p["zf"], p["fa"], p["ss"]
    e4, f6 = e - ea, zf - fa                  # joint-to-centre distances of bodies 4 and 6
    sth, cth, sph, cph, som, com = math.sin(th), math.cos(th), math.sin(ph), math.cos(ph), math.sin(om), math.cos(om)
    M = np.zeros((7, 7))
    M[0, 0] = m1 * ra ** 2 + m2 * (rr ** 2 - 2 * da * rr * cth + da ** 2) + i1 + i2
    M[1, 0] = M[0, 1] = m2 * (da ** 2 - da * rr * cth) + i2
    M[1, 1] = m2 * da ** 2 + i2
    M[2, 2] = m3 * (p["sa"] ** 2 + p["sb"] ** 2) + i3
    M[3, 3] = m4 * e4 ** 2 + i4
    M[4, 3] = M[3, 4] = m4 * (e4 ** 2 + zt * e4 * sph) + i4
    M[4, 4] = m4 * (zt ** 2 + 2 * zt * e4 * sph + e4 ** 2) + m5 * (p["ta"] ** 2 + p["tb"] ** 2) + i4 + i5
    M[5, 5] = m6 * f6 ** 2 + i6
    M[6, 5] = M[5, 6] = m6 * (f6 ** 2 - u * f6 * som) + i6
    M[6, 6] = m6 * (f6 ** 2 - 2 * u * f6 * som + u ** 2) + m7 * (p["ua"] ** 2 + p["ub"] ** 2) + i6 + i7
    # spring: from D on body 3 to C, force -c0 (L - l0) along (D - C)/L applied at D
    sga, cga = math.sin(ga), math.cos(ga)
    xd = p["sd"] * cga + p["sc"] * sga + p["xb"]
    yd = p["sd"] * sga - p["sc"] * cga + p["yb"]
    L = math.hypot(xd - p["xc"], yd - p["yc"])
    k = -p["c0"] * (L - p["l0"]) / L
    fx, fy = k * (xd - p["xc"]), k * (yd - p["yc"])
    f = np.array([
        p["mom"] - m2 * da * rr * thp * (thp + 2 * bep) * sth,
        m2 * da * rr * bep ** 2 * sth,
        fx * (p["sc"] * cga - p["sd"] * sga) + fy * (p["sd"] * cga + p["sc"] * sga),
        m4 * zt * e4 * dep ** 2 * cph,
        -m4 * zt * e4 * php * (php + 2 * dep) * cph,
        -m6 * u * f6 * epp ** 2 * com,
        m6 * u * f6 * omp * (omp + 2 * epp) * com,
    ])
    sbe, cbe = math.sin(be), math.cos(be)
    sbt, cbt = math.sin(be + th), math.cos(be + th)
    spd, cpd = math.sin(ph + de), math.cos(ph + de)
    soe, coe = math.sin(om + ep), math.cos(om + ep)
    sde, cde, sep, cep = math.sin(de), math.cos(de), math.sin(ep), math.cos(ep)
    ex, ey = rr * cbe - d * cbt, rr * sbe - d * sbt          # the pin E reached along bodies 1, 2
    g = np.array([ex - ss * sga - p["xb"], ey + ss * cga - p["yb"],
                  ex - e * spd - zt * cde - p["xa"], ey + e * cpd - zt * sde - p["ya"],
                  ex - zf * coe - u * sep - p["xa"], ey - zf * soe + u * cep - p["ya"]])
    G = np.zeros((6, 7))
    G[0::2, 0], G[1::2, 0] = -rr * sbe + d * sbt, rr * cbe - d * cbt
    G[0::2, 1], G[1::2, 1] = d * sbt, -d * cbt
    G[0, 2], G[1, 2] = -ss * cga, -ss * sga
    G[2, 3], G[3, 3] = -e * cpd, -e * spd
    G[2, 4], G[3, 4] = -e * cpd + zt * sde, -e * spd - zt * cde
    G[4, 5], G[5, 5] = zf * soe, -zf * coe
    G[4, 6], G[5, 6] = zf * soe - u * cep, -zf * coe - u * sep
    # each term r cos(a) or r sin(a) of g contributes -r cos(a) a'^2 or -r sin(a) a'^2
    w1, w12 = bep ** 2, (bep + thp) ** 2
    cx, cy = -rr * cbe * w1 + d * cbt * w12, -rr * sbe * w1 + d * sbt * w12
    c = np.array([cx + ss * sga * yp[2] ** 2, cy - ss * cga * yp[2] ** 2,
                  cx + e * spd * (php + dep) ** 2 + zt * cde * dep ** 2,
                  cy - e * cpd * (php + dep) ** 2 + zt * sde * dep ** 2,
                  cx + zf * coe * (omp + epp) ** 2 + u * sep * epp ** 2,
                  cy + zf * soe * (omp + epp) ** 2 - u * cep * epp ** 2])
    return M, f, G, g, c


if __name__ == "__main__":
    write()
