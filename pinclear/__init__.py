"""pinclear: dynamics of parallel mechanisms with joint clearance, on Pinocchio."""
__version__ = "0.1.0"

from . import errors, kinematics  # noqa: E402
from .errors import (AssemblyError, ContactSetupError, InputError, IntegrationError,  # noqa: E402
                     ModelFileError, PinclearError, RankLossError)
from .mechanism import Mechanism, Workspace  # noqa: E402
from .sidecar import load  # noqa: E402
from .simulate import simulate  # noqa: E402
from .sweeps import sweep  # noqa: E402
from .trajectory import Trajectory  # noqa: E402

__all__ = ["load", "simulate", "sweep", "Trajectory", "Mechanism", "Workspace", "kinematics", "errors",
           "PinclearError", "ModelFileError", "AssemblyError", "RankLossError", "IntegrationError",
           "ContactSetupError", "InputError"]
