"""The sidecar key reference (docs/keys.md), generated from the keys the code declares: the
sidecar's sections (pinclear.io.sidecar), the closure types (pinclear.model.closures.CLOSURES), the time
laws (pinclear.model.timelaws.LAW_KEYS), and the registries of force elements and clearance types
(pinclear.core.registry) with their laws (pinclear.contact.spec). Written by

    python -m pinclear.io.keyref --out docs/keys.md

and compared with the committed file by tests/core/test_registry.py, so the reference cannot drift
from the code.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from pinclear.core import safeio
from pinclear.core.registry import REQUIRED, Key

HEADER = ("| key | type | unit | default | range | source | meaning |", "|---|---|---|---|---|---|---|")


def _cell(x) -> str:
    text = x if isinstance(x, str) else json.dumps(x)
    return text.replace("|", "\\|").replace("\n", " ")


def _default(k: Key) -> str:
    if k.default is REQUIRED:
        return "**required**"
    if k.default is None:
        return "none"
    return _cell(k.default)


def key_table(keys) -> list[str]:
    """A markdown table of Key records, one row each."""
    rows = list(HEADER)
    for k in keys:
        rows.append(f"| `{k.name}` | {_cell(k.type)} | {_cell(k.unit)} | {_default(k)} | {_cell(k.range)} | "
                    f"{_cell(k.source)} | {_cell(k.doc)} |")
    return rows


def _section(title, intro, keys=None) -> list[str]:
    out = [f"## {title}", ""] + ([intro, ""] if intro else [])
    if keys:
        out += key_table(keys) + [""]
    return out


def _closures() -> list[str]:
    from pinclear.model.closures import CLOSURES, KEYS

    out = _section("closures", "Each entry closes a loop of the URDF's spanning tree: a cut joint. Frames are "
                   "joined by the closure type's equations (axes are the frames' z axes).", KEYS)
    out += ["| closure type | equations | keys it reads |", "|---|---|---|"]
    for t in CLOSURES.values():
        reads = ", ".join(f"`{k.name}`" for k in t.keys) or "-"
        out.append(f"| `{t.name}` | {_cell(t.doc)} | {reads} |")
    return out + [""]


def _laws() -> list[str]:
    from pinclear.model.timelaws import LAW_KEYS, SINE_TERM_KEYS

    out = ["## time laws", "", "A drive's or a joint force's `law:` is a mapping with a `type` (or a number: a "
           "constant). Its value is in the unit of what it drives.", ""]
    for kind, (keys, doc) in LAW_KEYS.items():
        out += [f"### `{kind}`", "", doc, ""]
        out += key_table(keys) + [""]
    out += ["### the terms of a `sines` law", ""] + key_table(SINE_TERM_KEYS) + [""]
    return out


def _types(registry, title, intro) -> list[str]:
    out = _section(title, intro + f" Types: {', '.join(f'`{n}`' for n in registry)}.", registry.common)
    for t in registry.types():
        lines = [f"### `{t.name}`", "", t.doc]
        if t.source:
            lines[-1] += f" Source: {t.source}."
        if t.replaces:
            lines[-1] += f" Replaces a closure of type {', '.join(f'`{c}`' for c in t.replaces)}."
        out += lines + [""]
        if t.keys:
            out += key_table(t.keys) + [""]
    return out


def _contact_laws() -> list[str]:
    from pinclear.contact.laws import MATERIALS, NORMAL_LAWS
    from pinclear.contact.spec import FRICTION_LAW_KEYS, NORMAL_LAW_KEYS

    out = ["### normal laws (`normal_law`)", "", f"Types: {', '.join(f'`{n}`' for n in NORMAL_LAWS)} "
           "(formulas: pinclear/contact/laws.py, docs/contact_models.md).", ""]
    out += key_table(NORMAL_LAW_KEYS) + [""]
    out += ["### friction laws (`friction_law`)", ""]
    for kind, keys in FRICTION_LAW_KEYS.items():
        out += [f"`{kind}`" + ("" if keys else ": no parameters"), ""]
        if keys:
            out += key_table(keys) + [""]
    out += ["### materials (`material`, `material1`, `material2`)", "", "| name | E [Pa] | nu |", "|---|---|---|"]
    out += [f"| `{n}` | {E:.4g} | {nu} |" for n, (E, nu) in MATERIALS.items()]
    return out + [""]


def render() -> str:
    """The whole key reference as markdown."""
    from pinclear.core.registry import CLEARANCE_TYPES, FORCE_TYPES
    from pinclear.io import sidecar as S

    out = ["# Sidecar keys", "",
           "Generated from the code by `python -m pinclear.io.keyref --out docs/keys.md` (tests/core/test_registry.py "
           "checks that this file matches the code). A sidecar (`urdf/NAME.yaml`) names the URDF of a mechanism's "
           "spanning tree and adds what a tree cannot hold. Units are SI, angles in radians. An unknown key is an "
           "error naming the file, the key and the valid keys. Every number is finite.", ""]
    out += _section("top level", "", S.TOP)
    out += _section("frames", "Wherever a key takes a frame: an existing frame's name, or a mapping that adds one "
                    "to the model.", S.FRAME)
    out += _section("initial", "The assembly guess; the start state is assembled from it (docs/design.md).",
                    S.INITIAL)
    out += _closures()
    out += _section("drives", "A drive makes a 1-DoF tree joint follow a time law: a constraint row q_j - f(t) = 0 "
                    "whose multiplier is the actuator's force or torque.", S.DRIVE)
    out += _laws()
    out += _types(FORCE_TYPES, "forces", "Force elements add a generalized force computed from the state "
                  "(pinclear/forces.py, contract ForceElement).")
    out += _types(CLEARANCE_TYPES, "clearances", "A clearance joint replaces an ideal closure (a cut joint) by "
                  "contact when active (`active: true`, `--clearance NAME`, `load(clearances=[...])`). Keys of every "
                  "type, then each type's own.")
    out += _contact_laws()
    out += _section("platform", "", S.PLATFORM)
    out += _section("options", "Each `options:` entry is a scene switch.", S.OPTION)
    out += _section("parameters", "A documentation table, one entry per number taken from a source.", S.PARAMETER)
    out += _section("baumgarte", "", S.BAUMGARTE)
    return "\n".join(out).rstrip("\n") + "\n"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="python -m pinclear.io.keyref", description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=None, help="file to write (default: print)")
    args = ap.parse_args(argv)
    text = render()
    if args.out is None:
        sys.stdout.write(text)
    else:
        safeio.write_text(Path(args.out), text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
