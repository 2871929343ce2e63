"""Layer 3, dynamics: forward and inverse dynamics of a loaded mechanism. The formulations
(one file each), the stepping engine, screw-theory inverse dynamics, simulate(), the
Trajectory result, the energy audit and the checks on what a run reads back.

Imports layers 0-2 (docs/design.md, "Layers").
"""
