"""The screw system of a parallel mechanism: platform + limbs, evaluated for screws, limb rates,
influence coefficients, drive forces and singularities (paper 004, Geng et al. 2014).

A parallel mechanism is read as a platform plus limbs, each limb a serial chain from the base to
the platform: the tree joints of the limb's branch, then the screws of the cut joint that closes it
on the platform (spherical: three rotations about the centre; universal: two; revolute: one), then
``6 - n`` *virtual joints* (paper 004, sec. 2.1; rules in :mod:`pinclear.dynamics.screw.virtual`) so that
every limb has six screws. The inputs q are the actuated joints plus the virtual joints (held at
zero rate); the rows of the inverted limb Jacobians for those joints stack into G_p^q, its inverse
is the platform's first-order influence coefficient G_q^p (eq. 8); the second order H_q^p follows
from Lie brackets [S_j, S_k] (eqs. 9-14). Inverse dynamics is Newton-Euler per body,
W = -(N A - V^^T N V) (eqs. 19, 21), plus gravity (eqs. 23-24), mapped by virtual work (eq. 26).

Everything per evaluation is vectorised over limbs and bodies (numpy batched algebra on padded
arrays); Pinocchio supplies the joint placements and joint screws (one computeJointJacobians).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from pinclear.core.errors import ModelFileError
from pinclear.dynamics.screw.algebra import (
    bracket,
    describe_twist,
    gravity_wrench,
    inertia_wrench,
    line_twist,
    skew,
    spatial_inertia,
)
from pinclear.dynamics.screw.section import ScrewSection, read_section
from pinclear.dynamics.screw.virtual import COMPLEMENT

#: screws of each cut-joint type that closes a limb on the platform
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
    virtual: object = COMPLEMENT   # COMPLEMENT or a rule f(real, base, platform) (pinclear.dynamics.screw.virtual)

    @property
    def nreal(self):
        return len(self.joints) + CUT_SCREWS.get(self.cut, 0)


class ScrewSystem:
    """A mechanism read as platform + limbs for the screw method (compiled once, evaluated often).

    Build with :func:`screw_system` from a :class:`pinclear.Mechanism`. A system owns its
    Pinocchio data and the continuity reference of its complement completions: one system per
    thread.
    """

    def __init__(self, model, platform_joint, limbs, drive_order, name="", length_scale=None,
                 platform_frame=None, q_ref=None, section=None, source=None):
        self.model = model
        self.data = model.createData()
        self.name = name
        self.source = source or name             # the file named in errors
        self.section = section                   # the sidecar's screw: section (ScrewSection)
        self.pj = int(platform_joint)
        self.platform_frame = platform_frame
        self.limbs = limbs
        nL = len(limbs)
        self.nL = nL
        for lb in limbs:
            if lb.nreal > 6:
                raise ModelFileError(self.source, f"screw.limbs.{lb.name}", f"{lb.nreal} screws (> 6): not a "
                                     "serial limb of a non-redundant parallel mechanism")
        # inputs: the drives in the mechanism's order, then the virtual joints limb by limb
        self.inputs = []                         # (limb index, screw index, label)
        by_drive = {}
        for li, lb in enumerate(limbs):
            for k, dn in zip(lb.actuated, lb.drive_names):
                by_drive[dn] = (li, k, dn)
        for dn in drive_order:
            if dn not in by_drive:
                raise ModelFileError(self.source, f"drives.{dn}", "the drive acts on no limb joint (the screw "
                                     "method needs every drive on a limb)", choices=[lb.name for lb in limbs])
            self.inputs.append(by_drive[dn])
        self.n_act = len(self.inputs)
        for li, lb in enumerate(limbs):
            for k in range(lb.nreal, 6):
                self.inputs.append((li, k, f"{lb.name}.virtual{k - lb.nreal + 1}"))
        if len(self.inputs) != 6:
            raise ModelFileError(self.source, "drives", f"{self.n_act} drives + {len(self.inputs) - self.n_act} "
                                 f"virtual joints = {len(self.inputs)} inputs; the screw method needs 6 (a "
                                 "non-redundant mechanism whose limbs each have at most 6 screws)")
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
        self._screws(pin.neutral(model) if q_ref is None else np.asarray(q_ref, float), check=True)

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
        return self._screws(q, False)

    def _screws(self, q, check):
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
                S[li, lb.nreal:] = self._virtual(lb, S[li, :lb.nreal], Mp, check)
        return S, Mp

    def _virtual(self, lb, real, Mp, check=False):
        nv = 6 - lb.nreal
        if lb.virtual != COMPLEMENT:
            if not check:
                return lb.virtual(real, self.data.oMi[lb.joints[0]].translation, Mp)
            # first evaluation (at build time): a rule that does not fit the limb is a sidecar error
            key = f"screw.virtual.{lb.name}"
            try:
                out = np.asarray(lb.virtual(real, self.data.oMi[lb.joints[0]].translation, Mp), float)
            except ValueError as exc:
                raise ModelFileError(self.source, key, str(exc)) from None
            if out.shape != (nv, 6) or not np.all(np.isfinite(out)):
                raise ModelFileError(self.source, key, f"the rule must return {nv} finite screw(s) of 6 "
                                     f"components for this limb of {lb.nreal} real screws, got shape {out.shape}")
            return out
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
        return singularity_of(self.input_matrix(Jinv), self.length_scale, self.labels, tol)

    def cond_sign(self, q, S=None):
        """(condition number, sign of det) of the normalised G_p^q at q: see :func:`cond_sign`."""
        if S is None:
            S, _ = self.screws(q)
        return cond_sign(self.input_matrix(np.linalg.inv(np.swapaxes(S, 1, 2))), self.length_scale)


def normalised_wrenches(Gpq, L):
    """Rows of G_p^q made unit-free: a wrench row (m; f) against a twist (w; v) is scaled like the
    twist (w L; v), i.e. to (m / L; f), then to unit norm."""
    Wn = Gpq.copy()
    Wn[:, :3] /= L
    return Wn / np.linalg.norm(Wn, axis=1, keepdims=True)


def singularity_of(Gpq, L, labels, tol):
    """Rank, condition number, lost twist and lost wrench of G_p^q (see ScrewSystem.singularity)."""
    Wn = normalised_wrenches(Gpq, L)
    u, s, vt = np.linalg.svd(Wn)
    rank = int(np.sum(s > tol * s[0]))
    cond = float(s[0] / s[-1]) if s[-1] > 0 else math.inf
    twist = vt[-1].copy()
    twist[:3] /= L              # back to (omega; v) in rad/s and m/s for a unit normalised twist
    return {"rank": rank, "cond": cond, "sigma": s, "singular": rank < 6,
            "lost_twist": twist, "lost_wrench": dict(zip(labels, u[:, -1])),
            "lost_motion": describe_twist(twist)}


def cond_sign(Gpq, L):
    """Condition number of the normalised wrench system and the sign of its determinant: the sign
    flips when a motion passes through a singular configuration, even between samples where the
    condition number itself looks moderate."""
    Wn = normalised_wrenches(Gpq, L)
    s = np.linalg.svd(Wn, compute_uv=False)
    return (s[0] / s[-1] if s[-1] > 0 else math.inf), float(np.sign(np.linalg.det(Wn)))


# --------------------------------------------------------------------------- building from a mechanism
def screw_system(mech, section: ScrewSection | None = None) -> ScrewSystem:
    """Read a loaded :class:`pinclear.Mechanism` as platform + limbs.

    Limbs come from the sidecar's ``screw: limbs:`` list when present, else are found from the
    topology: the branch carrying the platform frame is one limb (``platform_limb``), and every
    closure joining another branch to the platform closes one more (named after the closure).
    Drives must sit on limb joints. ``screw: virtual:`` picks each limb's virtual-joint rule."""
    model = mech.model
    section = section or read_section(mech)
    file = section.file
    if mech.platform_frame is None:
        raise ModelFileError(file, "platform.frame", "the screw method needs the platform frame")
    pj = model.frames[mech.platform_frame].parentJoint
    drive_joint = {model.getJointId(d.joint): d.name for d in mech.drives}
    closures = {c.name: c for c in mech.closures}

    def branch(j):
        return [int(i) for i in model.supports[j]][1:]        # base to j, the universe left out

    def make(name, joints, closure, key):
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
            raise ModelFileError(file, key, "a limb without a closure must carry the platform")
        for k, j in enumerate(joints):
            if j in drive_joint:
                lb.actuated.append(k)
                lb.drive_names.append(drive_joint[j])
        return lb

    limbs = []
    if section.limbs is not None:
        for i, sp in enumerate(section.limbs):
            key = f"screw.limbs[{i}]"
            joints = []
            for jn in sp["joints"]:
                if not isinstance(jn, str) or not model.existJointName(jn):
                    raise ModelFileError(file, f"{key}.joints", f"unknown joint {jn!r}",
                                         choices=list(model.names)[1:])
                joints.append(model.getJointId(jn))
            cname = sp["closure"]
            if cname is not None and cname not in closures:
                raise ModelFileError(file, f"{key}.closure", f"unknown closure {cname!r}", choices=list(closures))
            limbs.append(make(sp["name"], joints, closures[cname] if cname else None, key))
    else:
        limbs.append(make("platform_limb", branch(pj), None, "platform.frame"))
        for c in mech.closures:
            j1, j2 = model.frames[c.f1].parentJoint, model.frames[c.f2].parentJoint
            other = j1 if j2 == pj else j2 if j1 == pj else None
            if other is None:
                continue
            joints = branch(other)
            if set(joints) & set(limbs[0].joints):
                raise ModelFileError(file, f"closures.{c.name}", "limb branches must start at the base "
                                     "(this one shares joints with the platform's branch)")
            limbs.append(make(c.name, joints, c, f"closures.{c.name}"))
        limbs = limbs[1:] + limbs[:1]
    names = [lb.name for lb in limbs]
    for name, rule in section.virtual.items():
        if name not in names:
            raise ModelFileError(file, f"screw.virtual.{name}", "unknown limb", choices=names)
        lb = limbs[names.index(name)]
        if lb.nreal >= 6:
            raise ModelFileError(file, f"screw.virtual.{name}", f"limb {name} has {lb.nreal} real screws: "
                                 "it has no virtual joints to choose")
        lb.virtual = rule
    return ScrewSystem(model, pj, limbs, [d.name for d in mech.drives], name=mech.name,
                       platform_frame=mech.platform_frame, q_ref=mech.q0, section=section, source=file)
