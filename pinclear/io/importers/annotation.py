"""The pinclear annotation of an MJCF file, read as data: ``<custom><text name="pinclear:sidecar"
data="{...}">`` (pinclear.io.export_mjcf writes it) holds the sidecar mapping of the exported
mechanism, whose closures, drives and forces an import takes instead of the file's equalities.

The mapping becomes the imported sidecar, a file the user then loads as their own (and may trust),
so it is checked here, at the source, before anything is written (docs/security.md, "Importers"):

* bounded JSON: at most MAX_ANNOTATION_BYTES and MAX_ANNOTATION_DEPTH levels of nesting (the depth
  is counted before the JSON is parsed), finite numbers only, a mapping of sidecar keys;
* nothing that names code: a ``function``, ``hook`` or ``ik`` value, or any string spelled like
  ``module:function``, must be one of the functions pinclear offers to every untrusted data file
  (pinclear.core.trust.OFFERED: they resolve to the same function with or without ``--trust``);
* nothing that names a file: no key that names one (``urdf`` below the top, ``mesh``, ``path``,
  ``file``...; pinclear.core.trust.CODE_AND_FILE_KEYS) and no string holding a path separator
  outside the free-text keys (description, doc, note, source, unit, the reasons of
  ``nonphysical_inertia``). The top-level ``urdf`` an export writes is replaced by the import's
  own URDF, never opened.
"""
from __future__ import annotations

import json
import math
import re

from pinclear.core.errors import ModelFileError

#: an annotation is a sidecar: as large as one may be (pinclear.io.sidecar.MAX_SIDECAR_BYTES)
MAX_ANNOTATION_BYTES = 1_000_000
#: levels of nesting (a sidecar's deepest value, drives[0].law.terms[0].amp, is 5 levels deep)
MAX_ANNOTATION_DEPTH = 20
#: keys whose value must be a function pinclear offers to data files
FUNCTION_KEYS = ("function", "hook", "ik")
#: keys whose strings are prose, never looked up (a path in them names nothing); the
#: ``parameters`` table is documentation as a whole (pinclear.io.sidecar.TOP)
FREE_TEXT = ("description", "doc", "note", "notes", "source", "unit", "why", "parameters")
_STRING = re.compile(r'"(?:[^"\\]|\\.)*"', re.DOTALL)


def _depth(text) -> int:
    """The deepest nesting of ``[`` / ``{`` in a JSON text, its strings left out."""
    depth = deepest = 0
    for ch in _STRING.sub('""', text):
        if ch in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif ch in "]}":
            depth -= 1
    return deepest


def _no_constant(name):
    raise ValueError(f"{name} is not a finite number")


def check_annotation(text, file, where) -> dict:
    """The annotation's mapping, or a one-line ModelFileError naming ``file``, the annotation
    element ``where`` and the key inside the annotation."""
    from pinclear.io.sidecar import TOP_KEYS

    def refuse(key, message, choices=None):
        raise ModelFileError(file, f"{where}{' ' + key if key else ''}", message, choices)

    size = len(text.encode("utf-8", "surrogatepass"))
    if size > MAX_ANNOTATION_BYTES:
        refuse("", f"{size} bytes: larger than a sidecar may be (at most {MAX_ANNOTATION_BYTES})")
    if _depth(text) > MAX_ANNOTATION_DEPTH:
        refuse("", f"JSON nested more than {MAX_ANNOTATION_DEPTH} levels deep: not a sidecar")
    try:
        doc = json.loads(text, parse_constant=_no_constant)
    except (ValueError, RecursionError) as exc:
        refuse("", f"the pinclear annotation is not valid JSON ({' '.join(str(exc).split())[:200]})")
    if not isinstance(doc, dict):
        refuse("", f"the pinclear annotation is a JSON {type(doc).__name__}, not a mapping of sidecar keys")
    unknown = sorted(k for k in doc if k not in TOP_KEYS)
    if unknown:
        refuse(unknown[0], "not a sidecar key", choices=sorted(TOP_KEYS))
    doc.pop("urdf", None)                  # the import writes its own URDF beside the sidecar
    _walk(doc, "", refuse, free=False)
    return doc


def _walk(obj, key, refuse, free):
    from pinclear.core import aliases
    from pinclear.core.trust import _FUNCTION_NAME, CODE_AND_FILE_KEYS, OFFERED

    if isinstance(obj, dict):
        for k, v in obj.items():
            sub = f"{key}.{k}" if key else k
            if k in FUNCTION_KEYS:
                if not (isinstance(v, str) and _offered(v, aliases, OFFERED)):
                    refuse(sub, f"{str(v)[:100]!r} names code: an annotation may name only the functions pinclear "
                           "offers to every data file (remove the <text name=\"pinclear:sidecar\"> element to import "
                           "the file's own elements instead)", choices=list(OFFERED))
                continue
            if k in CODE_AND_FILE_KEYS and k not in ("motions", "virtual"):
                refuse(sub, "names a file: an annotation names no file (remove the <text name=\"pinclear:sidecar\"> "
                       "element to import the file's own elements instead)")
            _walk(v, sub, refuse, free or k in FREE_TEXT or key.endswith("nonphysical_inertia"))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            _walk(v, f"{key}[{i}]", refuse, free)
    elif isinstance(obj, str):
        if _FUNCTION_NAME.match(obj) and not _offered(obj, aliases, OFFERED) and not free:
            refuse(key, f"{obj[:100]!r} is spelled like a function name (module:function): an annotation may name "
                   "only the functions pinclear offers to every data file", choices=list(OFFERED))
        if not free and ("/" in obj or "\\" in obj or "\x00" in obj):
            refuse(key, f"{obj[:100]!r} looks like a file path: an annotation names no file")
    elif isinstance(obj, float) and not math.isfinite(obj):
        refuse(key, f"{obj!r} is not finite")


def _offered(spec, aliases, offered) -> bool:
    text = spec.strip()
    if text.count(":") != 1:
        return False
    mod, attr = text.split(":")
    return f"{aliases.current(mod.strip())}:{attr.strip()}" in offered
