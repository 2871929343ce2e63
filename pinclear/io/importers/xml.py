"""Robot description files read as data: bounded XML with each element's line number.

SDF, MJCF and URDF files are parsed with the standard library's expat, never by a program that
could run code (an SDF ``<plugin>`` or an MJCF ``<include>`` is named in the import report, not
loaded). Bounds: the file's bytes (regular files only, pinclear.core.bounded), the number of elements
and the nesting depth; a DOCTYPE is refused (no entity of any kind, as for URDF:
pinclear.io.urdf_check). Every element carries ``line`` so errors name element and line.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from xml.parsers import expat

from pinclear.core.bounded import read_bounded
from pinclear.core.errors import ModelFileError

#: bytes of a robot description (the largest Cassie SDF of example-robot-data is 48 kB)
MAX_XML_BYTES = 10_000_000
#: elements of one file (Cassie's cassie.sdf has about 1700)
MAX_XML_ELEMENTS = 200_000
#: nesting depth (SDF and MJCF bodies nest; MJCF's body tree is the deepest: one level a body)
MAX_XML_DEPTH = 300


class Element(ET.Element):
    """An ElementTree element that knows its line in the file."""

    line = 0


def parse(path, what="robot description"):
    """The root Element of the XML file ``path``, every element with its ``line``."""
    file = str(path)
    data = read_bounded(path, MAX_XML_BYTES, "path", what)
    if len(data) > MAX_XML_BYTES:
        raise ModelFileError(file, "path", f"larger than {MAX_XML_BYTES} bytes: not a {what}")
    p = expat.ParserCreate()
    stack, count, root = [], [0], [None]

    def start(tag, attrs):
        count[0] += 1
        if count[0] > MAX_XML_ELEMENTS:
            raise ModelFileError(file, f"<{tag}> (line {p.CurrentLineNumber})",
                                 f"more than {MAX_XML_ELEMENTS} elements")
        if len(stack) >= MAX_XML_DEPTH:
            raise ModelFileError(file, f"<{tag}> (line {p.CurrentLineNumber})",
                                 f"nested more than {MAX_XML_DEPTH} levels deep")
        el = Element(tag, attrs)
        el.line = p.CurrentLineNumber
        el.text = ""
        if stack:
            stack[-1].append(el)
        else:
            root[0] = el
        stack.append(el)

    def end(tag):
        stack.pop()

    def chars(text):
        if stack:
            stack[-1].text += text

    def doctype(name, *args):
        raise ModelFileError(file, f"DOCTYPE (line {p.CurrentLineNumber})",
                             f"a {what} needs no DOCTYPE, and entity declarations are not accepted")

    p.StartElementHandler, p.EndElementHandler, p.CharacterDataHandler = start, end, chars
    p.StartDoctypeDeclHandler = doctype
    p.EntityDeclHandler = lambda name, *a: doctype(name)
    try:
        p.Parse(data, True)
    except expat.ExpatError as exc:
        raise ModelFileError(file, f"line {exc.lineno}", f"malformed XML: {expat.ErrorString(exc.code)} "
                             f"(column {exc.offset})") from None
    return root[0]


def parse_root(path, tag, what):
    """The root Element of ``path``, refused unless it is ``<tag>`` (a ``what``)."""
    root = parse(path, what)
    if root.tag != tag:
        raise ModelFileError(str(path), where(root), f"not {what}: the root element is <{tag}>")
    return root


def where(el) -> str:
    """``<tag name="...">`` (line N): how errors and the report name an element."""
    name = el.get("name")
    return f"<{el.tag}{' name=' + repr(name) if name else ''}> (line {el.line})"


def numbers(text, n, file, el, what=None):
    """``n`` finite numbers from a text (an element's text or an attribute value)."""
    parts = (text or "").split()
    try:
        vals = [float(x) for x in parts]
    except ValueError:
        vals = None
    key = f"{where(el)}{' ' + what if what else ''}"
    if vals is None or len(vals) != n:
        raise ModelFileError(file, key, f"expected {n} number(s), got {(text or '').strip()!r}")
    if not all(math.isfinite(v) for v in vals):
        raise ModelFileError(file, key, f"{text.strip()!r} is not finite (nan and inf are not accepted)")
    return vals


def number(el, attr, file, default=None):
    """The one finite number of the attribute ``attr`` of ``el`` (``default`` when absent)."""
    text = el.get(attr)
    if text is None:
        return default
    return numbers(text, 1, file, el, attr)[0]


def child_number(el, tag, file, default=None):
    """The number in the child element ``tag`` of ``el`` (``default`` when absent)."""
    c = el.find(tag)
    if c is None:
        return default
    return numbers(c.text, 1, file, c)[0]
