"""Forward-dynamics formulations, chosen by name (one file each, one interface)."""
from ..errors import InputError
from .base import Formulation
from .lagrange import Lagrange
from .manifold import Manifold
from .pinocchio_cd import PinocchioCD
from .projection import Projection
from .proximal import Proximal

__all__ = ["Formulation", "Lagrange", "Projection", "PinocchioCD", "Proximal", "Manifold", "METHODS", "get"]

METHODS = {cls.name: cls for cls in (Lagrange, Projection, PinocchioCD, Proximal, Manifold)}


def get(name: str):
    try:
        return METHODS[name]
    except KeyError:
        raise InputError(f"unknown method {name!r}", choices=METHODS) from None
