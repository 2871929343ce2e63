"""The worn socket's elastic-foundation contact (pinclear.contact.worn_foundation): the unworn
socket's foundation energy against its defining integral, today's contact wherever the ball's cap
holds no worn node, the effective penetration against an independent dense quadrature of the
foundation over the worn surface, its gradient, and energy conservation of an elastic run."""
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

import pinclear
from pinclear.contact import channels
from pinclear.contact import worn_foundation as wf
from tests.helpers import wear_override

DATA = Path(__file__).parents[1] / "data"
BALL = DATA / "wear_ball.yaml"


def pocket(j, amp=0.8, width=0.15):
    """A Gaussian pocket of amp x c, width rad, about frame1 -y (the test's worn side)."""
    th, ph = j.wear.angles()
    x = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], 1)
    ang = np.arccos(np.clip(x @ j.wear.local(np.array([0.0, -1.0, 0.0])), -1, 1))
    return amp * j.c * np.exp(-0.5 * (ang / width) ** 2) * (ang < 0.6)


def kernel(joint, e):
    """(delta, n, weight |grad delta|) of the joint's compiled geometry, frame1 = world, ball at e."""
    M1, M2 = np.eye(4), np.eye(4)
    M2[:3, 3] = e
    out = np.zeros(1), np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 3))
    sc = np.zeros((4, 3))
    channels.channel_geometry(joint.geometry_code, joint._geo.gpar, M1, M2, sc, *out)
    return out[0][0], out[1][0].copy(), sc[3, 0]


def _G_quad(c, R1, R2, delta):
    """The unworn foundation energy by its definition: 2 pi R1^2 int (2/5) d(psi)^(5/2) sin psi dpsi
    over the cap, d the overlap along the socket's radius (adaptive quadrature)."""
    r = c + delta
    psi0 = math.acos((R1 * R1 + r * r - R2 * R2) / (2 * R1 * r))

    def f(p):
        d = r * math.cos(p) + math.sqrt(R2 * R2 - (r * math.sin(p)) ** 2) - R1
        return 0.4 * max(d, 0.0) ** 2.5 * math.sin(p)

    return 2 * math.pi * R1 * R1 * quad(f, 0.0, psi0, epsabs=0.0, epsrel=1e-9, limit=400)[0]


def test_unworn_foundation_energy_is_its_integral_and_the_inverse_is_exact():
    j = pinclear.load(BALL, clearances=["S"]).forces[-1]
    c, R1, R2 = j.c, j.R1, j.R2
    for delta in (1e-9, 1e-7, 3e-6, 5e-5):
        G, dG = wf.unworn_energy(c, R1, R2, delta)
        assert G == pytest.approx(_G_quad(c, R1, R2, delta), rel=1e-8)
        h = 1e-4 * delta
        fd = (_G_quad(c, R1, R2, delta + h) - _G_quad(c, R1, R2, delta - h)) / (2 * h)
        assert dG == pytest.approx(fd, rel=1e-6)
        g, dg = wf.unworn_penetration(c, R1, R2, G)
        assert g == pytest.approx(delta, rel=1e-12) and dg * dG == pytest.approx(1.0, rel=1e-12)


def test_a_cap_without_worn_nodes_gives_the_unworn_contact_to_1e_12():
    j = pinclear.load(BALL, clearances=["S"]).forces[-1]
    worn = j.with_depth(pocket(j))
    assert worn.wear.subdivision == 4
    rng = np.random.default_rng(5)
    # on the unworn side (+y), caps within kappa's full-weight radius (8 fine cells = 10 deg)
    for _ in range(100):
        u = np.array([0.0, 1.0, 0.0]) + 0.3 * rng.normal(size=3)
        u /= np.linalg.norm(u)
        e = (j.c + rng.uniform(1e-9, 1.5e-6)) * u
        delta, u = np.linalg.norm(e) - j.c, e / np.linalg.norm(e)
        d, n, W = kernel(worn, e)
        assert abs(d - delta) <= 1e-12 * delta
        assert np.max(np.abs(n - u)) <= 1e-12 and abs(W - 1.0) <= 1e-12


def _dense_effective_penetration(joint, e, n=200_000):
    """g(U_w) by plain NumPy: the foundation energy of the ball at e against the worn surface
    R1 + max(w, 0) (w the socket's interpolant, joint.profile) on a Fibonacci lattice of the
    unworn overlap's cap, mapped through the unworn energy of the adaptive quadrature (_G_quad)."""
    c, R1, R2 = joint.c, joint.R1, joint.R2
    r = np.linalg.norm(e)
    u = e / r
    cos0 = (R1 * R1 + r * r - R2 * R2) / (2 * R1 * r)
    k = np.arange(n) + 0.5
    cosa = 1.0 - (1.0 - cos0) * k / n
    az = math.pi * (1 + 5 ** 0.5) * k
    a = np.cross(u, [1.0, 0.0, 0.0] if abs(u[0]) < 0.9 else [0.0, 1.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(u, a)
    sina = np.sqrt(1 - cosa ** 2)
    dirs = cosa[:, None] * u + sina[:, None] * (np.cos(az)[:, None] * a + np.sin(az)[:, None] * b)
    loc = joint.wear.local(dirs)
    w = np.maximum(joint.profile(np.arccos(np.clip(loc[:, 2], -1, 1)), np.arctan2(loc[:, 1], loc[:, 0]))[0], 0.0)
    eu = dirs @ e
    d = np.maximum(eu + np.sqrt(R2 * R2 - r * r + eu * eu) - R1 - w, 0.0)
    U = np.sum(0.4 * d ** 2.5) * 2 * math.pi * R1 * R1 * (1.0 - cos0) / n
    if U == 0.0:
        return 0.0
    return brentq(lambda x: _G_quad(c, R1, R2, x) - U, 1e-9, 2 * c, xtol=1e-15, rtol=1e-12)


def test_effective_penetration_matches_a_dense_foundation_and_its_gradient_is_exact():
    j = pinclear.load(BALL, clearances=["S"]).forces[-1]
    worn = j.with_depth(pocket(j))
    rng = np.random.default_rng(7)
    checked = 0
    for _ in range(40):
        # ball centres near the pocket, pressed 0.1-3 um past the worn surface along their ray
        u = np.array([0.0, -1.0, 0.0]) + 0.25 * rng.normal(size=3)
        u /= np.linalg.norm(u)
        loc = j.wear.local(u)
        w = worn.profile(math.acos(loc[2]), math.atan2(loc[1], loc[0]))[0][0]
        e = (j.c + max(w, 0.0) + rng.uniform(1e-7, 3e-6)) * u
        d, n, W = kernel(worn, e)
        if d <= 0.0:
            continue
        checked += 1
        # the grid's quadrature (1.25 deg cells) against 2e5 points: the dense-distance
        # tolerance is 1e-3 of the clearance; the grid's error of U (<= 1e-4 beyond 8 cells) moves
        # delta_eff by about a 3.5th of it, <= 3e-5 x 73 um here: 1e-4 c (measured max 4.5e-6 c)
        assert abs(d - _dense_effective_penetration(worn, e)) <= 1e-4 * j.c
        h = 1e-10
        fd = np.array([(kernel(worn, e + h * v)[0] - kernel(worn, e - h * v)[0]) / (2 * h) for v in np.eye(3)])
        assert np.max(np.abs(W * n - fd)) <= 1e-6 * W
    assert checked >= 20


@pytest.mark.slow
def test_an_elastic_run_on_the_foundation_conserves_energy():
    from tests.contact.test_worn_contact import _drift, _elastic_worn_run

    # a coarse foundation (5 deg: the pocket's patch spans tens of cells) keeps the run short
    coarse_grid = wear_override(BALL, "S", foundation_cell=5.0)
    q0, v0 = np.array([2e-5, 0.0, 0.0, 0, 0, 0]), np.array([0.05, 0.03, -0.1, 30.0, 5.0, 0.0])
    runs = {rtol: _elastic_worn_run(BALL, "S", pocket, q0, v0, 0.03, rtol=rtol, overrides=coarse_grid)[1] for rtol in (1e-10, 1e-12)}
    assert runs[1e-12].outputs["S.fn"].max() > 5.0
    # a force that is not the energy's gradient (a jump of delta_eff at a node's entry, a culled
    # block) leaves a drift the tolerance does not reduce
    coarse, fine = _drift(runs[1e-10], "S"), _drift(runs[1e-12], "S")
    assert coarse <= 1e-5 and fine <= 0.2 * coarse


def test_the_foundation_wears_its_patch_with_archards_volume():
    """A ball pressed into a worn pocket: each sample's volume k F v dt / H lands whole (to
    round-off) and spread as the foundation's pressure A d^(3/2) over the cells: against the same
    pressure on 2e5 points of the cap (an independent quadrature of the patch), binned into the
    mesh cells, to 2 % of the largest cell's share; a patch narrower than a cell (a touch on the
    pocket's rim) falls back to the Hertz patch whole."""
    from pinclear.contact import wear_spherical as ws

    j = pinclear.load(BALL, clearances=["S"]).forces[-1]
    depth = pocket(j, amp=0.3, width=0.4)
    worn = j.with_depth(depth)
    wm = j.wear
    rng = np.random.default_rng(3)
    E, U = [], []
    for _ in range(6):
        u = np.array([0.0, -1.0, 0.0]) + 0.15 * rng.normal(size=3)
        u /= np.linalg.norm(u)
        loc = wm.local(u)
        w = worn.profile(math.acos(loc[2]), math.atan2(loc[1], loc[0]))[0][0]
        E.append((j.c + w + rng.uniform(5e-7, 3e-6)) * u)
        U.append(u)
    E, U = np.array(E), np.array(U)
    F, v, dt = np.full(len(E), 50.0), np.full(len(E), 0.2), np.full(len(E), 1e-3)
    h = ws.foundation_increment(wm, depth, wm.local(E), wm.local(U), F, v, dt)
    assert wm.volume(h) == pytest.approx(wm.k * np.sum(F * v * dt) / wm.hardness, rel=1e-12)
    # one sample against the dense patch
    e = E[0]
    one = ws.foundation_increment(wm, depth, wm.local(e[None]), wm.local(U[:1]), F[:1], v[:1], dt[:1])
    n = 200_000
    r = np.linalg.norm(e)
    cos0 = (j.R1 ** 2 + r * r - j.R2 ** 2) / (2 * j.R1 * r)
    k = np.arange(n) + 0.5
    cosa = 1.0 - (1.0 - cos0) * k / n
    az = math.pi * (1 + 5 ** 0.5) * k
    ue = e / r
    a = np.cross(ue, [1.0, 0.0, 0.0])
    a /= np.linalg.norm(a)
    b = np.cross(ue, a)
    sina = np.sqrt(1 - cosa ** 2)
    dirs = cosa[:, None] * ue + sina[:, None] * (np.cos(az)[:, None] * a + np.sin(az)[:, None] * b)
    loc = wm.local(dirs)
    th, ph = np.arccos(np.clip(loc[:, 2], -1, 1)), np.arctan2(loc[:, 1], loc[:, 0]) % (2 * math.pi)
    w = np.maximum(worn.profile(th, ph)[0], 0.0)
    eu = dirs @ e
    d = np.maximum(eu + np.sqrt(j.R2 ** 2 - r * r + eu * eu) - j.R1 - w, 0.0)
    cell = np.minimum((th / wm.dtheta).astype(int), wm.rows - 1) * wm.cols + \
        np.floor(ph / wm.dphi + 0.5).astype(int) % wm.cols
    ref = np.bincount(cell, weights=d ** 1.5, minlength=wm.nodes)
    ref *= wm.k * F[0] * v[0] * dt[0] / wm.hardness / ref.sum() / wm.cell_areas()
    assert np.count_nonzero(ref > 0.01 * ref.max()) >= 9                 # a patch over several cells
    assert np.max(np.abs(one - ref)) <= 0.02 * ref.max()
