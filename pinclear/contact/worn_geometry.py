"""Compiled geometry of the worn clearances: the worn bearing's profile (a periodic cubic spline
over the wear nodes) and the worn socket's mesh (Catmull-Rom), with the penetration, normal and
contact points a worn channel needs (pinclear.contact.wear, pinclear.contact.wear_spherical).
"""
from __future__ import annotations

import math

import numpy as np

from pinclear.contact.worn_foundation import CLEAR, FOUNDATION, NO_NODE, foundation_penetration
from pinclear.core.jit import njit

#: worn planar bearing: gpar = (c, R1, R2, ca, L, N, span, top, ray radius, then the periodic cubic
#: spline's 4 N coefficients of the wear depth, cell i = [i, i + 1) 2 pi / N, highest power first);
#: span and top bound the spline's range max - min and its maximum (the contact search's window);
#: below ray radius x c the ray's delta and n stand (1/2 for the dry joint, whose force needs no
#: gap there; 0 for a film's, whose asperities need the least gap at every eccentricity)
WORN_HEAD = 9
#: Newton iterations of the contact point's refinement, and its step tolerance (rad)
NEWTON_ITER, NEWTON_TOL = 30, 1e-14


@njit(cache=True)
def worn_depth(gpar, theta):
    """(w, dw/dtheta): wear depth of the bearing at its own angle theta (rad, frame1 x towards y),
    from the periodic cubic spline in gpar (C2 in theta: penetration and normal continuous)."""
    w, dw, _ = worn_depth2(gpar, theta)
    return w, dw


@njit(cache=True)
def worn_depth2(gpar, theta):
    """(w, w', w''): worn_depth with the spline's second derivative."""
    N = int(gpar[5])
    h = 2.0 * math.pi / N
    t = theta % (2.0 * math.pi)
    i = min(int(t / h), N - 1)
    x = t - i * h
    b = WORN_HEAD + 4 * i
    c3, c2, c1, c0 = gpar[b], gpar[b + 1], gpar[b + 2], gpar[b + 3]
    return ((c3 * x + c2) * x + c1) * x + c0, (3.0 * c3 * x + 2.0 * c2) * x + c1, 6.0 * c3 * x + 2.0 * c2


@njit(cache=True)
def search_half_angle(span, top, R1, r):
    """Largest angle psi between the eccentricity and a bearing point that can be nearer the
    journal centre than the point on the eccentricity ray: with rho = R1 + w, |P - e|^2 =
    (rho - r)^2 + 4 rho r sin^2(psi/2), so a point nearer than the ray's needs
    4 rho r sin^2(psi/2) < (w_ray - w)(rho_ray + rho - 2 r) <= span 2 (R1 + top), rho >= R1 + top - span
    (the pocket half-width sqrt(2 d / r) of a depth d, to first order)."""
    if span <= 0.0 or r <= 0.0:
        return 0.0
    x = span * (R1 + top) / (2.0 * r * (R1 + top - span))
    return math.pi if x >= 1.0 else 2.0 * math.asin(x ** 0.5)


@njit(cache=True)
def planar_gap(gpar, th_e, r, phi):
    """(delta, d, rho, w) of the bearing point at th_e + phi for a journal centre at distance r
    along th_e: d = |P - e| = ((rho - r)^2 + q)^(1/2), q = 4 rho r sin^2(phi/2), and
    delta = R2 - d written as r - c - w - q / (d + rho - r) (exactly the ray's r - c - w at phi = 0)."""
    c, R1 = gpar[0], gpar[1]
    w = worn_depth2(gpar, th_e + phi)[0]
    rho = R1 + w
    s = math.sin(0.5 * phi)
    q = 4.0 * rho * r * s * s
    d = ((rho - r) ** 2 + q) ** 0.5
    return r - c - w - q / (d + rho - r), d, rho, w


@njit(cache=True)
def planar_refine(gpar, th_e, r, phi):
    """phi of the nearest bearing point to the journal centre from the start phi: Newton on
    f = |P(th_e + phi) - e|^2 / 2, f' = w'(rho - r cos phi) + rho r sin phi, f'' = w''(rho - r cos phi)
    + w'(w' + 2 r sin phi) + rho r cos phi, steps held to one cell (a step downhill where f'' <= 0).
    At the ray (phi = 0) of an unworn bearing f' = 0 exactly: no step."""
    R1 = gpar[1]
    h = 2.0 * math.pi / gpar[5]
    for _ in range(NEWTON_ITER):
        w, w1, w2 = worn_depth2(gpar, th_e + phi)
        rho = R1 + w
        cp, sp = math.cos(phi), math.sin(phi)
        g = w1 * (rho - r * cp) + rho * r * sp
        if g == 0.0:
            break
        H = w2 * (rho - r * cp) + w1 * (w1 + 2.0 * r * sp) + rho * r * cp
        step = -g / H if H > 0.0 else (-0.5 * h if g > 0.0 else 0.5 * h)
        step = min(max(step, -h), h)
        phi += step
        if abs(step) < NEWTON_TOL:
            break
    return phi


@njit(cache=True, inline="always")
def keep_best(b, m, x, y):
    """The three best candidates b = (m1, x1, y1, m2, x2, y2, m3, x3, y3) (by increasing m, inf
    when empty) with (m, x, y) inserted: scalars, no array in the kernel."""
    m1, x1, y1, m2, x2, y2, m3, x3, y3 = b
    if m < m1:
        return m, x, y, m1, x1, y1, m2, x2, y2
    if m < m2:
        return m1, x1, y1, m, x, y, m2, x2, y2
    if m < m3:
        return m1, x1, y1, m2, x2, y2, m, x, y
    return b


@njit(cache=True)
def planar_nearest_nodes(gpar, th_e, r, psi):
    """The (up to) three profile samples nearest the journal centre among the local minima of the
    distance over the nodes and cell midpoints within psi of th_e (a spline's overshoot between
    nodes is a midpoint's), into b (keep_best; column 1: phi from th_e). cos of the offsets by
    rotation: no trigonometry per sample."""
    R1, N = gpar[1], int(gpar[5])
    h = 2.0 * math.pi / N
    hh = 0.5 * h
    K = min(int(psi / h) + 2, N // 2)
    i0 = int(math.floor(th_e / h + 0.5))
    phi0 = (i0 - K) * h - th_e
    cp, sp = math.cos(phi0), math.sin(phi0)
    ch, sh = math.cos(hh), math.sin(hh)
    inf = math.inf
    b = (inf, 0.0, 0.0, inf, 0.0, 0.0, inf, 0.0, 0.0)
    m_prev, m_cur = inf, inf
    for k in range(4 * K + 2):
        if k <= 4 * K:
            c = WORN_HEAD + 4 * ((i0 - K + k // 2) % N)
            w = gpar[c + 3] if k % 2 == 0 else ((gpar[c] * hh + gpar[c + 1]) * hh + gpar[c + 2]) * hh + gpar[c + 3]
            rho = R1 + w
            m = (rho - r) ** 2 + 2.0 * rho * r * (1.0 - cp)
            cp, sp = cp * ch - sp * sh, sp * ch + cp * sh
        else:
            m = math.inf
        # sample k - 1 is a local minimum of the distance over the window's samples
        if k >= 1 and m_cur <= m_prev and m_cur <= m:
            b = keep_best(b, m_cur, phi0 + (k - 1) * hh, 0.0)
        m_prev, m_cur = m_cur, m
    return b


@njit(cache=True)
def worn_planar_geometry(gpar, M1, s, a, j, delta, n, p1, p2, scratch):
    """A journal (centre j, radius R2) in a worn bearing of radius R1 + w(theta), e the eccentricity
    in the bearing plane, r = |e|: the penetration is the least-distance one, delta = R2 - min over
    the worn surface of |P - e| (the journal circle's overlap with the worn bearing), P the
    nearest bearing point: Newton on the smooth profile (planar_refine) from the three nearest
    local minima over the nodes and cell midpoints within search_half_angle of e
    (planar_nearest_nodes), the nearest kept; from the ray itself where the profile is flat (span 0).
    n = (P - e)/d is the exact gradient of delta in e (envelope theorem: P is stationary), so the
    force -F(delta) n is the exact gradient of the law's energy and n . (v2(p2) - v1(p1)) =
    d(delta)/dt (scratch[3, 0] = 1: the normal law's weight). At phi = 0 (an unworn bearing)
    delta = r - c - w and n = e/r exactly, the unworn joint's. Within r <= c/2, where
    delta <= r - c <= -c/2 (w >= 0), the ray's delta and n (no contact possible) for the dry joint
    (gpar[8] = 1/2); a film's (gpar[8] = 0) searches at every r and leaves its equivalent
    eccentricity's scale (r - w(theta_e)) / r in scratch[3, 1] (lubricated.journal_loads)."""
    c, R1, R2 = gpar[0], gpar[1], gpar[2]
    e0, e1, e2 = j[0] - s[0], j[1] - s[1], j[2] - s[2]
    u = e0 * a[0] + e1 * a[1] + e2 * a[2]
    e0 -= u * a[0]
    e1 -= u * a[1]
    e2 -= u * a[2]
    ex = e0 * M1[0, 0] + e1 * M1[1, 0] + e2 * M1[2, 0]
    ey = e0 * M1[0, 1] + e1 * M1[1, 1] + e2 * M1[2, 1]
    r = (e0 * e0 + e1 * e1 + e2 * e2) ** 0.5
    if r > 0.0:
        r0, r1, r2 = e0 / r, e1 / r, e2 / r
    else:
        r0, r1, r2 = M1[0, 0], M1[1, 0], M1[2, 0]
    th_e = math.atan2(ey, ex)
    phi = 0.0
    if r > gpar[8] * c:
        psi = search_half_angle(gpar[6], gpar[7], R1, r)
        if psi > 0.0:
            # the window holds the ray's node, so its sampled minima stand for the ray's start too (a
            # refine from the ray walks a conforming pocket's flat floor one cell a step, 30 steps);
            # the ray itself is kept where it is exactly stationary (unworn around it: w' = 0)
            best = planar_gap(gpar, th_e, r, 0.0)[0] if worn_depth2(gpar, th_e)[1] == 0.0 else -math.inf
            b = planar_nearest_nodes(gpar, th_e, r, psi)
            for k in range(3):
                if b[3 * k] < math.inf:
                    other = planar_refine(gpar, th_e, r, b[3 * k + 1])
                    d_ = planar_gap(gpar, th_e, r, other)[0]
                    if d_ > best:
                        best, phi = d_, other
        else:
            phi = planar_refine(gpar, th_e, r, 0.0)
    d_, dist, rho, _ = planar_gap(gpar, th_e, r, phi)
    # P - e = (rho cos phi - r) e/r + rho sin phi t, t = a x e/r; rho cos phi - r in the stable form
    sh = math.sin(0.5 * phi)
    ca, sa = (rho - r - 2.0 * rho * sh * sh) / dist, rho * math.sin(phi) / dist
    t0, t1, t2 = a[1] * r2 - a[2] * r1, a[2] * r0 - a[0] * r2, a[0] * r1 - a[1] * r0
    n0, n1, n2 = ca * r0 + sa * t0, ca * r1 + sa * t1, ca * r2 + sa * t2
    delta[0] = d_
    n[0, 0], n[0, 1], n[0, 2] = n0, n1, n2
    p2[0, 0], p2[0, 1], p2[0, 2] = j[0] + R2 * n0, j[1] + R2 * n1, j[2] + R2 * n2
    p1[0, 0], p1[0, 1], p1[0, 2] = j[0] + (R2 - d_) * n0, j[1] + (R2 - d_) * n1, j[2] + (R2 - d_) * n2
    scratch[3, 0] = 1.0
    if gpar[8] == 0.0:
        # a film's joint: the line of centres' gap is the worn bearing's, c + w - r, at the
        # equivalent eccentricity (r - w(theta_e)) e / r (continuous in e, where P can jump)
        scratch[3, 1] = (r - worn_depth2(gpar, th_e)[0]) / r if r > 0.0 else 1.0


#: worn spherical socket: gpar = (c, R1, R2, pole axis of frame1 (0, 1, 2), ray radius (below
#: ray radius x c the ray's delta and n stand: 1/2 for the dry joint, whose force needs no gap; 0 for
#: a film, which needs the gap at every eccentricity), Nt, Np, span, top,
#: then the Nt x Np node depths row by row: row i at theta = (i + 1/2) pi / Nt from the pole, column
#: j at phi = 2 pi j / Np; span and top as the bearing's: WORN_HEAD), then the elastic foundation's
#: subdivision m (0: the least-distance contact alone) and, for m > 0, its (m Nt) x (m Np) fine
#: depths row by row and the Nt x Np blocks' least depths (fine_depths; contact.worn_foundation)
WORN_SPHERE_HEAD = 9


@njit(cache=True)
def sphere_node(gpar, i, j):
    """Depth of socket node (row i, column j); rows continue across the poles (row -1 - k is row k
    at phi + pi, row Nt + k is row Nt - 1 - k at phi + pi: the great circle through the pole)."""
    Nt, Np = int(gpar[5]), int(gpar[6])
    if i < 0:
        i = -1 - i
        j += Np // 2
    elif i >= Nt:
        i = 2 * Nt - 1 - i
        j += Np // 2
    return gpar[WORN_SPHERE_HEAD + i * Np + (j % Np)]


@njit(cache=True)
def catmull_rom(x, f0, f1, f2, f3):
    """(value, d/dx, d2/dx2) at x in [0, 1] of the Catmull-Rom cubic between f1 (x = 0) and f2
    (x = 1) of four equally spaced values: passes through the nodes, C1, local (Catmull & Rom 1974)."""
    x2 = x * x
    x3 = x2 * x
    v = 0.5 * ((-x3 + 2.0 * x2 - x) * f0 + (3.0 * x3 - 5.0 * x2 + 2.0) * f1 + (-3.0 * x3 + 4.0 * x2 + x) * f2
               + (x3 - x2) * f3)
    d = 0.5 * ((-3.0 * x2 + 4.0 * x - 1.0) * f0 + (9.0 * x2 - 10.0 * x) * f1 + (-9.0 * x2 + 8.0 * x + 1.0) * f2
               + (3.0 * x2 - 2.0 * x) * f3)
    dd = 0.5 * ((-6.0 * x + 4.0) * f0 + (18.0 * x - 10.0) * f1 + (-18.0 * x + 8.0) * f2 + (6.0 * x - 2.0) * f3)
    return v, d, dd


@njit(cache=True)
def sphere_row(gpar, i, j, y):
    """catmull_rom along row i at column j + y."""
    return catmull_rom(y, sphere_node(gpar, i, j - 1), sphere_node(gpar, i, j), sphere_node(gpar, i, j + 1),
                       sphere_node(gpar, i, j + 2))


@njit(cache=True)
def worn_sphere_depth2(gpar, theta, phi):
    """(w, w_t, w_p, w_tt, w_tp, w_pp): wear depth of the socket at the direction (theta from the
    mesh pole, phi) and its derivatives, the tensor Catmull-Rom interpolant of the node depths (C1,
    local: 4 x 4 nodes). Where the two rows next to a pole carry no wear (contact.wear_spherical
    checks it) the field is exactly 0 within half a row of the pole, so it is continuous through
    the pole too."""
    Nt, Np = int(gpar[5]), int(gpar[6])
    ht, hp = math.pi / Nt, 2.0 * math.pi / Np
    tt = theta / ht - 0.5
    i = int(math.floor(tt))
    x = tt - i
    ss = (phi % (2.0 * math.pi)) / hp
    j = int(math.floor(ss))
    y = ss - j
    v0, d0, e0 = sphere_row(gpar, i - 1, j, y)
    v1, d1, e1 = sphere_row(gpar, i, j, y)
    v2, d2, e2 = sphere_row(gpar, i + 1, j, y)
    v3, d3, e3 = sphere_row(gpar, i + 2, j, y)
    w, wt, wtt = catmull_rom(x, v0, v1, v2, v3)
    wp, wtp, _ = catmull_rom(x, d0, d1, d2, d3)
    wpp = catmull_rom(x, e0, e1, e2, e3)[0]
    return w, wt / ht, wp / hp, wtt / (ht * ht), wtp / (ht * hp), wpp / (hp * hp)


@njit(cache=True)
def worn_sphere_depth(gpar, theta, phi):
    """(w, dw/dtheta, dw/dphi) of worn_sphere_depth2."""
    w, wt, wp, _, _, _ = worn_sphere_depth2(gpar, theta, phi)
    return w, wt, wp


@njit(cache=True)
def sphere_gap(gpar, ua, ub, up, r, th, ph):
    """(delta, d, rho, sa, sb, sp) of the socket point in the direction (th, ph) (mesh axes) for a
    ball centre at r along the unit u: q = 4 rho r s^2 with s = |v - u| / 2, v the point's
    direction (sa, sb, sp), d = ((rho - r)^2 + q)^(1/2) = |P - e|, delta = r - c - w - q / (d + rho - r)
    (planar_gap's form: the ray's r - c - w where v = u)."""
    c, R1 = gpar[0], gpar[1]
    w = worn_sphere_depth2(gpar, th, ph)[0]
    rho = R1 + w
    st = math.sin(th)
    sa, sb, sp = st * math.cos(ph), st * math.sin(ph), math.cos(th)
    s2 = 0.25 * ((sa - ua) ** 2 + (sb - ub) ** 2 + (sp - up) ** 2)
    q = 4.0 * rho * r * s2
    d = ((rho - r) ** 2 + q) ** 0.5
    return r - c - w - q / (d + rho - r), d, rho, sa, sb, sp


@njit(cache=True)
def sphere_refine(gpar, th_e, ph_e, r, th, ph):
    """(theta, phi) of the nearest socket point to the ball centre (at r along (th_e, ph_e)) from
    the start (th, ph): Newton on f = |P - e|^2 / 2 = (rho^2 + r^2) / 2 - rho r C, C = cos of the
    angle to the centre's direction (C_tt = -C, C_tp = -cos t sin t_e sin dp, C_pp = -sin t sin t_e
    cos dp), the step held to one cell (a step downhill where the Hessian is not positive). At
    the ray of an unworn socket the gradient is 0 exactly: no step."""
    R1 = gpar[1]
    ht, hp = math.pi / gpar[5], 2.0 * math.pi / gpar[6]
    se, ce = math.sin(th_e), math.cos(th_e)
    for _ in range(NEWTON_ITER):
        w, wt, wp, wtt, wtp, wpp = worn_sphere_depth2(gpar, th, ph)
        rho = R1 + w
        st, ct = math.sin(th), math.cos(th)
        cd, sd = math.cos(ph - ph_e), math.sin(ph - ph_e)
        C = st * se * cd + ct * ce
        Ct, Cp = ct * se * cd - st * ce, -st * se * sd
        Ctt, Ctp, Cpp = -C, -ct * se * sd, -st * se * cd
        gt = wt * (rho - r * C) - r * rho * Ct
        gp = wp * (rho - r * C) - r * rho * Cp
        if gt == 0.0 and gp == 0.0:
            break
        Htt = wt * wt + rho * wtt - r * (wtt * C + 2.0 * wt * Ct + rho * Ctt)
        Htp = wt * wp + rho * wtp - r * (wtp * C + wt * Cp + wp * Ct + rho * Ctp)
        Hpp = wp * wp + rho * wpp - r * (wpp * C + 2.0 * wp * Cp + rho * Cpp)
        det = Htt * Hpp - Htp * Htp
        if Htt > 0.0 and det > 0.0:
            dt, dp = -(Hpp * gt - Htp * gp) / det, -(Htt * gp - Htp * gt) / det
        else:
            # downhill, half a cell on the sphere (the metric's phi factor sin^2 theta)
            s2 = max(st * st, 1e-12)
            dt, dp = -gt, -gp / s2
            scale = 0.5 * ht / max((dt * dt + s2 * dp * dp) ** 0.5, 1e-300)
            dt, dp = dt * scale, dp * scale
        lim = max(abs(dt) / ht, abs(dp) / hp)
        if lim > 1.0:
            dt, dp = dt / lim, dp / lim
        th += dt
        ph += dp
        # a step across a pole continues on the great circle through it
        if th < 0.0:
            th, ph = -th, ph + math.pi
        elif th > math.pi:
            th, ph = 2.0 * math.pi - th, ph + math.pi
        if abs(dt) + abs(st * dp) < NEWTON_TOL:
            break
    return th, ph


@njit(cache=True)
def sphere_nearest_nodes(gpar, th_e, ph_e, r, psi):
    """The (up to) three socket nodes nearest the ball centre among the local minima of the
    distance along each row within the cap of angle psi about its direction, as keep_best's tuple
    (x, y: theta, phi): the rows within psi, in each the columns within the cap (all of
    them where the cap holds a pole); cos of the column offsets by rotation."""
    R1, Nt, Np = gpar[1], int(gpar[5]), int(gpar[6])
    ht, hp = math.pi / Nt, 2.0 * math.pi / Np
    se = math.sin(th_e)
    i_lo = max(int(math.floor((th_e - psi) / ht - 0.5)), 0)
    i_hi = min(int(math.ceil((th_e + psi) / ht - 0.5)), Nt - 1)
    s_psi = math.sin(min(0.5 * psi, 0.5 * math.pi))
    ch, sh = math.cos(hp), math.sin(hp)
    inf = math.inf
    b = (inf, 0.0, 0.0, inf, 0.0, 0.0, inf, 0.0, 0.0)
    for i in range(i_lo, i_hi + 1):
        th = (i + 0.5) * ht
        sdt = math.sin(0.5 * (th - th_e))
        # sin^2(angle / 2) = sin^2(dt / 2) + sin t sin t_e sin^2(dp / 2) (haversine)
        ss = math.sin(th) * se
        x = s_psi / ss ** 0.5 if ss > 0.0 else 2.0
        K = Np // 2 if x >= 1.0 else min(int(2.0 * math.asin(x) / hp) + 2, Np // 2)
        j0 = int(math.floor(ph_e / hp + 0.5)) - K
        dp0 = j0 * hp - ph_e
        cp, sp = math.cos(dp0), math.sin(dp0)
        m_prev, m_cur = math.inf, math.inf
        for k in range(2 * K + 2):
            if k <= 2 * K:
                rho = R1 + sphere_node(gpar, i, j0 + k)
                m = (rho - r) ** 2 + 4.0 * rho * r * (sdt * sdt + 0.5 * ss * (1.0 - cp))
                cp, sp = cp * ch - sp * sh, sp * ch + cp * sh
            else:
                m = math.inf
            if k >= 1 and m_cur <= m_prev and m_cur <= m:
                b = keep_best(b, m_cur, th, dp0 + (k - 1) * hp + ph_e)
            m_prev, m_cur = m_cur, m
    return b


@njit(cache=True)
def fine_depths(gpar, m):
    """The foundation's fine grid: the interpolant's depth at the (m Nt) x (m Np) nodes theta =
    (i + 1/2) pi / (m Nt), phi = 2 pi j / (m Np), row by row, its undershoot below the unworn
    surface (next to a pocket's rim) clipped to 0 (wear only removes material), then the least
    depth of each m x m block of it, Nt x Np row by row."""
    Nt, Np = int(gpar[5]), int(gpar[6])
    Ntf, Npf = m * Nt, m * Np
    out = np.empty(Ntf * Npf + Nt * Np)
    for i in range(Ntf):
        th = (i + 0.5) * math.pi / Ntf
        for j in range(Npf):
            out[i * Npf + j] = max(worn_sphere_depth2(gpar, th, 2.0 * math.pi * j / Npf)[0], 0.0)
    # each m x m block's least depth (rows I m.., columns J m..): the foundation's culling bound
    for I in range(Nt):
        for J in range(Np):
            lo = math.inf
            for a in range(m):
                for b in range(m):
                    lo = min(lo, out[(I * m + a) * Npf + J * m + b])
            out[Ntf * Npf + I * Np + J] = lo
    return out


@njit(cache=True)
def worn_spherical_geometry(gpar, M1, M2, delta, n, p1, p2, scratch):
    """A ball (centre M2, radius R2) in a worn socket of radius R1 + w(direction), e = ball centre -
    socket centre, r = |e|: the least-distance penetration delta = R2 - min |P - e| over the worn
    socket, as the worn bearing's (worn_planar_geometry): Newton on the smooth interpolant
    (sphere_refine) from the three nearest of the nodes' local minima along the rows within
    search_half_angle of e (sphere_nearest_nodes), the nearest kept (from the ray where span is 0); n = (P - e)/d, the exact gradient of delta (the force is the
    law's energy gradient, scratch[3, 0] = 1); at the ray of an unworn socket delta = r - c and
    n = e/r. Within r <= gpar[4] c (1/2 for the dry joint: no contact possible there) the ray's delta and n. Mesh coordinates: frame1
    axes cyclically permuted so the pole is the third."""
    c, R1, R2 = gpar[0], gpar[1], gpar[2]
    ip = int(gpar[3])
    ia, ib = (ip + 1) % 3, (ip + 2) % 3
    e0, e1, e2 = M2[0, 3] - M1[0, 3], M2[1, 3] - M1[1, 3], M2[2, 3] - M1[2, 3]
    ea = e0 * M1[0, ia] + e1 * M1[1, ia] + e2 * M1[2, ia]
    eb = e0 * M1[0, ib] + e1 * M1[1, ib] + e2 * M1[2, ib]
    ep = e0 * M1[0, ip] + e1 * M1[1, ip] + e2 * M1[2, ip]
    r = (ea * ea + eb * eb + ep * ep) ** 0.5
    if r > 0.0:
        ua, ub, up = ea / r, eb / r, ep / r
    else:
        ua, ub, up = 1.0, 0.0, 0.0
    th_e = math.acos(min(max(up, -1.0), 1.0))
    ph_e = math.atan2(ub, ua)
    th, ph = th_e, ph_e
    w_ray, have_ray = 0.0, False
    Nt, Np = int(gpar[5]), int(gpar[6])
    f0 = WORN_SPHERE_HEAD + Nt * Np
    m = int(gpar[f0]) if gpar.shape[0] > f0 else 0
    status = NO_NODE
    if m > 0 and gpar[7] > 0.0 and r > gpar[4] * c:
        status, d_, ga, gb, gp = foundation_penetration(gpar, f0 + 1, m * Nt, m * Np, m, ea, eb, ep, r, scratch[3])
        if status == FOUNDATION:
            W = (ga * ga + gb * gb + gp * gp) ** 0.5
            delta[0] = d_
            for i in range(3):
                ni = (M1[i, ia] * ga + M1[i, ib] * gb + M1[i, ip] * gp) / W
                n[0, i] = ni
                p2[0, i] = M2[i, 3] + R2 * ni
                p1[0, i] = M2[i, 3] + (R2 - d_) * ni
            scratch[3, 0] = W
            return
    if r > gpar[4] * c:
        psi = search_half_angle(gpar[7], gpar[8], R1, r)
        if psi > 0.0:
            # the cap's sampled minima stand for the ray's start too, the ray kept where it is exactly
            # stationary (worn_planar_geometry)
            w_ray, wt, wp, _, _, _ = worn_sphere_depth2(gpar, th_e, ph_e)
            have_ray = True
            best = sphere_gap(gpar, ua, ub, up, r, th_e, ph_e)[0] if wt == 0.0 and wp == 0.0 else -math.inf
            b = sphere_nearest_nodes(gpar, th_e, ph_e, r, psi)
            for k in range(3):
                if b[3 * k] < math.inf:
                    t0, p0 = sphere_refine(gpar, th_e, ph_e, r, b[3 * k + 1], b[3 * k + 2])
                    d_ = sphere_gap(gpar, ua, ub, up, r, t0, p0)[0]
                    if d_ > best:
                        best, th, ph = d_, t0, p0
        else:
            th, ph = sphere_refine(gpar, th_e, ph_e, r, th_e, ph_e)
    d_, dist, rho, sa, sb, sp = sphere_gap(gpar, ua, ub, up, r, th, ph)
    # P - e = (rho - r) u + rho (v - u): exactly (rho - r) u where v = u
    na = ((rho - r) * ua + rho * (sa - ua)) / dist
    nb = ((rho - r) * ub + rho * (sb - ub)) / dist
    np_ = ((rho - r) * up + rho * (sp - up)) / dist
    if th == th_e and ph == ph_e:
        na, nb, np_ = ua, ub, up
    if status == CLEAR:
        # the foundation's nodes all clear the worn surface: no contact, whatever a sub-cell point says
        d_ = min(d_, 0.0)
    delta[0] = d_
    for i in range(3):
        ni = M1[i, ia] * na + M1[i, ib] * nb + M1[i, ip] * np_
        n[0, i] = ni
        p2[0, i] = M2[i, 3] + R2 * ni
        p1[0, i] = M2[i, 3] + (R2 - d_) * ni
    scratch[3, 0] = 1.0
    if gpar[4] == 0.0:
        # a film's joint (ray radius 0): the equivalent eccentricity on the line of centres, (r - w) e_hat
        # (world axes), whose gap c - |.| is the worn socket's there (lubricated_spherical, film kind 3)
        f = r - (w_ray if have_ray else worn_sphere_depth2(gpar, th_e, ph_e)[0])
        for i in range(3):
            scratch[2, i] = f * (M1[i, ia] * ua + M1[i, ib] * ub + M1[i, ip] * up)
