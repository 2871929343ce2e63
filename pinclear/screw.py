"""Screw-theory kinematics and inverse dynamics of parallel mechanisms (paper 004, Geng et al. 2014).

Conventions (the paper's): a twist is S = (omega; v_o), v_o the velocity of the body point at the
fixed origin; a wrench is W = (m_o; f), m_o the moment about the origin, so that W . S is a power.
Both live in the fixed (WORLD) frame. Pinocchio orders Motion and Force (linear; angular): the
converters :func:`to_motion`, :func:`from_motion`, :func:`to_force`, :func:`from_force` swap halves,
and SE3 actions are Pinocchio's own (``pin.SE3.act``) wherever a frame change is needed.

A parallel mechanism is read as a platform plus limbs, each limb a serial chain from the base to
the platform: the tree joints of the limb's branch, then the screws of the cut joint that closes it
on the platform (spherical: three rotations about the centre; universal: two; revolute: one), then
``6 - n`` *virtual joints* (paper 004, sec. 2.1, the virtual-mechanism method) so that every limb
has six screws. The inputs q are the actuated joints plus the virtual joints (held at zero rate);
the rows of the inverted limb Jacobians for those joints stack into G_p^q, its inverse is the
platform's first-order influence coefficient G_q^p (eq. 8); the second order H_q^p follows from
Lie brackets [S_j, S_k] (eqs. 9-14). Inverse dynamics is Newton-Euler per body,
W = -(N A - V^^T N V) (eqs. 19, 21), plus gravity (eqs. 23-24), mapped by virtual work (eq. 26).

Everything per evaluation is vectorised over limbs and bodies (numpy batched algebra on padded
arrays); Pinocchio supplies the joint placements and joint screws (one computeJointJacobians).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pinocchio as pin

from .errors import InputError, ModelFileError, PinclearError

# --------------------------------------------------------------------------- screw algebra


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


# --------------------------------------------------------------------------- limb description
CUT_SCREWS = {"spherical": 3, "universal": 2, "revolute": 1}


@dataclass
class Limb:
    name: str
    joints: list                   # joint ids of the branch, base to tip
    bodies: list                   # joint ids whose bodies belong to the limb (platform excluded)
    cut: str | None = None         # closure type closing the limb on the platform (None: tree limb)
    f_limb: int = -1               # closure frame on the limb side
    f_plat: int = -1               # closure frame on the platform side
    actuated: list = field(default_factory=list)    # indices into the limb's screws
    drive_names: list = field(default_factory=list)
    virtual: str = "complement"    # "complement" | "upr" (paper 004's choice for the UPR limb)

    @property
    def nreal(self):
        return len(self.joints) + CUT_SCREWS.get(self.cut, 0)


class ScrewSystem:
    """A mechanism read as platform + limbs for the screw method (compiled once, evaluated often).

    Build with :func:`screw_system` from a :class:`pinclear.Mechanism`.
    """

    def __init__(self, model, platform_joint, limbs, drive_order, name="", length_scale=None,
                 platform_frame=None, q_ref=None):
        self.model = model
        self.data = model.createData()
        self.name = name
        self.pj = int(platform_joint)
        self.platform_frame = platform_frame
        self.limbs = limbs
        nL = len(limbs)
        self.nL = nL
        for lb in limbs:
            if lb.nreal > 6:
                raise InputError(f"{name}: limb {lb.name} has {lb.nreal} screws (> 6): not a serial limb of a "
                                 "non-redundant parallel mechanism")
        # inputs: the drives in the mechanism's order, then the virtual joints limb by limb
        self.inputs = []                         # (limb index, screw index, label)
        by_drive = {}
        for li, lb in enumerate(limbs):
            for k, dn in zip(lb.actuated, lb.drive_names):
                by_drive[dn] = (li, k, dn)
        for dn in drive_order:
            if dn not in by_drive:
                raise InputError(f"{name}: drive {dn!r} acts on no limb joint")
            self.inputs.append(by_drive[dn])
        self.n_act = len(self.inputs)
        for li, lb in enumerate(limbs):
            for k in range(lb.nreal, 6):
                self.inputs.append((li, k, f"{lb.name}.virtual{k - lb.nreal + 1}"))
        if len(self.inputs) != 6:
            raise InputError(f"{name}: {self.n_act} drives + {len(self.inputs) - self.n_act} virtual joints = "
                             f"{len(self.inputs)} inputs; the screw method needs 6 (a non-redundant mechanism "
                             "whose limbs each have at most 6 screws)")
        self.in_limb = np.array([i[0] for i in self.inputs])
        self.in_screw = np.array([i[1] for i in self.inputs])
        self.labels = [i[2] for i in self.inputs]
        self.drive_names = list(drive_order)
        # padded body arrays: (nL, nbmax) joint ids, -1 = none
        nb = max(len(lb.bodies) for lb in limbs)
        self.nb = nb
        self.body_j = -np.ones((nL, nb), dtype=int)
        for li, lb in enumerate(limbs):
            self.body_j[li, :len(lb.bodies)] = lb.bodies
        # body k of limb li follows tree screw k (bodies are the branch joints' children)
        self.body_mask = self.body_j >= 0
        self.joint_v = np.zeros((nL, 6), dtype=int)
        self.joint_mask = np.zeros((nL, 6), dtype=bool)
        for li, lb in enumerate(limbs):
            for k, j in enumerate(lb.joints):
                self.joint_v[li, k] = model.joints[j].idx_v
                self.joint_mask[li, k] = True
        self._inertia_arrays()
        self.length_scale = length_scale or self._default_length()
        sph = [li for li, lb in enumerate(limbs) if lb.cut == "spherical"]
        self._sph_limbs = np.array(sph, dtype=int)
        self._sph_frames = np.array([limbs[li].f_plat for li in sph], dtype=int)
        # cut centres in the platform joint's frame (frames on the platform body are rigidly fixed)
        self._sph_local = np.array([model.frames[int(f)].placement.translation for f in self._sph_frames])
        # columns of the three spherical screws: right after the limb's tree joints
        self._sph_cols = np.array([[len(limbs[li].joints) + k for k in range(3)] for li in sph], dtype=int)
        self._needs_frames = any(lb.cut not in (None, "spherical") for lb in limbs)
        self._other_limbs = [li for li, lb in enumerate(limbs)
                             if (lb.cut is not None and lb.cut != "spherical") or lb.nreal < 6]
        # reference completion of each limb with complement virtual joints, taken once at q_ref:
        # later completions are its projection on the current complement, orthonormalised with a
        # positive-diagonal QR, so they vary continuously (an SVD basis may flip sign from one
        # instant to the next, which would fake a determinant sign change, i.e. a singular crossing)
        self._vref = {}
        self.screws(pin.neutral(model) if q_ref is None else np.asarray(q_ref, float))

    @staticmethod
    def _sph_block(C):
        # (k, 3, 6): rows (e_j; c x e_j) for j = 1..3
        out = np.zeros((len(C), 3, 6))
        out[:, :, :3] = np.eye(3)
        out[:, :, 3:] = -skew(C)           # c x e_j is column j of c^, i.e. row j of -c^
        return out

    # -- constant inertia data (in joint frames)
    def _inertia_arrays(self):
        model = self.model
        nL, nb = self.body_j.shape
        self.b_mass = np.zeros((nL, nb))
        self.b_com = np.zeros((nL, nb, 3))
        self.b_I = np.zeros((nL, nb, 3, 3))
        for li in range(nL):
            for k in range(nb):
                j = self.body_j[li, k]
                if j >= 0:
                    Y = model.inertias[int(j)]
                    self.b_mass[li, k], self.b_com[li, k], self.b_I[li, k] = Y.mass, Y.lever, Y.inertia
        Y = model.inertias[self.pj]
        self.p_mass, self.p_com, self.p_I = Y.mass, np.array(Y.lever), np.array(Y.inertia)
        self.bj_flat = np.where(self.body_mask, self.body_j, 0)

    def _default_length(self):
        # platform size: mean distance of the cut points from the platform joint (characteristic
        # length that makes moments and forces commensurable in condition numbers)
        pts = [self.model.frames[lb.f_plat].placement.translation for lb in self.limbs if lb.f_plat >= 0]
        r = float(np.mean([np.linalg.norm(p) for p in pts])) if pts else 1.0
        return r if r > 1e-6 else 1.0

    # ------------------------------------------------------------------ evaluation
    def screws(self, q):
        """Limb screw matrices (nL, 6, 6): S[l, k] is the k-th screw of limb l (paper order), with
        the cut-joint screws and the virtual joints appended. Also returns the platform pose."""
        model, data = self.model, self.data
        pin.computeJointJacobians(model, data, q)
        if self._needs_frames:
            pin.updateFramePlacements(model, data)
        Jw = data.J                                      # 6 x nv, WORLD, (v; w)
        Jp = np.concatenate([Jw[3:], Jw[:3]], axis=0)    # paper order
        S = np.zeros((self.nL, 6, 6))
        S[self.joint_mask] = Jp[:, self.joint_v[self.joint_mask]].T
        Mp = data.oMi[self.pj]
        if self._sph_limbs.size:
            # spherical cuts, all limbs at once: rotations about e1, e2, e3 through the centre c
            C = self._sph_local @ Mp.rotation.T + Mp.translation            # (k, 3) world centres
            S[self._sph_limbs[:, None], self._sph_cols] = self._sph_block(C)
        for li in self._other_limbs:
            lb = self.limbs[li]
            n = len(lb.joints)
            if lb.cut is not None and lb.cut != "spherical":
                c = data.oMf[lb.f_plat].translation
                if lb.cut == "universal":
                    S[li, n] = line_twist(data.oMf[lb.f_limb].rotation[:, 2], c)
                    S[li, n + 1] = line_twist(data.oMf[lb.f_plat].rotation[:, 2], c)
                else:
                    S[li, n] = line_twist(data.oMf[lb.f_plat].rotation[:, 2], c)
            if lb.nreal < 6:
                S[li, lb.nreal:] = self._virtual(lb, S[li, :lb.nreal], Mp)
        return S, Mp

    def _virtual(self, lb, real, Mp):
        nv = 6 - lb.nreal
        if lb.virtual == "upr" and lb.nreal == 4:
            # paper 004, sec. 2.1: S5 = (l; u x l) about the limb axis through the U centre u,
            # S6 = (s6; p' x s6) through the platform origin p', with s2 = e1 x l / |e1 x l| (the
            # U's second axis, e1 its first) and s6 = l x s2 / |l x s2| (the printed "s5 x l5" is
            # an extraction slip, s5 = l5; the order l x s2 reproduces the sign of the printed G)
            u = self.data.oMi[lb.joints[0]].translation
            pp = Mp.translation
            ell = (pp - u) / np.linalg.norm(pp - u)
            s2 = cross(real[0, :3], ell)
            s2 /= np.linalg.norm(s2)
            s6 = cross(ell, s2)
            s6 /= np.linalg.norm(s6)
            return np.stack([line_twist(ell, u), line_twist(s6, pp)])
        # orthogonal complement of the real screws' span (any completion gives the same drive
        # forces; only the virtual joints' own generalized forces depend on it)
        u = np.linalg.svd(real.T)[0]
        comp = u[:, lb.nreal:lb.nreal + nv]
        ref = self._vref.setdefault(lb.name, comp)
        Q, R = np.linalg.qr(comp @ (comp.T @ ref))
        return (Q * np.sign(np.diag(R))).T

    def kinematics(self, q, V, A=None, S=None):
        """Limb joint rates and accelerations for a platform twist V and acceleration A (paper order):
        phid (nL, 6), phidd (nL, 6) from eqs. 7 and 10, body twists and accelerations (nL, nb, 6)."""
        if S is None:
            S, _ = self.screws(q)
        Jinv = np.linalg.inv(np.swapaxes(S, 1, 2))      # (nL, 6, 6): limb Jacobians' inverses
        phid = Jinv @ V
        Sd = S * phid[:, :, None]                       # S_k phid_k
        Vc = np.cumsum(Sd, axis=1)                      # twist after screw k
        Vprev = np.concatenate([np.zeros((self.nL, 1, 6)), Vc[:, :-1]], axis=1)
        # Lie-bracket bias: d/dt S_k = [V_{k-1}, S_k] (paper 004, eq. 9, H_phi entries [S_j, S_k])
        Bc = np.cumsum(bracket(Vprev, Sd), axis=1)
        out = {"S": S, "Jinv": Jinv, "phid": phid, "Vb": Vc[:, :self.nb], "bias": Bc}
        if A is not None:
            phidd = Jinv @ (A - Bc[:, -1])[:, :, None]
            phidd = phidd[:, :, 0]
            Ac = np.cumsum(S * phidd[:, :, None], axis=1) + Bc
            out["phidd"] = phidd
            out["Ab"] = Ac[:, :self.nb]
        return out

    def input_matrix(self, Jinv):
        """G_p^q (6 x 6): rows of the inverted limb Jacobians for the inputs (paper 004, before eq. 8)."""
        return Jinv[self.in_limb, self.in_screw]

    def inverse_dynamics(self, q, V, A, limbs=True, gravity=None, wrench=None, S=None):
        """Input generalized forces tau (6,) at one instant, with the platform moving with twist V and
        acceleration A (paper order) and the tree at q (for the limb axes). ``gravity``: 3-vector
        (default: the model's), ``wrench``: external wrench (m_o; f) on the platform. Returns
        (tau, info) with tau = drive forces then virtual-joint forces (paper 004, eq. 26)."""
        kin = self.kinematics(q, V, A, S)
        S, Jinv = kin["S"], kin["Jinv"]
        data = self.data
        g = np.array(self.model.gravity.linear) if gravity is None else np.asarray(gravity, float)
        Mp = data.oMi[self.pj]
        # platform: eqs. 19, 23
        cp = Mp.act(self.p_com)
        Rp = Mp.rotation
        Np = spatial_inertia(self.p_mass, cp, Rp, self.p_I)
        W = inertia_wrench(Np, V, A) + gravity_wrench(self.p_mass, cp, g)
        if wrench is not None:
            W = W + np.asarray(wrench, float)
        if limbs:
            H = np.array(data.oMi)[self.bj_flat]              # (nL, nb, 4, 4)
            R, p = H[..., :3, :3], H[..., :3, 3]
            com = np.einsum("lkij,lkj->lki", R, self.b_com) + p
            Nb = spatial_inertia(self.b_mass, com, R, self.b_I)
            Wb = inertia_wrench(Nb, kin["Vb"], kin["Ab"]) + gravity_wrench(self.b_mass, com, g)   # eqs. 21, 24
            Wb *= self.body_mask[..., None]
            # generalized force of limb screw k: S_k . (sum of the wrenches of the bodies it carries)
            Wsum = np.cumsum(Wb[:, ::-1], axis=1)[:, ::-1]
            sigma = np.zeros((self.nL, 6))
            sigma[:, :self.nb] = np.einsum("lki,lki->lk", S[:, :self.nb], Wsum)
            # its platform-equivalent wrench J^-T sigma (virtual work through phid = J^-1 V)
            W = W + np.einsum("lki,lk->i", Jinv, sigma)
        Gpq = self.input_matrix(Jinv)
        try:
            tau = np.linalg.solve(Gpq.T, -W)       # G_q^p^T W + tau = 0, G_q^p = (G_p^q)^-1
        except np.linalg.LinAlgError:              # exactly singular: no finite drive forces
            tau = np.full(6, np.nan)
        return tau, {"Gpq": Gpq, "W": W, "kin": kin}

    def influence_coefficients(self, q, S=None):
        """(G, H): A_p = G qdd + einsum('xab,a,b', H, qd, qd) (paper 004, eqs. 8, 14), inputs ordered
        as :attr:`labels`; H symmetrised in its last two indices."""
        if S is None:
            S, _ = self.screws(q)
        Jinv = np.linalg.inv(np.swapaxes(S, 1, 2))
        Gpq = self.input_matrix(Jinv)
        G = np.linalg.inv(Gpq)
        Mi = Jinv @ G                                       # (nL, 6, 6): phid = Mi qd
        Bk = bracket(S[:, :, None, :], S[:, None, :, :])    # (nL, j, k, 6)
        Bk *= np.triu(np.ones((6, 6)), 1)[None, :, :, None]
        rows = Jinv[self.in_limb, self.in_screw]            # (6 inputs, 6)
        Lr = np.einsum("ri,rjki,rja,rkb->rab", rows, Bk[self.in_limb], Mi[self.in_limb], Mi[self.in_limb])
        # qdd = G_p^q A - Lr(qd, qd) (eqs. 10-12)  =>  A = G qdd + G Lr(qd, qd) (eq. 14)
        H = np.einsum("xr,rab->xab", G, Lr)
        H = 0.5 * (H + np.swapaxes(H, 1, 2))
        return G, H

    def body_influence_coefficients(self, q, S=None):
        """(Gk, Hk) of every limb body: its twist V_k = Gk qd and acceleration
        A_k = Gk qdd + einsum('xab,a,b', Hk, qd, qd) in terms of the inputs (paper 004, eqs. 15-18);
        shapes (nL, nb, 6, 6) and (nL, nb, 6, 6, 6), padded bodies zero."""
        if S is None:
            S, _ = self.screws(q)
        G, H = self.influence_coefficients(q, S)
        Jinv = np.linalg.inv(np.swapaxes(S, 1, 2))
        Mi = Jinv @ G                                        # G_q^phi(i): phid = Mi qd (eq. 15)
        Bk = bracket(S[:, :, None, :], S[:, None, :, :]) * np.triu(np.ones((6, 6)), 1)[None, :, :, None]
        # Lie-bracket terms of the whole limb and of the chain up to each screw
        P = np.einsum("ljkx,lja,lkb->ljkxab", Bk, Mi, Mi)      # (nL, j, k, 6, a, b)
        Lall = P.sum(axis=(1, 2))                             # (nL, 6, a, b)
        Lcum = np.cumsum(P.sum(axis=1), axis=1)               # up to screw k (bracket partner j < k)
        # joint accelerations: phidd = Jinv (A - L(qd)), A = G qdd + H(qd)
        Hphi = np.einsum("lij,jab->liab", Jinv, H) - np.einsum("lij,ljab->liab", Jinv, Lall)
        Gk = np.cumsum(S[:, :, :, None] * Mi[:, :, None, :], axis=1)                 # (nL, k, 6, a)
        Hk = np.cumsum(np.einsum("lkx,lkab->lkxab", S, Hphi), axis=1) + Lcum
        mask = self.body_mask[:, :, None, None]
        return Gk[:, :self.nb] * mask, Hk[:, :self.nb] * mask[..., None]

    def singularity(self, q, S=None, tol=1e-9):
        """Rank and conditioning of the combined actuation + constraint wrench system G_p^q.

        Rows are normalised (moments divided by the length scale, then unit norm) so that the
        condition number is unit-free; the lost twist is the platform motion no input resists,
        the lost wrench the combination of input wrenches that vanishes."""
        if S is None:
            S, _ = self.screws(q)
        Jinv = np.linalg.inv(np.swapaxes(S, 1, 2))
        return _singularity_of(self.input_matrix(Jinv), self.length_scale, self.labels, tol)


def _normalised(Gpq, L):
    # wrench row (m; f) against twist (w; v): scale twist (w L; v) -> wrench (m / L; f)
    Wn = Gpq.copy()
    Wn[:, :3] /= L
    return Wn / np.linalg.norm(Wn, axis=1, keepdims=True)


def _singularity_of(Gpq, L, labels, tol):
    Wn = _normalised(Gpq, L)
    u, s, vt = np.linalg.svd(Wn)
    rank = int(np.sum(s > tol * s[0]))
    cond = float(s[0] / s[-1]) if s[-1] > 0 else math.inf
    twist = vt[-1].copy()
    twist[:3] /= L              # back to (omega; v) in rad/s and m/s for a unit normalised twist
    return {"rank": rank, "cond": cond, "sigma": s, "singular": rank < 6,
            "lost_twist": twist, "lost_wrench": dict(zip(labels, u[:, -1])),
            "lost_motion": describe_twist(twist)}


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
            "point": point.round(6).tolist(), "pitch": round(pitch, 9)}


# --------------------------------------------------------------------------- building from a mechanism
def _branch(model, j):
    """Joint ids from the base to joint j (inclusive)."""
    out = []
    while j > 0:
        out.append(j)
        j = model.parents[j]
    return out[::-1]


def screw_system(mech, virtual=None) -> ScrewSystem:
    """Read a loaded :class:`pinclear.Mechanism` as platform + limbs.

    Limbs come from the sidecar's ``limbs:`` list when present (``{name, joints: [...], closure:
    NAME | null, virtual: complement|upr}``), else are found from the topology: the branch
    carrying the platform frame is one limb, and every closure joining another branch to the
    platform closes one more. Drives must sit on limb joints."""
    model = mech.model
    file = mech.path or mech.name
    if mech.platform_frame is None:
        raise ModelFileError(file, "platform.frame", "the screw method needs the platform frame")
    pj = model.frames[mech.platform_frame].parentJoint
    drive_joint = {model.getJointId(d.joint): d.name for d in mech.drives}
    closures = {c.name: c for c in mech.closures}
    specs = (mech.sidecar or {}).get("limbs")
    limbs = []

    def make(name, joints, closure, virt):
        lb = Limb(name=name, joints=joints, bodies=[j for j in joints if j != pj])
        if closure is not None:
            if closure.type not in CUT_SCREWS:
                raise ModelFileError(file, f"closures.{closure.name}.type",
                                     f"the screw method closes limbs with {', '.join(CUT_SCREWS)} joints",
                                     choices=list(CUT_SCREWS))
            j1, j2 = model.frames[closure.f1].parentJoint, model.frames[closure.f2].parentJoint
            if j2 == pj:
                lb.f_limb, lb.f_plat = closure.f1, closure.f2
            elif j1 == pj:
                lb.f_limb, lb.f_plat = closure.f2, closure.f1
            else:
                raise ModelFileError(file, f"closures.{closure.name}",
                                     "a limb's closure must join the limb to the platform body")
            lb.cut = closure.type
        elif pj not in joints:
            raise ModelFileError(file, f"limbs.{name}", "a limb without a closure must carry the platform")
        for k, j in enumerate(joints):
            if j in drive_joint:
                lb.actuated.append(k)
                lb.drive_names.append(drive_joint[j])
        lb.virtual = virt or "complement"
        return lb

    if specs:
        for i, sp in enumerate(specs):
            key = f"limbs[{i}]"
            bad = set(sp) - {"name", "joints", "closure", "virtual"}
            if bad:
                raise ModelFileError(file, f"{key}.{sorted(bad)[0]}", "unknown key",
                                     choices=["name", "joints", "closure", "virtual"])
            joints = []
            for jn in sp.get("joints", []):
                if not model.existJointName(jn):
                    raise ModelFileError(file, f"{key}.joints", f"unknown joint {jn!r}",
                                         choices=list(model.names)[1:])
                joints.append(model.getJointId(jn))
            cname = sp.get("closure")
            if cname is not None and cname not in closures:
                raise ModelFileError(file, f"{key}.closure", f"unknown closure {cname!r}", choices=list(closures))
            virt = sp.get("virtual", "complement")
            if virt not in ("complement", "upr"):
                raise ModelFileError(file, f"{key}.virtual", f"unknown virtual-joint rule {virt!r}",
                                     choices=["complement", "upr"])
            limbs.append(make(sp.get("name", f"limb{i + 1}"), joints,
                              closures[cname] if cname else None, virt))
    else:
        limbs.append(make("platform_limb", _branch(model, pj), None, virtual))
        for c in mech.closures:
            j1, j2 = model.frames[c.f1].parentJoint, model.frames[c.f2].parentJoint
            other = j1 if j2 == pj else j2 if j1 == pj else None
            if other is None:
                continue
            branch = _branch(model, other)
            if set(branch) & set(limbs[0].joints):
                raise ModelFileError(file, f"closures.{c.name}", "limb branches must start at the base "
                                     "(this one shares joints with the platform's branch)")
            limbs.append(make(c.name, branch, c, virtual))
        limbs = limbs[1:] + limbs[:1]
    return ScrewSystem(model, pj, limbs, [d.name for d in mech.drives], name=mech.name,
                       platform_frame=mech.platform_frame, q_ref=mech.q0)


# --------------------------------------------------------------------------- trajectories
@dataclass
class InverseDynamicsResult:
    t: np.ndarray
    tau: np.ndarray                  # (N, n_act) drive forces
    virtual: np.ndarray              # (N, 6 - n_act) virtual-joint generalized forces
    constraint_wrench: np.ndarray    # (N, 6) wrench (m_o; f) the constraint limbs exert on the platform
    cond: np.ndarray                 # (N,) condition number of G_p^q (normalised)
    drive_names: list
    threshold: float
    intervals: list                  # [(t_start, t_end, max cond)] where cond > threshold
    limbs: bool
    gravity: bool
    q: np.ndarray | None = None
    crossings: list = field(default_factory=list)   # [(t, cond)] singular crossings (det sign change)

    def peaks(self) -> dict:
        k = np.argmax(np.abs(self.tau), axis=0)
        return {n: {"peak_abs": float(abs(self.tau[k[i], i])), "t": float(self.t[k[i]]),
                    "max": float(self.tau[:, i].max()), "min": float(self.tau[:, i].min())}
                for i, n in enumerate(self.drive_names)}

    def outside_intervals(self) -> np.ndarray:
        """Mask of the samples outside every reported ill-conditioned interval."""
        ok = np.ones(len(self.t), dtype=bool)
        for a, b, _ in self.intervals:
            ok &= (self.t < a) | (self.t > b)
        return ok

    def summary(self) -> dict:
        ok = self.outside_intervals()
        return {"drive_names": self.drive_names, "peaks": self.peaks(),
                "peak_abs_all": float(np.abs(self.tau).max()),
                "peak_abs_outside_intervals": float(np.abs(self.tau[ok]).max()) if ok.any() else None,
                "limbs": self.limbs, "gravity": self.gravity,
                "cond_max": float(self.cond.max()), "cond_min": float(self.cond.min()),
                "cond_threshold": self.threshold,
                "ill_conditioned_intervals": [{"t_start": a, "t_end": b, "cond_max": c}
                                              for a, b, c in self.intervals],
                "singular_crossings": [{"t": tc, "cond": c} for tc, c in self.crossings]}


def threshold_intervals(t, x, threshold):
    """Maximal intervals of t where x > threshold: [(t_start, t_end, max x)]."""
    above = np.asarray(x) > threshold
    out = []
    i, n = 0, len(t)
    while i < n:
        if above[i]:
            j = i
            while j + 1 < n and above[j + 1]:
                j += 1
            out.append((float(t[i]), float(t[j]), float(np.max(x[i:j + 1]))))
            i = j + 1
        else:
            i += 1
    return out


def _motion_callable(mech, motion):
    """motion: callable t -> (SE3, V, A) (paper order) or t -> SE3, or a law name of paper 004."""
    if isinstance(motion, str):
        from .mechanisms import four_ups_upr

        if motion not in four_ups_upr.LAWS:
            raise InputError(f"unknown motion law {motion!r} (valid: {', '.join(four_ups_upr.LAWS)})")
        return lambda t: four_ups_upr.platform_motion(t, motion)
    if motion is None:
        motion = mech.platform_motion
        if motion is None:
            raise InputError(f"{mech.name}: no platform motion given and none in the sidecar")
    return motion


def pose_derivatives(f, t, h=1e-3):
    """(SE3, V, A) of a pose function by 4th-order central differences of pin.log6 (world twist);
    used only when a motion gives poses without derivatives (truncation error ~ h^4)."""
    M0 = f(t)

    def tw(s):
        return from_motion(pin.log6(f(t + s) * M0.inverse()))

    d1, d2 = tw(h), tw(2 * h)
    m1, m2 = tw(-h), tw(-2 * h)
    V = (8 * (d1 - m1) - (d2 - m2)) / (12 * h)
    # twist at t +- h from the same stencil is costly; the spatial acceleration is dV/dt
    Vp = _twist_at(f, t + h, h)
    Vm = _twist_at(f, t - h, h)
    return M0, V, (Vp - Vm) / (2 * h)


def _twist_at(f, t, h):
    M0 = f(t)
    d1 = from_motion(pin.log6(f(t + h) * M0.inverse()))
    m1 = from_motion(pin.log6(f(t - h) * M0.inverse()))
    return (d1 - m1) / (2 * h)


def _ik_solver(mech):
    """Tree configuration for a platform pose: analytic for paper 004's model, else Newton on the
    closures plus the platform pose (warm-started)."""
    model = mech.model
    if mech.name == "four_ups_upr":
        from .mechanisms import four_ups_upr

        layout = (mech.options or {}).get("layout", "f")
        return lambda M, q_prev: four_ups_upr.tree_configuration(model, M, layout)
    from . import kinematics

    ws = mech.workspace()
    data = model.createData()
    fid = mech.platform_frame
    m = mech.compiled.m

    def solve(M, q_prev):
        q = np.array(mech.q0 if q_prev is None else q_prev, float)
        for _ in range(50):
            kinematics.update_positions(mech, ws, q)
            kinematics.constraint_rows(mech, ws, 0.0, ws.zero_v)
            pin.framesForwardKinematics(model, data, q)
            err = pin.log6(M.actInv(data.oMf[fid])).np
            Jf = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL)
            r = np.concatenate([ws.phi[:m], err])
            if np.max(np.abs(r)) < 1e-13:
                return q
            Jr = np.vstack([ws.J[:m], pin.Jlog6(M.actInv(data.oMf[fid])) @ Jf])
            q = pin.integrate(model, q, np.linalg.lstsq(Jr, -r, rcond=None)[0])
        if np.max(np.abs(r)) > 1e-9:
            raise PinclearError(f"{mech.name}: cannot place the platform at the commanded pose "
                                f"(residual {np.max(np.abs(r)):.2e})")
        return q

    return solve


def inverse_dynamics(mech, motion=None, t=None, limbs=True, gravity=None, wrench=None, threshold=1e3,
                     system=None, keep_q=False) -> InverseDynamicsResult:
    """Drive forces along a prescribed platform motion by the screw method (paper 004, eq. 26).

    mech: a loaded Mechanism (pinclear.load); motion: callable t -> (SE3, V, A) in the paper's
    order, or t -> SE3 (differentiated numerically), or 'low'/'high' (paper 004's laws), default the
    sidecar's platform motion; t: sample times; limbs: include limb inertia; gravity: None (the
    model's), False/True or a 3-vector; wrench: constant external wrench (m_o; f) on the platform;
    threshold: condition number above which an interval is reported."""
    sys_ = system or screw_system(mech)
    f = _motion_callable(mech, motion)
    t = np.atleast_1d(np.asarray(t if t is not None else [0.0], float))
    if gravity is None or gravity is True:
        g = np.array(mech.model.gravity.linear)
        if gravity is True and not np.any(g):
            g = np.array([0.0, 0.0, -9.81])
    elif gravity is False:
        g = np.zeros(3)
    else:
        g = np.asarray(gravity, float)
    ik = _ik_solver(mech)
    N, na = len(t), sys_.n_act
    tau = np.zeros((N, 6))
    cw = np.zeros((N, 6))
    cond = np.zeros(N)
    sign = np.zeros(N)
    qs = np.zeros((N, mech.model.nq)) if keep_q else None
    q = None
    for i, ti in enumerate(t):
        out = f(ti)
        M, V, A = out if isinstance(out, tuple) else pose_derivatives(f, ti)
        q = ik(M, q)
        tau[i], info = sys_.inverse_dynamics(q, V, A, limbs=limbs, gravity=g, wrench=wrench)
        Gpq = info["Gpq"]
        # input r balances W with the wrench tau_r * (row r of G_p^q); the virtual rows are the
        # constraint limbs' reactions
        cw[i] = Gpq[na:].T @ tau[i, na:]
        cond[i], sign[i] = _cond_sign(Gpq, sys_.length_scale)
        if keep_q:
            qs[i] = q
    crossings = _crossings(t, sign, lambda s: _cond_sign(_gpq_at(sys_, ik, f, s), sys_.length_scale))
    intervals = _merge(threshold_intervals(t, cond, threshold)
                       + [(a, b, c) for a, b, _, c in crossings])
    return InverseDynamicsResult(t=t, tau=tau[:, :na], virtual=tau[:, na:], constraint_wrench=cw, cond=cond,
                                 drive_names=sys_.drive_names, threshold=threshold, intervals=intervals,
                                 limbs=limbs, gravity=bool(np.any(g)), q=qs,
                                 crossings=[(tc, c) for _, _, tc, c in crossings])


def _cond_sign(Gpq, L):
    """Condition number of the normalised wrench system and the sign of its determinant: the sign
    flips when a motion passes through a singular configuration, even between samples where the
    condition number itself looks moderate."""
    Wn = _normalised(Gpq, L)
    s = np.linalg.svd(Wn, compute_uv=False)
    return (s[0] / s[-1] if s[-1] > 0 else math.inf), float(np.sign(np.linalg.det(Wn)))


def _gpq_at(sys_, ik, f, t):
    out = f(t)
    M = out[0] if isinstance(out, tuple) else out
    S, _ = sys_.screws(ik(M, None))
    return sys_.input_matrix(np.linalg.inv(np.swapaxes(S, 1, 2)))


def _crossings(t, sign, at):
    """[(t_i, t_i+1, t_crossing, cond at it)] for each sign change of det between samples, the
    crossing located by bisection on the sign (to 1e-10 s)."""
    out = []
    for i in np.nonzero(sign[:-1] * sign[1:] < 0)[0]:
        a, b = float(t[i]), float(t[i + 1])
        sa = sign[i]
        while b - a > 1e-10:
            c = 0.5 * (a + b)
            if at(c)[1] == sa:
                a = c
            else:
                b = c
        tc = 0.5 * (a + b)
        out.append((float(t[i]), float(t[i + 1]), tc, float(at(tc)[0])))
    return out


def _merge(intervals):
    out = []
    for a, b, c in sorted(intervals):
        if out and a <= out[-1][1]:
            pa, pb, pc = out[-1]
            out[-1] = (pa, max(pb, b), max(pc, c))
        else:
            out.append((a, b, c))
    return out


def influence_coefficients(mech, q, system=None):
    """(G, H) at q: first- and second-order influence coefficients of the platform (paper 004,
    eqs. 8, 14), inputs = drives then virtual joints (``screw_system(mech).labels``)."""
    return (system or screw_system(mech)).influence_coefficients(q)


def singularity(mech, q, system=None, tol=1e-9):
    """Rank, condition number and lost motion/wrench of the actuation + constraint wrench system at q."""
    return (system or screw_system(mech)).singularity(q, tol=tol)


def condition_along(mech, q_traj, system=None):
    """Condition number of the actuation map and sign of its determinant at each row of q_traj
    (e.g. a simulated Trajectory.q)."""
    sys_ = system or screw_system(mech)
    out = np.zeros(len(q_traj))
    sign = np.zeros(len(q_traj))
    for i, q in enumerate(q_traj):
        S, _ = sys_.screws(q)
        out[i], sign[i] = _cond_sign(sys_.input_matrix(np.linalg.inv(np.swapaxes(S, 1, 2))), sys_.length_scale)
    return out, sign


def monitor(mech, traj, threshold=1e3, system=None) -> dict:
    """Condition-number monitor of a simulated trajectory (``traj.t``, ``traj.q``): the series, the
    intervals above threshold and the sample pairs between which det changes sign (a crossing)."""
    cond, sign = condition_along(mech, traj.q, system)
    t = np.asarray(traj.t)
    flips = [(float(t[i]), float(t[i + 1]), max(cond[i], cond[i + 1]))
             for i in np.nonzero(sign[:-1] * sign[1:] < 0)[0]]
    return {"t": t, "cond": cond, "threshold": threshold,
            "intervals": _merge(threshold_intervals(t, cond, threshold) + flips)}


# --------------------------------------------------------------------------- Lagrangian reference
def lagrange_inverse_dynamics(mech, q, v, a, ws=None):
    """Drive forces from Pinocchio: tau = rnea(q, v, a), then J^T lam = tau with J the closure and
    drive rows (sign convention M a + b = tau + J^T lam); returns lam for the drives."""
    from . import kinematics

    ws = ws or mech.workspace()
    kinematics.update_positions(mech, ws, q)
    kinematics.constraint_rows(mech, ws, 0.0, ws.zero_v)
    J = ws.J[:mech.m]
    tau = pin.rnea(mech.model, ws.data, q, v, a)
    lam = np.linalg.lstsq(J.T, tau, rcond=None)[0]
    return lam[mech.compiled.m:]


# --------------------------------------------------------------------------- CLI
def _onoff(s):
    s = str(s).lower()
    if s in ("on", "true", "yes", "1"):
        return True
    if s in ("off", "false", "no", "0"):
        return False
    raise argparse.ArgumentTypeError(f"expected on/off, got {s!r}")


def cli_main(argv=None) -> int:
    """``pinclear inverse-dynamics SIDECAR --law high --limbs on --out DIR``: drive forces along the
    platform law (screw method), CSV + PNG + peaks JSON, with the condition-number monitor."""
    p = argparse.ArgumentParser(prog="pinclear inverse-dynamics",
                                description="screw-theory inverse dynamics (paper 004) along a platform motion")
    p.add_argument("sidecar")
    p.add_argument("--law", default=None, help="motion law name (paper 004: low|high); default: the sidecar's")
    p.add_argument("--limbs", type=_onoff, default=True, help="limb inertia on|off (default on)")
    p.add_argument("--gravity", type=_onoff, default=None, help="gravity on|off (default: the sidecar's)")
    p.add_argument("--layout", default=None, help="hinge layout option (paper 004: a..f)")
    p.add_argument("--t-end", type=float, default=None, help="default: one full period of the law")
    p.add_argument("--n", type=int, default=1001, help="samples")
    p.add_argument("--threshold", type=float, default=1e3, help="condition-number threshold")
    p.add_argument("--out", default="inverse_dynamics_out")
    args = p.parse_args(argv)
    try:
        import yaml

        from .sidecar import load

        try:
            name = (yaml.safe_load(Path(args.sidecar).read_text()) or {}).get("name")
        except (OSError, yaml.YAMLError, AttributeError):
            name = None                    # let load() report the file problem
        t_end = args.t_end
        motion = None
        law = args.law
        if name == "four_ups_upr":
            from .mechanisms import four_ups_upr

            law = law or four_ups_upr.SIDECAR_LAW
            if law not in four_ups_upr.LAWS:
                raise ModelFileError(args.sidecar, "--law", f"unknown motion law {law!r}",
                                     choices=list(four_ups_upr.LAWS))
            if args.layout is not None and args.layout not in four_ups_upr.LAYOUTS:
                raise ModelFileError(args.sidecar, "--layout", f"unknown hinge layout {args.layout!r}",
                                     choices=list(four_ups_upr.LAYOUTS))
            mech = four_ups_upr.load(args.sidecar, law=law, layout=args.layout)
            motion = law
            if t_end is None:
                t_end = four_ups_upr.PERIODS[law]
        else:
            if args.law is not None or args.layout is not None:
                raise ModelFileError(args.sidecar, "--law/--layout", "known only for paper 004's model "
                                     "(four_ups_upr); this mechanism moves along its sidecar's platform.motion")
            mech = load(args.sidecar)
        if t_end is None:
            t_end = 2.0
        t = np.linspace(0.0, t_end, args.n)
        res = inverse_dynamics(mech, motion, t, limbs=args.limbs, gravity=args.gravity, threshold=args.threshold)
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        header = ["t"] + res.drive_names + [f"virtual{k + 1}" for k in range(res.virtual.shape[1])] + ["cond"]
        np.savetxt(out / "drive_forces.csv", np.column_stack([res.t, res.tau, res.virtual, res.cond]),
                   delimiter=",", header=",".join(header), comments="")
        summ = res.summary()
        summ.update({"mechanism": mech.name, "law": law, "t_end": t_end, "samples": args.n,
                     "units": "N for prismatic drives, N m for revolute"})
        (out / "peaks.json").write_text(json.dumps(summ, indent=2))
        _plot(res, out / "drive_forces.png", f"{mech.name} {law or ''} limbs={'on' if args.limbs else 'off'}")
        outside = summ["peak_abs_outside_intervals"]
        print(f"peak |drive force| {summ['peak_abs_all']:.1f} (outside ill-conditioned intervals: "
              f"{'none' if outside is None else f'{outside:.1f}'}); cond max at samples {summ['cond_max']:.3g}; "
              f"{len(res.intervals)} interval(s) above {args.threshold:g}; written to {out}")
        if res.crossings:
            at = ", ".join(f"{tc:.6f}" for tc, _ in res.crossings)
            print(f"warning: the motion passes through a singular configuration at t = {at} s; "
                  "drive forces there are unbounded (sampled peaks depend on the sampling)", file=sys.stderr)
        return 0
    except PinclearError as exc:
        print(f"pinclear: error: {exc}", file=sys.stderr)
        return 2


def _plot(res, path, title):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for i, n in enumerate(res.drive_names):
        ax[0].plot(res.t, res.tau[:, i], label=n)
    ok = res.outside_intervals()
    if ok.any() and not ok.all():
        lim = 1.5 * float(np.abs(res.tau[ok]).max())
        ax[0].set_ylim(-lim, lim)      # the spikes at singular crossings would hide everything else
    for a, b, _ in res.intervals:
        ax[0].axvspan(a, b, color="r", alpha=0.15)
    ax[0].set_ylabel("drive force [N]")
    ax[0].legend(loc="upper right", fontsize=8)
    ax[0].set_title(title)
    ax[1].semilogy(res.t, res.cond)
    ax[1].axhline(res.threshold, color="r", ls="--", lw=0.8)
    for a, b, _ in res.intervals:
        ax[1].axvspan(a, b, color="r", alpha=0.15)
    ax[1].set_ylabel("cond(G_p^q)")
    ax[1].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
