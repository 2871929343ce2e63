"""Forward-dynamics formulations, chosen by name (one file each, one interface), registered in
pinclear.core.registry.FORMULATIONS (one module and one line each)."""
from pinclear.core.errors import InputError
from pinclear.core.registry import FORMULATIONS
from pinclear.dynamics.formulations.base import Formulation
from pinclear.dynamics.formulations.lagrange import Lagrange
from pinclear.dynamics.formulations.manifold import Manifold
from pinclear.dynamics.formulations.pinocchio_cd import PinocchioCD
from pinclear.dynamics.formulations.projection import Projection
from pinclear.dynamics.formulations.proximal import Proximal

__all__ = ["Formulation", "Lagrange", "Projection", "PinocchioCD", "Proximal", "Manifold", "METHODS", "get"]

#: the registry itself (added formulations included)
METHODS = FORMULATIONS


def get(name: str):
    """The formulation class registered as ``name``."""
    try:
        return METHODS[name]
    except (KeyError, TypeError):
        raise InputError(f"unknown method {name!r}", choices=METHODS) from None
