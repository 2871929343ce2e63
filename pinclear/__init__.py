"""pinclear: dynamics of parallel mechanisms with joint clearance, on Pinocchio."""
__version__ = "0.1.0"


def _quiet_interrupt_while_the_cli_imports():
    """Launched as the command line (``pinclear ...`` or ``python -m pinclear.cli``), a SIGINT
    while the imports below run (about a second) ends the command with one line and exit 130
    instead of a KeyboardInterrupt traceback; pinclear.cli.main takes over from there. A library
    import changes no signal handler."""
    import os
    import signal
    import sys

    argv = list(getattr(sys, "orig_argv", []))
    cli = len(argv) > 1 and (os.path.basename(argv[1]) == "pinclear" or argv[1:3] == ["-m", "pinclear.cli"])
    if not cli or signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        return

    def interrupted(signum, frame):
        print("pinclear: interrupted", file=sys.stderr)
        raise SystemExit(130)

    signal.signal(signal.SIGINT, interrupted)


_quiet_interrupt_while_the_cli_imports()

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
