"""Compiled geometry of the prismatic clearance: the slider's corner channels against the guide,
the contact modes, the per-channel laws and the energy-consistent elastic foundation of its
faces (pinclear.contact.prismatic; maths: docs/contact_models.md).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np

from pinclear.core.jit import njit


class Modes(NamedTuple):
    """The prismatic joint's contact-mode classification (paper 003 Table 1): the four channels
    of each guide face, the mode number by (points, lines, planes), and the result (info:
    mode, counts, kind of each face)."""
    members: np.ndarray
    table: np.ndarray
    info: np.ndarray


class Foundation(NamedTuple):
    """The energy-consistent prismatic model's Winkler foundation: moduli kf of the x and y faces
    (Pa/m), hysteresis chi of the corner loads, onset-speed floor vmin, the clipped-polygon
    work array and the energy Uf of each face."""
    kf: np.ndarray
    chi: float
    vmin: float
    poly: np.ndarray
    Uf: np.ndarray


@njit(cache=True)
def prismatic_geometry(gpar, M1, M2, delta, n, p1, p2):
    """Corners of the slider box (half sizes gpar[2:5] in frame 2) against the guide faces at
    +-a'/2 (x1) and +-b'/2 (y1), gpar[0:2] = (a'/2, b'/2), paper 003 eq. 1: channel 2k + 0 is
    corner k against its x face, 2k + 1 against its y face; corner k has the signs of its
    bits (4: x, 2: y, 1: z). Contact points: the corner itself on both bodies."""
    ha, hb = gpar[0], gpar[1]
    for k in range(8):
        s1 = 1.0 if k & 4 else -1.0
        s2 = 1.0 if k & 2 else -1.0
        s3 = 1.0 if k & 1 else -1.0
        cx, cy, cz = s1 * gpar[2], s2 * gpar[3], s3 * gpar[4]
        r0 = 0.0
        r1 = 0.0
        for i in range(3):
            P = M2[i, 3] + (cx * M2[i, 0] + cy * M2[i, 1] + cz * M2[i, 2])
            p1[2 * k, i] = p1[2 * k + 1, i] = p2[2 * k, i] = p2[2 * k + 1, i] = P
            r0 += (P - M1[i, 3]) * M1[i, 0]
            r1 += (P - M1[i, 3]) * M1[i, 1]
            n[2 * k, i] = s1 * M1[i, 0]
            n[2 * k + 1, i] = s2 * M1[i, 1]
        delta[2 * k] = s1 * r0 - ha
        delta[2 * k + 1] = s2 * r1 - hb


@njit(cache=True)
def prismatic_mode(delta, members, modes, info):
    """Contact kind of each guide face from its touching corners and the paper's mode (paper 003
    Table 1): info = (mode, points, lines, planes, kind of face 0..3). members[f] are the four
    channels of face f (channel 2k + d: corner k)."""
    pts = lines = planes = 0
    for f in range(4):
        m = 0
        c0 = c1 = -1
        for j in range(4):
            ch = members[f, j]
            if delta[ch] > 0.0:
                if m == 0:
                    c0 = ch
                elif m == 1:
                    c1 = ch
                m += 1
        kind = K_NONE
        if m == 1:
            kind = K_POINT
            pts += 1
        elif m == 2:
            # corners differ in one sign: they share an edge, along the slide axis (bit 0) or across
            x = (c0 // 2) ^ (c1 // 2)
            if x == 1:
                kind = K_LINE_LONG
                lines += 1
            elif x == 2 or x == 4:
                kind = K_LINE_SHORT
                lines += 1
            else:
                kind = K_POINTS2
                pts += 2
        elif m > 2:
            kind = K_PLANE
            planes += 1
        info[4 + f] = kind
    info[1], info[2], info[3] = pts, lines, planes
    info[0] = modes[pts, lines, planes]


@njit(cache=True)
def prismatic_laws(info, members, table, code, P0, P1, chi, W):
    """Each channel's normal law and weight for the face kinds in info: a point law per touching
    corner, half a line load per edge end, a quarter of a plane load per corner (paper 003 sec.
    2.2). table rows: point, line_long, line_x, line_y, plane_x, plane_y (code, p0, p1, chi)."""
    for f in range(4):
        kind = info[4 + f]
        row, w = 0, 0.0
        if kind == K_POINT or kind == K_POINTS2:
            row, w = 0, 1.0
        elif kind == K_LINE_LONG:
            row, w = 1, 0.5
        elif kind == K_LINE_SHORT:
            row, w = (2 if f < 2 else 3), 0.5
        elif kind == K_PLANE:
            row, w = (4 if f < 2 else 5), 0.25
        for j in range(4):
            ch = members[f, j]
            code[ch] = int(table[row, 0])
            P0[ch], P1[ch], chi[ch] = table[row, 1], table[row, 2], table[row, 3]
            W[ch] = w


# ------------------------------------------------------------------ energy-consistent prismatic model
# Each of the slider's four side faces rests on a linear elastic foundation (Winkler) against
# the guide face it can reach: pressure p = kf delta(xi, eta) where it penetrates. The slider is
# rigid, so delta is affine over the face, and the penetrated region is the face rectangle
# clipped by a line. Potential U = kf/2 int delta^2 dA; its gradient is the virtual work of p,
# which bilinear shape functions N_j (exact for an affine field) lump onto the face's corner
# channels: F_j = int p N_j dA >= 0. Integrated exactly (degree-3 rule on the triangles of the
# clipped polygon), so the forces are the exact gradient of the reported energy and a corner, an
# edge and a face are limits of one law (F ~ delta^3, delta^2, delta). Maths: docs/contact_models.md.


@njit(cache=True)
def _tri_moments(x0, y0, d0, x1, y1, d1, x2, y2, d2):
    """int over the triangle of (d, d x, d y, d x y, d^2/2) for an affine d (vertex values d_i):
    the 7-point rule exact to degree 3 (vertices 3/60, edge midpoints 8/60, centroid 27/60)."""
    A = 0.5 * abs((x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0))
    s0 = s1 = s2 = s3 = s4 = 0.0
    for i in range(7):
        if i < 3:
            w = 3.0
            if i == 0:
                x, y, d = x0, y0, d0
            elif i == 1:
                x, y, d = x1, y1, d1
            else:
                x, y, d = x2, y2, d2
        elif i < 6:
            w = 8.0
            if i == 3:
                x, y, d = 0.5 * (x0 + x1), 0.5 * (y0 + y1), 0.5 * (d0 + d1)
            elif i == 4:
                x, y, d = 0.5 * (x1 + x2), 0.5 * (y1 + y2), 0.5 * (d1 + d2)
            else:
                x, y, d = 0.5 * (x2 + x0), 0.5 * (y2 + y0), 0.5 * (d2 + d0)
        else:
            w = 27.0
            x, y, d = (x0 + x1 + x2) / 3.0, (y0 + y1 + y2) / 3.0, (d0 + d1 + d2) / 3.0
        s0 += w * d
        s1 += w * d * x
        s2 += w * d * y
        s3 += w * d * x * y
        s4 += w * 0.5 * d * d
    A /= 60.0
    return A * s0, A * s1, A * s2, A * s3, A * s4


#: rectangle corners in cyclic order as member indices j (xi sign: bit 1, eta sign: bit 0)
_CYCLE = (0, 2, 3, 1)


@njit(cache=True)
def foundation_face(d, hx, hy, kf, poly, F):
    """Nodal loads F[j] (j: member index, xi sign bit 1, eta sign bit 0) of a Winkler foundation
    of modulus kf (Pa/m) on the rectangle |xi| <= hx, |eta| <= hy, for the corner penetrations d
    (4,), and its elastic energy (returned). The affine field is the least-squares plane of the
    four corner values (equal to them for a rigid slider up to round-off)."""
    c0 = 0.25 * (d[0] + d[1] + d[2] + d[3])
    gx = 0.25 * ((d[2] + d[3]) - (d[0] + d[1])) / hx
    gy = 0.25 * ((d[1] + d[3]) - (d[0] + d[2])) / hy
    F[0] = F[1] = F[2] = F[3] = 0.0
    if c0 + abs(gx) * hx + abs(gy) * hy <= 0.0:
        return 0.0
    # clip the rectangle by delta > 0 (Sutherland-Hodgman, one line): at most 5 vertices
    m = 0
    for i in range(4):
        ji, jn = _CYCLE[i], _CYCLE[(i + 1) % 4]
        xi = hx if ji & 2 else -hx
        yi = hy if ji & 1 else -hy
        xn = hx if jn & 2 else -hx
        yn = hy if jn & 1 else -hy
        di = c0 + gx * xi + gy * yi
        dn = c0 + gx * xn + gy * yn
        if di > 0.0:
            poly[m, 0], poly[m, 1], poly[m, 2] = xi, yi, di
            m += 1
        if (di > 0.0) != (dn > 0.0):
            t = di / (di - dn)
            poly[m, 0], poly[m, 1], poly[m, 2] = xi + t * (xn - xi), yi + t * (yn - yi), 0.0
            m += 1
    I0 = Ix = Iy = Ixy = U = 0.0
    for i in range(1, m - 1):
        a0, a1, a2, a3, a4 = _tri_moments(poly[0, 0], poly[0, 1], poly[0, 2], poly[i, 0], poly[i, 1], poly[i, 2],
                                          poly[i + 1, 0], poly[i + 1, 1], poly[i + 1, 2])
        I0 += a0
        Ix += a1
        Iy += a2
        Ixy += a3
        U += a4
    # N_j = (1 + sx xi/hx)(1 + sy eta/hy)/4
    for j in range(4):
        sx = 1.0 if j & 2 else -1.0
        sy = 1.0 if j & 1 else -1.0
        F[j] = 0.25 * kf * (I0 + sx * Ix / hx + sy * Iy / hy + sx * sy * Ixy / (hx * hy))
    return kf * U


@njit(cache=True)
def prismatic_foundation(gpar, kf, members, delta, poly, Fel, Uf):
    """Elastic nodal loads Fel of every corner channel and the energy Uf[f] of each face f
    (0, 1: the x faces, modulus kf[0], half widths b/2 x L/2; 2, 3: the y faces, kf[1], a/2 x
    L/2). members[f, j]: face f's channel with xi sign bit 1, eta sign bit 0 of j (the
    prismatic module's face table). Returns the number of faces in contact."""
    d4 = poly[5, 0:4]
    F4 = poly[6, 0:4]
    on = 0
    for f in range(4):
        for j in range(4):
            d4[j] = delta[members[f, j]]
        hx = gpar[3] if f < 2 else gpar[2]
        U = foundation_face(d4, hx, gpar[4], kf[0] if f < 2 else kf[1], poly, F4)
        Uf[f] = U
        if U > 0.0:
            on += 1
        for j in range(4):
            Fel[members[f, j]] = F4[j]
    return on


#: contact kinds of a guide face (pinclear.contact.prismatic.classify names them)
K_NONE, K_POINT, K_POINTS2, K_LINE_LONG, K_LINE_SHORT, K_PLANE = 0, 1, 2, 3, 4, 5
