"""The public callables document every parameter of their signature in a numpydoc
"Parameters" section (and what they return in "Returns"), so a parameter added without its
documentation fails here."""
import inspect
import re

import pytest

import pinclear
from pinclear.dynamics.trajectory import Trajectory
from pinclear.io import builder


def _public_methods(cls):
    """Every public method, classmethod and staticmethod ``cls`` defines itself (inherited ones
    are their base's to document), with ``__init__`` for a class that defines it."""
    names = [n for n in vars(cls) if not n.startswith("_") or n == "__init__"]
    return [getattr(cls, n) for n in names if callable(getattr(cls, n))]


#: the documented surface: the package's face, the run's result object, the builder
CALLABLES = ([pinclear.load, pinclear.simulate, pinclear.sweep]
             + _public_methods(Trajectory) + _public_methods(builder.Builder)
             + [f for n, f in vars(builder).items() if not n.startswith("_") and inspect.isfunction(f)
                and f.__module__ == builder.__name__])
#: callables that return nothing (their docstring needs no "Returns")
NO_RETURN = {"Trajectory.__init__", "Trajectory.fill_states", "Trajectory.write_outputs", "Builder.__init__"}


def _section(doc, title):
    """The lines of numpydoc section ``title`` (the title, a dashed underline, then everything up
    to the next titled section), or None if the docstring has none."""
    lines = inspect.cleandoc(doc).splitlines()
    for k in range(len(lines) - 1):
        if lines[k].strip() == title and re.fullmatch(r"-{3,}", lines[k + 1].strip()):
            body = []
            for j in range(k + 2, len(lines)):
                if j + 1 < len(lines) and lines[j].strip() and re.fullmatch(r"-{3,}", lines[j + 1].strip()):
                    break
                body.append(lines[j])
            return body
    return None


def _documented(body):
    """The names a Parameters section documents: its unindented entry lines ``name : type`` or
    ``name`` (several as ``a, b : type``; ``*args``/``**kw`` keep their stars)."""
    names = set()
    for line in body:
        if line.strip() and not line[0].isspace():
            names.update(n.strip() for n in line.split(" : ")[0].split(","))
    return names


def _id(f):
    return f.__qualname__


def test_the_surface_is_listed():
    """The list reaches what it means to: the builder's methods and functions and the
    trajectory's I/O (a refactor that hid them from the walk would silently test nothing)."""
    ids = {_id(f) for f in CALLABLES}
    for name in ("Builder.__init__", "Builder.body", "Builder.joint", "Builder.closure", "Builder.drive",
                 "Builder.clearance", "Builder.platform", "Builder.parameter", "Builder.urdf_text",
                 "Builder.sidecar_dict", "Builder.write", "rod", "plate", "sines", "Trajectory.summary",
                 "Trajectory.save", "Trajectory.load", "Trajectory.to_csv", "Trajectory.to_mat",
                 "Trajectory.energy", "Trajectory.window_peaks", "load", "simulate", "sweep"):
        assert name in ids, name


@pytest.mark.parametrize("f", CALLABLES, ids=_id)
def test_every_parameter_is_documented(f):
    doc = f.__doc__
    assert doc, f"{_id(f)} has no docstring"
    params = []
    for p in inspect.signature(f).parameters.values():
        if p.name in ("self", "cls"):
            continue
        star = {p.VAR_POSITIONAL: "*", p.VAR_KEYWORD: "**"}.get(p.kind, "")
        params.append(star + p.name)
    body = _section(doc, "Parameters")
    if params:
        assert body is not None, f"{_id(f)}: no 'Parameters' section"
        missing = [p for p in params if p not in _documented(body)]
        assert not missing, f"{_id(f)}: parameters not documented: {missing}"
    if _id(f) not in NO_RETURN:
        returns = _section(doc, "Returns")
        assert returns and any(line.strip() for line in returns), f"{_id(f)}: no 'Returns' section"


def test_the_parser_reads_numpydoc():
    """The section reader itself: an entry per name, several names on one line, a description
    line that happens to contain " : " is not an entry, and the next section ends the list."""
    doc = """Summary.

    Parameters
    ----------
    a, b : float
        Two numbers; x : y is prose.
    **kw
        Others.

    Returns
    -------
    float
        The sum.
    """
    assert _documented(_section(doc, "Parameters")) == {"a", "b", "**kw"}
    assert _section(doc, "Raises") is None
    assert next(line for line in _section(doc, "Returns") if line.strip()) == "float"


def test_no_docstring_tells_history_issue_numbers_or_dates():
    """Docstrings say what and why; the history of a change (an issue number, the date it was
    measured) belongs in benchmarks/*.md and the commit log (docs/design.md)."""
    import ast
    from pathlib import Path

    history = re.compile(r"\bissue\s*#?\d+|\b20\d\d-\d\d-\d\d\b", re.I)
    found = []
    for path in sorted(Path(pinclear.__file__).parent.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
                m = history.search(ast.get_docstring(node) or "")
                if m:
                    found.append(f"{path.name}:{getattr(node, 'name', '<module>')}: {m.group(0)}")
    assert not found, found
