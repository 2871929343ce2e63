"""Drives: a 1-DoF tree joint's coordinate follows a time law, enforced as a constraint row
q_j - f(t) = 0 whose multiplier is the actuator's generalized force."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .timelaws import TimeLaw


@dataclass
class Drive:
    name: str
    joint: str
    idx_q: int
    idx_v: int
    law: TimeLaw


class DriveRows:
    """Vectorised drive rows: phi = q[iq] - f(t), dphi = v[iv] - f'(t), f''(t)."""

    def __init__(self, drives: list[Drive], nv: int):
        self.drives = drives
        self.iq = np.array([d.idx_q for d in drives], dtype=int)
        self.iv = np.array([d.idx_v for d in drives], dtype=int)
        self.J = np.zeros((len(drives), nv))
        self.J[np.arange(len(drives)), self.iv] = 1.0
        self._f = np.zeros((3, len(drives)))
        # drives whose laws are components of one shared vector function (e.g. every limb length
        # from one inverse kinematics) are filled together: one call, one fancy-index copy
        groups: dict = {}
        self._single = []
        for k, d in enumerate(drives):
            shared = getattr(d.law, "_shared", None)
            if shared is not None:
                g = groups.setdefault(id(shared), (shared, [], []))
                g[1].append(k)
                g[2].append(d.law.index)
            else:
                self._single.append((k, d.law))
        self._groups = [(s, np.array(ks), np.array(ix)) for s, ks, ix in groups.values()]

    def values(self, t):
        f = self._f
        for shared, ks, ix in self._groups:
            y, yd, ydd = shared(t)
            f[0, ks], f[1, ks], f[2, ks] = y[ix], yd[ix], ydd[ix]
        for k, law in self._single:
            f[:, k] = law.eval(t)
        return f

    def rows(self, t, q, v):
        f = self.values(t)
        return q[self.iq] - f[0], v[self.iv] - f[1], f[2]
