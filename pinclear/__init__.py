"""pinclear: dynamics of parallel mechanisms with joint clearance, on Pinocchio."""
__version__ = "0.1.0"


def _launched_as_cli() -> bool:
    """``pinclear ...`` or ``python -m pinclear.cli ...`` (not a library import)."""
    import os
    import sys

    argv = list(getattr(sys, "orig_argv", []))
    return len(argv) > 1 and (os.path.basename(argv[1]) == "pinclear" or argv[1:3] == ["-m", "pinclear.cli"])


def _quiet_interrupt_while_the_cli_imports():
    """Launched as the command line (``pinclear ...`` or ``python -m pinclear.cli``), a SIGINT
    while the imports below run (about a second) ends the command with one line and exit 130
    instead of a KeyboardInterrupt traceback; pinclear.cli.main takes over from there. A library
    import changes no signal handler."""
    import signal
    import sys

    if not _launched_as_cli() or signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        return

    def interrupted(signum, frame):
        print("pinclear: interrupted", file=sys.stderr)
        raise SystemExit(130)

    signal.signal(signal.SIGINT, interrupted)


_quiet_interrupt_while_the_cli_imports()

from . import errors  # noqa: E402

try:
    # the kernel cache folder is checked here, before any kernel loads (pinclear._jit)
    from . import _jit as _jit  # noqa: E402
except errors.PinclearError as _exc:      # the command line: one line, exit 2 (a library import raises)
    if not _launched_as_cli():
        raise
    import sys as _sys

    print(f"pinclear: error: {_exc}", file=_sys.stderr)
    raise SystemExit(2) from None

from . import kinematics  # noqa: E402
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
