"""Compiled inner loops of the clearance joints (numba), for the same reason as
pinclear.core.dense: the arithmetic per contact channel is a handful of flops, and ~30 small numpy
calls per right-hand side cost far more than the work. The maths is in pinclear.contact.base and
pinclear.contact.laws.
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from pinclear.contact.force_laws import F_LUGRE, channel_force, law_energy, lugre_channel, normal_force
from pinclear.contact.prismatic_geometry import prismatic_geometry
from pinclear.contact.radial_geometry import radial_geometry
from pinclear.contact.worn_geometry import worn_planar_geometry, worn_spherical_geometry
from pinclear.core.jit import njit
from pinclear.model.forces import add_wrenches, place_frames, relative_velocity


class Geometry(NamedTuple):
    """A joint's compiled geometry: its code (G_* below) and parameters (channel_geometry)."""
    code: int
    gpar: np.ndarray


class Channels(NamedTuple):
    """What one workspace writes per contact channel (ClearanceData's arrays): penetration
    delta, outward normal n, contact points p1 (body 1) and p2 (body 2), normal rate dd, slip
    velocity vt, floored onset speed dd0, normal force Fn and its elastic part Fel, force F2 on
    body 2 at p2, and a (4, 3) work array of the geometry."""
    delta: np.ndarray
    n: np.ndarray
    p1: np.ndarray
    p2: np.ndarray
    dd: np.ndarray
    vt: np.ndarray
    dd0: np.ndarray
    Fn: np.ndarray
    Fel: np.ndarray
    F2: np.ndarray
    scratch: np.ndarray


class Laws(NamedTuple):
    """Each channel's normal law (``NormalLaw.kernel_params()``): code, p0, p1, hysteresis chi,
    weight W (the share of a line or plane load a corner carries), and the joint's floor vmin
    of the onset speed the damping divides by."""
    code: np.ndarray
    P0: np.ndarray
    P1: np.ndarray
    chi: np.ndarray
    W: np.ndarray
    vmin: float


class Friction(NamedTuple):
    """The joint's friction law (``FrictionLaw.kernel_params()``): its code and parameters."""
    code: int
    par: np.ndarray


# The kernels below take the structured arguments above and unpack them once, at the top: the
# helpers they call take plain arrays, because handing a tuple of arrays to a compiled call, or
# reading its fields inside a loop of an inlined one, reference-counts every array each time
# (measured: the prismatic kernel ran 1.6x slower).


@njit(cache=True, inline="always")
def channel_friction(k, fcode, fpar, f, vt, n, F2, z, zdot):
    """Channel k's force on body 2 (F2[k]) from its normal load f and the friction law; for a
    law with states, their rates into zdot (same layout as z: [onset speeds (nc) | dissipated
    energy | 3 states per channel]). Returns the friction power -Ft . vt."""
    if fcode == F_LUGRE:
        b = n.shape[0] + 1 + 3 * k
        return lugre_channel(k, fpar, f, vt, n, z[b:b + 3], zdot[b:b + 3], F2)
    return channel_force(k, f, vt, n, fcode, fpar, F2)


@njit(cache=True, inline="always")
def free_flight(zdot, Fn, Fel, F2):
    """No channel touches: no force, nothing to integrate."""
    for k in range(zdot.shape[0]):
        zdot[k] = 0.0
    for k in range(Fn.shape[0]):
        Fn[k] = 0.0
        Fel[k] = 0.0
        F2[k, 0] = F2[k, 1] = F2[k, 2] = 0.0


@njit(cache=True, inline="always")
def onset_speeds(z, vmin, dd0, zdot):
    """dd0 = the recorded onset speeds floored at vmin (the damping divides by them); zdot = 0."""
    for k in range(zdot.shape[0]):
        zdot[k] = 0.0
    for k in range(dd0.shape[0]):
        dd0[k] = max(z[k], vmin)


#: geometry codes of the fused channel evaluation (``ClearanceJoint.geometry_code``)
G_SPHERICAL, G_PLANAR_REVOLUTE, G_REVOLUTE, G_PRISMATIC, G_WORN_PLANAR, G_WORN_SPHERICAL = 0, 1, 2, 3, 4, 5


@njit(cache=True)
def channel_geometry(code, gpar, M1, M2, scratch, delta, n, p1, p2):
    """The geometry hooks of the spherical and revolute joints (``_geometry``) from the frame
    placements M1 (socket/bearing) and M2 (ball/journal) as 4x4 homogeneous matrices.
    gpar = (c, R1, R2, ca, L); scratch is a (4, 3) work array: s, a, and two journal points."""
    if code == G_PRISMATIC:
        prismatic_geometry(gpar, M1, M2, delta, n, p1, p2)
        return
    if code == G_WORN_SPHERICAL:
        worn_spherical_geometry(gpar, M1, M2, delta, n, p1, p2, scratch)
        return
    c, R1, R2 = gpar[0], gpar[1], gpar[2]
    s, a, pts = scratch[0], scratch[1], scratch[2:4]
    for i in range(3):
        s[i] = M1[i, 3]
        a[i] = 0.0 if code == G_SPHERICAL else M1[i, 2]
        pts[0, i] = M2[i, 3]
    if code == G_WORN_PLANAR:
        worn_planar_geometry(gpar, M1, s, a, pts[0], delta, n, p1, p2, scratch)
        return
    if code != G_REVOLUTE:
        radial_geometry(s, a, pts[0:1], c, R1, R2, delta, n, p1, p2)
        return
    # journal ends against the bearing cylinder (channels 0, 1), centre against the thrust faces
    ca, half = gpar[3], 0.5 * gpar[4]
    u = 0.0
    for i in range(3):
        j = M2[i, 3]
        pts[0, i] = j + half * M2[i, 2]
        pts[1, i] = j - half * M2[i, 2]
        u += (j - s[i]) * a[i]
    radial_geometry(s, a, pts, c, R1, R2, delta[:2], n[:2], p1[:2], p2[:2])
    delta[2], delta[3] = u - ca, -u - ca
    for i in range(3):
        n[2, i], n[3, i] = a[i], -a[i]
        p1[2, i] = p1[3, i] = p2[2, i] = p2[3, i] = M2[i, 3]


@njit(cache=True, inline="always")
def channel_penetrations(geo, frames, ch, snap):
    """Penetration of every channel (the event values), values within ``snap`` of zero set to 0."""
    M, delta = frames.M, ch.delta
    place_frames(frames)
    channel_geometry(geo.code, geo.gpar, M[0], M[1], ch.scratch, delta, ch.n, ch.p1, ch.p2)
    for k in range(delta.shape[0]):
        if abs(delta[k]) < snap:
            delta[k] = 0.0


@njit(cache=True, inline="always")
def event_penetrations(geo, frames, ch, snap, g):
    """channel_penetrations into the event values g (ForceElement.event_kernel)."""
    channel_penetrations(geo, frames, ch, snap)
    delta = ch.delta
    for k in range(delta.shape[0]):
        g[k] = delta[k]


@njit(cache=True, inline="always")
def channel_forces(bodies, laws, fr, ch, v, z, tau, zdot):
    """After the geometry: relative velocity, each channel's normal law (times its weight W: the
    share of a line or plane load a corner carries) and the friction law, wrenches into tau;
    zdot = (0 per channel, dissipated power (Fn - Fel) dd - Ft . vt, friction-state rates).
    Returns the number of touching channels (0: free flight, no velocities computed, as in
    ClearanceJoint._compute)."""
    delta, n, p1, p2, dd, vt, dd0 = ch.delta, ch.n, ch.p1, ch.p2, ch.dd, ch.vt, ch.dd0
    Fn, Fel, F2 = ch.Fn, ch.Fel, ch.F2
    code, P0, P1, chi, W = laws.code, laws.P0, laws.P1, laws.chi, laws.W
    fcode, fpar = fr.code, fr.par
    nc = delta.shape[0]
    on = 0
    for k in range(nc):
        if delta[k] > 0.0:
            on += 1
    if on == 0:
        free_flight(zdot, Fn, Fel, F2)
        return 0
    relative_velocity(bodies.J, bodies.idx1, bodies.idx2, v, n, p1, p2, dd, vt)
    onset_speeds(z, laws.vmin, dd0, zdot)
    loss = 0.0
    for k in range(nc):
        f, fe = normal_force(code[k], delta[k], dd[k], dd0[k], P0[k], P1[k], chi[k])
        f *= W[k]
        fe *= W[k]
        Fn[k] = f
        Fel[k] = fe
        if delta[k] <= 0.0:
            F2[k, 0] = F2[k, 1] = F2[k, 2] = 0.0
            continue
        loss += (f - fe) * dd[k] + channel_friction(k, fcode, fpar, f, vt, n, F2, z, zdot)
    zdot[nc] = loss
    add_wrenches(bodies.J, bodies.idx1, bodies.idx2, F2, p1, p2, tau)
    return on


@njit(cache=True, inline="always")
def clearance_force(geo, frames, bodies, laws, fr, ch, v, z, tau, zdot):
    """One spherical or revolute clearance joint's whole right-hand-side contribution in one call,
    the same steps as ClearanceJoint._compute + add_force: its frames' placements from the
    workspace's frame kinematics, the geometry, then channel_forces."""
    M = frames.M
    place_frames(frames)
    channel_geometry(geo.code, geo.gpar, M[0], M[1], ch.scratch, ch.delta, ch.n, ch.p1, ch.p2)
    return channel_forces(bodies, laws, fr, ch, v, z, tau, zdot)


@njit(cache=True, inline="always")
def worn_clearance_force(geo, frames, bodies, laws, fr, ch, v, z, tau, zdot):
    """clearance_force of a worn bearing or socket: the normal law's force scaled by the weight the
    worn geometry leaves in scratch[3, 0] (1: its n is the exact gradient of its least-distance
    delta; laws.W is this workspace's own array)."""
    M = frames.M
    place_frames(frames)
    channel_geometry(geo.code, geo.gpar, M[0], M[1], ch.scratch, ch.delta, ch.n, ch.p1, ch.p2)
    laws.W[0] = ch.scratch[3, 0]
    return channel_forces(bodies, laws, fr, ch, v, z, tau, zdot)


#: layout of channel_record's output row: (name, start, size); potential last
RECORD = (("penetration", 0, 1), ("normal_force", 1, 3), ("friction_force", 4, 3), ("fn", 7, 1),
          ("contact", 8, 1), ("dissipated", 9, 1), ("eccentricity", 10, 3))
RECORD_SIZE = 14


@njit(cache=True)
def channel_record(delta, n, Fn, F2, M1, M2, dissipated, code, P0, P1, W, out):
    """One output sample of a clearance joint (ClearanceJoint.outputs, in the RECORD layout) and
    its elastic energy, from what the fused evaluation left: the deepest penetration, the normal
    and friction resultants on body 2 (world), the total normal force, contact (0/1), the
    dissipated energy, frame 2's origin in frame 1 axes (paper 000 eq. 3)."""
    out[:] = 0.0
    out[0] = delta[0]
    for k in range(delta.shape[0]):
        out[0] = max(out[0], delta[k])
        for i in range(3):
            out[1 + i] -= Fn[k] * n[k, i]
            out[4 + i] += F2[k, i] + Fn[k] * n[k, i]
        out[7] += Fn[k]
        if delta[k] > 0.0:
            out[8] = 1.0
            out[13] += W[k] * law_energy(code[k], delta[k], P0[k], P1[k])
    out[9] = dissipated
    for i in range(3):
        acc = 0.0
        for j in range(3):
            acc += M1[j, i] * (M2[j, 3] - M1[j, 3])
        out[10 + i] = acc


@njit(cache=True)
def clearance_record(ch, M, z, zdot, nc, code, P0, P1, W, work, row):
    """One output sample of a clearance joint (ClearanceJoint.record after its compiled force at
    this state): row = [elastic energy, dissipated power (the rate of its dissipation state), the
    RECORD outputs]."""
    channel_record(ch.delta, ch.n, ch.Fn, ch.F2, M[0], M[1], z[nc], code, P0, P1, W, work)
    row[0] = work[RECORD_SIZE - 1]
    row[1] = zdot[nc]
    for i in range(RECORD_SIZE - 1):
        row[2 + i] = work[i]


@njit(cache=True)
def worn_record(ch, M, z, zdot, nc, code, P0, P1, W, work, row):
    """clearance_record followed by the slip speed |vt| of the contact (0 without load): the
    Archard wear integrand's speed (pinclear.contact.wear), and the contact point on the worn
    surface p1 in frame1 (where the wear goes)."""
    clearance_record(ch, M, z, zdot, nc, code, P0, P1, W, work, row)
    vt = ch.vt
    slip = (vt[0, 0] * vt[0, 0] + vt[0, 1] * vt[0, 1] + vt[0, 2] * vt[0, 2]) ** 0.5
    row[RECORD_SIZE + 1] = slip if ch.Fn[0] > 0.0 else 0.0
    for i in range(3):
        acc = 0.0
        for j in range(3):
            acc += M[0, j, i] * (ch.p1[0, j] - M[0, j, 3])
        row[RECORD_SIZE + 2 + i] = acc


@njit(cache=True)
def total_normal_force(Fn, out, k):
    """out[k] = the joint's total normal force (the ``fn`` output): its contact-force peak's value."""
    acc = 0.0
    for i in range(Fn.shape[0]):
        acc += Fn[i]
    out[k] = acc
