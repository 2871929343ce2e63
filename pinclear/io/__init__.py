"""Layer 4, io: mechanisms in and out of files. The sidecar loader, URDF checks and writing,
the key reference, the builder, the importers (SDF, MJCF, closing-frame URDF) and the MJCF
export.

Imports layers 0-3 (docs/design.md, "Layers").
"""
