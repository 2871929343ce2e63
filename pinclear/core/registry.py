"""Registries of the plug-in kinds, all of one style (:class:`Registry`): clearance types and
force element types (the sidecar's), formulations and integrators (below); closure readers
(pinclear.io.sidecar), importers (pinclear.io.importers), paper reproductions
(pinclear.studies.reproduce), studies (pinclear.studies.wear) and commands (pinclear.cli.commands)
in the module of their kind (:data:`KINDS` lists where each is).

Each type declares, in its own module, one :class:`PluginType` record: its sidecar ``type``
name, its keys (:class:`Key`: type, unit, default, range, source equation), its parser (the
sidecar entry -> the object), and for clearance types the closure types it may replace and how
the plots draw it. The sidecar (pinclear.io.sidecar), the clearance builder (pinclear.contact),
the plots (pinclear.viz) and the key reference (docs/keys.md, pinclear.io.keyref) read these
records and nothing else, so a new type is one new module plus one line in its registry below
(``"name": "module:ATTRIBUTE"``), or, for a type defined outside pinclear, one
``REGISTRY.add(record)`` call before loading.

A kind whose plug-ins are functions (a reader, a study, a command) registers :class:`Entry`
records: a name, its ``"module:function"`` (imported on first call) and one line of doc.

Entries are imported when first used, so a registry lists its names without importing the
modules behind them (the sidecar checks a type name without loading the contact kernels).
"""
from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any, Callable


class _Required:
    """The default of a key that has none: the entry must give it."""

    def __repr__(self):
        return "required"


REQUIRED = _Required()


@dataclass(frozen=True)
class Key:
    """One sidecar key: what it holds (``type``), its unit (SI; "-" for none), its default
    (REQUIRED when it has none), the values allowed (``range``), where its meaning comes from
    (``source``: a paper's equation or a project doc) and one line of ``doc``."""

    name: str
    type: str
    unit: str = "-"
    default: Any = REQUIRED
    range: str = ""
    source: str = ""
    doc: str = ""

    @property
    def required(self) -> bool:
        return self.default is REQUIRED


def key_names(keys) -> frozenset:
    return frozenset(k.name for k in keys)


@dataclass(frozen=True)
class PluginType:
    """One sidecar type of a plug-in kind.

    name: the sidecar ``type``. keys: the keys its entries may hold besides those every entry of
    its kind holds (a registry's ``common`` keys). parse: ``parse(entry, ctx)`` -> the object,
    where ``entry`` is the sidecar mapping (keys checked) and ``ctx`` what the kind's caller
    passes (pinclear.io.sidecar.Context for force elements; pinclear.contact.spec.Spec, the
    mechanism and the replaced closure for clearance types). doc: one paragraph for the key
    reference. replaces: the closure types a clearance type may replace. plot: how the plots
    draw it (pinclear.viz.plots.ClearancePlot for clearance types)."""

    name: str
    keys: tuple = ()
    parse: Callable | None = None
    doc: str = ""
    source: str = ""
    replaces: tuple = ()
    plot: Any = None

    def value(self, entry: dict, name: str):
        """``entry[name]``, else the key's declared default (KeyError(name) when it has none)."""
        if name in entry:
            return entry[name]
        default = next(k.default for k in self.keys if k.name == name)
        if default is REQUIRED:
            raise KeyError(name)
        return default


@dataclass(frozen=True)
class ClearancePlot:
    """How the figures and the viewer draw a clearance type (PluginType.plot).

    across_axis: the journal figure shows body 2's centre across frame1's z axis (a bearing's or
    a guide's axis); else the two directions it explores most (a ball). travel: body 2 moves
    freely along frame1's z (a slider), which is motion, not play. boundary: "circle" (a radial
    clearance c, the element's ``c``) or "rectangle" (the gaps c1 x c2, ``c1`` and ``c2``).
    body: what body 2 is called in titles."""

    across_axis: bool
    travel: bool
    boundary: str
    body: str


def _resolve(ref: str):
    module, attr = ref.split(":")
    return getattr(importlib.import_module(module), attr)


@dataclass(frozen=True)
class Entry:
    """A registered function: ``name``, ``target`` (``"module:function"``, imported on first
    use, or the function itself) and one line of ``doc`` (a command's help, a study's title)."""

    name: str
    target: Any
    doc: str = ""

    def load(self) -> Callable:
        """The function itself (its module imported now if named as text)."""
        return _resolve(self.target) if isinstance(self.target, str) else self.target

    def __call__(self, *args, **kwargs):
        return self.load()(*args, **kwargs)


class Registry:
    """name -> record (a PluginType, or the ``record`` class given: an integrator is a
    pinclear.dynamics.stepping.base.Method, a function an :class:`Entry`), each entry given as a
    record or as "module:attribute" (imported on first use). ``classes=True``: the records are
    subclasses of ``record`` (a formulation is its class). Iterating gives the names in
    registration order."""

    def __init__(self, what: str, entries: dict, common=(), record=PluginType, classes=False):
        self.what = what
        self._common = common
        self._record = record
        self._classes = classes
        self._entries = dict(entries)

    def _is_record(self, entry) -> bool:
        if self._classes:
            return isinstance(entry, type) and issubclass(entry, self.record)
        return isinstance(entry, self.record)

    @property
    def record(self) -> type:
        """The class every entry is an instance of (given as a class or "module:attribute")."""
        if isinstance(self._record, str):
            self._record = _resolve(self._record)
        return self._record

    @property
    def common(self) -> tuple:
        """The keys every entry of this kind holds (given as "module:attribute" or a tuple)."""
        if isinstance(self._common, str):
            self._common = tuple(_resolve(self._common))
        return tuple(self._common)

    def __contains__(self, name) -> bool:
        return isinstance(name, str) and name in self._entries

    def __iter__(self):
        return iter(list(self._entries))

    def __len__(self):
        return len(self._entries)

    def names(self) -> tuple:
        return tuple(self._entries)

    def get(self, name) -> PluginType:
        entry = self._entries[name]
        if isinstance(entry, str):
            entry = _resolve(entry)
            if not self._is_record(entry) or entry.name != name:
                raise TypeError(f"{self.what} {name!r}: {self._entries[name]} is not its {self.record.__name__} "
                                "record")
            self._entries[name] = entry
        return entry

    __getitem__ = get

    def items(self) -> list:
        """(name, record) pairs in registration order (every entry imported)."""
        return [(n, self.get(n)) for n in self]

    def types(self) -> list:
        return [self.get(n) for n in self]

    def allowed(self, name) -> frozenset:
        """Every key an entry of type ``name`` may hold."""
        return key_names(self.common) | key_names(self.get(name).keys)

    def add(self, record):
        """Register a type defined outside pinclear (the one line of a user's plug-in)."""
        if not self._is_record(record):
            raise TypeError(f"a {self.what} is registered as a {self.record.__name__} record, got "
                            f"{type(record).__name__}")
        if record.name in self._entries:
            raise ValueError(f"{self.what} {record.name!r} is already registered")
        self._entries[record.name] = record

    def replace(self, record):
        """Put ``record`` in place of the one registered under its name, keeping the order (a
        benchmark trying variants of a type); returns the one replaced."""
        old = self.get(record.name)
        if not self._is_record(record):
            raise TypeError(f"a {self.what} is registered as a {self.record.__name__} record")
        self._entries[record.name] = record
        return old

    def remove(self, name):
        """Undo :meth:`add` (tests that register a toy type)."""
        self._entries.pop(name)


#: clearance types (sidecar ``clearances: [{type: ...}]``); the keys every type takes are
#: pinclear.contact.spec.COMMON
CLEARANCE_TYPES = Registry("clearance type", {
    "spherical": "pinclear.contact.spherical:SPHERICAL",
    "planar_revolute": "pinclear.contact.revolute:PLANAR_REVOLUTE",
    "revolute": "pinclear.contact.revolute:REVOLUTE",
    "prismatic": "pinclear.contact.prismatic:PRISMATIC",
    "lubricated_revolute": "pinclear.contact.lubricated:LUBRICATED_REVOLUTE",
    "lubricated_spherical": "pinclear.contact.lubricated_spherical:LUBRICATED_SPHERICAL",
}, common="pinclear.contact.spec:COMMON")

#: force element types (sidecar ``forces: [{type: ...}]``)
FORCE_TYPES = Registry("force element type", {
    "spring_damper": "pinclear.model.forces:SPRING_DAMPER",
    "joint_force": "pinclear.model.forces:JOINT_FORCE",
    "joint_spring": "pinclear.model.joint_spring:JOINT_SPRING",
}, common=(Key("name", "string", default="<type><index>", doc="the element's name (outputs are named NAME.key)"),
           Key("type", "string", doc="the force element type")))

#: integrators (``simulate(..., integrator=NAME)``, ``--integrator``): each a pinclear.dynamics.stepping.base.
#: Method instance in its module (its contract there); the atlas runs them in this order
INTEGRATORS = Registry("integrator", {
    "RK45": "pinclear.dynamics.stepping.rk:RK45",
    "DOP853": "pinclear.dynamics.stepping.rk:DOP853",
    "ROS34PW2": "pinclear.dynamics.stepping.rosenbrock:ROS34PW2",
    "Radau": "pinclear.dynamics.stepping.external:RADAU",
    "BDF": "pinclear.dynamics.stepping.external:BDF",
    "LSODA": "pinclear.dynamics.stepping.external:LSODA",
    "RK4": "pinclear.dynamics.stepping.rk:RK4",
}, record="pinclear.dynamics.stepping.base:Method")

#: forward-dynamics formulations (``simulate(..., method=NAME)``, ``--method``): each a subclass of
#: pinclear.dynamics.formulations.base.Formulation in its module (its contract there)
FORMULATIONS = Registry("formulation", {
    "lagrange": "pinclear.dynamics.formulations.lagrange:Lagrange",
    "projection": "pinclear.dynamics.formulations.projection:Projection",
    "pinocchio": "pinclear.dynamics.formulations.pinocchio_cd:PinocchioCD",
    "proximal": "pinclear.dynamics.formulations.proximal:Proximal",
    "manifold": "pinclear.dynamics.formulations.manifold:Manifold",
}, record="pinclear.dynamics.formulations.base:Formulation", classes=True)

#: every plug-in kind: its registry, as "module:NAME" (tests/core/test_registry.py checks each is a
#: Registry)
KINDS = {
    "clearance type": "pinclear.core.registry:CLEARANCE_TYPES",
    "force element type": "pinclear.core.registry:FORCE_TYPES",
    "integrator": "pinclear.core.registry:INTEGRATORS",
    "formulation": "pinclear.core.registry:FORMULATIONS",
    "closure reader": "pinclear.io.sidecar:CLOSURE_READERS",
    "importer": "pinclear.io.importers:READERS",
    "paper reproduction": "pinclear.studies.reproduce:PAPERS",
    "study": "pinclear.studies.wear:STUDIES",
    "command": "pinclear.cli.commands:COMMANDS",
}


def kinds() -> dict:
    """{kind: its Registry} (each registry's module imported)."""
    return {k: _resolve(ref) for k, ref in KINDS.items()}
