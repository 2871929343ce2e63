"""The module names of pinclear before its layered layout (docs/design.md, "Layers"), kept
working: ``import pinclear.sidecar`` is ``pinclear.io.sidecar``, the same module object, so user
code, notebooks and data files that name an old path (``module:function`` in a sidecar) go on
working. Two old kernel files were split by physics; their old names are a read-only view that
finds each name in the modules that now hold it.

The finder is installed by the package face (pinclear/__init__.py); nothing inside pinclear
imports an old name.
"""
from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
import types

#: old module -> new module
MOVED = {
    "pinclear._argtypes": "pinclear.cli.args",
    "pinclear._jit": "pinclear.core.jit",
    "pinclear.analysis.cli": "pinclear.cli.analyse",
    "pinclear.analysis.sweep": "pinclear.analysis.diagrams",
    "pinclear.atlas": "pinclear.studies.bench.atlas",
    "pinclear.bench": "pinclear.studies.bench.rhs",
    "pinclear.bounded": "pinclear.core.bounded",
    "pinclear.builder": "pinclear.io.builder",
    "pinclear.closures": "pinclear.model.closures",
    "pinclear.contact.bench": "pinclear.studies.bench.restitution",
    "pinclear.coupling": "pinclear.model.coupling",
    "pinclear.drives": "pinclear.model.drives",
    "pinclear.economy": "pinclear.analysis.economy",
    "pinclear.energy": "pinclear.dynamics.energy",
    "pinclear.errors": "pinclear.core.errors",
    "pinclear.export_mjcf": "pinclear.io.export_mjcf",
    "pinclear.failures": "pinclear.core.failures",
    "pinclear.forces": "pinclear.model.forces",
    "pinclear.formulations": "pinclear.dynamics.formulations",
    "pinclear.formulations.base": "pinclear.dynamics.formulations.base",
    "pinclear.formulations.lagrange": "pinclear.dynamics.formulations.lagrange",
    "pinclear.formulations.manifold": "pinclear.dynamics.formulations.manifold",
    "pinclear.formulations.pinocchio_cd": "pinclear.dynamics.formulations.pinocchio_cd",
    "pinclear.formulations.projection": "pinclear.dynamics.formulations.projection",
    "pinclear.formulations.proximal": "pinclear.dynamics.formulations.proximal",
    "pinclear.importers": "pinclear.io.importers",
    "pinclear.importers.cuts": "pinclear.io.importers.cuts",
    "pinclear.importers.graph": "pinclear.io.importers.graph",
    "pinclear.importers.mjcf": "pinclear.io.importers.mjcf",
    "pinclear.importers.sdf": "pinclear.io.importers.sdf",
    "pinclear.importers.urdf_closing": "pinclear.io.importers.urdf_closing",
    "pinclear.importers.write": "pinclear.io.importers.write",
    "pinclear.importers.xml": "pinclear.io.importers.xml",
    "pinclear.joint_spring": "pinclear.model.joint_spring",
    "pinclear.jsonsafe": "pinclear.core.jsonsafe",
    "pinclear.keyref": "pinclear.io.keyref",
    "pinclear.kinematics": "pinclear.model.kinematics",
    "pinclear.mechanism": "pinclear.model.mechanism",
    "pinclear.models": "pinclear.core.models",
    "pinclear.native": "pinclear.model.native",
    "pinclear.registry": "pinclear.core.registry",
    "pinclear.reproduce": "pinclear.studies.reproduce",
    "pinclear.reproduce.bands": "pinclear.studies.reproduce.bands",
    "pinclear.reproduce.chaos": "pinclear.studies.reproduce.chaos",
    "pinclear.reproduce.paper000": "pinclear.studies.reproduce.paper000",
    "pinclear.reproduce.paper002": "pinclear.studies.reproduce.paper002",
    "pinclear.reproduce.paper003": "pinclear.studies.reproduce.paper003",
    "pinclear.reproduce.paper004": "pinclear.studies.reproduce.paper004",
    "pinclear.reproduce.report": "pinclear.studies.reproduce.report",
    "pinclear.reproduce.verdicts": "pinclear.studies.reproduce.verdicts",
    "pinclear.safeio": "pinclear.core.safeio",
    "pinclear.screw": "pinclear.dynamics.screw",
    "pinclear.screw.algebra": "pinclear.dynamics.screw.algebra",
    "pinclear.screw.cli": "pinclear.cli.inverse_dynamics",
    "pinclear.screw.inverse_dynamics": "pinclear.dynamics.screw.inverse_dynamics",
    "pinclear.screw.section": "pinclear.dynamics.screw.section",
    "pinclear.screw.system": "pinclear.dynamics.screw.system",
    "pinclear.screw.virtual": "pinclear.dynamics.screw.virtual",
    "pinclear.sidecar": "pinclear.io.sidecar",
    "pinclear.simulate": "pinclear.dynamics.simulate",
    "pinclear.stepping": "pinclear.dynamics.stepping",
    "pinclear.stepping.base": "pinclear.dynamics.stepping.base",
    "pinclear.stepping.build": "pinclear.dynamics.stepping.build",
    "pinclear.stepping.call": "pinclear.core.call",
    "pinclear.stepping.checks": "pinclear.dynamics.stepping.checks",
    "pinclear.stepping.chunk": "pinclear.dynamics.stepping.chunk",
    "pinclear.stepping.control": "pinclear.dynamics.stepping.control",
    "pinclear.stepping.external": "pinclear.dynamics.stepping.external",
    "pinclear.stepping.outputs": "pinclear.dynamics.stepping.outputs",
    "pinclear.stepping.peaks": "pinclear.dynamics.stepping.peaks",
    "pinclear.stepping.rk": "pinclear.dynamics.stepping.rk",
    "pinclear.stepping.roots": "pinclear.dynamics.stepping.roots",
    "pinclear.stepping.rosenbrock": "pinclear.dynamics.stepping.rosenbrock",
    "pinclear.stepping.run": "pinclear.dynamics.stepping.run",
    "pinclear.stepping.stage": "pinclear.core.stage",
    "pinclear.stepping.state": "pinclear.dynamics.stepping.state",
    "pinclear.stepping.system": "pinclear.dynamics.stepping.system",
    "pinclear.study": "pinclear.studies.wear",
    "pinclear.study_paper000": "pinclear.studies.wear_paper000",
    "pinclear.sweeps": "pinclear.analysis.sweeps",
    "pinclear.timelaws": "pinclear.model.timelaws",
    "pinclear.trajectory": "pinclear.dynamics.trajectory",
    "pinclear.trust": "pinclear.core.trust",
    "pinclear.urdf_check": "pinclear.io.urdf_check",
    "pinclear.validate": "pinclear.dynamics.validate",
    "pinclear.viz.cli": "pinclear.cli.view",
    "pinclear.wearing": "pinclear.analysis.wear_life",
}

#: old kernel files split by physics -> the modules that hold their names, searched in order
SPLIT = {
    "pinclear._kernels": (
        "pinclear.model.frames", "pinclear.model.rows", "pinclear.core.tree_solve", "pinclear.dynamics.formulations.base",
        "pinclear.dynamics.formulations.lagrange", "pinclear.dynamics.formulations.proximal", "pinclear.core.regularised", "pinclear.core.dense"),
    "pinclear.contact._kernels": (
        "pinclear.contact.force_laws", "pinclear.contact.radial_geometry", "pinclear.contact.worn_geometry",
        "pinclear.contact.prismatic_geometry", "pinclear.contact.prismatic", "pinclear.contact.channels"),
}


def current(name: str) -> str:
    """The module's current name (``name`` itself when it did not move)."""
    return MOVED.get(name, name)


class _SplitModule(types.ModuleType):
    """An old kernel file's name as a view: each attribute from the module that now holds it."""

    def __init__(self, name, holders):
        super().__init__(name, f"{name}: moved; its names are in {', '.join(holders)}")
        self.__dict__["_holders"] = holders

    def __getattr__(self, attr):
        for holder in self.__dict__["_holders"]:
            mod = importlib.import_module(holder)
            if attr in vars(mod):
                return vars(mod)[attr]
        raise AttributeError(f"module {self.__name__!r} (moved to {', '.join(self._holders)}) has no attribute {attr!r}")

    def __dir__(self):
        return sorted({a for h in self._holders for a in vars(importlib.import_module(h))})


class _Loader(importlib.abc.Loader):
    def create_module(self, spec):
        if spec.name in SPLIT:
            return _SplitModule(spec.name, SPLIT[spec.name])
        module = importlib.import_module(MOVED[spec.name])
        spec.loader_state = module.__spec__
        return module

    def exec_module(self, module):
        # the import system stamped the old name's spec on the module: give it back its own
        real = module.__spec__.loader_state
        if real is not None:
            module.__spec__ = real


class OldNames(importlib.abc.MetaPathFinder):
    """Finds the old module names (:data:`MOVED`, :data:`SPLIT`) and hands back today's modules."""

    def find_spec(self, fullname, path=None, target=None):
        if fullname in MOVED or fullname in SPLIT:
            return importlib.util.spec_from_loader(fullname, _Loader())
        return None


def install() -> None:
    """Put the finder on sys.meta_path once (the package face calls it). It goes first: the path
    finder would otherwise load an old submodule name (``pinclear.stepping.build``) a second
    time from its aliased package's folder, as a module of its own. It answers only the names of
    its tables."""
    if not any(isinstance(f, OldNames) for f in sys.meta_path):
        sys.meta_path.insert(0, OldNames())
