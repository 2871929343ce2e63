"""Archard wear of a spherical clearance's socket (pinclear.contact.wear_spherical) against the law
integrated by hand, the worn socket's geometry (continuity, force = energy gradient), energy
conservation in a worn socket, the iterative scheme on a socket and the sidecar's errors."""
import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import dblquad, quad

import pinclear
from pinclear.analysis.wear_life import WearSettings, converged, wear_run
from pinclear.contact import wear_spherical as ws
from pinclear.contact import worn_geometry
from pinclear.contact.wear import trapezoid_weights
from pinclear.core.errors import ContactSetupError, InputError
from tests.helpers import assert_audit_closes, wear_override

BALL = Path(__file__).parents[1] / "data" / "wear_ball.yaml"
OMEGA, W = 20.0, 20.0                 # spin about x (rad/s); weight m g (N), along -z


def _static_start(mech):
    j = mech.forces[-1]
    delta = (W / j.law.K) ** (1.0 / j.law.n)
    return np.array([0.0, 0.0, -(j.c + delta), 0.0, 0.0, 0.0]), np.array([0.0, 0.0, 0.0, OMEGA, 0.0, 0.0])


def _hand_depth(wm, u, F, v, T, cells):
    """k v T / H times the Hertz pressure (Johnson eq. 4.23) integrated over each cell by scipy's
    dblquad, the pressure normalised to carry F on the socket's curved surface, over the cell area."""
    a = float(ws.contact_radius(wm, F))

    def p(th, ph):
        x = np.array([math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th)])
        rho = 2 * wm.R1 * math.asin(min(0.5 * np.linalg.norm(x - u), 1.0))
        return math.sqrt(max(0.0, 1 - (rho / a) ** 2)) * wm.R1 ** 2 * math.sin(th)

    # the whole load: axisymmetric about u, 2 pi R1^2 int sqrt(1 - (R1 alpha / a)^2) sin(alpha) d alpha
    total = 2 * math.pi * wm.R1 ** 2 * quad(lambda al: math.sqrt(max(0.0, 1 - (wm.R1 * al / a) ** 2)) * math.sin(al),
                                            0.0, a / wm.R1, epsabs=0, epsrel=1e-12)[0]
    out = {}
    for c in cells:
        i, j = divmod(int(c), wm.cols)
        lo, ph = i * wm.dtheta, j * wm.dphi
        val = dblquad(lambda f, th: p(th, f), lo, lo + wm.dtheta, ph - 0.5 * wm.dphi, ph + 0.5 * wm.dphi,
                      epsabs=0, epsrel=1e-9)[0]
        out[c] = wm.k * v * T * F * val / total / (wm.hardness * wm.cell_areas()[c])
    return out


@pytest.mark.slow
def test_ball_under_constant_load_and_spin_wears_k_F_s_over_H_and_the_hertz_profile():
    mech = pinclear.load(BALL, clearances=["S"])
    wm = mech.forces[-1].wear
    q0, v0 = _static_start(mech)
    T = 0.05
    tr = pinclear.simulate(mech, T, integrator="DOP853", rtol=1e-10, q0=q0, v0=v0, assemble=False, dt_out=1e-4)
    assert tr.status == "success"
    vs = OMEGA * mech.forces[-1].R2                          # the bottom point slides at omega R_ball
    # the static load holds to the integration error of the penetration (rtol 1e-10 on ~1e-4 m positions
    # against a ~2e-6 m penetration: ~1e-6 relative in F)
    assert np.allclose(tr.outputs["S.fn"], W, rtol=1e-5) and np.allclose(tr.outputs["S.slip"], vs, rtol=1e-9)
    h = ws.block_increment(wm, "S", tr)
    # Archard's volume k F s / H, exactly (the shares sum to 1)
    assert wm.volume(h) == pytest.approx(wm.k * W * vs * T / wm.hardness, rel=1e-5)
    # node by node against the pressure integrated by hand; the load is at -z = mesh (0, -1, 0)
    # (pole x: mesh axes y, z, x); the error falls as the share quadrature is refined
    u = np.array([0.0, -1.0, 0.0])
    worn = np.flatnonzero(h)
    ref = _hand_depth(wm, u, W, vs, T, worn)
    refv = np.array([ref[c] for c in worn])
    err8 = np.max(np.abs(h[worn] - refv)) / refv.max()
    fine = dataclasses.replace(wm, quad=32)
    h32 = ws.depth_increment(fine, np.tile(u, (len(tr.t), 1)), tr.outputs["S.fn"], tr.outputs["S.slip"],
                             trapezoid_weights(tr.t))
    err32 = np.max(np.abs(h32[worn] - refv)) / refv.max()
    # the sub-cell midpoint rule converges (order >= 1 from 8 to 32 sub-cells a side) and at 8 is within 1 %
    assert err32 < 0.25 * err8 and err8 < 0.01
    # several cells across; the deepest cells hold the contact point (theta 90 deg: rows 17, 18; phi 270 deg)
    assert float(ws.contact_radius(wm, W)) > 2 * wm.R1 * wm.dtheta
    assert divmod(int(np.argmax(h)), wm.cols) in ((17, 54), (18, 54))


def test_small_contact_and_off_grid_loads_lose_no_volume():
    mech = pinclear.load(BALL, clearances=["S"])
    wm = mech.forces[-1].wear
    rng = np.random.default_rng(3)
    u = rng.normal(size=(40, 3))
    u[:, 2] *= 0.2                                            # keep off the mesh poles
    u /= np.linalg.norm(u, axis=1)[:, None]
    F = np.concatenate([np.full(20, 1e-9), np.full(20, 50.0)])   # contacts far below and above a sub-cell
    v, dt = rng.uniform(0.1, 1.0, 40), np.full(40, 1e-3)
    for dist in ("hertz", "uniform"):
        m = dataclasses.replace(wm, distribution=dist)
        h = ws.depth_increment(m, u, F, v, dt)
        assert m.volume(h) == pytest.approx(m.k * np.sum(F * v * dt) / m.hardness, rel=1e-12)
        assert np.all(h >= 0.0)


def _worn(mech, depth):
    j = mech.forces[-1]
    return j.with_depth(depth)


def _bump(wm, amp):
    """A smooth bump of depth amp centred at mesh (theta 100 deg, phi 250 deg), 15 deg wide."""
    th, ph = wm.angles()
    x = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], 1)
    c = np.array([math.sin(math.radians(100)) * math.cos(math.radians(250)),
                  math.sin(math.radians(100)) * math.sin(math.radians(250)), math.cos(math.radians(100))])
    ang = np.arccos(np.clip(x @ c, -1, 1))
    return amp * np.exp(-0.5 * (ang / math.radians(15)) ** 2) * (ang < math.radians(60))


def _geometry(joint, e):
    """(delta, n, |grad delta|) of the compiled worn geometry, socket at the origin with identity axes."""
    M1, M2 = np.eye(4), np.eye(4)
    M2[:3, 3] = e
    delta, n, p1, p2, scr = np.zeros(1), np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((4, 3))
    worn_geometry.worn_spherical_geometry(joint._geo.gpar, M1, M2, delta, n, p1, p2, scr)
    return delta[0], n[0].copy(), scr[3, 0]


def _world(wm, th, ph, r):
    """frame1 position of mesh direction (th, ph) at radius r (pole x: mesh axes y, z, x)."""
    loc = r * np.array([math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th)])
    out = np.zeros(3)
    p = wm.pole
    out[[(p + 1) % 3, (p + 2) % 3, p]] = loc
    return out


def test_compiled_shares_equal_the_numpy_quadrature_including_polar_windows():
    """The compiled share kernel (wear_spherical._share_volumes, one sample at a time) against the
    NumPy expression of the same quadrature (cell_shares: batched windows, bincount): equal to
    rounding, for loads near the pole (whole rows visited), on the equator, tiny and large, in
    both distributions."""
    mech = pinclear.load(BALL, clearances=["S"])
    wm = mech.forces[-1].wear
    rng = np.random.default_rng(11)
    u = rng.normal(size=(60, 3))
    u[:20, 2] = np.abs(u[:20, 2]) * 8.0                        # within a few rows of the pole
    u /= np.linalg.norm(u, axis=1)[:, None]
    F = rng.choice([1e-9, 5.0, 50.0, 400.0], size=60)
    v, dt = rng.uniform(0.1, 1.0, 60), np.full(60, 1e-3)
    for dist in ("hertz", "uniform"):
        m = dataclasses.replace(wm, distribution=dist)
        cells, share = ws.cell_shares(m, u, ws.contact_radius(m, F))
        work = m.k * F * v * dt / m.hardness
        ref = np.bincount(cells.ravel(), weights=(work[:, None] * share).ravel(), minlength=m.nodes) / m.cell_areas()
        h = ws.depth_increment(m, u, F, v, dt)
        assert np.max(np.abs(h - ref)) <= 1e-12 * ref.max()


def test_worn_socket_geometry_passes_the_nodes_is_continuous_and_its_force_is_the_energy_gradient():
    # the least-distance contact (the foundation's: test_worn_foundation.py)
    mech = pinclear.load(BALL, clearances=["S"], overrides=wear_override(BALL, "S", contact="least_distance"))
    wm = mech.forces[-1].wear
    depth = _bump(wm, 0.5 * mech.forces[-1].c)
    j = _worn(mech, depth)
    th, ph = wm.angles()
    # passes through the nodes
    k = np.flatnonzero(depth > 0.1 * depth.max())[:25]
    assert j.profile(th[k], ph[k])[0] == pytest.approx(depth[k], abs=1e-12 * depth.max())
    # continuous across the pieces' joins (the node rows and columns): penetration and normal
    r, eps = j.c + 0.3 * depth.max(), 1e-9
    for t0, p0 in [(th[k[3]], ph[k[3]] + 0.37 * wm.dphi), (th[k[5]] + 0.41 * wm.dtheta, ph[k[5]])]:
        for dt_, dp_ in [(eps, 0.0), (0.0, eps)]:
            a = _geometry(j, _world(wm, t0 - dt_, p0 - dp_, r))
            b = _geometry(j, _world(wm, t0 + dt_, p0 + dp_, r))
            assert abs(a[0] - b[0]) < 1e-6 * depth.max()
            assert np.linalg.norm(a[1] - b[1]) < 1e-5
    # through the pole (no wear near it): the same value from every azimuth
    vals = [_geometry(j, _world(wm, 1e-7, p, r))[0] for p in np.linspace(0, 2 * math.pi, 7)]
    assert np.ptp(vals) < 1e-15 and vals[0] == pytest.approx(r - j.c, abs=1e-15)
    # the force direction is grad delta: central differences of delta against |grad delta| n
    rng = np.random.default_rng(5)
    for _ in range(20):
        e = _world(wm, math.radians(rng.uniform(80, 120)), math.radians(rng.uniform(230, 270)),
                   j.c + rng.uniform(0, 0.5) * depth.max())
        d0, n0, g0 = _geometry(j, e)
        h = 1e-9
        grad = np.array([(_geometry(j, e + h * dx)[0] - _geometry(j, e - h * dx)[0]) / (2 * h) for dx in np.eye(3)])
        assert np.linalg.norm(grad - g0 * n0) < 1e-5 * g0
        # least distance: delta = r - |e - nearest point| has a unit gradient (eikonal), whatever the
        # wear's slope (the radial penetration's was > 1 on a slope)
        assert abs(np.linalg.norm(grad) - 1.0) < 1e-5


def test_worn_socket_run_closes_the_energy_balance_and_creates_none():
    mech = pinclear.load(BALL, clearances=["S"], overrides={"S.friction_law": {"type": "modified_coulomb",
                                                                                    "mu": 0.2}})
    wm = mech.forces[-1].wear
    # a pocket of 80 % of the clearance at the bottom (-z: mesh theta 90, phi 270 deg), 1 rad wide:
    # its floor's extra curvature 0.8 c / sigma^2 stays below c, so the ball's centre never crosses
    # the medial axis where two wall points are equally near. A 0.1 rad pocket (80 c) is narrower
    # than the ball: the single least-distance contact flips between the walls (delta has a kink,
    # the force a jump), the damped ball settles into that V and DOP853 stalls at t = 0.0145 s
    th, ph = wm.angles()
    x = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], 1)
    ang = np.arccos(np.clip(x @ np.array([0.0, -1.0, 0.0]), -1, 1))
    pocket = 0.8 * mech.forces[-1].c * np.exp(-0.5 * ang ** 2)
    worn = mech.replace(forces=list(mech.forces[:-1]) + [_worn(mech, pocket)])
    tr = pinclear.simulate(worn, 0.05, integrator="DOP853", rtol=1e-10, q0=np.array([2e-5, 0.0, 0.0, 0, 0, 0]),
                           v0=np.array([0.05, 0.03, -0.1, 30.0, 5.0, 0.0]), assemble=False, dt_out=1e-5)
    assert tr.status == "success"
    assert tr.outputs["S.fn"].max() > 5.0 and len(tr.stats["events"]) >= 2
    assert_audit_closes(tr, "S")


def test_scheme_on_a_socket_converges_writes_its_files_and_refuses_wear_at_the_pole(tmp_path):
    mech = pinclear.load(BALL, clearances=["S"])
    start = _static_start(mech)
    s = WearSettings(cycles=1000.0, period=0.01, updates=2, block_periods=1, transient_periods=0, rtol=1e-8,
                     dt_out=1e-3)
    res = converged(mech, "S", s, out=tmp_path, start=start)
    assert res["converged"]
    # constant load and slip: the volume grows as k F v t / H over the service life
    wm = mech.forces[-1].wear
    vol = res["history"]["S.worn_volume"][-1]
    assert vol == pytest.approx(wm.k * W * OMEGA * mech.forces[-1].R2 * s.cycles * s.period / wm.hardness, rel=1e-6)
    u = res["rounds"][-1]["updates"]
    for name in ("checkpoint.npz", "history.csv", "profile.csv"):
        assert (tmp_path / f"updates_{u}" / name).exists()
    head = (tmp_path / f"updates_{u}" / "profile.csv").read_text().splitlines()[0]
    assert "theta from the pole [deg]" in head and "phi [deg]" in head
    polar = pinclear.load(BALL, clearances=["S"], overrides={"S.wear": {"k": 1e-4, "hardness": 1e8, "pole": "z"}})
    with pytest.raises(InputError, match=r"clearances\.S\.wear\.pole.*x, y"):
        wear_run(polar, "S", s, start=start)


@pytest.mark.parametrize("wear_spec, key, text", [
    ({"model": "archard", "hardness": 1e8}, "clearances.S.wear.k", "required"),
    ({"model": "rabinowicz", "k": 1e-4, "hardness": 1e8}, "clearances.S.wear.model", "archard"),
    ({"k": 1e-4, "hardness": 1e8, "nodes": 4}, "clearances.S.wear.nodes", "in [8, 200]"),
    ({"k": 1e-4, "hardness": 1e8, "pole": "w"}, "clearances.S.wear.pole", "x, y, z"),
    ({"k": 1e-4, "hardness": 1e8, "shape": 1}, "clearances.S.wear.shape", "pole"),
])
def test_socket_wear_key_errors_name_file_key_and_choices(wear_spec, key, text):
    with pytest.raises(ContactSetupError) as exc:
        pinclear.load(BALL, clearances=["S"], overrides={"S.wear": wear_spec})
    msg = str(exc.value)
    assert "wear_ball.yaml" in msg and key in msg and text in msg and "\n" not in msg


@pytest.mark.slow
def test_s2_of_the_4ups_upu_wears_where_its_ball_rests(tmp_path):
    """pinclear.studies.wear_paper000's worn case on a short life (40 periods, 2 then 4 updates): the socket
    wears on the side the new joint's ball presses (its mean eccentricity direction), the worn volume
    is the history's, and no checkpoint lands in the report folder."""
    from pinclear.core.models import model_path
    from pinclear.studies import wear_paper000 as study

    s = {**study._settings(True), "periods": 1, "window": 1, "wear cycles": 40.0, "wear first updates": 2,
         "wear max rounds": 2}
    row = study.worn_case(s, tmp_path, work=tmp_path / "work")
    w = row["wear"]
    assert row["status"] == "success" and len(w["rounds"]) >= 1 and w["max_depth_um"] > 0
    mech = pinclear.load(model_path("four_ups_upu"), clearances=["S2"], overrides={"S2.mu": study.MU})
    tr = pinclear.simulate(mech, 2 * 2.0, dt_out=2e-3)
    on = tr.outputs["S2.fn"] > 0
    e = tr.outputs["S2.eccentricity"][on]
    u = e / np.linalg.norm(e, axis=1)[:, None]
    press = np.mean(u, axis=0)
    press /= np.linalg.norm(press)
    th, ph = math.radians(w["deepest_theta_deg"]), math.radians(w["deepest_phi_deg"])
    deep = np.array([math.sin(th) * math.cos(ph), math.sin(th) * math.sin(ph), math.cos(th)])   # pole z: x, y, z
    # within the cone of the contact directions, widened by the contact circle and half a cell diagonal
    wm = study.load(model_path("four_ups_upu"), clearances=["S2"],
                    overrides={"S2.mu": study.MU, "S2.wear": s["wear"]}).forces[-1].wear
    spread = np.arccos(np.clip(u @ press, -1, 1)).max()
    bound = spread + float(ws.contact_radius(wm, tr.outputs["S2.fn"].max())) / wm.R1 + 0.75 * wm.dtheta
    assert math.acos(np.clip(deep @ press, -1, 1)) <= bound
    assert not list(tmp_path.glob("*.npz")) and (tmp_path / "depth_map_S2.png").exists()
