"""URDF text of links and joints, and the mass properties the writers share (a thin rod's
central inertia): the one writer of the builder and the bundled generators.
"""
from __future__ import annotations

from xml.sax.saxutils import quoteattr

import numpy as np


def attr(text) -> str:
    """An XML attribute value, quoted and escaped: a name is never markup."""
    return quoteattr(str(text))


def _fmt(v):
    return " ".join(repr(float(x)) for x in v)


def urdf_link(name, inertial=None):
    if inertial is None:
        return f'  <link name={attr(name)}/>\n'
    m, c, I = inertial
    return (f'  <link name={attr(name)}>\n    <inertial>\n      <origin xyz="{_fmt(c)}" rpy="0 0 0"/>\n'
            f'      <mass value="{m!r}"/>\n'
            f'      <inertia ixx="{float(I[0, 0])!r}" ixy="{float(I[0, 1])!r}" ixz="{float(I[0, 2])!r}" '
            f'iyy="{float(I[1, 1])!r}" iyz="{float(I[1, 2])!r}" izz="{float(I[2, 2])!r}"/>\n'
            f'    </inertial>\n  </link>\n')


def urdf_joint(name, jtype, parent, child, xyz=(0, 0, 0), axis=None, limits=None, rpy=(0, 0, 0)):
    s = (f'  <joint name={attr(name)} type={attr(jtype)}>\n    <parent link={attr(parent)}/>\n'
         f'    <child link={attr(child)}/>\n    <origin xyz="{_fmt(xyz)}" rpy="{_fmt(rpy)}"/>\n')
    if axis is not None:
        s += f'    <axis xyz="{_fmt(axis)}"/>\n'
    if limits is not None:
        s += f'    <limit lower="{limits[0]:.12g}" upper="{limits[1]:.12g}" effort="1e6" velocity="100"/>\n'
    return s + "  </joint>\n"


def thin_rod(m, L, axial=1e-7):
    """Central inertia of a uniform thin rod along local x: I = m L^2 / 12 about y and z. The
    loader rejects a zero principal moment, so the axial one is a token ``axial`` (kg m^2): in
    planar motion about z it never enters the dynamics."""
    i = m * L * L / 12.0
    return np.diag([axial, i, i])
