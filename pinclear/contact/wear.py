"""Archard wear of a planar revolute clearance's bearing, and the worn bearing's contact geometry.

Law (Archard 1953, J. Appl. Phys. 24, 981; local form as in Flores 2009, Mech. Mach. Theory 44,
1211, eq. 1 and Mukras et al. 2010, Wear 268, 643, eq. 2): the wear depth of the bearing surface
grows at

    dh/dt = k p v_slip / H

(k dimensionless wear coefficient, H hardness of the worn surface in Pa, p the contact pressure,
v_slip the sliding speed), accumulated on ``nodes`` points of the bearing equally spaced in its own
angle theta (frame1's x towards y). Integrated over the contact, the worn volume rate is
k F v_slip / H: Archard's law for the whole load.

Pressure distribution: the normal law's force F (what the joint's contact law gives, its damping
included) spread over the Hertz half-width of a cylinder in a conformal cylindrical hole,
b = sqrt(4 F R* / (pi L E*)) with R* = R_j R_b / (R_b - R_j) (Johnson 1985, Contact Mechanics,
eq. 4.43 with the internal contact's relative curvature), either elliptic
p(s) = (2 F / (pi b L)) sqrt(1 - s^2 / b^2) (Johnson eq. 4.45: ``distribution: hertz``, the
default) or uniform F / (2 b L) (``distribution: uniform``) on the new bearing; on a worn one the
same elastic foundation over the gap to the worn profile (patch_shares): a pocket that conforms
to the journal widens the patch (docs/wear_lubrication.md sec. 8). Each node receives the exact
integral of the distribution over its cell, so the worn volume is k F s / H to round-off whatever
the nodes.

Geometry: the worn bearing's radius is R_b + w(theta), w a periodic cubic spline through the node
depths (C2 in theta), evaluated in the compiled kernel (contact._kernels.worn_planar_geometry):
penetration and normal are continuous in the state, and the normal force is the exact gradient of
the law's energy (the energy audit closes between reshapes).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from pinclear.contact import channels
from pinclear.contact.base import ClearanceData
from pinclear.contact.channels import Laws
from pinclear.core.registry import Key

MODELS = ("archard",)
#: most wear nodes of a bearing (a finer mesh than 0.004 deg cells is not a mesh study, it is a typo)
MAX_NODES = 100_000
DISTRIBUTIONS = ("hertz", "uniform")

#: the keys of a clearance's ``wear:`` mapping (docs/keys.md, docs/wear_lubrication.md)
WEAR_KEYS = (
    Key("model", "string", "-", "archard", ", ".join(MODELS), "Archard 1953", "the wear law"),
    Key("k", "number", "-", None, "> 0", "Archard 1953: V = k F s / H", "dimensionless wear coefficient"),
    Key("hardness", "number", "Pa", None, "> 0", "Archard 1953", "hardness H of the worn bearing"),
    Key("nodes", "integer", "-", 360, ">= 16, <= MAX_NODES (100000)", "contact/wear.py", "wear nodes around the bearing"),
    Key("distribution", "string", "-", "hertz", ", ".join(DISTRIBUTIONS), "Johnson 1985 eqs. 4.43-4.45",
        "pressure over the Hertz half-width: elliptic (hertz) or uniform"),
)
_WEAR_NAMES = tuple(k.name for k in WEAR_KEYS)


@dataclass(frozen=True)
class WearModel:
    """What the wear law needs of one joint: k, H, the node count, the distribution and the
    contact's geometry (journal and bearing radii, length, E*, R*)."""
    k: float
    hardness: float
    nodes: int
    distribution: str
    R1: float
    R2: float
    L: float
    estar: float
    rstar: float

    @property
    def spacing(self) -> float:
        return 2.0 * math.pi / self.nodes

    def angles(self) -> np.ndarray:
        """Node angles (rad, bearing frame)."""
        return np.arange(self.nodes) * self.spacing

    def volume(self, depth) -> float:
        """Worn volume (m^3) of the node depths."""
        return float(np.sum(depth)) * self.R1 * self.spacing * self.L

    def profile_columns(self) -> dict:
        return {"angle [deg]": np.degrees(self.angles())}

    def increment(self, name, traj, depth=None):
        """Node depth increment of one simulated block on the profile ``depth`` (block_increment)."""
        return block_increment(self, name, traj, depth)


def parse(sp, R1, R2, L):
    """The ``wear:`` mapping of a clearance entry as a WearModel (None without it)."""
    w = wear_mapping(sp, _WEAR_NAMES)
    if w is None:
        return None
    model = w.get("model", "archard")
    if model not in MODELS:
        raise sp.error("wear.model", f"unknown wear model {model!r}", MODELS)
    dist = w.get("distribution", "hertz")
    if dist not in DISTRIBUTIONS:
        raise sp.error("wear.distribution", f"unknown distribution {dist!r}", DISTRIBUTIONS)
    k, hardness = positive(sp, w, "k"), positive(sp, w, "hardness")
    nodes = w.get("nodes", 360)
    if isinstance(nodes, bool) or not isinstance(nodes, int) or not 16 <= nodes <= MAX_NODES:
        raise sp.error("wear.nodes", f"an integer in [16, {MAX_NODES}], got {nodes!r}")
    return WearModel(k, hardness, int(nodes), dist, R1, R2, L, sp.estar(), R2 * R1 / (R1 - R2))


def wear_mapping(sp, names):
    """The entry's ``wear:`` mapping with only the keys ``names`` (None without it), or the one-line
    error naming the key and the choices (both worn joint types' parsers)."""
    w = sp.d.get("wear")
    if w is None:
        return None
    if not isinstance(w, dict):
        raise sp.error("wear", f"expected a mapping {{model: archard, k, hardness, ...}}, got {w!r}", names)
    bad = sorted(set(w) - set(names))
    if bad:
        raise sp.error(f"wear.{bad[0]}", "unknown key", names)
    return w


def positive(sp, w, key):
    """The required number > 0 ``wear.KEY`` of the mapping w (also the spherical socket's)."""
    v = w.get(key)
    try:
        # YAML 1.1 reads 1.0e8 (no exponent sign) as a string
        x = float(v) if not isinstance(v, bool) else math.nan
    except (TypeError, ValueError):
        x = math.nan
    if not (math.isfinite(x) and x > 0):
        raise sp.error(f"wear.{key}", f"required, a number > 0, got {v!r}")
    return x


# ------------------------------------------------------------------ the law
def half_width(wm: WearModel, F):
    """Hertz half-width b (m) of the journal's line contact under the load F (N), Johnson eq. 4.43."""
    return np.sqrt(4.0 * np.maximum(F, 0.0) * wm.rstar / (math.pi * wm.L * wm.estar))


def _ellipse_integral(x):
    """int_0^x sqrt(1 - s^2) ds for x clipped to [-1, 1]."""
    x = np.clip(x, -1.0, 1.0)
    return 0.5 * (x * np.sqrt(1.0 - x * x) + np.arcsin(x))


def cell_shares(wm: WearModel, theta, beta):
    """(nodes, shares), both (samples, K): the node cells each sample's load reaches and its share
    on each (rows sum to 1): the distribution centred at the contact angle theta with angular
    half-width beta (<= pi/2), integrated exactly over the cell [theta_i - d/2, theta_i + d/2].
    Only the K cells around the contact are visited (a wear update costs O(samples x K))."""
    theta = np.atleast_1d(np.asarray(theta, float))
    beta = np.clip(np.atleast_1d(np.asarray(beta, float)), 1e-300, math.pi / 2)
    d = wm.spacing
    K = int(math.ceil(2.0 * beta.max() / d)) + 3
    first = np.floor((theta - beta) / d).astype(np.int64)
    idx = first[:, None] + np.arange(K)[None, :]
    # node angle idx d, unwrapped around theta: rel is the node's offset from the contact centre
    rel = idx * d - theta[:, None]
    lo, hi = (rel - 0.5 * d) / beta[:, None], (rel + 0.5 * d) / beta[:, None]
    if wm.distribution == "uniform":
        share = 0.5 * (np.clip(hi, -1.0, 1.0) - np.clip(lo, -1.0, 1.0))
    else:
        share = (_ellipse_integral(hi) - _ellipse_integral(lo)) / (0.5 * math.pi)
    return idx % wm.nodes, share


def spline_eval(coef, theta):
    """(w, w') of the periodic spline (spline_coefficients) at the angles theta (any shape)."""
    N = len(coef)
    h = 2.0 * math.pi / N
    t = np.mod(theta, 2.0 * math.pi)
    i = np.minimum((t / h).astype(np.int64), N - 1)
    x = t - i * h
    c3, c2, c1, c0 = coef[i, 0], coef[i, 1], coef[i, 2], coef[i, 3]
    return ((c3 * x + c2) * x + c1) * x + c0, (3.0 * c3 * x + 2.0 * c2) * x + c1


def patch_shares(wm: WearModel, theta, beta, depth, chunk=2048):
    """(nodes, shares), both (samples, K): each load's pressure over the worn bearing's patch, an
    elastic foundation calibrated on Hertz (docs/wear_lubrication.md sec. 8): the journal touching
    the worn surface at theta (its nearest point) leaves the gap g(x) = A x^2 / 2 + w(theta + x) -
    w - w' x at the angle x from it (A = r (1 + r / R_j), r = c + w: the circles' gap, and the
    wear's departure from its tangent), and a foundation of approach a presses
    p = E* sqrt((a - g) / (2 R*)) where g < a, the approach set by the load, int p L R_b dx = F.
    On the new bearing g = (R_b x)^2 / (2 R*): Johnson's elliptic pressure over the Hertz
    half-width, exactly (a = b^2 / (2 R*)); in a pocket conforming to the journal the patch
    spreads over the conforming arc at a smaller approach. ``uniform``: the same patch, uniform
    pressure. Cell integrals in closed form, the wear's departure linear across each cell."""
    theta = np.atleast_1d(np.asarray(theta, float))
    if not np.all(np.isfinite(theta)):
        raise ValueError(f"patch_shares: {int(np.sum(~np.isfinite(theta)))} contact angles are not finite")
    beta = np.clip(np.atleast_1d(np.asarray(beta, float)), 1e-300, math.pi / 2)
    if not np.any(depth):
        return cell_shares(wm, theta, beta)
    # a vanishing load (a sample at the edge of contact) has an approach too small to represent
    # (df underflows and its window is 0 / 0); its share of no wear goes to a patch of this width
    beta = np.maximum(beta, PATCH_BETA_MIN)
    coef = spline_coefficients(depth)
    parts = [_patch_chunk(wm, theta[k:k + chunk], beta[k:k + chunk], coef, float(np.min(depth)))
             for k in range(0, len(theta), chunk)]
    K = max(p[0].shape[1] for p in parts)
    nodes = np.concatenate([np.pad(p[0], ((0, 0), (0, K - p[0].shape[1]))) for p in parts])
    share = np.concatenate([np.pad(p[1], ((0, 0), (0, K - p[1].shape[1]))) for p in parts])
    return nodes, share


#: the smallest patch half-width (rad) the worn bearing's patch is computed for: below it (loads
#: of order 1e-13 N on steel) the load, and so its wear, is nil and only its window must stay finite
PATCH_BETA_MIN = 1e-9
#: the foundation's approach relative to the new bearing's Hertz approach: at most (a sharper
#: seat than the new bearing's narrows the patch) and the bisection's steps
APPROACH_MAX, APPROACH_STEPS = 4.0, 40


def _patch_cells(G0, g1, lo, hi, B, s, uniform):
    """Per cell: int sqrt(1 - s G) dx (or the patch's length) with G = (x / B)^2 + G0 + g1 (x - lo)
    on [lo, hi] (the square completed: an ellipse's integral, _ellipse_integral)."""
    Bs = B / math.sqrt(s) if np.isscalar(s) else B / np.sqrt(s)
    x0 = -0.5 * g1 * B ** 2
    Kq = 1.0 - s * (G0 - g1 * lo) + 0.25 * s * (g1 * B) ** 2
    half = Bs * np.sqrt(np.maximum(Kq, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        if uniform:
            out = np.maximum(np.minimum(hi, x0 + half) - np.maximum(lo, x0 - half), 0.0)
        else:
            out = Bs * Kq * (_ellipse_integral((hi - x0) / half) - _ellipse_integral((lo - x0) / half))
    return np.where(Kq > 0.0, out, 0.0)


def _patch_chunk(wm, theta, beta, coef, wmin):
    c, d = wm.R1 - wm.R2, wm.spacing
    ws, w1 = spline_eval(coef, theta)
    r = c + ws
    bp = beta / np.sqrt((r / c) * (wm.R2 + r) / (wm.R2 + c))          # beta / sqrt(A / A_new)
    df = (wm.R1 * beta) ** 2 / (2.0 * wm.rstar)                       # the new bearing's approach
    # the patch at the largest approach lies where A x^2 / 2 - (w - w_min) - |w'| |x| < APPROACH_MAX df
    # the spline may dip below its lowest node between nodes: w - w_min >= 0 holds for the nodes' minimum only
    a, b, cc = 1.0 / bp ** 2, np.abs(w1) / df, APPROACH_MAX + np.maximum(ws - wmin, 0.0) / df
    X = np.minimum((b + np.sqrt(b * b + 4.0 * a * cc)) / (2.0 * a), 0.5 * math.pi)
    K = int(math.ceil(2.0 * X.max() / d)) + 3
    idx = np.floor((theta - X) / d).astype(np.int64)[:, None] + np.arange(K)[None, :]
    edge = np.concatenate([idx * d - 0.5 * d, idx[:, -1:] * d + 0.5 * d], axis=1) - theta[:, None]
    # g / df at the cell edges less the parabola, linear across each cell
    gam = (spline_eval(coef, theta[:, None] + edge)[0] - ws[:, None] - w1[:, None] * edge) / df[:, None]
    lo, hi = edge[:, :-1], edge[:, 1:]
    g1 = (gam[:, 1:] - gam[:, :-1]) / d
    B = bp[:, None]
    # approach a = df / s: the load sqrt(a) int sqrt(1 - g / a) dx = the new bearing's sqrt(df) beta pi / 2
    target = (0.5 * math.pi) * beta
    s_lo, s_hi = np.full(len(theta), 1.0 / APPROACH_MAX), np.full(len(theta), 1e12)
    for _ in range(APPROACH_STEPS):
        s = np.sqrt(s_lo * s_hi)
        load = _patch_cells(gam[:, :-1], g1, lo, hi, B, s[:, None], False).sum(axis=1) / np.sqrt(s)
        more = load > target
        s_lo, s_hi = np.where(more, s, s_lo), np.where(more, s_hi, s)
    share = _patch_cells(gam[:, :-1], g1, lo, hi, B, np.sqrt(s_lo * s_hi)[:, None], wm.distribution == "uniform")
    total = share.sum(axis=1)
    none = total <= 0.0
    if none.any():
        # a patch narrower than the linearised cells: the whole load on the cell holding the contact
        share[none] = 0.0
        share[none, np.argmin(np.abs(lo[none] + hi[none]), axis=1)] = 1.0
        total[none] = 1.0
    return idx % wm.nodes, share / total[:, None]


def depth_increment(wm: WearModel, theta, F, slip, dt, depth=None):
    """Wear depth (m) added at each node by the samples (contact angle theta, normal force F, slip
    speed, time weight dt) on the profile ``depth`` (None: the new bearing): sum k F v dt / H
    times the sample's share of the cell (patch_shares), over the cell's area R_b d L (so the worn
    volume is k sum F v dt / H exactly)."""
    F, slip, dt = (np.atleast_1d(np.asarray(x, float)) for x in (F, slip, dt))
    keep = (F > 0.0) & (slip > 0.0) & (dt > 0.0)
    if not keep.any():
        return np.zeros(wm.nodes)
    th, F, slip, dt = np.atleast_1d(theta)[keep], F[keep], slip[keep], dt[keep]
    beta = half_width(wm, F) / wm.R1
    work = wm.k * F * slip * dt / wm.hardness                              # worn volume per sample, m^3
    nodes, share = patch_shares(wm, th, beta, np.zeros(wm.nodes) if depth is None else np.asarray(depth, float))
    vol = np.bincount(nodes.ravel(), weights=(work[:, None] * share).ravel(), minlength=wm.nodes)
    return vol / (wm.R1 * wm.spacing * wm.L)


def trapezoid_weights(t):
    """Quadrature weights of samples at times t (trapezoid rule)."""
    t = np.asarray(t, float)
    w = np.zeros(len(t))
    if len(t) > 1:
        dt = np.diff(t)
        w[:-1] += 0.5 * dt
        w[1:] += 0.5 * dt
    return w


def wear_load(out, name):
    """The load Archard's law wears by: NAME.wear_load where the joint records one (a lubricated
    worn joint: dry plus asperity, the film's wears nothing), else the contact's NAME.fn."""
    return out[f"{name}.wear_load"] if f"{name}.wear_load" in out else out[f"{name}.fn"]


def block_increment(wm: WearModel, name, traj, depth=None):
    """Node depth increment (m) worn over one simulated block (a Trajectory of the worn joint
    ``name``) on the profile ``depth`` it ran on: the samples' contact angle (the angle of the
    contact point NAME.contact_point on the worn surface, frame1 axes: where the contact is, not
    where the eccentricity points), load (wear_load) and slip speed (NAME.slip), trapezoid rule."""
    out = traj.outputs
    p = out[f"{name}.contact_point"]
    return depth_increment(wm, np.arctan2(p[:, 1], p[:, 0]), wear_load(out, name), out[f"{name}.slip"],
                           trapezoid_weights(traj.t), depth)


def spline_bounds(coef):
    """(span, top): the range max - min and the maximum of the profile's spline (coefficients
    ``coef``, spline_coefficients), sampled 8 times a cell with a 5 % margin: the contact search's
    window (worn_geometry.search_half_angle) needs bounds, not values."""
    x = np.linspace(0.0, 2.0 * math.pi / len(coef), 9)
    v = ((coef[:, :1] * x + coef[:, 1:2]) * x + coef[:, 2:3]) * x + coef[:, 3:4]
    lo, hi = float(v.min()), float(v.max())
    return 1.05 * (hi - lo), hi + 0.025 * (hi - lo)


def spline_coefficients(depth):
    """(N, 4) coefficients (highest power first, local in each cell) of the periodic cubic spline
    through the node depths: the worn profile the kernel evaluates (C2, exact at the nodes)."""
    from scipy.interpolate import CubicSpline

    depth = np.asarray(depth, float)
    N = len(depth)
    th = np.arange(N + 1) * (2.0 * math.pi / N)
    sp = CubicSpline(th, np.append(depth, depth[0]), bc_type="periodic")
    return sp.c.T.copy()


# ------------------------------------------------------------------ the worn joint
class WornData(ClearanceData):
    """ClearanceData plus the workspace's own weight array of the normal law."""

    def __init__(self, nc, nfs):
        super().__init__(nc, nfs)
        self.W = np.ones(nc)


class WornJoint:
    """Mixin of the worn joints (revolute bearing, spherical socket): the worn ``depth`` (m, one value
    per wear node of the ``wear`` model) and the contact's slip speed (the Archard integrand's) as
    output NAME.slip."""

    def __init__(self, *args, wear, depth=None, **kw):
        self.wear = wear
        d = np.zeros(wear.nodes) if depth is None else np.array(depth, float)
        if d.shape != (wear.nodes,) or not np.all(np.isfinite(d)):
            raise ValueError(f"wear depth must be {wear.nodes} finite values, got shape {d.shape}")
        d.flags.writeable = False
        self.depth = d
        self._ctor = (args, dict(kw))
        super().__init__(*args, **kw)

    def outputs(self, mech, ws, d, t, q, v, z):
        out = super().outputs(mech, ws, d, t, q, v, z)
        out["slip"] = self._slip(d)
        out["contact_point"] = self._contact_point(d, ws.data.oMf[self.f1].homogeneous)
        return out

    def record(self, mech, ws, d, t, q, v, z, after_rhs):
        pot, loss, out = super().record(mech, ws, d, t, q, v, z, after_rhs)
        if "slip" not in out:
            out["slip"] = self._slip(d)
        if "contact_point" not in out:
            out["contact_point"] = self._contact_point(d, d.M[0])
        return pot, loss, out

    def record_layout(self):
        lay = super().record_layout()
        return None if lay is None else lay + (("slip", 1), ("contact_point", 3))

    @staticmethod
    def _contact_point(d, M1):
        """The contact point p1 on the worn surface (the nearest point, worn_geometry) in frame1
        axes from its origin: where the wear goes (block_increment)."""
        return M1[:3, :3].T @ (d.p1[0] - M1[:3, 3])

    def with_depth(self, depth, continuing=False):
        """The same joint with the bearing worn to ``depth`` (a new, immutable joint).
        continuing: its runs continue a run's state (a block of pinclear.analysis.wear_life), which may be
        in a deep impact: the start-pose check (max_initial_penetration) is then off."""
        args, kw = self._ctor
        if continuing:
            kw = {**kw, "max_initial_penetration": None}
        return type(self)(*args, wear=self.wear, depth=depth, **kw)

    def _compiled_kernel(self):
        if self._geo is None or self._laws is None or self._friction is None:
            return None
        return channels.worn_clearance_force

    def _kernel_args(self, ws, d):
        lw = self._laws
        laws = Laws(lw.code, lw.P0, lw.P1, lw.chi, d.W, lw.vmin)
        return (self._geo, self._frames(ws, d), self._bodies(ws), laws, self._friction, d.channels)

    def _normal(self, d, delta, dd, dd0):
        # the Python twin of worn_clearance_force: the law's force times the geometry's weight
        Fn, Fel = self.law.force_and_elastic(delta, dd, dd0)
        g = d.scratch[3, 0]
        return Fn * g, Fel * g

    def _record_laws(self, d):
        # the elastic energy is the law's U(delta): unit weights
        lw = self._laws
        return lw.code, lw.P0, lw.P1, np.ones(self.nc)

    def _slip(self, d):
        return float(np.linalg.norm(d.vt[0])) if (d.moving and d.Fn[0] > 0.0) else 0.0

    def record_kernel(self, mech, ws, d, z, zdot, row):
        if self._kernel is None:
            return None
        return channels.worn_record, (d.channels, d.M, z, zdot, self.nc, *self._record_laws(d),
                                      np.zeros(channels.RECORD_SIZE), row)
