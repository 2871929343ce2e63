"""Layer 5, mechanisms: per-mechanism Python: URDF generators, parameter tables, inverse kinematics, motion laws."""
