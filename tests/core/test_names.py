"""No bundled mechanism's name and no paper number in the behaviour of the generic layers.

The generic layers (core, model, contact, dynamics, analysis, viz, the benchmarks of
studies/bench) work on any mechanism: what they know about a bundled one lives in
pinclear/mechanisms (pinclear.mechanisms.bench_scenes for the benchmarks) and in its sidecar, and a
paper's study lives in pinclear/studies/reproduce. This test reads every string constant of those
layers (the literal parts of f-strings included) and refuses a bundled mechanism's name or a paper
number ("paper 003", "paper003", "issue 40"). Not read: docstrings (documentation may cite a
paper), the ``source`` and ``doc`` of a sidecar key or type (its citation and its paragraph of
the key reference, docs/keys.md: Key's sixth and seventh fields), and names of pinclear modules ("pinclear.…": a registry line, an alias table, the
trust list), which name code, not a mechanism the code singles out. :data:`ALLOWED` lists the
rest, each with its reason.
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PKG = ROOT / "pinclear"
GENERIC = ("core", "model", "contact", "dynamics", "analysis", "viz", "studies/bench")

#: bundled mechanisms: every sidecar of urdf/ and every mechanism module
BUNDLED = sorted({p.stem for p in (ROOT / "urdf").glob("*.yaml")}
                 | {p.stem for p in (PKG / "mechanisms").glob("*.py") if not p.stem.startswith("_")}
                 - {"__init__", "benchmarks", "bench_scenes", "clearance_scenes"}, key=len, reverse=True)
#: a numbered family's stem as well (a02_nfourbar_1, _2, _10: "a02_nfourbar", as a pattern would name it)
BUNDLED += sorted({re.sub(r"_\d+$", "", n) for n in BUNDLED} - set(BUNDLED), key=len, reverse=True)
NAME = re.compile(r"(?<![A-Za-z0-9_])(" + "|".join(map(re.escape, BUNDLED)) + r")(?![A-Za-z0-9])")
PAPER = re.compile(r"paper[ _]?\d{3}|\bpapers? \d{3}|\bissues? \d+", re.I)

#: (module, the string found): why it may stay
ALLOWED = {
    ("pinclear.contact.prismatic", "paper003"): "the old name of the prismatic 'mode_laws' model, accepted as "
                                                "an alias (MODEL_ALIASES) so that existing sidecars still load",
}


def _skipped(tree) -> set:
    """ids of the constants not read: docstrings, key citations."""
    out = set()
    for n in ast.walk(tree):
        if isinstance(n, ast.Expr) and isinstance(n.value, ast.Constant) and isinstance(n.value.value, str):
            out.add(id(n.value))            # a docstring, or a bare string used as one
        if isinstance(n, ast.Call):
            f = n.func.attr if isinstance(n.func, ast.Attribute) else getattr(n.func, "id", "")
            # a key's or a type's citation (source) and its paragraph of the key reference (doc)
            cited = [k.value for k in n.keywords if k.arg in ("source", "doc")]
            if f == "Key":
                cited += n.args[5:7]
            for c in cited:
                out.update(id(m) for m in ast.walk(c))
    return out


def found(path: Path) -> list:
    """(line, match, text) of every name or paper number in ``path``'s string constants."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip = _skipped(tree)
    hits = []
    for n in ast.walk(tree):
        if not (isinstance(n, ast.Constant) and isinstance(n.value, str)) or id(n) in skip:
            continue
        if n.value.startswith("pinclear."):
            continue
        for rx in (NAME, PAPER):
            for m in rx.finditer(n.value):
                hits.append((n.lineno, m.group(0), n.value[:70]))
    return hits


def _module(p: Path) -> str:
    return ".".join(p.relative_to(ROOT).with_suffix("").parts).removesuffix(".__init__")


def test_generic_layers_name_no_bundled_mechanism_and_no_paper():
    bad = []
    for layer in GENERIC:
        for p in sorted((PKG / layer).rglob("*.py")):
            mod = _module(p)
            bad += [f"{mod}:{line}: {m!r} in {text!r}" for line, m, text in found(p) if (mod, m) not in ALLOWED]
    assert not bad, "\n".join(bad)


def test_the_scan_finds_a_name_and_a_paper_but_not_a_citation(tmp_path):
    """The scanner itself: a window keyed by a scene, a regex on a scene's name and an f-string part
    are found; a docstring and a key's source are not."""
    p = tmp_path / "m.py"
    p.write_text('"""Cites paper 003 eq. 4."""\n'
                 'W = {"four_ups_upu+S2": 0.2}\n'
                 'import re\nm = re.fullmatch(r"a02_nfourbar_(\\d+)", "x")\n'
                 'k = Key("c", "number", "m", 1.0, "> 0", "paper 000 eq. 6", "gap")\n'
                 'def f(n):\n    """As issue 40 asks."""\n    return f"see paper003 at {n}"\n', encoding="utf-8")
    assert sorted(m for _, m, _ in found(p)) == ["a02_nfourbar", "four_ups_upu", "paper003"]
    assert len(BUNDLED) > 10 and "four_bar" in BUNDLED and "nine_bar" in BUNDLED
