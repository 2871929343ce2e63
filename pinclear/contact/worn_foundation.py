"""Elastic-foundation contact of a ball in a worn socket (docs/wear_lubrication.md sec. 11).

Why: on a worn socket the ball can touch in two places at once (two shallow basins of the mesh's
ripples, or a pocket's two walls); one least-distance contact then flips its normal between them
and a step-size controlled integrator stalls (sec. 8, Limits). Here the contact is distributed:
a Winkler-type foundation over the socket surface, pressure p = kappa d^(3/2) at the local overlap
d (measured along the socket's radius: the ray from the socket centre through the node meets the
ball's sphere at s, d = s - (R1 + w)), energy

    U_w(e) = sum_k A_k (2/5) d_k^(5/2)          (the sum over a fixed fine grid of the socket)

(Johnson 1985, Contact Mechanics, sec. 4.4's simple elastic foundation, with the 3/2 power so that
the unworn socket's energy grows as delta^(7/2) / alpha, close to the conforming Hertz contact's
reach). The paper's normal law K delta^n is kept: it acts on the effective penetration delta_eff,
the unworn socket's penetration that stores the same foundation energy, so the normal force is the
gradient of the one energy U_law(delta_eff(e)) and elastic runs conserve energy. With G the
unworn socket's foundation energy as a function of its penetration (exact to 1e-10 by a
Gauss-Jacobi rule in the overlap, below) and g its inverse,

    delta_eff = g(U_w) + kappa U_w / U_0,     kappa = delta_c - g(U_0),

U_0 the same grid sum with the depths set to zero and delta_c = |e| - c the unworn circle's
penetration: kappa removes the grid's quadrature error, so where the ball's cap holds no worn node
(U_w = U_0) delta_eff = delta_c and grad delta_eff = e / |e| to round-off, and where it touches no
node (U_w = 0) the least-distance contact (worn_geometry) stands.
"""
from __future__ import annotations

import math

from scipy.special import roots_jacobi

from pinclear.core.jit import njit

#: Gauss-Jacobi rules on [0, 1] for the weights t^(5/2) (G) and t^(3/2) (dG/d delta): the overlap
#: vanishes as a power at the cap's rim, which these weights carry exactly
_X5, _W5 = roots_jacobi(6, 0.0, 2.5)
_X3, _W3 = roots_jacobi(6, 0.0, 1.5)
T5, A5 = 0.5 * (_X5 + 1.0), _W5 / 2.0 ** 3.5
T3, A3 = 0.5 * (_X3 + 1.0), _W3 / 2.0 ** 2.5
#: foundation_penetration's status: no fine node in the unworn cap, all clear of the worn surface,
#: in contact
NO_NODE, CLEAR, FOUNDATION = 0, 1, 2
#: the cap radii (in fine cells) over which kappa's quadrature correction fades out (its beta)
KAPPA_CELLS = (8.0, 16.0)
#: Newton iterations of g = G^-1 (on G^(2/7), nearly linear in delta: 3-4 suffice)
INVERSE_ITER = 12


@njit(cache=True)
def unworn_energy(c, R1, R2, delta):
    """(G, dG/d delta) of the unworn socket at the penetration delta > 0 (ball centre at r = c +
    delta): G = 2 pi R1^2 int_0^delta (2/5) d^(5/2) / (ds/dx) dd over the overlap d = s - R1, with
    x = cos psi of the ray, s = r x + (R2^2 - r^2 + r^2 x^2)^(1/2) and x(d) in closed form from
    |(R1 + d) u - e| = R2; dG/d delta = 2 pi R1^2 int d^(3/2) (ds/dr) / (ds/dx) dd (the rim's term
    vanishes with d)."""
    r = c + delta
    G = 0.0
    for k in range(T5.shape[0]):
        A = R1 + delta * T5[k]
        x = (A * A - R2 * R2 + r * r) / (2.0 * A * r)
        q = A - r * x
        G += A5[k] / (r + r * r * x / q)
    dG = 0.0
    for k in range(T3.shape[0]):
        A = R1 + delta * T3[k]
        x = (A * A - R2 * R2 + r * r) / (2.0 * A * r)
        q = A - r * x
        dG += A3[k] * (x - r * (1.0 - x * x) / q) / (r + r * r * x / q)
    s = 2.0 * math.pi * R1 * R1
    return s * 0.4 * delta ** 3.5 * G, s * delta ** 2.5 * dG


@njit(cache=True)
def unworn_penetration(c, R1, R2, U):
    """(g, dg/dU): the unworn socket's penetration whose foundation energy is U > 0, and its
    derivative 1 / G'(g); Newton on G^(2/7) from the small-cap estimate G ~ (4 pi R1^2 / 35)
    delta^(7/2) / (r (1 + r / R2))."""
    d = (U * 35.0 * c * (1.0 + c / R2) / (4.0 * math.pi * R1 * R1)) ** (2.0 / 7.0)
    y = U ** (2.0 / 7.0)
    G, dG = unworn_energy(c, R1, R2, d)
    for _ in range(INVERSE_ITER):
        gy = G ** (2.0 / 7.0)
        step = (gy - y) / ((2.0 / 7.0) * gy / G * dG)
        d = max(d - step, 0.5 * d)
        G, dG = unworn_energy(c, R1, R2, d)
        if abs(step) <= 1e-15 * d:
            break
    return d, 1.0 / dG


@njit(cache=True, inline="always")
def deposit(vol, I, j, m, Np, x):
    """vol += x at the wear mesh node of row I whose cell [J - 1/2, J + 1/2) (in mesh columns) holds
    fine column j; with m even, every m-th fine node sits on a cell edge: half to each side."""
    J = (2 * j + m) // (2 * m)
    if (2 * j + m) % (2 * m) == 0:
        vol[I * Np + J % Np] += 0.5 * x
        vol[I * Np + (J - 1) % Np] += 0.5 * x
    else:
        vol[I * Np + J % Np] += x


@njit(cache=True, inline="always")
def node_terms(ea, eb, ep, ua, ub, up, b, R1):
    """(d0, t-factor pieces) of one node: the unworn overlap d0 = s - R1 along the node's direction
    u and (1 + e.u / q, 1 / q) of grad s = u (1 + e.u / q) - e / q, q = (R2^2 - r^2 + (e.u)^2)^(1/2)
    (b = R2^2 - r^2)."""
    eu = ea * ua + eb * ub + ep * up
    q = (b + eu * eu) ** 0.5
    return eu + q - R1, 1.0 + eu / q, 1.0 / q


@njit(cache=True, inline="always")
def node_load(area, d, fa, fq, ua, ub, up, ea, eb, ep):
    """One overlapping node's (A d^(3/2), energy A (2/5) d^(5/2), its gradient (3)): the terms the
    sums add (node_terms' fa, fq)."""
    t = area * d * d ** 0.5
    return t, 0.4 * t * d, t * (fa * ua - fq * ea), t * (fa * ub - fq * eb), t * (fa * up - fq * ep)


@njit(cache=True, inline="always")
def add_worn(acc, area, dw, fa, fq, ua, ub, up, ea, eb, ep, vol, scale, i, j, m, Np):
    """acc = (n, P, U_w, grad U_w (3)) with fine node (i, j)'s overlap dw of the worn surface
    added (and its load share scale A dw^(3/2) deposited on its mesh cell when scale > 0)."""
    t, u_, ga, gb, gp = node_load(area, dw, fa, fq, ua, ub, up, ea, eb, ep)
    if scale > 0.0:
        deposit(vol, i // m, j, m, Np, scale * t)
    return acc[0] + 1, acc[1] + t, acc[2] + u_, acc[3] + ga, acc[4] + gb, acc[5] + gp


@njit(cache=True)
def foundation_sums(gpar, f0, Ntf, Npf, m, R1, R2, c, ea, eb, ep, r, full, vol, scale):
    """The grid sums of a ball centre e (mesh axes, |e| = r > c): (n, U_w, U_0, grad U_w (3),
    grad U_0 (3), P), n the number of nodes that overlap the worn surface and P = sum A d^(3/2) over
    them (the foundation's load over its stiffness), over the fine nodes inside the unworn
    overlap's cap (cos psi > C0 = (R1^2 + r^2 - R2^2) / (2 R1 r), law of cosines: outside it
    neither surface is reached). ``full``: every node of the cap, U_0 too (cap_sums); otherwise
    U_w alone, over the blocks that can reach the worn surface (block_sums). With scale > 0 each
    worn node's load share scale A d^(3/2) is also added to vol at the wear mesh node whose cell
    holds it (foundation_deposit)."""
    C0 = (R1 * R1 + r * r - R2 * R2) / (2.0 * R1 * r)
    if C0 >= 1.0:
        return 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    psi0 = math.acos(C0)
    th_e = math.acos(min(max(ep / r, -1.0), 1.0))
    ph_e = math.atan2(eb, ea)
    if full:
        return cap_sums(gpar, f0, Ntf, Npf, m, R1, R2, ea, eb, ep, r, psi0, th_e, ph_e, vol, scale)
    return block_sums(gpar, f0, Ntf, Npf, m, R1, R2, ea, eb, ep, r, psi0, th_e, ph_e, vol, scale)


@njit(cache=True)
def cap_sums(gpar, f0, Ntf, Npf, m, R1, R2, ea, eb, ep, r, psi0, th_e, ph_e, vol, scale):
    """foundation_sums over every fine node of the cap of half-angle psi0 about (th_e, ph_e):
    the rows within psi0, in each the columns within it (haversine)."""
    U0 = g0a = g0b = g0p = 0.0
    acc = (0, 0.0, 0.0, 0.0, 0.0, 0.0)
    Np_ = Npf // m
    ht, hp = math.pi / Ntf, 2.0 * math.pi / Npf
    se = math.sin(th_e)
    b = R2 * R2 - r * r
    i_lo = max(int(math.floor((th_e - psi0) / ht - 0.5)), 0)
    i_hi = min(int(math.ceil((th_e + psi0) / ht - 0.5)), Ntf - 1)
    s2 = math.sin(0.5 * psi0) ** 2
    ch, sh = math.cos(hp), math.sin(hp)
    for i in range(i_lo, i_hi + 1):
        th = (i + 0.5) * ht
        st, ct = math.sin(th), math.cos(th)
        room = s2 - math.sin(0.5 * (th - th_e)) ** 2
        if room < 0.0:
            continue
        ss = st * se
        x = (room / ss) ** 0.5 if ss > 0.0 else 2.0
        K = Npf // 2 if x >= 1.0 else min(int(2.0 * math.asin(x) / hp) + 1, Npf // 2)
        j0 = int(math.floor(ph_e / hp + 0.5)) - K
        cp, sp = math.cos(j0 * hp), math.sin(j0 * hp)
        area = R1 * R1 * (math.cos(th - 0.5 * ht) - math.cos(th + 0.5 * ht)) * hp
        for k in range(min(2 * K + 1, Npf)):
            ua, ub = st * cp, st * sp
            cp, sp = cp * ch - sp * sh, sp * ch + cp * sh
            d0, fa, fq = node_terms(ea, eb, ep, ua, ub, ct, b, R1)
            if d0 <= 0.0:
                continue
            _, u_, ga, gb, gp = node_load(area, d0, fa, fq, ua, ub, ct, ea, eb, ep)
            U0 += u_
            g0a += ga
            g0b += gb
            g0p += gp
            j = (j0 + k) % Npf
            dw = d0 - gpar[f0 + i * Npf + j]
            if dw <= 0.0:
                continue
            acc = add_worn(acc, area, dw, fa, fq, ua, ub, ct, ea, eb, ep, vol, scale, i, j, m, Np_)
    return acc[0], acc[2], U0, acc[3], acc[4], acc[5], g0a, g0b, g0p, acc[1]


@njit(cache=True)
def block_sums(gpar, f0, Ntf, Npf, m, R1, R2, ea, eb, ep, r, psi0, th_e, ph_e, vol, scale):
    """foundation_sums' U_w alone, over the m x m blocks of fine nodes that can reach the worn
    surface: the block's least depth (stored after the fine depths) below the largest unworn
    overlap d0 over the block (d0 falls with the angle psi from e: at the block's least angle)."""
    acc = (0, 0.0, 0.0, 0.0, 0.0, 0.0)
    ht, hp = math.pi / Ntf, 2.0 * math.pi / Npf
    se = math.sin(th_e)
    b = R2 * R2 - r * r
    Nt, Np = Ntf // m, Npf // m
    bt, bp = math.pi / Nt, 2.0 * math.pi / Np
    chi = 0.5 * (bt * bt + bp * bp) ** 0.5          # a block's angular half-diagonal, at most
    ue = (ea / r, eb / r, ep / r)
    blocks = f0 + Ntf * Npf
    I_lo = max(int(math.floor((th_e - psi0 - chi) / bt)), 0)
    I_hi = min(int(math.floor((th_e + psi0 + chi) / bt)), Nt - 1)
    s2 = math.sin(min(0.5 * (psi0 + chi), 0.5 * math.pi)) ** 2
    for I in range(I_lo, I_hi + 1):
        thc = (I + 0.5) * bt
        room = s2 - math.sin(0.5 * max(abs(thc - th_e) - 0.5 * bt, 0.0)) ** 2
        if room < 0.0:
            continue
        # the least sin theta over the block row (the haversine's phi term weighs least there)
        ss = max(min(math.sin(thc - 0.5 * bt), math.sin(thc + 0.5 * bt)), 0.0) * se
        x = (room / ss) ** 0.5 if ss > 0.0 else 2.0
        K = Np // 2 if x >= 1.0 else min(int(2.0 * math.asin(x) / bp) + 2, Np // 2)
        J0 = int(math.floor(ph_e / bp - 0.5 * (m - 1) / m + 0.5)) - K
        for kb in range(min(2 * K + 1, Np)):
            J = (J0 + kb) % Np
            phc = (J * m + 0.5 * (m - 1)) * hp
            stc = math.sin(thc)
            cosc = stc * math.cos(phc) * ue[0] + stc * math.sin(phc) * ue[1] + math.cos(thc) * ue[2]
            psi_min = max(math.acos(min(max(cosc, -1.0), 1.0)) - chi, 0.0)
            if psi_min >= psi0:
                continue
            # the largest unworn overlap over the block, at its least angle from e
            d0max = r * math.cos(psi_min) + (R2 * R2 - (r * math.sin(psi_min)) ** 2) ** 0.5 - R1
            if d0max <= gpar[blocks + I * Np + J]:
                continue
            for a in range(m):
                i = I * m + a
                th = (i + 0.5) * ht
                st, ct = math.sin(th), math.cos(th)
                area = R1 * R1 * (math.cos(th - 0.5 * ht) - math.cos(th + 0.5 * ht)) * hp
                for bb in range(m):
                    j = J * m + bb
                    ph = j * hp
                    ua, ub = st * math.cos(ph), st * math.sin(ph)
                    d0, fa, fq = node_terms(ea, eb, ep, ua, ub, ct, b, R1)
                    dw = d0 - gpar[f0 + i * Npf + j]
                    if d0 <= 0.0 or dw <= 0.0:
                        continue
                    acc = add_worn(acc, area, dw, fa, fq, ua, ub, ct, ea, eb, ep, vol, scale, i, j, m, Np)
    return acc[0], acc[2], 0.0, acc[3], acc[4], acc[5], 0.0, 0.0, 0.0, acc[1]


@njit(cache=True)
def foundation_penetration(gpar, f0, Ntf, Npf, m, ea, eb, ep, r, spare):
    """(status, delta_eff, its gradient (3, mesh axes)): the effective penetration of the
    module's docstring where fine nodes overlap the worn surface (status FOUNDATION). Elsewhere the
    caller's least-distance contact stands: as it is where the unworn cap holds no node (NO_NODE:
    a contact narrower than a cell, continuous with delta_eff at U_w = U_0), held at <= 0 where
    the cap's nodes all clear the worn surface (CLEAR: delta_eff -> 0 as U_w -> 0, so the onset
    is continuous; spare: any writable float array, untouched). kappa's correction is weighted by beta, 1 while the cap's radius psi0 is within
    KAPPA_CELLS[0] fine cells and 0 beyond KAPPA_CELLS[1] (a smoothstep between): the grid's error
    falls as the cap widens (below 1e-4 of U_0 beyond 8 cells), and a wide cap with a worn node in
    it is a ball in a pocket, where U_w / U_0 is small; beyond it only the blocks that reach the
    worn surface are summed."""
    c, R1, R2 = gpar[0], gpar[1], gpar[2]
    if r <= c:
        return NO_NODE, 0.0, 0.0, 0.0, 0.0
    C0 = (R1 * R1 + r * r - R2 * R2) / (2.0 * R1 * r)
    psi0 = math.acos(min(C0, 1.0))
    ht = math.pi / Ntf
    lo, hi = KAPPA_CELLS[0] * ht, KAPPA_CELLS[1] * ht
    full = psi0 < hi
    # scale 0: nothing deposited (spare, a writable work row of the caller, only fills the argument)
    tw, Uw, U0, gwa, gwb, gwp, g0a, g0b, g0p, _ = foundation_sums(gpar, f0, Ntf, Npf, m, R1, R2, c, ea, eb, ep, r,
                                                                  full, spare, 0.0)
    if tw == 0:
        return NO_NODE if (full and U0 == 0.0) else CLEAR, 0.0, 0.0, 0.0, 0.0
    gw, dgw = unworn_penetration(c, R1, R2, Uw)
    da, db, dp = dgw * gwa, dgw * gwb, dgw * gwp
    if not full:
        return FOUNDATION, gw, da, db, dp
    g0, dg0 = unworn_penetration(c, R1, R2, U0)
    kappa = (r - c) - g0
    rho = Uw / U0
    t = min(max((psi0 - lo) / (hi - lo), 0.0), 1.0)
    beta = 1.0 - t * t * (3.0 - 2.0 * t)
    m_, br = beta * kappa / U0, beta * rho
    # grouped so that where the cap holds no worn node (U_w = U_0, rho = beta = 1) the differences
    # vanish exactly: delta_c and e / r to round-off
    da = br * ea / r + (da - br * dg0 * g0a) + m_ * (gwa - rho * g0a)
    db = br * eb / r + (db - br * dg0 * g0b) + m_ * (gwb - rho * g0b)
    dp = br * ep / r + (dp - br * dg0 * g0p) + m_ * (gwp - rho * g0p)
    if 0.0 < t < 1.0:
        # d beta / d e = beta'(psi0) dpsi0/dr e / r, dpsi0/dr = -dC0/dr / sin psi0
        dC0 = 0.5 / R1 - (R1 * R1 - R2 * R2) / (2.0 * R1 * r * r)
        f = kappa * rho * (-6.0 * t * (1.0 - t) / (hi - lo)) * (-dC0 / math.sin(psi0)) / r
        da += f * ea
        db += f * eb
        dp += f * ep
    # = g(U_w) + beta kappa rho, written to vanish exactly with the worn nodes (as the gradient)
    return FOUNDATION, (r - c) + (gw - g0) + (br - 1.0) * kappa, da, db, dp


@njit(cache=True)
def foundation_deposit(gpar, f0, Ntf, Npf, m, E, work, vol, missed):
    """vol[mesh node] += each sample's worn volume work[s] shared over the fine nodes by the
    foundation's pressure A d^(3/2) (the actual patch on the worn surface), each share on the wear
    mesh node whose cell holds it; E (S, 3) the ball centres in the mesh axes. A sample whose ball
    touches no fine node (its load from a contact narrower than a cell) is flagged in missed (the
    caller spreads it over the Hertz patch)."""
    c, R1, R2 = gpar[0], gpar[1], gpar[2]
    for s in range(E.shape[0]):
        ea, eb, ep = E[s, 0], E[s, 1], E[s, 2]
        r = (ea * ea + eb * eb + ep * ep) ** 0.5
        missed[s] = True
        if r <= c or work[s] <= 0.0:
            continue
        P = foundation_sums(gpar, f0, Ntf, Npf, m, R1, R2, c, ea, eb, ep, r, False, vol, 0.0)[9]
        if P > 0.0:
            foundation_sums(gpar, f0, Ntf, Npf, m, R1, R2, c, ea, eb, ep, r, False, vol, work[s] / P)
            missed[s] = False
