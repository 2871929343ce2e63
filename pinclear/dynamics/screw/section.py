"""The sidecar's ``screw:`` section, validated once (the format is documented in
:mod:`pinclear.dynamics.screw`). Every ``module:function`` goes through
:func:`pinclear.model.timelaws.resolve_function`, which applies the loader's trust rule."""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Callable

from pinclear.core.errors import ModelFileError
from pinclear.dynamics.screw.virtual import COMPLEMENT, VIRTUAL_RULES, rule_choices
from pinclear.model.timelaws import resolve_function

SECTION_KEYS = ("limbs", "ik", "motions", "virtual")
LIMB_KEYS = ("name", "joints", "closure")
MOTION_KEYS = ("function", "args", "period")


@dataclass(frozen=True)
class Motion:
    """A named platform motion: ``function(t, **args)`` returns (pin.SE3, V, A) with V, A in the
    paper's order, or only the pin.SE3 (then differentiated numerically)."""
    name: str
    function: Callable
    args: dict = field(default_factory=dict)
    period: float | None = None

    def __call__(self, t):
        return self.function(t, **self.args)


@dataclass(frozen=True)
class ScrewSection:
    file: str
    limbs: tuple | None = None               # validated limb mappings, or None: found from the topology
    ik: Callable | None = None               # f(mech, M_platform, q_prev) -> q, or None: numerical IK
    motions: MappingProxyType = field(default_factory=lambda: MappingProxyType({}))
    virtual: MappingProxyType = field(default_factory=lambda: MappingProxyType({}))  # limb -> COMPLEMENT | rule
    virtual_specs: MappingProxyType = field(default_factory=lambda: MappingProxyType({}))  # as spelt in the file


def _mapping(value, file, key):
    if not isinstance(value, dict):
        raise ModelFileError(file, key, f"expected a mapping, got {type(value).__name__}")
    return value


def _known(d, allowed, file, key):
    for k in d:
        if k not in allowed:
            raise ModelFileError(file, f"{key}.{k}", "unknown key", choices=list(allowed))


def _trust(mech):
    # pinclear.load records how a mechanism was loaded; honour the trust it was given
    return (mech.load_args or {}).get("trust")


def read_section(mech, trust=None) -> ScrewSection:
    """The validated ``screw:`` section of ``mech.sidecar`` (an empty one when absent). trust:
    as for pinclear.load (default: what the mechanism was loaded with, else PINCLEAR_TRUST)."""
    file = mech.path or mech.name
    raw = (mech.sidecar or {}).get("screw")
    if raw is None:
        return ScrewSection(file=file)
    _known(_mapping(raw, file, "screw"), SECTION_KEYS, file, "screw")
    trust = _trust(mech) if trust is None else trust

    limbs = None
    if raw.get("limbs") is not None:
        if not isinstance(raw["limbs"], list) or not raw["limbs"]:
            raise ModelFileError(file, "screw.limbs", "expected a non-empty list of limbs")
        limbs = []
        for i, sp in enumerate(raw["limbs"]):
            key = f"screw.limbs[{i}]"
            _known(_mapping(sp, file, key), LIMB_KEYS, file, key)
            if not isinstance(sp.get("joints"), list) or not sp["joints"]:
                raise ModelFileError(file, f"{key}.joints", "expected a non-empty list of joint names")
            limbs.append({"name": str(sp.get("name", f"limb{i + 1}")), "joints": list(sp["joints"]),
                          "closure": sp.get("closure")})
        names = [lb["name"] for lb in limbs]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ModelFileError(file, "screw.limbs", f"limb name {dup[0]!r} used twice")
        limbs = tuple(limbs)

    ik = None
    if raw.get("ik") is not None:
        ik = resolve_function(raw["ik"], file, "screw.ik", trust)

    motions = {}
    for name, sp in _mapping(raw.get("motions") or {}, file, "screw.motions").items():
        key = f"screw.motions.{name}"
        _known(_mapping(sp, file, key), MOTION_KEYS, file, key)
        func = resolve_function(sp.get("function"), file, f"{key}.function", trust)
        args = _mapping(sp.get("args") or {}, file, f"{key}.args")
        period = sp.get("period")
        if period is not None:
            if isinstance(period, bool) or not isinstance(period, (int, float)) \
                    or not math.isfinite(period) or period <= 0:
                raise ModelFileError(file, f"{key}.period", f"expected a positive time in s, got {period!r}")
            period = float(period)
        motions[str(name)] = Motion(str(name), func, dict(args), period)

    virtual, specs = {}, {}
    for name, spec in _mapping(raw.get("virtual") or {}, file, "screw.virtual").items():
        key = f"screw.virtual.{name}"
        if spec == COMPLEMENT:
            rule = COMPLEMENT
        elif isinstance(spec, str) and spec in VIRTUAL_RULES:
            rule = VIRTUAL_RULES[spec]
        elif isinstance(spec, str) and ":" in spec:
            rule = resolve_function(spec, file, key, trust)
            if not callable(rule):
                raise ModelFileError(file, key, f"{spec!r} is not a function")
        else:
            raise ModelFileError(file, key, f"unknown virtual-joint rule {spec!r}", choices=rule_choices())
        virtual[str(name)], specs[str(name)] = rule, str(spec)
    return ScrewSection(file=file, limbs=limbs, ik=ik, motions=MappingProxyType(motions),
                        virtual=MappingProxyType(virtual), virtual_specs=MappingProxyType(specs))
