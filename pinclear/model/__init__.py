"""Layer 1, model: the immutable description of a mechanism and its kinematics. Mechanism and
Workspace, frame and closure-row kernels, closures, couplings, drives, time laws, force
elements and the compiled Pinocchio passes (native, the C++ extension _passes).

Imports only pinclear.core (docs/design.md, "Layers").
"""
