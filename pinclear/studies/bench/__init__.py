"""The benchmarks of the engine as library code (``pinclear bench``): right-hand-side cost
(rhs), the stability atlas (atlas) and the restitution of the normal laws (restitution).
"""
