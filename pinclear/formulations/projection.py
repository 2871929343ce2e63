"""Exact acceleration-level constraints (no Baumgarte) plus projection of q and v back onto the
constraint manifold after every accepted step: positions by Gauss-Newton on the manifold
(pin.integrate), velocities by the mass-metric projection v <- v - M^-1 J^T S^-1 (J v + Phi_t)."""
from __future__ import annotations

import numpy as np
import pinocchio as pin
from scipy.linalg import cho_solve

from .. import kinematics
from .lagrange import Lagrange


def project_to_manifold(form, t, q, v, tol, max_iter, solve=None):
    """(q, v) moved onto Phi(q, t) = 0 and J v + Phi_t = 0 over the formulation's rows: the
    shared projection of every formulation that offers one. ``solve(A, b)`` solves the normal
    equations A x = b of both steps (default: least squares, minimum norm)."""
    if solve is None:
        def solve(A, b):
            return np.linalg.lstsq(A, b, rcond=1e-12)[0]
    mech, ws, rows = form.mech, form.ws, form.rows
    for _ in range(max_iter):
        kinematics.update_positions(mech, ws, q)
        kinematics.constraint_rows(mech, ws, t, q, ws.zero_v)
        phi = ws.phi[rows]
        if np.linalg.norm(phi, np.inf) < tol:
            break
        J = ws.J[rows]
        # minimum-norm Gauss-Newton step J^T (J J^T)^+ phi, defined at a rank loss
        q = pin.integrate(mech.model, q, -J.T @ solve(J @ J.T, phi))
    kinematics.update(mech, ws, q, v)
    kinematics.constraint_rows(mech, ws, t, q, v)
    J = ws.J[rows]
    c = form.mass_factor()
    MiJt = cho_solve(c, J.T, check_finite=False)
    v = v - MiJt @ solve(J @ MiJt, ws.dphi[rows])
    return q, v


class Projection(Lagrange):
    name = "projection"
    options = {"tol": 1e-12, "max_iter": 10, "drop_redundant": True}
    supports_projection = True

    def baumgarte(self):
        return (0.0, 0.0)

    def project(self, t, q, v):
        return project_to_manifold(self, t, q, v, self.opts["tol"], self.opts["max_iter"])
