"""Forward-dynamics formulations, chosen by name (one file each, one interface)."""
from pinclear.core.errors import InputError
from pinclear.dynamics.formulations.base import Formulation
from pinclear.dynamics.formulations.lagrange import Lagrange
from pinclear.dynamics.formulations.manifold import Manifold
from pinclear.dynamics.formulations.pinocchio_cd import PinocchioCD
from pinclear.dynamics.formulations.projection import Projection
from pinclear.dynamics.formulations.proximal import Proximal

__all__ = ["Formulation", "Lagrange", "Projection", "PinocchioCD", "Proximal", "Manifold", "METHODS", "get"]

METHODS = {cls.name: cls for cls in (Lagrange, Projection, PinocchioCD, Proximal, Manifold)}


def get(name: str):
    try:
        return METHODS[name]
    except KeyError:
        raise InputError(f"unknown method {name!r}", choices=METHODS) from None
