"""The stepping engine: compiled step logic shared by every formulation, integrator and force
element (pinclear.simulate drives it; docs/design.md, "The stepping engine").

A run's right-hand side, event values and state projection are compiled per mechanism as C
callbacks (``RHS``, ``EVENTS``, ``PROJECT`` below); everything else — Runge-Kutta steps with
their step-size control and dense output, event crossings, the stall test, the pivot monitor —
is ordinary compiled code in this package, called with the callbacks' addresses.
"""
