"""Per-mechanism Python: URDF generators, parameter tables, inverse kinematics, motion laws."""
