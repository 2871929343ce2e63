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

    def values(self, t):
        f = self._f
        for k, d in enumerate(self.drives):
            f[:, k] = d.law.eval(t)
        return f

    def rows(self, t, q, v):
        f = self.values(t)
        return q[self.iq] - f[0], v[self.iv] - f[1], f[2]
