"""Cassie (Agility Robotics) from example-robot-data's SDF files, imported by pinclear import.

example-robot-data ships five SDF 1.6 variants of Cassie in robots/cassie_description/robots:
``cassie.sdf`` (motor rotors and ten gearbox joints), ``cassie_v2``, ``cassie_reduced``,
``cassie_simple`` and ``cassie_wo_gearbox_spring``. Every variant has four ball-joint loops
(per leg: the achilles rod from the hip-pitch link to the heel spring, the plantar rod from the
foot crank to the foot) and joint springs (knee-shin 1500 N m/rad, tarsus-heel 1250 N m/rad).
The pelvis is welded to the world (``--fix pelvis``; the SDF's prismatic "static" joint to the
world gives way): a passive leg swing under gravity and prescribed hip motions are the scenes.

``python -m pinclear.mechanisms.cassie`` writes urdf/cassie*.urdf + .yaml (bundled names
``cassie``, ``cassie_v2``, ...); meshes are found through example-robot-data's package folder.
"""
from __future__ import annotations

from pathlib import Path

VARIANTS = ("cassie", "cassie_v2", "cassie_reduced", "cassie_simple", "cassie_wo_gearbox_spring")
#: the SDF folder inside example-robot-data's robots folder
SDF_DIR = "cassie_description/robots"


def sdf_path(variant: str) -> Path:
    """example-robot-data's SDF file of a Cassie variant."""
    from pinclear.core.errors import ModelFileError
    from pinclear.core.models import example_robot_data_dir

    if variant not in VARIANTS:
        raise ModelFileError(variant, "variant", "not a Cassie variant of example-robot-data", choices=VARIANTS)
    root = example_robot_data_dir()
    if root is None:
        raise ModelFileError(variant, "example-robot-data", "is not installed (pip install example-robot-data)")
    return root / SDF_DIR / f"{variant}.sdf"


def write_models(out=None) -> dict:
    """Import the five variants into ``out`` (default: the bundled models folder); {variant: report}."""
    from pinclear.core.models import models_dir
    from pinclear.io.importers import import_file

    out = Path(out) if out is not None else models_dir()
    reports = {}
    for v in VARIANTS:
        reports[v] = import_file(sdf_path(v), out, fix="pelvis", name=v)
        (out / f"{v}.import.json").unlink(missing_ok=True)     # the sidecar's header holds the report
    return reports


if __name__ == "__main__":
    for v, r in write_models().items():
        print(f"{v}: {r['bodies']} bodies, {len(r['cut'])} cut joints, {r['closure_rows']} closure rows, "
              f"residual at the reference {r['residual_at_reference']:.1e}")
