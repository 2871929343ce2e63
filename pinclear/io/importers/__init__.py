"""``pinclear import FILE --out DIR``: a mechanism from another tool's file, as a URDF spanning
tree and a sidecar that pinclear.load accepts (docs/import_export.md).

One reader per format (a module and one line of READERS) fills pinclear.io.importers.graph; the
spanning tree is chosen in pinclear.io.importers.cuts and written by pinclear.io.importers.write.
"""
from __future__ import annotations

import json
import os
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
    """(urdf text, sidecar mapping, report) of a mechanism file; nothing written. Everything
    the written files could not hold with the file's meaning is refused here, naming the source
    file, the element and its line (pinclear.io.importers.graph.validate), before any URDF text
    reaches Pinocchio's parser."""
    from pinclear.io.importers import write
    from pinclear.io.importers.cuts import spanning_tree
    from pinclear.io.importers.graph import MAX_DEPTH, WORLD, validate

    g = read_graph(path)
    g.file = shown_path(path)
    name = name or g.name
    check_names(g, name)
    validate(g)
    notes = write.fix_root(g, fix)
    tree = spanning_tree(g, WORLD, tuple(cut))
    deepest = max(tree.depth, key=tree.depth.get)
    if tree.depth[deepest] > MAX_DEPTH:
        b = g.bodies[deepest]
        raise ModelFileError(g.file, f"body {deepest!r} (line {b.line})", f"lies {tree.depth[deepest]} joints below "
                             f"the world in the spanning tree: deeper than pinclear imports (at most {MAX_DEPTH})")
    F = write.frames_of(g, tree)
    closures = write.closures_of(g, tree, F) + write.couplings_of(g, tree)
    forces, lost = write.forces_of(g, tree)
    sidecar = {"name": name, "urdf": f"{name}.urdf",
               "description": f"imported by pinclear import from {write.comment_text(Path(g.file).name)} "
                              f"({g.fmt.upper()})",
               "gravity": [float(x) for x in g.gravity]}
    if closures:
        sidecar["closures"] = closures
    if forces:
        sidecar["forces"] = forces
    if g.sidecar is not None:
        # a file pinclear exported: its own description wins (closure types MuJoCo cannot express)
        sidecar = {**g.sidecar, "name": name, "urdf": f"{name}.urdf"}
    urdf = write.urdf_text(g, tree, F)
    accepted = nonphysical_inertias(urdf, g.file)
    if accepted:
        sidecar["nonphysical_inertia"] = accepted
    report = write.report_of(g, tree, [c for c in closures if c["type"] != "coupling"],
                             [c for c in closures if c["type"] == "coupling"], forces, lost, notes)
    report["nonphysical_inertia"] = sorted(accepted)
    report["warnings"] = ([g.replaced] if g.replaced else []) + list(g.warnings)
    if g.sidecar is not None:
        report["annotation_element"] = g.sidecar_where
        report["annotation"] = (f"closures, drives and forces from the pinclear annotation {g.sidecar_where}"
                                + (f"; {g.replaced}" if g.replaced else ""))
    return urdf, sidecar, report


def nonphysical_inertias(urdf, file) -> dict:
    """{joint: reason} of the bodies whose inertia breaks the triangle inequality (pinclear's
    sidecar check, pinclear.io.sidecar.check_inertias): the file's values are kept, and said so in
    the sidecar's ``nonphysical_inertia`` (any other bad inertia stays an error)."""
    import xml.etree.ElementTree as ET

    import pinocchio as pin

    from pinclear.io.sidecar import check_inertias
    from pinclear.io.urdf_check import check_urdf_tree

    # the generated text meets every URDF check before Pinocchio's parser sees it (the readers'
    # limits keep it inside them: pinclear.io.importers.graph)
    check_urdf_tree(ET.fromstring(urdf), file)
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
    outside --out) and names that would not survive as XML attribute values or YAML keys (a
    mesh's file name is escaped instead: any path is a valid one)."""
    if not SAFE_NAME.fullmatch(name):
        raise ModelFileError(g.file, "name", f"{name!r} is not a plain file name (letters, digits, _ . + -); give "
                             "--name")
    items = [(b.name, f"line {b.line}") for b in g.bodies.values()] + [(j.name, f"line {j.line}") for j in g.joints]
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
    from pinclear.io.importers.write import comment_text

    source = f"Imported by `pinclear import` from {comment_text(report['source'])} ({report['format']})"
    sizes = f"{report['bodies']} bodies, {report['tree_joints']} tree joints (depth {report['depth']})"
    lines = [f"{source}; edit the source and import again rather than this file.",
             f"{sizes}, {report['closure_rows']} closure rows."]
    if report.get("annotation"):
        lines.append(report["annotation"])
    lines += [f"cut {c['joint']} ({c['type']}, {c['rows']} rows): {c['why']}" for c in report["cut"]]
    lines += [f"not imported: {x}" for x in report["not_imported"]]
    lines += [f"kept as data: {x}" for x in report["kept_as_data"]]
    # one comment line each, whatever a name or a path holds
    return "".join(f"# {' '.join(ln.splitlines())}\n" for ln in lines)


#: the files an import writes into OUT, by suffix after NAME
OUTPUTS = (".urdf", ".yaml", ".import.json")


def _message(exc) -> str:
    """A ModelFileError's own message, without its ``FILE: KEY: `` prefix."""
    text = str(exc)
    for part in (exc.file, exc.key):
        if part is not None and text.startswith(f"{part}: "):
            text = text[len(part) + 2:]
    return text


def import_file(path, out, cut=(), fix=None, name=None) -> dict:
    """Write OUT/NAME.urdf, OUT/NAME.yaml and OUT/NAME.import.json; load the result back and add
    its closure residual at the reference configuration to the report.

    The files are written into a private folder inside OUT and loaded back from there; only a
    mechanism that loads is moved into OUT (a refused one leaves OUT as it was: no file of it
    stays behind to be loaded, or trusted, later). A load-back refusal names the source file
    (and the annotation's element when the annotation supplied the refused key)."""
    import contextlib
    import shutil
    import stat
    import tempfile

    from pinclear.core.errors import PinclearError
    from pinclear.io.sidecar import load
    from pinclear.model import kinematics

    urdf, sidecar, report = convert(path, cut, fix, name)
    out = Path(out)
    name = sidecar["name"]
    targets = [out / f"{name}{suffix}" for suffix in OUTPUTS]
    for t in targets:
        try:
            st = t.lstat()
        except FileNotFoundError:
            continue
        except OSError as exc:
            raise ModelFileError(str(t), "--out", f"cannot be written ({exc.strerror})") from None
        if not (stat.S_ISREG(st.st_mode) or stat.S_ISLNK(st.st_mode)):
            raise ModelFileError(str(t), "--out", "is a folder or a special file, not a file the import may replace")
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
        work = Path(tempfile.mkdtemp(prefix=".pinclear-import-", dir=out))
    except OSError as exc:
        raise ModelFileError(str(out), "--out", f"cannot be created or written ({exc.strerror})") from None
    try:
        safeio.write_text(work / f"{name}.urdf", urdf, root=out)
        text = header(report) + yaml.safe_dump(sidecar, sort_keys=False, width=120, default_flow_style=None)
        safeio.write_text(work / f"{name}.yaml", text, root=out)
        try:
            mech = load(work / f"{name}.yaml")
            ws = mech.workspace()
            phi = kinematics.closure_residual(mech, ws, mech.q0)
        except PinclearError as exc:
            inner = " ".join(_message(exc).replace(str(work), str(out)).split()) if isinstance(exc, ModelFileError) \
                else " ".join(str(exc).replace(str(work), str(out)).split())
            key = getattr(exc, "key", None)
            where = f"{report['annotation_element']} {key}" if report.get("annotation_element") and key else "import"
            raise ModelFileError(report["source"], where, f"the imported mechanism does not load back: {inner}; "
                                 "nothing was written to --out") from None
        report["residual_at_reference"] = float(np.max(np.abs(phi))) if phi.size else 0.0
        report["files"] = [str(t) for t in targets[:2]]
        safeio.write_text(work / f"{name}.import.json", json.dumps(report, indent=2) + "\n", root=out)
        for t in targets:
            os.replace(work / t.name, t)
        created = False
    except OSError as exc:
        target = exc.filename if exc.filename and str(work) not in str(exc.filename) else str(out)
        raise ModelFileError(str(target), "--out", f"cannot be written ({exc.strerror or exc})") from None
    finally:
        shutil.rmtree(work, ignore_errors=True)
        if created:                        # a refused import leaves no folder it made
            with contextlib.suppress(OSError):
                out.rmdir()
    return report
