"""Benchmark mechanisms of the multibody community, as URDF + sidecar, with their references.

* **IFToMM A02, "N-four-bar"** (library of computational benchmark problems, M. González et
  al., Multibody Syst. Dyn. 16 (2006) 179-190; http://lim.ii.udc.es/mbsbenchmark/, problem A02).
  N parallelograms in a row: N + 1 cranks pinned to the ground 1 m apart and N couplers joined
  end to end, 2N + 1 bars of 1 m and 1 kg (uniform thin rods), gravity 9.81 m/s^2 along -y.
  Published start: the cranks at 45 deg, point B0 (tip of the first crank) moving at 1 m/s
  along +x, hence crank rate -1 / (L sin 45 deg) = -sqrt(2) rad/s. The library runs N = 40 for
  20 s; the bundled scenes take N = 1, 2, 10 for 10 s. In the flat position (cranks horizontal) the
  closure Jacobian loses N rows of rank: the mobility jumps from 1 to N + 1 (the spec's words),
  so a method must keep the parallelogram branch through a bifurcation twice per swing.

  Spanning tree: ground -> crank k (joint ``crank{k}_joint`` at x = k L, k = 0..N), crank 0 ->
  coupler 1 -> coupler 2 -> ... -> coupler N (joints ``coupler{k}_joint``). The pins where crank
  k (k >= 1) meets the end of coupler k are cut as ``planar_point`` closures ``B{k}`` (2 rows):
  nv = 2N + 1, 2N rows, mobility 1 (Grübler's planar count gives 1 as well: no row is redundant
  away from the flat position).

  On the parallelogram branch every crank has angle th, coupler 1 turns by -th relative to
  crank 0 and the other couplers by 0: the motion is a 1-dof pendulum with constant inertia
  ``I = (N + 1) m L^2 / 3 + N m L^2`` and potential ``V = ((N + 1) / 2 + N) m g L sin th``
  (:func:`a02_branch_rhs`), independent of Pinocchio.

* **IFToMM A04, Bricard's mechanism** (same library, problem A04). Five rods of 1 m, 1 kg,
  square section 0.1 m, six revolute joints closing one loop through the ground. In the
  published initial position the rods run along the edges of a unit cube:
  P0 = (0,0,0) -> P1 = (1,0,0) -> P2 = (1,-1,0) -> P3 = (1,-1,1) -> P4 = (0,-1,1) ->
  P5 = (0,0,1) -> P0 (the last edge is the ground), each joint axis perpendicular to both rods
  it joins (y, z, x, y, z, x at P0..P5; the geometry of S. Acuña's simEngine3D driver for A04,
  which follows the library's figure). Grübler's count gives 6 - 6 = 0; the special axes give
  mobility 1 with one redundant constraint in every configuration. Gravity along -y.
  Tree: ground -> rod1 -> ... -> rod5 (joints ``J0``..``J4``), the joint at P5 cut as a
  ``revolute`` closure ``J5`` (5 rows on nv = 5: rank 4). The library's initial velocity was
  not retrieved: the mechanism starts from rest and falls under gravity (reconstructed).

* **Slider-crank with a revolute clearance at the piston pin** (P. Flores, J. Ambrósio,
  J.C.P. Claro, H.M. Lankarani, "Kinematics and Dynamics of Multibody Systems with Imperfect
  Joints", LNACM 34, Springer 2008, and their papers of 2004-2006): crank 0.05 m, connecting
  rod 0.12 m, crank driven at 5000 rpm, radial clearance 0.5 mm, journal radius 10 mm,
  Lankarani-Nikravesh law, ce = 0.9, steel. Masses and inertias are the values usually quoted
  from that work (crank 0.30 kg / 1.0e-4 kg m^2, rod 0.21 kg / 2.5e-4 kg m^2, slider 0.14 kg);
  the search tool found no copy of the text, so every number is marked "recalled, not
  verified". Tree: ground -> crank (``crank_joint``) -> rod (``rod_joint``); ground -> slider
  (prismatic ``slider_joint`` along x); the piston pin is the ``planar_point`` closure ``P``
  (bearing frame1 on the slider, journal frame2 at the rod's end), replaced by the
  ``planar_revolute`` clearance ``P`` when activated. Ideal kinematics in closed form:
  :func:`slider_position`.

Run ``python -m pinclear.mechanisms.benchmarks`` to regenerate the five URDF + sidecar pairs.
"""
from __future__ import annotations

import math
from pathlib import Path
from types import MappingProxyType

import numpy as np

from pinclear.io.urdf_write import thin_rod
from pinclear.mechanisms._common import URDF_DIR, axis_inertia

G = 9.81                     # m/s^2, along -y

# ----------------------------------------------------------------------------- A02
A02_L = 1.0                  # m, every bar
A02_M = 1.0                  # kg, every bar
A02_THETA0 = math.pi / 4     # rad, crank angle of the published start
A02_VB0X = 1.0               # m/s, x-velocity of B0 (tip of crank 0) at t = 0
A02_SIZES = (1, 2, 10)

# ----------------------------------------------------------------------------- A04
A04_L = 1.0
A04_M = 1.0
A04_SECTION = 0.1            # m, square cross-section side (library table)
#: joint points P0..P5 and axes; rod k runs from P_k to P_{k+1}, the ground from P5 to P0
A04_POINTS = np.array([[0, 0, 0], [1, 0, 0], [1, -1, 0], [1, -1, 1], [0, -1, 1], [0, 0, 1]], float)
A04_AXES = np.array([[0, 1, 0], [0, 0, 1], [1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 0, 0]], float)
A04_POINTS.setflags(write=False)        # constants, not state
A04_AXES.setflags(write=False)

# ----------------------------------------------------------------------------- slider-crank
SC = MappingProxyType({
    "r": 0.05, "l": 0.12,                          # m, crank and connecting rod
    "m_crank": 0.30, "I_crank": 1.0e-4,            # kg, kg m^2 (about the centre of mass)
    "m_rod": 0.21, "I_rod": 2.5e-4,
    "m_slider": 0.14,
    "rpm": 5000.0,
    "clearance": 5.0e-4, "radius": 0.01, "length": 0.02, "ce": 0.9,
})
SC_SOURCE = ("recalled from Flores, Ambrósio, Claro, Lankarani, LNACM 34 (2008) slider-crank "
             "tables; not verified against the text (no copy found by the search tool)")

_LIMIT = '<limit lower="-1e9" upper="1e9" effort="1e9" velocity="1e9"/>'


def _fmt(v):
    return " ".join(repr(float(x)) for x in v)


def _link(name, m=None, com=(0, 0, 0), I=None):
    if m is None:
        return f'  <link name="{name}"/>\n'
    I = np.asarray(I, float)
    I = np.where(np.abs(I) < 1e-15 * np.abs(I).max(), 0.0, I).tolist()    # rotation round-off
    return (f'  <link name="{name}">\n    <inertial>\n      <origin xyz="{_fmt(com)}" rpy="0 0 0"/>\n'
            f'      <mass value="{float(m)!r}"/>\n'
            f'      <inertia ixx="{I[0][0]!r}" ixy="{I[0][1]!r}" ixz="{I[0][2]!r}" iyy="{I[1][1]!r}" '
            f'iyz="{I[1][2]!r}" izz="{I[2][2]!r}"/>\n    </inertial>\n  </link>\n')


def _joint(name, parent, child, xyz, axis, kind="revolute"):
    return (f'  <joint name="{name}" type="{kind}">\n    <parent link="{parent}"/><child link="{child}"/>\n'
            f'    <origin xyz="{_fmt(xyz)}" rpy="0 0 0"/><axis xyz="{_fmt(axis)}"/>{_LIMIT}\n  </joint>\n')


def _robot(name, generator, body):
    return (f'<?xml version="1.0"?>\n<!-- generated by pinclear.mechanisms.benchmarks.{generator}; '
            f'edit the generator, not this file -->\n<robot name="{name}">\n{body}</robot>\n')


def square_rod(m, L, a):
    """Central inertia of a rod of square section a x a along local x."""
    return np.diag([m * a * a / 6.0, m * (L * L + a * a) / 12.0, m * (L * L + a * a) / 12.0])


def _write_sidecar(path, d, head):
    import yaml

    text = yaml.safe_dump(d, sort_keys=False, default_flow_style=None, width=110, allow_unicode=True)
    Path(path).write_text(head + text, encoding="utf-8")


# ============================================================================= A02
def a02_name(n):
    return f"a02_nfourbar_{n}"


def a02_urdf(n):
    L, m = A02_L, A02_M
    body = _link("ground")
    for k in range(n + 1):
        body += _link(f"crank{k}", m, (L / 2, 0, 0), thin_rod(m, L))
    for k in range(1, n + 1):
        body += _link(f"coupler{k}", m, (L / 2, 0, 0), thin_rod(m, L))
    for k in range(n + 1):
        body += _joint(f"crank{k}_joint", "ground", f"crank{k}", (k * L, 0, 0), (0, 0, 1))
    for k in range(1, n + 1):
        parent = "crank0" if k == 1 else f"coupler{k - 1}"
        body += _joint(f"coupler{k}_joint", parent, f"coupler{k}", (L, 0, 0), (0, 0, 1))
    return _robot(a02_name(n), "a02_urdf", body)


def a02_branch_state(n, theta, omega):
    """Joint positions and rates (by joint name) on the parallelogram branch at crank angle theta."""
    q = {f"crank{k}_joint": theta for k in range(n + 1)}
    v = {f"crank{k}_joint": omega for k in range(n + 1)}
    q["coupler1_joint"], v["coupler1_joint"] = -theta, -omega
    for k in range(2, n + 1):
        q[f"coupler{k}_joint"], v[f"coupler{k}_joint"] = 0.0, 0.0
    return q, v


def a02_initial_rate(theta=A02_THETA0, vb0x=A02_VB0X, L=A02_L):
    """Crank rate giving B0 = L (cos th, sin th) the x-velocity vb0x: -L sin(th) w = vb0x."""
    return -vb0x / (L * math.sin(theta))


def a02_sidecar(n):
    w0 = a02_initial_rate()
    q, v = a02_branch_state(n, A02_THETA0, w0)
    closures = [{"name": f"B{k}", "type": "planar_point",
                 "frame1": {"parent": f"crank{k}", "xyz": [A02_L, 0.0, 0.0]},
                 "frame2": {"parent": f"coupler{k}", "xyz": [A02_L, 0.0, 0.0]}} for k in range(1, n + 1)]
    return {
        "name": a02_name(n),
        "urdf": f"{a02_name(n)}.urdf",
        "description": (f"IFToMM benchmark A02: {n} parallelogram four-bar(s) in a row, {2 * n + 1} bars of 1 m "
                        "and 1 kg, gravity -y; passes the flat singular position twice a swing"),
        "gravity": [0.0, -G, 0.0],
        "initial": {"q": q, "v": v},
        "closures": closures,
        "parameters": [
            {"name": "N", "value": n, "unit": "-",
             "source": "issue 12 (the IFToMM library specifies N = 40; its OpenSim port N = 2)"},
            {"name": "L", "value": A02_L, "unit": "m", "source": "IFToMM A02 specification: links of 1 m"},
            {"name": "m", "value": A02_M, "unit": "kg",
             "source": "IFToMM A02 specification: uniformly distributed mass of 1 kg (thin rod, I = m L^2/12)"},
            {"name": "g", "value": G, "unit": "m/s^2", "source": "IFToMM A02 specification: 9.81 N/kg along -y"},
            {"name": "theta0", "value": A02_THETA0, "unit": "rad",
             "source": "IFToMM A02 figure: cranks at 45 deg (pi/4)"},
            {"name": "vB0x", "value": A02_VB0X, "unit": "m/s",
             "source": "IFToMM A02 specification: initial x-velocity of point B0 (crank 0 tip) 1 m/s"},
            {"name": "omega0", "value": w0, "unit": "rad/s",
             "source": "derived: -vB0x / (L sin theta0), every crank (parallelogram branch)"},
            {"name": "t_end", "value": 10.0, "unit": "s",
             "source": "issue 12 and the OpenSim port (the library runs 20 s)"},
        ],
    }


def a02_branch_rhs(n, L=A02_L, m=A02_M, g=G):
    """Right-hand side of the parallelogram branch as a 1-dof pendulum (th, th'):
    I th'' = -dV/dth with I = (N+1) m L^2 / 3 + N m L^2, V = ((N+1)/2 + N) m g L sin th."""
    inertia = (n + 1) * m * L * L / 3.0 + n * m * L * L
    grav = ((n + 1) / 2.0 + n) * m * g * L

    def f(t, y):
        return [y[1], -grav * math.cos(y[0]) / inertia]

    return f


def a02_branch_energy(n, theta, omega, L=A02_L, m=A02_M, g=G):
    inertia = (n + 1) * m * L * L / 3.0 + n * m * L * L
    return 0.5 * inertia * np.asarray(omega) ** 2 + ((n + 1) / 2.0 + n) * m * g * L * np.sin(theta)


def write_a02(n, folder=URDF_DIR):
    folder = Path(folder)
    (folder / f"{a02_name(n)}.urdf").write_text(a02_urdf(n))
    head = (f"# Generated by pinclear.mechanisms.benchmarks (python -m pinclear.mechanisms.benchmarks);\n"
            f"# IFToMM benchmark A02 with N = {n}. Pins B1..B{n} (crank k tip = coupler k end) are cut as\n"
            "# planar_point closures; plane x-y, axes z, gravity -y.\n")
    _write_sidecar(folder / f"{a02_name(n)}.yaml", a02_sidecar(n), head)


# ============================================================================= A04
def a04_urdf():
    L, m, a = A04_L, A04_M, A04_SECTION
    body = _link("ground")
    for k in range(5):
        d = A04_POINTS[k + 1] - A04_POINTS[k]
        # every link frame is world-aligned at q = 0 with its origin at the rod's first joint
        body += _link(f"rod{k + 1}", m, 0.5 * d, axis_inertia(square_rod(m, L, a), d))
    for k in range(5):
        parent = "ground" if k == 0 else f"rod{k}"
        origin = A04_POINTS[0] if k == 0 else A04_POINTS[k] - A04_POINTS[k - 1]
        body += _joint(f"J{k}", parent, f"rod{k + 1}", origin, A04_AXES[k])
    return _robot("a04_bricard", "a04_urdf", body)


def a04_sidecar():
    # the cut joint J5 at P5 (axis x): revolute closures take the frames' z axes as the axis
    rpy_x = [0.0, math.pi / 2, 0.0]
    return {
        "name": "a04_bricard",
        "urdf": "a04_bricard.urdf",
        "description": ("IFToMM benchmark A04: Bricard's overconstrained 6R loop, five 1 m / 1 kg rods; "
                        "mobility 1 though Grübler gives 0, one redundant constraint everywhere"),
        "gravity": [0.0, -G, 0.0],
        "initial": {"q": {f"J{k}": 0.0 for k in range(5)}, "v": {f"J{k}": 0.0 for k in range(5)}},
        "closures": [{"name": "J5", "type": "revolute",
                      "frame1": {"parent": "rod5", "xyz": (A04_POINTS[5] - A04_POINTS[4]).tolist(), "rpy": rpy_x},
                      "frame2": {"parent": "ground", "xyz": A04_POINTS[5].tolist(), "rpy": list(rpy_x)}}],
        "parameters": [
            {"name": "L", "value": A04_L, "unit": "m", "source": "IFToMM A04 specification: rods of 1 m"},
            {"name": "m", "value": A04_M, "unit": "kg", "source": "IFToMM A04 specification: rods of 1 kg"},
            {"name": "section", "value": A04_SECTION, "unit": "m",
             "source": "IFToMM A04 table (OpenSim port): square cross-section 0.1 m"},
            {"name": "points", "value": A04_POINTS.tolist(), "unit": "m",
             "source": ("IFToMM A04 figure as coded in S. Acuña's simEngine3D A04 driver: rods along the edges "
                        "of a unit cube, joint axes perpendicular to both rods they join")},
            {"name": "v0", "value": 0.0, "unit": "rad/s",
             "source": "reconstructed: the library's initial velocity was not retrieved; released from rest"},
            {"name": "t_end", "value": 10.0, "unit": "s", "source": "issue 12 and the OpenSim port"},
        ],
    }


def write_a04(folder=URDF_DIR):
    folder = Path(folder)
    (folder / "a04_bricard.urdf").write_text(a04_urdf())
    head = ("# Generated by pinclear.mechanisms.benchmarks (python -m pinclear.mechanisms.benchmarks);\n"
            "# IFToMM benchmark A04 (Bricard). The sixth joint (P5, axis x) is the revolute closure J5.\n")
    _write_sidecar(folder / "a04_bricard.yaml", a04_sidecar(), head)


# ============================================================================= slider-crank
def crank_rate(rpm=SC["rpm"]):
    return rpm * 2.0 * math.pi / 60.0


def slider_position(theta, r=SC["r"], l=SC["l"]):
    """Closed-form piston-pin position of the centred slider-crank: r cos th + sqrt(l^2 - r^2 sin^2 th)."""
    theta = np.asarray(theta, float)
    return r * np.cos(theta) + np.sqrt(l * l - (r * np.sin(theta)) ** 2)


def slider_crank_urdf():
    r, l = SC["r"], SC["l"]
    rod_I = np.diag([1e-7, SC["I_rod"], SC["I_rod"]])
    crank_I = np.diag([1e-7, SC["I_crank"], SC["I_crank"]])
    # the slider's rotational inertia never enters (it only translates); a 50 mm cube stands for it
    s = 0.05
    slider_I = np.eye(3) * SC["m_slider"] * s * s / 6.0
    body = (_link("ground") + _link("crank", SC["m_crank"], (r / 2, 0, 0), crank_I)
            + _link("rod", SC["m_rod"], (l / 2, 0, 0), rod_I) + _link("slider", SC["m_slider"], (0, 0, 0), slider_I)
            + _joint("crank_joint", "ground", "crank", (0, 0, 0), (0, 0, 1))
            + _joint("rod_joint", "crank", "rod", (r, 0, 0), (0, 0, 1))
            + _joint("slider_joint", "ground", "slider", (0, 0, 0), (1, 0, 0), kind="prismatic"))
    return _robot("slider_crank_clearance", "slider_crank_urdf", body)


def slider_crank_sidecar():
    r, l, w = SC["r"], SC["l"], crank_rate()
    return {
        "name": "slider_crank_clearance",
        "urdf": "slider_crank_clearance.urdf",
        "description": ("slider-crank (Flores et al.): crank 0.05 m at 5000 rpm, rod 0.12 m; piston pin P ideal or "
                        "a 0.5 mm planar revolute clearance (clearances: P)"),
        "gravity": [0.0, -G, 0.0],
        # crank at 0: rod along +x, slider at r + l; the rod's rate follows from the pin's y row
        "initial": {"q": {"crank_joint": 0.0, "rod_joint": 0.0, "slider_joint": r + l},
                    "v": {"crank_joint": w, "rod_joint": -w * (r + l) / l, "slider_joint": 0.0}},
        "closures": [{"name": "P", "type": "planar_point",
                      "frame1": {"parent": "slider", "xyz": [0.0, 0.0, 0.0]},
                      "frame2": {"parent": "rod", "xyz": [l, 0.0, 0.0]}}],
        "drives": [{"name": "crank_drive", "joint": "crank_joint",
                    "law": {"type": "polynomial", "coeffs": [0.0, w]}}],
        "clearances": [{
            "name": "P", "type": "planar_revolute", "closure": "P", "active": False,
            "clearance": SC["clearance"], "radius": SC["radius"], "length": SC["length"], "material": "steel",
            "normal_law": "lankarani_nikravesh", "ce": SC["ce"], "friction_law": "none",
            "notes": ("Flores et al.: c = 0.5 mm, journal radius 10 mm, Lankarani-Nikravesh, ce 0.9, steel "
                      "(E 207 GPa, nu 0.3), frictionless baseline (" + SC_SOURCE + "); reconstructed: "
                      "journal length 20 mm, default (conformal) stiffness")}],
        "parameters": [
            {"name": "r", "value": r, "unit": "m", "source": SC_SOURCE},
            {"name": "l", "value": l, "unit": "m", "source": SC_SOURCE},
            {"name": "m_crank", "value": SC["m_crank"], "unit": "kg", "source": SC_SOURCE},
            {"name": "I_crank", "value": SC["I_crank"], "unit": "kg m^2", "source": SC_SOURCE + "; about the centre"},
            {"name": "m_rod", "value": SC["m_rod"], "unit": "kg", "source": SC_SOURCE},
            {"name": "I_rod", "value": SC["I_rod"], "unit": "kg m^2", "source": SC_SOURCE + "; about the centre"},
            {"name": "m_slider", "value": SC["m_slider"], "unit": "kg", "source": SC_SOURCE},
            {"name": "crank_speed", "value": SC["rpm"], "unit": "rpm", "source": SC_SOURCE},
            {"name": "centres", "value": 0.5, "unit": "-",
             "source": "reconstructed: centres of mass at mid-length of crank and rod"},
            {"name": "gravity", "value": G, "unit": "m/s^2",
             "source": "reconstructed: -y, negligible at 5000 rpm (kept for the project's convention)"},
        ],
    }


def write_slider_crank(folder=URDF_DIR):
    folder = Path(folder)
    (folder / "slider_crank_clearance.urdf").write_text(slider_crank_urdf())
    head = ("# Generated by pinclear.mechanisms.benchmarks (python -m pinclear.mechanisms.benchmarks);\n"
            "# Flores et al.'s slider-crank with a revolute clearance at the piston pin P (inactive by\n"
            "# default: load(..., clearances=['P'])). Plane x-y, axes z, slider along x.\n")
    _write_sidecar(folder / "slider_crank_clearance.yaml", slider_crank_sidecar(), head)


def write_all(folder=URDF_DIR):
    for n in A02_SIZES:
        write_a02(n, folder)
    write_a04(folder)
    write_slider_crank(folder)


if __name__ == "__main__":
    write_all()
