"""Archard wear of a spherical clearance's socket, and the worn socket's contact geometry.

Law: as the revolute bearing's (contact.wear; Archard 1953, local form of Flores 2009 and Mukras
et al. 2010): the socket surface recedes at dh/dt = k p v_slip / H, accumulated on the nodes of a
(theta, phi) mesh of the socket's surface: ``nodes`` rows in theta (polar angle from the mesh's
pole, one of frame1's axes: ``pole``), 2 x nodes columns in phi, nodes at the cell centres
theta_i = (i + 1/2) pi / rows, phi_j = 2 pi j / cols (no node at a pole).

Pressure: the contact law's normal force F (output NAME.fn, damping included) spread over the
Hertz contact circle of a ball in a conforming spherical seat, a = (3 F R* / (4 E*))^(1/3) with
R* = R_ball R_socket / (R_socket - R_ball) (Johnson 1985, Contact Mechanics, eqs. 4.22-4.23 with
the internal contact's relative curvature), either p(rho) = (3 F / (2 pi a^2)) sqrt(1 - rho^2/a^2)
(``distribution: hertz``, the default, Johnson eq. 4.23) or uniform F / (pi a^2), rho the arc length
on the socket from the contact direction. Each sample's share of each cell is its pressure integrated
over the cell (midpoint rule on quad x quad sub-cells) and normalised so the shares sum to 1: the worn
volume is k F s / H to round-off. R* is the new socket's (as the revolute's: a conforming pocket
widens the true contact, which this distribution does not follow).

Geometry: the worn socket's radius is R_socket + w(direction), w the tensor Catmull-Rom
interpolant of the node depths in (theta, phi) (C1, passes through the nodes, local;
contact._kernels.worn_sphere_depth), rows continued across each pole along the great circle. The
(theta, phi) chart is singular at its poles: the wear must stay off the two rows next to each pole
(then w = 0 within half a row of it and the field is continuous through the pole); an increment
that reaches them stops the run with an error naming ``pole``. Penetration and normal against the
worn surface in the compiled kernel (contact._kernels.worn_spherical_geometry); the force is
-F(delta) grad delta (the energy audit closes between reshapes).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from pinclear.contact import worn_geometry, worn_foundation
from pinclear.contact.wear import DISTRIBUTIONS, MODELS, positive, trapezoid_weights, wear_load, wear_mapping
from pinclear.core.errors import InputError
from pinclear.core.jit import njit
from pinclear.core.registry import Key

POLES = ("x", "y", "z")
#: most mesh rows in theta: 2 x 200^2 = 80000 nodes (0.9 deg cells), within contact.wear.MAX_NODES
MAX_ROWS = 200

#: the worn socket's contact models (worn_foundation, worn_geometry) and the foundation cell's bounds [deg]
CONTACTS = ("foundation", "least_distance")
CELL_DEG = (0.1, 5.0)

#: the keys of a spherical clearance's ``wear:`` mapping (docs/wear_lubrication.md sec. 6)
WEAR_KEYS = (
    Key("model", "string", "-", "archard", ", ".join(MODELS), "Archard 1953", "the wear law"),
    Key("k", "number", "-", None, "> 0", "Archard 1953: V = k F s / H", "dimensionless wear coefficient"),
    Key("hardness", "number", "Pa", None, "> 0", "Archard 1953", "hardness H of the worn socket"),
    Key("nodes", "integer", "-", 36, ">= 8", "contact/wear_spherical.py",
        "mesh rows in theta (2 x nodes columns in phi; 36: 5 deg cells; at most 200)"),
    Key("distribution", "string", "-", "hertz", ", ".join(DISTRIBUTIONS), "Johnson 1985 eqs. 4.22-4.23",
        "pressure over the Hertz contact circle: elliptic (hertz) or uniform"),
    Key("pole", "string", "-", "z", ", ".join(POLES), "contact/wear_spherical.py",
        "frame1 axis of the mesh's poles (keep it away from where the socket wears)"),
    Key("contact", "string", "-", "foundation", ", ".join(CONTACTS), "docs/wear_lubrication.md sec. 11",
        "the worn socket's contact: an elastic foundation over a fine grid (the normal law at its "
        "effective penetration) or one least-distance point (sec. 8)"),
    Key("foundation_cell", "number", "deg", 1.25, f"[{CELL_DEG[0]:g}, {CELL_DEG[1]:g}]",
        "docs/wear_lubrication.md sec. 11", "largest cell side of the foundation's grid (the mesh's cells "
        "subdivided: each side into ceil(mesh cell / this) parts)"),
)
_NAMES = tuple(k.name for k in WEAR_KEYS)


@dataclass(frozen=True)
class SphericalWearModel:
    """What the wear law needs of one socket: k, H, mesh rows, distribution, pole axis (0, 1, 2
    of frame1), radii, E*, R* and the sub-cells per cell side of the share quadrature."""
    k: float
    hardness: float
    rows: int
    distribution: str
    pole: int
    R1: float
    R2: float
    estar: float
    rstar: float
    quad: int = 8
    contact: str = "foundation"
    cell: float = math.radians(1.25)

    @property
    def subdivision(self) -> int:
        """The foundation grid's cells per mesh cell side (0: the least-distance contact alone)."""
        return math.ceil(self.dtheta / self.cell - 1e-9) if self.contact == "foundation" else 0

    @property
    def cols(self) -> int:
        return 2 * self.rows

    @property
    def nodes(self) -> int:
        return self.rows * self.cols

    @property
    def dtheta(self) -> float:
        return math.pi / self.rows

    @property
    def dphi(self) -> float:
        return 2.0 * math.pi / self.cols

    def angles(self) -> np.ndarray:
        """(2, nodes): theta and phi (rad) of each node, row by row."""
        th = (np.arange(self.rows) + 0.5) * self.dtheta
        ph = np.arange(self.cols) * self.dphi
        T, P = np.meshgrid(th, ph, indexing="ij")
        return np.array([T.ravel(), P.ravel()])

    def cell_areas(self) -> np.ndarray:
        """Socket area (m^2) of each node's cell [theta -+ dtheta/2] x [phi -+ dphi/2]."""
        th = (np.arange(self.rows) + 0.5) * self.dtheta
        band = np.cos(th - 0.5 * self.dtheta) - np.cos(th + 0.5 * self.dtheta)
        return np.repeat(self.R1 ** 2 * band * self.dphi, self.cols)

    def volume(self, depth) -> float:
        """Worn volume (m^3) of the node depths."""
        return float(np.dot(depth, self.cell_areas()))

    def profile_columns(self) -> dict:
        th, ph = np.degrees(self.angles())
        return {"theta from the pole [deg]": th, "phi [deg]": ph}

    def local(self, vec) -> np.ndarray:
        """frame1 components (..., 3) in the mesh's axes (pole third)."""
        vec = np.asarray(vec, float)
        p = self.pole
        return vec[..., [(p + 1) % 3, (p + 2) % 3, p]]

    @cached_property
    def _subpoints(self):
        """Unit vectors (rows, cols, quad^2, 3) of the sub-cell midpoints and their areas (rows, quad^2)."""
        m = self.quad
        off = (np.arange(m) + 0.5) / m - 0.5
        th = ((np.arange(self.rows) + 0.5)[:, None] + off[None, :]) * self.dtheta          # (rows, m)
        ph = (np.arange(self.cols)[:, None] + off[None, :]) * self.dphi                    # (cols, m)
        T = np.broadcast_to(th[:, None, :, None], (self.rows, self.cols, m, m))
        P = np.broadcast_to(ph[None, :, None, :], (self.rows, self.cols, m, m))
        u = np.stack([np.sin(T) * np.cos(P), np.sin(T) * np.sin(P), np.cos(T)], axis=-1)
        area = self.R1 ** 2 * np.sin(th) * (self.dtheta / m) * (self.dphi / m)             # (rows, m)
        area = np.broadcast_to(area[:, :, None], (self.rows, m, m))
        return u.reshape(self.rows, self.cols, m * m, 3), area.reshape(self.rows, m * m)

    def increment(self, name, traj, depth=None):
        return block_increment(self, name, traj, depth)


def parse(sp, R1, R2):
    """The ``wear:`` mapping of a spherical clearance entry as a SphericalWearModel (None without it)."""
    w = wear_mapping(sp, _NAMES)
    if w is None:
        return None
    for key, choices, default in (("model", MODELS, "archard"), ("distribution", DISTRIBUTIONS, "hertz"),
                                  ("pole", POLES, "z"), ("contact", CONTACTS, "foundation")):
        if w.get(key, default) not in choices:
            raise sp.error(f"wear.{key}", f"unknown {key} {w[key]!r}", choices)
    rows = w.get("nodes", 36)
    if isinstance(rows, bool) or not isinstance(rows, int) or not 8 <= rows <= MAX_ROWS:
        raise sp.error("wear.nodes", f"an integer in [8, {MAX_ROWS}] (mesh rows in theta), got {rows!r}")
    cell = w.get("foundation_cell", 1.25)
    if isinstance(cell, bool) or not isinstance(cell, (int, float)) or not CELL_DEG[0] <= cell <= CELL_DEG[1]:
        raise sp.error("wear.foundation_cell", f"a number of degrees in [{CELL_DEG[0]:g}, {CELL_DEG[1]:g}] (the "
                       f"foundation grid's largest cell side), got {cell!r}")
    return SphericalWearModel(positive(sp, w, "k"), positive(sp, w, "hardness"), rows, w.get("distribution", "hertz"),
                              POLES.index(w.get("pole", "z")), R1, R2, sp.estar(), R2 * R1 / (R1 - R2),
                              contact=w.get("contact", "foundation"), cell=math.radians(float(cell)))


def catmull_rom_bounds(depth):
    """(span, top): bounds of the range and the maximum of the socket's tensor Catmull-Rom
    interpolant (the contact search's window, worn_geometry.search_half_angle): its weights sum
    to 1 with absolute sum <= 1.25 per direction (x = 1/2), so it stays within 1.25^2 half-ranges
    of the nodes' mid-range."""
    lo, hi = float(np.min(depth)), float(np.max(depth))
    half = 1.5625 * 0.5 * (hi - lo)
    return 2.0 * half, 0.5 * (lo + hi) + half


def socket_gpar(wm: SphericalWearModel, c, ray_radius, depth, m):
    """The worn socket kernel's parameters (worn_geometry.WORN_SPHERE_HEAD's layout): the head,
    the mesh depths and, for the foundation (m > 0 cells per mesh cell side), m, its fine depths
    and blocks' least depths (zeros on an unworn socket, where the kernel takes the circle)."""
    depth = np.asarray(depth, float)
    g = np.concatenate([[c, wm.R1, wm.R2, float(wm.pole), ray_radius, float(wm.rows), float(wm.cols),
                         *catmull_rom_bounds(depth)], depth])
    if m == 0:
        return g
    return np.concatenate([g, [float(m)], worn_geometry.fine_depths(g, m) if np.any(depth) else
                           np.zeros((m * m + 1) * wm.nodes)])


# ------------------------------------------------------------------ the law
def contact_radius(wm: SphericalWearModel, F):
    """Hertz contact radius a (m) of the ball in its seat under the load F (N), Johnson eq. 4.22."""
    return np.cbrt(3.0 * np.maximum(F, 0.0) * wm.rstar / (4.0 * wm.estar))


def _window_loads(wm: SphericalWearModel, u, a, i0, Kr, j0, Kc):
    """(cells, loads), both (S, Kr Kc): the pressure of each load (unit direction u (S, 3), contact
    radius a) integrated over the Kr x Kc cells from row i0, column j0 (sub-cell midpoints)."""
    sub, area = wm._subpoints
    rows = i0[:, None] + np.arange(Kr)[None, :]                                 # (S, Kr)
    cols = (j0[:, None] + np.arange(Kc)[None, :]) % wm.cols                     # (S, Kc)
    pts = sub[rows[:, :, None], cols[:, None, :]]                               # (S, Kr, Kc, m^2, 3)
    chord = np.linalg.norm(pts - u[:, None, None, None, :], axis=-1)
    rho = 2.0 * wm.R1 * np.arcsin(np.minimum(0.5 * chord, 1.0))                # arc length on the socket
    x = np.clip(1.0 - (rho / np.maximum(a, 1e-300)[:, None, None, None]) ** 2, 0.0, None)
    p = np.sqrt(x) if wm.distribution == "hertz" else (x > 0).astype(float)
    load = (p * area[rows][:, :, None, :]).sum(axis=-1)                         # (S, Kr, Kc)
    cells = rows[:, :, None] * wm.cols + cols[:, None, :]
    return cells.reshape(len(u), -1), load.reshape(len(u), -1)


def cell_shares(wm: SphericalWearModel, u, a):
    """The NumPy reference of the compiled _share_volumes (tests compare the two; the runs call the
    kernel). (cells, shares), both (S, K): each load's (unit direction u (S, 3) in the mesh axes, contact
    radius a (S,)) pressure integrated over the cells it can reach, normalised to sum 1 per load; a
    contact smaller than the sub-cells goes whole to the cell holding u. Only the rows within reach
    are visited, and away from the poles only the columns within reach (a window fixed per batch)."""
    u, a = np.atleast_2d(u), np.atleast_1d(a)
    th = np.arccos(np.clip(u[:, 2], -1.0, 1.0))
    ph = np.arctan2(u[:, 1], u[:, 0]) % (2.0 * math.pi)
    reach = a / wm.R1
    Kr = min(int(math.ceil(2.0 * reach.max() / wm.dtheta)) + 3, wm.rows)
    i0 = np.clip(np.floor((th - reach) / wm.dtheta).astype(np.int64) - 1, 0, wm.rows - Kr)
    smin = np.minimum(np.sin(i0 * wm.dtheta), np.sin((i0 + Kr) * wm.dtheta))
    half = (reach + wm.dtheta) / np.maximum(smin, 1e-300) / wm.dphi          # columns either side
    polar = half * wm.dphi >= 0.5 * math.pi
    K = Kr * wm.cols
    cells, load = np.zeros((len(u), K), np.int64), np.zeros((len(u), K))
    for group in (polar, ~polar):
        if not group.any():
            continue
        Kc = wm.cols if group is polar else int(math.ceil(2.0 * half[group].max())) + 4
        j0 = np.zeros(group.sum(), np.int64) if group is polar else \
            np.floor(ph[group] / wm.dphi - half[group]).astype(np.int64) - 1
        c, l = _window_loads(wm, u[group], a[group], i0[group], Kr, j0, Kc)
        cells[group, :c.shape[1]], load[group, :c.shape[1]] = c, l
    total = load.sum(axis=1)
    none = total <= 0.0
    if none.any():
        i = np.minimum((th[none] / wm.dtheta).astype(np.int64), wm.rows - 1)
        j = np.round(ph[none] / wm.dphi).astype(np.int64) % wm.cols
        cells[none, 0], load[none, 0], load[none, 1:] = i * wm.cols + j, 1.0, 0.0
        total[none] = 1.0
    return cells, load / total[:, None]


def depth_increment(wm: SphericalWearModel, u, F, slip, dt):
    """Wear depth (m) added at each node by the samples (unit contact direction u (samples, 3) in the
    mesh axes, normal force F, slip speed, time weight dt): each sample's worn volume k F v dt / H
    shared over the cells by its pressure (cell_shares' rule, compiled: _share_volumes), over each
    cell's area."""
    F, slip, dt = (np.atleast_1d(np.asarray(x, float)) for x in (F, slip, dt))
    u = np.atleast_2d(np.asarray(u, float))
    keep = np.flatnonzero((F > 0.0) & (slip > 0.0) & (dt > 0.0))
    vol = np.zeros(wm.nodes)
    if len(keep):
        sub, area = wm._subpoints
        work = wm.k * F[keep] * slip[keep] * dt[keep] / wm.hardness                 # worn volume per sample, m^3
        _share_volumes(np.ascontiguousarray(sub), np.ascontiguousarray(area), np.ascontiguousarray(u[keep]),
                       contact_radius(wm, F[keep]), work, wm.R1, wm.rows, wm.distribution == "hertz", vol)
    return vol / wm.cell_areas()


@njit(cache=True)
def _share_volumes(sub, area, u, a, work, R1, rows, hertz, vol):
    """vol[node] += each sample's worn volume work[s] shared over the cells by its pressure: the
    sub-cell quadrature of cell_shares (the same windows per sample, the same fallback to the cell
    holding u when the contact is smaller than the sub-cells), without its (samples, cells,
    sub-cells, 3) temporaries, which made a socket's wear update cost about the block it follows."""
    cols = 2 * rows
    dth, dph = math.pi / rows, 2.0 * math.pi / cols
    nsub = sub.shape[2]
    cells = np.empty(rows * cols, np.int64)
    load = np.empty(rows * cols)
    for s in range(u.shape[0]):
        ux, uy, uz = u[s, 0], u[s, 1], u[s, 2]
        th = math.acos(min(max(uz, -1.0), 1.0))
        ph = math.atan2(uy, ux) % (2.0 * math.pi)
        reach = a[s] / R1
        Kr = min(int(math.ceil(2.0 * reach / dth)) + 3, rows)
        i0 = min(max(int(math.floor((th - reach) / dth)) - 1, 0), rows - Kr)
        smin = min(math.sin(i0 * dth), math.sin((i0 + Kr) * dth))
        half = (reach + dth) / max(smin, 1e-300) / dph
        if half * dph >= 0.5 * math.pi:
            j0, Kc = 0, cols
        else:
            j0, Kc = int(math.floor(ph / dph - half)) - 1, min(int(math.ceil(2.0 * half)) + 4, cols)
        # sub-points whose chord to u exceeds the contact circle's carry no pressure: skip their asin
        c2max = 4.0 * math.sin(0.5 * reach) ** 2 if reach < math.pi else 4.0
        n, total = 0, 0.0
        for i in range(i0, i0 + Kr):
            for jj in range(Kc):
                j = (j0 + jj) % cols
                acc = 0.0
                for k in range(nsub):
                    dx, dy, dz = sub[i, j, k, 0] - ux, sub[i, j, k, 1] - uy, sub[i, j, k, 2] - uz
                    c2 = dx * dx + dy * dy + dz * dz
                    if c2 > c2max:
                        continue
                    rho = 2.0 * R1 * math.asin(min(0.5 * math.sqrt(c2), 1.0))
                    x = 1.0 - (rho / max(a[s], 1e-300)) ** 2
                    if x > 0.0:
                        acc += (math.sqrt(x) if hertz else 1.0) * area[i, k]
                if acc > 0.0:
                    cells[n], load[n] = i * cols + j, acc
                    n += 1
                    total += acc
        if total <= 0.0:
            i = min(int(th / dth), rows - 1)
            vol[i * cols + int(np.rint(ph / dph)) % cols] += work[s]
        else:
            for q in range(n):
                vol[cells[q]] += work[s] * load[q] / total


def foundation_increment(wm: SphericalWearModel, depth, E, u, F, slip, dt):
    """depth_increment on the worn socket ``depth`` of the foundation contact: each sample's worn
    volume shared by the foundation's pressure over the actual patch (worn_foundation.
    foundation_deposit, ball centres E in the mesh axes); a sample touching no fine node (a patch
    narrower than a cell) by the Hertz patch at its contact direction u."""
    F, slip, dt = (np.atleast_1d(np.asarray(x, float)) for x in (F, slip, dt))
    keep = np.flatnonzero((F > 0.0) & (slip > 0.0) & (dt > 0.0))
    vol = np.zeros(wm.nodes)
    if not len(keep):
        return vol
    m = wm.subdivision
    g = socket_gpar(wm, wm.R1 - wm.R2, 0.5, depth, m)
    f0 = worn_geometry.WORN_SPHERE_HEAD + wm.nodes + 1
    work = wm.k * F[keep] * slip[keep] * dt[keep] / wm.hardness
    missed = np.zeros(len(keep), np.bool_)
    worn_foundation.foundation_deposit(g, f0, m * wm.rows, m * wm.cols, m, np.ascontiguousarray(E[keep]), work, vol,
                                       missed)
    vol /= wm.cell_areas()
    if missed.any():
        k = keep[missed]
        vol += depth_increment(wm, u[k], F[k], slip[k], dt[k])
    return vol


def block_increment(wm: SphericalWearModel, name, traj, depth=None):
    """Node depth increment (m) worn over one block (a Trajectory of the worn socket ``name``) on
    the profile ``depth``: load (contact.wear.wear_load), slip NAME.slip, trapezoid rule; shared by
    the foundation's pressure over the actual patch where the socket is worn and its contact the
    foundation (foundation_increment, the ball centre NAME.eccentricity), else over the Hertz patch
    at the contact point's direction (NAME.contact_point, frame1 axes). An increment reaching the
    two rows next to a pole stops with an error naming ``pole``."""
    out = traj.outputs
    e = wm.local(out[f"{name}.contact_point"])
    r = np.linalg.norm(e, axis=1)
    u = e / np.where(r > 0.0, r, 1.0)[:, None]
    args = (wear_load(out, name), out[f"{name}.slip"], trapezoid_weights(traj.t))
    if wm.subdivision and depth is not None and np.any(depth):
        h = foundation_increment(wm, depth, wm.local(out[f"{name}.eccentricity"]), u, *args)
    else:
        h = depth_increment(wm, u, *args)
    grid = h.reshape(wm.rows, wm.cols)
    if np.any(grid[[0, 1, -2, -1]] > 0.0):
        raise InputError(f"the wear of {name!r} reaches its mesh pole (frame1 {POLES[wm.pole]} axis), where the "
                         "(theta, phi) chart is singular: put the pole on another frame1 axis",
                         key=f"clearances.{name}.wear.pole", choices=[p for p in POLES if p != POLES[wm.pole]])
    return h


def plot_depth_map(ax, wm: SphericalWearModel, depth, title=""):
    """Depth (um) on the socket's (theta, phi) map, degrees labelled; returns the image."""
    ext = [0.0, 360.0, 180.0, 0.0]
    grid = 1e6 * np.asarray(depth).reshape(wm.rows, wm.cols)
    im = ax.imshow(grid, extent=ext, aspect="auto", cmap="viridis", interpolation="nearest")
    ax.set(xlabel="phi [deg] (about the pole)", ylabel=f"theta from the frame1 {POLES[wm.pole]} pole [deg]",
           title=title)
    ax.figure.colorbar(im, ax=ax, label="wear depth [um]")
    return im
