"""The pinclear annotation of an MJCF file, and what an import writes (issue 53, items 1 and 9):
an annotation naming code or files is refused at the source and nothing stays in OUT (so nothing
can be loaded, or trusted, later); an annotation replacing the file's own equalities is said; a
load-back refusal leaves OUT as it was and names the source; any valid file path is accepted
and escaped where it is written; a refused mesh is a warning line, not a Python warning; a target
that is a folder is named, never a temporary file."""
from __future__ import annotations

import contextlib
import io
import json
import os
import re
import shutil
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path
from xml.sax.saxutils import quoteattr

import pytest
import yaml

from pinclear.core.errors import ModelFileError
from pinclear.io.importers import import_file

DATA = Path(__file__).parents[1] / "data"


def _cli(argv):
    from pinclear.cli import commands

    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        rc = commands.main(argv)
    return rc, err.getvalue()


def _with_annotation(doc) -> str:
    """The hand-written four-bar MJCF fixture carrying ``doc`` as its pinclear annotation."""
    text = (DATA / "import_four_bar.xml").read_text()
    return text.replace("</mujoco>", f'  <custom><text name="pinclear:sidecar" data={quoteattr(json.dumps(doc))}/>'
                                     "</custom>\n</mujoco>")


CLOSURE_B = {"name": "B", "type": "spherical", "frame1": {"parent": "coupler", "xyz": [0.35, 0, 0]},
             "frame2": {"parent": "rocker", "xyz": [0.15, 0, 0]}}

#: annotations that name code or files, each at another place of the sidecar (the class: every
#: key through which a sidecar can reach a function or a file)
CODE_OR_FILES = [
    ("drive-law", {"drives": [{"joint": "crank_joint", "law": {"type": "python", "function": "os:system",
                                                                 "args": {"command": "touch MARKER"}}}]},
     "drives[0].law.function"),
    ("attribute-chain", {"drives": [{"joint": "crank_joint", "law": {"type": "python",
                                                                      "function": "pinclear.model.timelaws:os.system"}}]},
     "drives[0].law.function"),
    ("hook", {"hook": "pinclear.cli:main"}, "hook"),
    ("platform", {"platform": {"frame": "rocker", "motion": {"function": "builtins:exec"}}}, "platform.motion.function"),
    ("screw-ik", {"screw": {"ik": "os:system"}}, "screw.ik"),
    ("option-default", {"options": {"law": {"default": "os:system"}}}, "options.law.default"),
    ("nested-urdf", {"closures": [{**CLOSURE_B, "urdf": "/etc/passwd"}]}, "closures[0].urdf"),
    ("mesh", {"forces": [{"name": "f", "meshes": ["a.stl"]}]}, "forces[0].meshes"),
    ("path-value", {"closures": [{**CLOSURE_B, "name": "/etc/passwd"}]}, "closures[0].name"),
]


@pytest.mark.parametrize("case, doc, key", CODE_OR_FILES, ids=[c[0] for c in CODE_OR_FILES])
def test_an_annotation_naming_code_or_files_is_refused_and_writes_nothing(case, doc, key, tmp_path, monkeypatch):
    """`pinclear import` and then `pinclear info OUT/four_bar.yaml --trust` ran the annotation's
    os:system: now the import is exit 2 naming the annotation's element, line and key, OUT holds
    no file, and no marker appears."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "x.xml").write_text(_with_annotation(doc))
    rc, err = _cli(["import", str(tmp_path / "x.xml"), "--out", str(tmp_path / "out")])
    assert rc == 2, err
    assert err.count("\n") == 1 and f"<text name='pinclear:sidecar'> (line 25) {key}:" in err, err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
    rc, _ = _cli(["info", str(tmp_path / "out" / "four_bar.yaml"), "--trust"])
    assert rc == 2 and not (tmp_path / "MARKER").exists()


def test_an_annotation_may_name_the_functions_offered_to_every_data_file():
    from pinclear.core.trust import OFFERED
    from pinclear.io.importers.annotation import check_annotation

    for spec in OFFERED:
        doc = {"drives": [{"joint": "j", "law": {"type": "python", "function": spec}}], "hook": spec}
        assert check_annotation(json.dumps(doc), "f.xml", "<text>") == doc
    with pytest.raises(ModelFileError, match="names code"):
        check_annotation(json.dumps({"hook": next(iter(OFFERED)) + ".__globals__"}), "f.xml", "<text>")


def test_an_annotation_replacing_the_files_equalities_is_said(tmp_path):
    """The fixture's own connect B is replaced by the annotation's closure B: the report, the
    sidecar's header and one warning line on stderr say so; the import itself succeeds."""
    (tmp_path / "x.xml").write_text(_with_annotation({"closures": [CLOSURE_B]}))
    rc, err = _cli(["import", str(tmp_path / "x.xml"), "--out", str(tmp_path / "out")])
    assert rc == 0, err
    line = ("pinclear: warning: the pinclear annotation <text name='pinclear:sidecar'> (line 25) replaced the file's "
            "own 1 equality element (<connect name='B'> (line 23))")
    assert err.startswith(line) and err.count("\n") == 1, err
    report = json.loads((tmp_path / "out" / "four_bar.import.json").read_text())
    assert report["annotation_element"] == "<text name='pinclear:sidecar'> (line 25)"
    assert "replaced the file's own 1 equality element" in (tmp_path / "out" / "four_bar.yaml").read_text()
    # without the file's own equalities nothing is replaced, nothing said
    text = re.sub(r"<equality>.*</equality>", "", _with_annotation({"closures": [CLOSURE_B]}), flags=re.DOTALL)
    (tmp_path / "y.xml").write_text(text)
    assert import_file(tmp_path / "y.xml", tmp_path / "out2")["warnings"] == []


def test_a_load_back_refusal_leaves_out_as_it_was_and_names_the_source(tmp_path):
    """An annotation that passes the reader but not pinclear.load (a closure frame on a link the
    URDF does not have): one line naming the source file, the annotation and its key; a previous
    import in OUT is kept, byte for byte, and no working folder is left behind."""
    out = tmp_path / "out"
    import_file(DATA / "import_four_bar.xml", out)
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    bad = {**CLOSURE_B, "frame2": {"parent": "nolink", "xyz": [0, 0, 0]}}
    (tmp_path / "four_bar.xml").write_text(_with_annotation({"closures": [bad]}))
    with pytest.raises(ModelFileError) as exc:
        import_file(tmp_path / "four_bar.xml", out)
    msg = str(exc.value)
    assert msg.startswith(f"{tmp_path / 'four_bar.xml'}: <text name='pinclear:sidecar'> (line 25) closures"), msg
    assert "'nolink'" in msg and "nothing was written to --out" in msg and ".pinclear-import" not in msg
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_a_target_that_is_a_folder_is_named_never_a_temporary(tmp_path):
    (tmp_path / "out" / "four_bar.urdf").mkdir(parents=True)
    rc, err = _cli(["import", str(DATA / "import_four_bar.xml"), "--out", str(tmp_path / "out")])
    assert rc == 2 and f"{tmp_path / 'out' / 'four_bar.urdf'}: --out: is a folder" in err, err
    assert ".tmp" not in err
    # the link-safe writer names the target too (pinclear export --mjcf DIR ended in '.o.xml.XXXX.tmp')
    from pinclear.core import safeio

    (tmp_path / "o.xml").mkdir()
    with pytest.raises(OSError) as exc:
        safeio.write_text(tmp_path / "o.xml", "x")
    assert exc.value.filename == str(tmp_path / "o.xml") and not list(tmp_path.glob(".o.xml.*"))


#: folder names that are valid paths and break what is written naively: an XML comment ("--"),
#: an attribute (quotes, &, <), a YAML comment (a newline), a percent sign, a byte that is not UTF-8
ODD = ["a--b", 'q"uo\'te&amp<gt>', "new\nline", "pct%41 and spaces", "ünï", os.fsdecode(b"raw\xff")]


@pytest.mark.parametrize("name", ODD, ids=["dashes", "xml-chars", "newline", "percent", "unicode", "not-utf8"])
def test_any_valid_path_is_accepted_and_escaped(name, tmp_path):
    """The source path is written into the URDF's comment, the sidecar's comment header and its
    description: each stays well-formed and says the path; a mesh beside the source is named in
    the URDF attribute exactly."""
    import pinclear

    src = tmp_path / name
    src.mkdir()
    sdf = (DATA / "import_four_bar.sdf").read_text()
    utf8 = "\udcff" not in name               # an XML text cannot name a file whose name is not UTF-8
    mesh = src / f"m{name if utf8 else ''}.stl"
    shutil.copy(DATA / "import_four_bar.sdf", mesh)           # a mesh is not opened by the import
    uri = mesh.name.replace("&", "&amp;").replace("<", "&lt;")
    sdf = sdf.replace("</link>", f"<visual name='v'><geometry><mesh><uri>{uri}</uri></mesh></geometry></visual></link>",
                      1)
    (src / "four_bar.sdf").write_text(sdf, encoding="utf-8")
    out = src / "out"
    report = import_file(src / "four_bar.sdf", out, cut=["B"])
    assert report["source"] == str(src / "four_bar.sdf")
    root = ET.parse(out / "four_bar.urdf").getroot()              # the comment did not break the XML
    # a mesh whose path is not UTF-8 cannot be named by a URDF: said, not written
    assert [m.get("filename") for m in root.iter("mesh")] == ([str(mesh)] if utf8 else [])
    assert utf8 or "is not UTF-8: a URDF cannot name it" in report["warnings"][0]
    text = (out / "four_bar.yaml").read_text(encoding="utf-8")
    head = text[:text.index("\nname:")]
    assert all(ln.startswith("#") for ln in head.splitlines())
    assert yaml.safe_load(text)["name"] == "four_bar"
    assert pinclear.load(out / "four_bar.yaml").nq == 3            # crank, coupler, rocker


def test_a_refused_mesh_is_a_warning_line_not_a_python_warning(tmp_path):
    sdf = (DATA / "import_four_bar.sdf").read_text().replace(
        "</link>", "<visual name='v'><geometry><mesh><uri>/etc/passwd</uri></mesh></geometry></visual></link>", 1)
    (tmp_path / "m.sdf").write_text(sdf)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rc, err = _cli(["import", str(tmp_path / "m.sdf"), "--out", str(tmp_path / "out")])
    assert rc == 0, err
    assert err.startswith("pinclear: warning: <mesh> (line ") and "mesh '/etc/passwd' not imported: it lies outside " \
        "the SDF's folder" in err and err.count("\n") == 1, err
    assert "passwd" not in (tmp_path / "out" / "four_bar.urdf").read_text()


def test_export_notes_never_break_their_xml_comment():
    """A note naming a closure 'a--b' (a valid URDF name) was written into an XML comment as it
    is: '--' inside a comment makes the MJCF malformed for MuJoCo and for the importer."""
    from pinclear.io.export_mjcf import _comment

    for note in ("closure 'a--b' (universal): not written", "ends in a dash -", "x---y\nz"):
        body = _comment(note)
        ET.fromstring(f"<r><!-- pinclear: {body} --></r>")
        assert "--" not in body and not body.endswith("-") and "\n" not in body
