"""The layering rule of pinclear (docs/design.md, "Layers"), checked on the import graph.

Every module of ``pinclear/`` belongs to the subpackage it sits in, and the subpackages are
stacked: a module of layer i imports modules of layers <= i only (function-level imports
included: an import inside a function ties the modules as much as one at the top), except the
edges in :data:`ALLOWED_UP`, each with its reason. There is no import cycle anywhere in the
package, nothing inside it takes names from the package face ``pinclear/__init__.py``, and a
module name computed at run time is imported only where :data:`DYNAMIC_IMPORTS` says why.
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "pinclear"

#: the layers, bottom up (docs/design.md's "Layers" table lists the same, in the same order)
LAYERS = ("core", "model", "contact", "dynamics", "io", "mechanisms", "analysis", "viz", "studies", "cli")

#: (importer, imported): why the edge runs up
ALLOWED_UP = {
    ("pinclear.dynamics.trajectory", "pinclear.io.sidecar"):
        "Trajectory.mechanism() reopens the run's own mechanism file: a saved result that loads its model",
}

#: modules that import a module whose name is computed at run time, and why
DYNAMIC_IMPORTS = {
    "pinclear.core.registry": "a plug-in record named as 'module:NAME' in a registry line (every kind's, "
                              "commands, readers and studies included: pinclear.core.registry.KINDS)",
    "pinclear.core.trust": "a data file's 'module:function', through the trust gate",
    "pinclear.core.aliases": "the old module names (a fixed table in that file)",
    "pinclear": "the face's lazy old submodule names (pinclear.core.aliases)",
}


def modname(p: Path) -> str:
    parts = list(p.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


MODULES = {modname(p): p for p in PKG.rglob("*.py")}


def _resolve(cur: str, is_pkg: bool, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    base = cur.split(".") if is_pkg else cur.split(".")[:-1]
    if node.level > 1:
        base = base[:len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def _owner(name: str) -> str | None:
    """The pinclear module a dotted import name lands in (its longest module prefix)."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def import_graph():
    """{module: {imported module: [(line, what), ...]}} over pinclear, function-level imports included."""
    graph = {}
    for m, p in MODULES.items():
        tree = ast.parse(p.read_text(), str(p))
        out = graph.setdefault(m, {})
        for n in ast.walk(tree):
            targets = []
            if isinstance(n, ast.Import):
                targets = [(a.name, a.name) for a in n.names]
            elif isinstance(n, ast.ImportFrom):
                base = _resolve(m, p.name == "__init__.py", n)
                targets = [((f"{base}.{a.name}" if f"{base}.{a.name}" in MODULES else base), a.name) for a in n.names]
            for full, what in targets:
                if full != "pinclear" and not full.startswith("pinclear."):
                    continue
                t = _owner(full)
                if t is not None and t != m:
                    out.setdefault(t, []).append((n.lineno, what))
    return graph


GRAPH = import_graph()


def layer(module: str) -> int | None:
    parts = module.split(".")
    return LAYERS.index(parts[1]) if len(parts) > 1 and parts[1] in LAYERS else None


def test_every_module_sits_in_a_layer():
    loose = sorted(m for m in MODULES if m != "pinclear" and layer(m) is None)
    assert not loose, f"modules outside the layer subpackages: {loose}"
    subpackages = sorted(p.name for p in PKG.iterdir() if p.is_dir() and (p / "__init__.py").exists())
    assert subpackages == sorted(LAYERS)


@pytest.mark.parametrize("name", LAYERS)
def test_each_layer_docstring_names_its_layer(name):
    doc = ast.get_docstring(ast.parse((PKG / name / "__init__.py").read_text())) or ""
    assert doc.startswith(f"Layer {LAYERS.index(name)}, {name}:"), doc[:80]


def test_imports_run_only_downward():
    up = []
    for m, targets in GRAPH.items():
        if m == "pinclear":
            continue
        for t, sites in targets.items():
            if t == "pinclear" or layer(t) is None:
                continue
            if layer(t) > layer(m) and (m, t) not in ALLOWED_UP:
                up.append(f"{m}:{sites[0][0]} imports {t} (layer {LAYERS[layer(m)]} -> {LAYERS[layer(t)]})")
    assert not up, "\n".join(up)
    assert len(ALLOWED_UP) <= 2
    for (m, t) in ALLOWED_UP:       # an allowance for an edge that no longer exists is stale
        assert t in GRAPH[m], (m, t)


def _cycles(graph):
    """Strongly connected components of more than one module (Tarjan), as sorted lists."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def test_no_import_cycle():
    # the face imports everything and nothing imports it (next test): it cannot close a cycle
    cycles = _cycles(GRAPH)
    assert not cycles, cycles


def test_cycle_detection_finds_a_cycle():
    assert _cycles({"a": {"b": 1}, "b": {"c": 1}, "c": {"a": 1}, "d": {"a": 1}}) == [["a", "b", "c"]]


def test_nothing_inside_imports_the_face():
    bad = [f"{m}:{sites[0][0]}" for m, targets in GRAPH.items() if m != "pinclear"
           for t, sites in targets.items() if t == "pinclear"]
    assert not bad, bad


def test_module_names_computed_at_run_time_are_imported_only_where_listed():
    found = {}
    for m, p in MODULES.items():
        for n in ast.walk(ast.parse(p.read_text())):
            if not isinstance(n, ast.Call):
                continue
            f = n.func
            name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", None)
            if name in ("import_module", "__import__") and n.args and not isinstance(n.args[0], ast.Constant):
                found.setdefault(m, []).append(n.lineno)
    assert set(found) <= set(DYNAMIC_IMPORTS), {m: found[m] for m in set(found) - set(DYNAMIC_IMPORTS)}


def test_design_doc_layers_table_matches():
    text = (ROOT / "docs" / "design.md").read_text()
    sec = text.split("## Layers", 1)[1].split("\n## ", 1)[0]
    rows = re.findall(r"^\|\s*(\d+)\s*\|\s*`(\w+)`", sec, re.M)
    assert [(int(i), n) for i, n in rows] == list(enumerate(LAYERS))
    for (m, t) in ALLOWED_UP:
        assert f"{m} -> {t}" in sec or f"`{m}` -> `{t}`" in sec, (m, t)


def test_no_kernel_file_over_600_lines():
    long = {m: n for m, p in MODULES.items()
            if (b"@njit" in p.read_bytes() or b"cfunc(" in p.read_bytes())
            and (n := len(p.read_text().splitlines())) > 600}
    assert not long, long


def test_tests_sit_by_layer_and_every_module_keeps_fast_tests():
    """tests/<layer>/ per layer; a module whose every test is marked slow would drop out of the
    README's test command (the fast tier) entirely."""
    tests = ROOT / "tests"
    assert sorted(p.name for p in tests.iterdir() if p.is_dir() and (p / "__init__.py").exists()) == sorted(LAYERS)
    assert [p.name for p in tests.glob("test_*.py")] == ["test_layers.py"]
    only_slow = []
    for p in sorted(tests.glob("*/test_*.py")):
        funcs = [n for n in ast.parse(p.read_text()).body if isinstance(n, ast.FunctionDef) and n.name.startswith("test_")]
        fast = [f for f in funcs if not any(ast.unparse(d) in ("pytest.mark.slow", "pytest.mark.examples")
                                            for d in f.decorator_list)]
        if funcs and not fast and "pytestmark" not in p.read_text():
            only_slow.append(p.relative_to(tests).as_posix())
    assert not only_slow, only_slow


#: the longest a function's code may be (lines, its docstring not counted: a numpydoc parameter
#: list documents, it does not add logic)
MAX_FUNCTION_LINES = 80
#: functions over MAX_FUNCTION_LINES, each with its reason (none may be added)
LONG_FUNCTIONS: dict = {}


def function_lengths(path: Path) -> dict:
    """{qualified name: lines of code} of every function in ``path`` (docstrings left out)."""
    tree = ast.parse(path.read_text())
    out = {}

    def visit(node, prefix):
        for n in ast.iter_child_nodes(node):
            if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = n.end_lineno - n.lineno + 1
                first = n.body[0]
                if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) \
                        and isinstance(first.value.value, str):
                    lines -= first.end_lineno - first.lineno + 1
                out[prefix + n.name] = lines
                visit(n, prefix + n.name + ".")
            elif isinstance(n, ast.ClassDef):
                visit(n, prefix + n.name + ".")
    visit(tree, "")
    return out


def test_no_function_over_80_lines():
    long = {f"{m}:{f}": n for m, p in MODULES.items() for f, n in function_lengths(p).items()
            if n > MAX_FUNCTION_LINES}
    assert set(long) <= set(LONG_FUNCTIONS), {k: v for k, v in long.items() if k not in LONG_FUNCTIONS}


def test_function_lengths_count_code_not_docstrings(tmp_path):
    p = tmp_path / "m.py"
    p.write_text('def f():\n    """Doc\n    on two lines."""\n    a = 1\n    return a\n\n\n'
                 'class C:\n    def g(self):\n        return 2\n')
    assert function_lengths(p) == {"f": 3, "C.g": 2}
