"""Screw-theory kinematics and inverse dynamics of parallel mechanisms (paper 004, Geng et al. 2014).

Modules: :mod:`~pinclear.dynamics.screw.algebra` (twists and wrenches in Plücker coordinates, Pinocchio
conversions), :mod:`~pinclear.dynamics.screw.system` (the mechanism read as platform + limbs:
:class:`ScrewSystem`, :func:`screw_system`), :mod:`~pinclear.dynamics.screw.virtual` (virtual-joint rules),
:mod:`~pinclear.dynamics.screw.inverse_dynamics` (drive forces along a motion, condition monitor,
Pinocchio's Lagrangian reference), :mod:`~pinclear.cli.inverse_dynamics` (``pinclear inverse-dynamics``).

Nothing here knows a particular mechanism. What the screw method needs from one is declared in
its sidecar, in the optional top-level section ``screw:`` (every key optional)::

    screw:
      limbs:                  # default: found from the topology (the platform's branch, plus one
                              # limb per closure joining another branch to the platform)
        - {name: UPS1, joints: [ups1_u1, ups1_u2, ups1_p], closure: S1}
        - {name: UPR, joints: [upr_u1, upr_u2, upr_p, upr_r], closure: null}
      virtual: {UPR: line_normal}   # limb name -> virtual-joint rule (default: complement)
      ik: pinclear.mechanisms.MODULE:tree_configuration_ik
      motions:                # named platform motions (``--law NAME``, ``inverse_dynamics(mech, NAME)``)
        high: {function: pinclear.mechanisms.MODULE:platform_motion, args: {law: high},
               period: 1.2566370614359172}

* ``limbs[i]``: ``name``, ``joints`` (tree joints of the branch, base to tip) and ``closure`` (the
  closure joining it to the platform: spherical, universal or revolute; ``null`` for the limb
  that carries the platform in the tree).
* ``virtual``: ``complement`` (orthogonal complement of the real screws, continuous along a
  motion), a rule of :data:`VIRTUAL_RULES` (``line_normal``: paper 004's choice for a UPR limb),
  or ``module:function`` with the signature of :mod:`pinclear.dynamics.screw.virtual`. Limb names are the
  ``limbs`` names, or for found limbs ``platform_limb`` and the closures' names.
* ``ik``: ``module:function``, ``f(mech, M_platform: pin.SE3, q_prev) -> q`` (tree configuration
  placing the platform frame at M_platform; q_prev the previous sample's or None). Default: Newton
  on the closures and the platform pose (:func:`numerical_ik`).
* ``motions.NAME``: ``function`` (``module:function``, called as ``function(t, **args)``,
  returning (pin.SE3, V, A) with V, A in the paper's order, or a pin.SE3 alone, then
  differentiated numerically), ``args`` (mapping) and ``period`` (s, optional: the CLI's default
  end time). Without ``--law`` the motion is the sidecar's ``platform.motion``.

Every ``module:function`` is imported through :func:`pinclear.model.timelaws.resolve_function` (the
loader's trust rule). Errors name the file, the key and the valid choices.
"""
from __future__ import annotations

from pinclear.dynamics.screw.algebra import (
                                             adjoint,
                                             bracket,
                                             cross,
                                             describe_twist,
                                             dual_cross,
                                             from_force,
                                             from_motion,
                                             gravity_wrench,
                                             inertia_wrench,
                                             line_twist,
                                             reciprocal_product,
                                             skew,
                                             spatial_inertia,
                                             swap,
                                             to_force,
                                             to_motion,
)
from pinclear.dynamics.screw.inverse_dynamics import (
                                             InverseDynamicsResult,
                                             condition_along,
                                             ik_solver,
                                             influence_coefficients,
                                             inverse_dynamics,
                                             lagrange_inverse_dynamics,
                                             monitor,
                                             motion_function,
                                             numerical_ik,
                                             pose_derivatives,
                                             singularity,
                                             threshold_intervals,
)
from pinclear.dynamics.screw.section import Motion, ScrewSection, read_section
from pinclear.dynamics.screw.system import CUT_SCREWS, Limb, ScrewSystem, cond_sign, screw_system, singularity_of
from pinclear.dynamics.screw.virtual import VIRTUAL_RULES, line_normal

__all__ = [
    "adjoint", "bracket", "cross", "describe_twist", "dual_cross", "from_force", "from_motion",
    "gravity_wrench", "inertia_wrench", "line_twist", "reciprocal_product", "skew", "spatial_inertia",
    "swap", "to_force", "to_motion", "InverseDynamicsResult", "condition_along", "ik_solver",
    "influence_coefficients", "inverse_dynamics", "lagrange_inverse_dynamics", "monitor", "motion_function",
    "numerical_ik", "pose_derivatives", "singularity", "threshold_intervals", "Motion", "ScrewSection",
    "read_section", "CUT_SCREWS", "Limb", "ScrewSystem", "cond_sign", "screw_system", "singularity_of",
    "VIRTUAL_RULES", "line_normal",
]
