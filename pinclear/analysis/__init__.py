"""Layer 6, analysis: nonlinear analysis of simulated runs: phase portraits, Poincaré maps, bifurcation diagrams
and a classification of the motion (period-k / quasi-periodic / chaotic).

Papers 000 and 002 judge the motion of a clearance joint and of the platform from phase
trajectories, stroboscopic Poincaré maps (one point per driving period) and bifurcation
diagrams (Poincaré samples of a relative velocity against a swept parameter: friction
coefficient, clearance size, driving speed). This module produces those three objects from
:class:`pinclear.Trajectory` runs and adds two things the papers do by eye:

* :func:`detect_period`: the period k of the Poincaré sequence (smallest shift that maps it
  onto itself within a tolerance) and the number of distinct clusters;
* :func:`largest_lyapunov` / :func:`mechanism_lyapunov`: the largest Lyapunov exponent by
  Benettin's renormalised companion trajectory (lyapunov.py);
* :func:`chaos_01`: the 0-1 test for chaos of Gottwald & Melbourne (Proc. R. Soc. A 460, 2004;
  correlation method and modified mean-square displacement of SIAM J. Appl. Dyn. Syst. 8, 2009):
  K ~ 0 for regular (periodic or quasi-periodic) motion, K ~ 1 for chaotic motion.

Signals (the ``signal`` argument) name a scalar coordinate of a run and its exact rate:

* a joint name, ``"crank"`` or ``"joint[k]"`` for component k of a multi-DoF joint
  (nq = nv joints): q and v;
* a frame coordinate ``"<frame>.x|y|z"`` (``"platform.z"`` uses the sidecar's platform frame):
  world position of the frame origin and its linear velocity (Pinocchio LOCAL_WORLD_ALIGNED);
* a force-element output ``"<element>.<output>"`` or ``"<element>.<output>[k]"``, e.g.
  ``"S2.eccentricity[1]"``: the recorded output; for ``eccentricity`` of a clearance joint the
  rate is the exact relative velocity of journal/ball and bearing/socket centres in the
  bearing frame, for other outputs (and drive forces named as in ``traj.lam``) it is the
  derivative of a cubic spline through the samples (approximate, flagged ``exact_rate=False``);
* a pair ``(x_spec, xdot_spec)`` of two such names, or a callable ``f(traj) -> x`` or
  ``-> (x, xdot)`` (module-level, so it pickles for :func:`bifurcation`'s worker processes).

Poincaré sections are taken at t = t0 + k T + phase. Simulating with ``t_eval`` from
:func:`section_times` puts output samples exactly on the section, so no interpolation error
enters (the samples are the integrator's own dense output); otherwise samples are interpolated
with cubic Hermite polynomials (using the signal's rate) and flagged ``interpolated``.

:func:`bifurcation` runs one simulation per parameter value in worker processes, keeps every
failure as a result, and classifies each value; :func:`plot_phase_portrait`,
:func:`plot_poincare` and :func:`plot_bifurcation` draw on matplotlib Figures (no pyplot,
no GUI backend) and return the arrays they drew. Command line (:func:`cli_main`):
``pinclear analyse bifurcation|poincare ...``.
"""
from pinclear.analysis.classify import (
                                        CHAOS_THRESHOLD,
                                        CLEARANCE_FRACTION,
                                        Classification,
                                        chaos_01,
                                        classify,
                                        classify_state,
                                        detect_period,
                                        integration_rtol,
                                        settled_period,
)
from pinclear.analysis.convergence import (StepConvergence, TransientCheck, sampled_convergence, step_convergence,
                                          transient_check)
from pinclear.analysis.diagrams import BifurcationResult, BifurcationRun, bifurcation, signal_key
from pinclear.analysis.lyapunov import (
                                        ChaosEvidence,
                                        LyapunovResult,
                                        batch_means_bound,
                                        confirm_chaos,
                                        largest_lyapunov,
                                        mechanism_lyapunov,
)
from pinclear.analysis.plots import plot_bifurcation, plot_phase_portrait, plot_poincare
from pinclear.analysis.poincare import PoincareSection, poincare, section_times
from pinclear.analysis.signals import Series, phase_portrait, relative_rate, series

__all__ = ["CHAOS_THRESHOLD", "Classification", "chaos_01", "classify", "classify_state", "detect_period",
           "integration_rtol", "settled_period",
           "plot_bifurcation", "plot_phase_portrait", "plot_poincare", "PoincareSection", "poincare",
           "section_times", "Series", "phase_portrait", "relative_rate", "series", "BifurcationResult",
           "BifurcationRun", "bifurcation", "signal_key", "LyapunovResult", "largest_lyapunov",
           "mechanism_lyapunov", "ChaosEvidence", "confirm_chaos", "CLEARANCE_FRACTION",
           "batch_means_bound", "transient_check", "TransientCheck", "step_convergence", "StepConvergence",
           "sampled_convergence"]
