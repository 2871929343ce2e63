"""Layer 8, studies: whole studies built from the layers below. The papers' reproductions
(reproduce/), the wear studies and the benchmarks of the engine (bench/: right-hand sides, the
stability atlas, restitution).

Imports layers 0-7 (docs/design.md, "Layers").
"""
