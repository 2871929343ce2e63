"""Screw algebra in Plücker coordinates (paper 004, Geng et al. 2014) and the conversions to
Pinocchio's spatial types.

Conventions (the paper's): a twist is S = (omega; v_o), v_o the velocity of the body point at the
fixed origin; a wrench is W = (m_o; f), m_o the moment about the origin, so that W . S is a power.
Both live in the fixed (WORLD) frame. Pinocchio orders Motion and Force (linear; angular): the
converters :func:`to_motion`, :func:`from_motion`, :func:`to_force`, :func:`from_force` swap halves,
and SE3 actions are Pinocchio's own (``pin.SE3.act``) wherever a frame change is needed.

Every function is batched over leading axes (numpy), so the screw system evaluates all limbs and
bodies of a mechanism in one call.
"""
from __future__ import annotations

import numpy as np
import pinocchio as pin


def cross(a, b):
    """Batched 3-vector cross product (..., 3); np.cross's axis handling costs ~10 us a call, which
    dominated this module's small-array evaluations."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[..., 0] = a1 * b2 - a2 * b1
    out[..., 1] = a2 * b0 - a0 * b2
    out[..., 2] = a0 * b1 - a1 * b0
    return out


def skew(w):
    """Batched 3x3 cross-product matrices of vectors (..., 3)."""
    w = np.asarray(w, float)
    out = np.zeros(w.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -w[..., 2], w[..., 1]
    out[..., 1, 0], out[..., 1, 2] = w[..., 2], -w[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -w[..., 1], w[..., 0]
    return out


def adjoint(S):
    """Adjoint (6x6) of twists S = (s; s0), batched: [[s^, 0], [s0^, s^]] (paper 004, after eq. 9)."""
    S = np.asarray(S, float)
    out = np.zeros(S.shape[:-1] + (6, 6))
    ws, vs = skew(S[..., :3]), skew(S[..., 3:])
    out[..., :3, :3] = ws
    out[..., 3:, 3:] = ws
    out[..., 3:, :3] = vs
    return out


def bracket(S1, S2):
    """Lie bracket [S1, S2] = adjoint(S1) S2 of twists (batched over leading axes)."""
    S1, S2 = np.asarray(S1, float), np.asarray(S2, float)
    w1, v1, w2, v2 = S1[..., :3], S1[..., 3:], S2[..., :3], S2[..., 3:]
    return np.concatenate([cross(w1, w2), cross(w1, v2) + cross(v1, w2)], axis=-1)


def dual_cross(V, h):
    """Action of a twist on a wrench/momentum, V x* h = -adjoint(V)^T h (batched)."""
    w, v, m, f = V[..., :3], V[..., 3:], h[..., :3], h[..., 3:]
    return np.concatenate([cross(w, m) + cross(v, f), cross(w, f)], axis=-1)


def reciprocal_product(S, W):
    """Virtual power of wrench W on twist S (both in the paper's order)."""
    return np.einsum("...i,...i->...", S, W)


def line_twist(axis, point, pitch=0.0):
    """Twist of unit rotation about the line through ``point`` along ``axis`` (pitch 0), or of a
    unit translation along ``axis`` when ``pitch`` is ``inf``."""
    s = np.asarray(axis, float)
    s = s / np.linalg.norm(s, axis=-1, keepdims=True)
    if np.isinf(pitch):
        return np.concatenate([np.zeros_like(s), s], axis=-1)
    return np.concatenate([s, cross(point, s) + pitch * s], axis=-1)


def to_motion(S) -> pin.Motion:
    """Paper twist (omega; v_o) -> pin.Motion in Pinocchio's WORLD convention."""
    S = np.asarray(S, float)
    return pin.Motion(S[3:], S[:3])


def from_motion(m: pin.Motion) -> np.ndarray:
    """pin.Motion (WORLD) -> paper twist (omega; v_o)."""
    return np.concatenate([m.angular, m.linear])


def to_force(W) -> pin.Force:
    """Paper wrench (m_o; f) -> pin.Force (f; m_o) in WORLD."""
    W = np.asarray(W, float)
    return pin.Force(W[3:], W[:3])


def from_force(f: pin.Force) -> np.ndarray:
    return np.concatenate([f.angular, f.linear])


def swap(X):
    """Swap the two halves of 6-vectors / rows of 6 x n matrices (paper order <-> Pinocchio order)."""
    X = np.asarray(X)
    return np.concatenate([X[3:], X[:3]], axis=0)


def spatial_inertia(mass, com, R, I_c):
    """N = [[I_o, m c^], [m c^T, m I3]] about the fixed origin (paper 004, eq. 19), batched:
    mass (...,), com (..., 3) world centre of mass, R (..., 3, 3) world orientation of the
    principal frame, I_c (..., 3, 3) central inertia in that frame; I_o = R I_c R^T - m c^ c^."""
    mass = np.asarray(mass, float)
    C = skew(com)
    m = mass[..., None, None]
    out = np.zeros(np.shape(mass) + (6, 6))
    out[..., :3, :3] = R @ I_c @ np.swapaxes(R, -1, -2) - m * (C @ C)
    out[..., :3, 3:] = m * C
    out[..., 3:, :3] = -m * C
    out[..., 3:, 3:] = m * np.eye(3)
    return out


def inertia_wrench(N, V, A):
    """Newton-Euler inertia wrench W = -(N A - V^^T N V) = -(N A + V x* N V) (paper 004, eq. 19)."""
    return -(np.einsum("...ij,...j->...i", N, A) + dual_cross(V, np.einsum("...ij,...j->...i", N, V)))


def gravity_wrench(mass, com, g):
    """Gravity wrench (com x m g; m g) about the origin (paper 004, eq. 23), g the gravity vector."""
    f = np.asarray(mass, float)[..., None] * np.asarray(g, float)
    return np.concatenate([cross(com, f), f], axis=-1)


def describe_twist(V, tol=1e-6):
    """Human-readable axis of a twist: rotation about a line (point, direction, pitch) or translation."""
    w, v = np.asarray(V[:3]), np.asarray(V[3:])
    nw = np.linalg.norm(w)
    if nw < tol * max(1.0, np.linalg.norm(v)):
        d = v / np.linalg.norm(v)
        return {"kind": "translation", "direction": d.round(6).tolist()}
    d = w / nw
    point = cross(w, v) / nw ** 2       # foot of the axis nearest the origin
    pitch = float(w @ v) / nw ** 2
    return {"kind": "rotation" if abs(pitch) < 1e-6 else "screw", "direction": d.round(6).tolist(),
            "point": point.round(6).tolist(), "pitch": round(float(pitch), 9)}
