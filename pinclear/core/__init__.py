"""Layer 0, core: what every other layer stands on and that knows nothing of mechanisms. Errors
and failures as data, the plug-in registry, the compiled calling convention (call, stage) and
the one numba entry (jit), the dense linear algebra kernels (dense, tree_solve), the shared value
checks, bounded reads, link-safe writes, the trust gate and where the bundled models are.

Imports only the standard library, numpy, scipy, numba and pinocchio (docs/design.md, "Layers").
"""
