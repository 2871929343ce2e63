"""``pinclear import FILE --out DIR``: a mechanism from another tool's file, as a URDF spanning
tree and a sidecar that pinclear.load accepts (docs/import_export.md).

One reader per format (a module and one line of READERS) fills pinclear.io.importers.graph; the
spanning tree is chosen in pinclear.io.importers.cuts and written by pinclear.io.importers.write.
"""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import yaml

from pinclear.core import safeio
from pinclear.core.errors import ModelFileError
from pinclear.core.registry import Entry, Registry

#: file suffix -> the reader of each format (an Entry: "module:function")
READERS = Registry("importer", {e.name: e for e in (
    Entry(".sdf", "pinclear.io.importers.sdf:read"), Entry(".xml", "pinclear.io.importers.mjcf:read"),
    Entry(".mjcf", "pinclear.io.importers.mjcf:read"), Entry(".urdf", "pinclear.io.importers.urdf_closing:read"))},
    record=Entry)


def read_graph(path):
    """The Graph of a mechanism file, by its suffix."""
    suffix = Path(path).suffix.lower()
    if suffix not in READERS:
        raise ModelFileError(str(path), "path", f"no importer for {suffix or 'files without a suffix'!r}",
                             choices=sorted(READERS))
    return READERS[suffix](path)


def convert(path, cut=(), fix=None, name=None):
    """(urdf text, sidecar mapping, report) of a mechanism file; nothing written."""
    from pinclear.io.importers import write
    from pinclear.io.importers.cuts import spanning_tree
    from pinclear.io.importers.graph import WORLD

    g = read_graph(path)
    g.file = shown_path(path)
    name = name or g.name
    check_names(g, name)
    notes = write.fix_root(g, fix)
    tree = spanning_tree(g, WORLD, tuple(cut))
    F = write.frames_of(g, tree)
    closures = write.closures_of(g, tree, F) + write.couplings_of(g, tree)
    forces, lost = write.forces_of(g, tree)
    sidecar = {"name": name, "urdf": f"{name}.urdf",
               "description": f"imported by pinclear import from {Path(path).name} ({g.fmt.upper()})",
               "gravity": [float(x) for x in g.gravity]}
    if closures:
        sidecar["closures"] = closures
    if forces:
        sidecar["forces"] = forces
    if g.sidecar is not None:
        # a file pinclear exported: its own description wins (closure types MuJoCo cannot express)
        sidecar = {**g.sidecar, "name": name, "urdf": f"{name}.urdf"}
    accepted = nonphysical_inertias(write.urdf_text(g, tree, F), g.file)
    if accepted:
        sidecar["nonphysical_inertia"] = accepted
    report = write.report_of(g, tree, [c for c in closures if c["type"] != "coupling"],
                             [c for c in closures if c["type"] == "coupling"], forces, lost, notes)
    report["nonphysical_inertia"] = sorted(accepted)
    return write.urdf_text(g, tree, F), sidecar, report


def nonphysical_inertias(urdf, file) -> dict:
    """{joint: reason} of the bodies whose inertia breaks the triangle inequality (pinclear's
    sidecar check, pinclear.io.sidecar.check_inertias): the file's values are kept, and said so in
    the sidecar's ``nonphysical_inertia`` (any other bad inertia stays an error)."""
    import pinocchio as pin

    from pinclear.io.sidecar import check_inertias

    model = pin.buildModelFromXML(urdf)
    accepted = {}
    while True:
        try:
            check_inertias(model, file, accepted)
            return accepted
        except ModelFileError as exc:
            joint = str(exc.key).split("'")[1] if "'" in str(exc.key) else None
            if joint is None or joint in accepted or "not physically possible" not in str(exc):
                raise
            accepted[joint] = (f"the values of {Path(file).name} kept as given: their principal moments break the "
                               "triangle inequality (pinclear import)")


#: a mechanism's name becomes file names: no folder parts, no hidden files
SAFE_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_.+-]{0,127}")
#: link, joint and frame names are written into XML attributes and YAML keys
UNSAFE_CHARS = re.compile(r'[<>&"\'\x00-\x1f\x7f]')


def check_names(g, name):
    """Refuse a mechanism name that is not a plain file name (``<model name="../x">`` would write
    outside --out) and names or mesh URIs that would not survive as XML attribute values."""
    if not SAFE_NAME.fullmatch(name):
        raise ModelFileError(g.file, "name", f"{name!r} is not a plain file name (letters, digits, _ . + -); give "
                             "--name")
    items = [(b.name, f"line {b.line}") for b in g.bodies.values()] + [(j.name, f"line {j.line}") for j in g.joints]
    items += [(geom.get("mesh", ""), f"line {b.line}") for b in g.bodies.values() for _, geom in b.visuals]
    items += [(c.name, f"line {c.line}") for c in list(g.couplings) + list(g.closings)]
    items += [(f[0], "frame") for f in g.frames]
    for text, where in items:
        if text is None or UNSAFE_CHARS.search(text):
            raise ModelFileError(g.file, where, f"name {text!r} holds a character pinclear does not write into "
                                 "XML (< > & quotes, control characters)")


def shown_path(path) -> str:
    """A source path as the report shows it: inside example-robot-data's robots folder, relative
    to it (the same on every machine)."""
    from pinclear.core.models import example_robot_data_dir

    p, erd = Path(path).resolve(), example_robot_data_dir()
    if erd is not None and p.is_relative_to(erd):
        return f"example-robot-data robots/{p.relative_to(erd)}"
    return str(path)


def header(report) -> str:
    """The sidecar's comment block: where it comes from and which joints were cut, and why."""
    lines = [f"Imported by `pinclear import` from {report['source']} ({report['format']}); edit the source and "
             "import again rather than this file.",
             f"{report['bodies']} bodies, {report['tree_joints']} tree joints (depth {report['depth']}), "
             f"{report['closure_rows']} closure rows."]
    lines += [f"cut {c['joint']} ({c['type']}, {c['rows']} rows): {c['why']}" for c in report["cut"]]
    lines += [f"not imported: {x}" for x in report["not_imported"]]
    lines += [f"kept as data: {x}" for x in report["kept_as_data"]]
    return "".join(f"# {ln}\n" for ln in lines)


def import_file(path, out, cut=(), fix=None, name=None) -> dict:
    """Write OUT/NAME.urdf, OUT/NAME.yaml and OUT/NAME.import.json; load the result back and add
    its closure residual at the reference configuration to the report."""
    from pinclear.io.sidecar import load
    from pinclear.model import kinematics

    urdf, sidecar, report = convert(path, cut, fix, name)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    name = sidecar["name"]
    safeio.write_text(out / f"{name}.urdf", urdf)
    text = header(report) + yaml.safe_dump(sidecar, sort_keys=False, width=120, default_flow_style=None)
    safeio.write_text(out / f"{name}.yaml", text)
    mech = load(out / f"{name}.yaml")
    ws = mech.workspace()
    phi = kinematics.closure_residual(mech, ws, mech.q0)
    report["residual_at_reference"] = float(np.max(np.abs(phi))) if phi.size else 0.0
    report["files"] = [str(out / f"{name}.urdf"), str(out / f"{name}.yaml")]
    safeio.write_text(out / f"{name}.import.json", json.dumps(report, indent=2) + "\n")
    return report
