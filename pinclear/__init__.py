"""pinclear: dynamics of parallel mechanisms with joint clearance, on Pinocchio."""


def _launched_as_cli() -> bool:
    """``pinclear ...`` or ``python -m pinclear.cli ...`` (not a library import)."""
    import os
    import sys

    argv = list(getattr(sys, "orig_argv", []))
    return len(argv) > 1 and (os.path.basename(argv[1]) == "pinclear" or argv[1:3] in (["-m", "pinclear.cli"], ["-m", "pinclear.cli.commands"]))


def _quiet_interrupt_while_the_cli_imports():
    """Launched as the command line (``pinclear ...`` or ``python -m pinclear.cli``), a SIGINT
    while the imports below run (about a second) ends the command with one line and exit 130
    instead of a KeyboardInterrupt traceback; pinclear.cli.commands takes over from there. A library
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

from pinclear.core import errors  # noqa: E402

try:
    # the kernel cache folder is checked here, before any kernel loads (pinclear.core.jit)
    from pinclear.core import jit as _jit  # noqa: E402
except errors.PinclearError as _exc:      # the command line: one line, exit 2 (a library import raises)
    if not _launched_as_cli():
        raise
    import sys as _sys

    print(f"pinclear: error: {_exc}", file=_sys.stderr)
    raise SystemExit(2) from None

from pinclear.model import kinematics  # noqa: E402
from pinclear.core.errors import (AssemblyError, ContactSetupError, InputError, IntegrationError,
                                  ModelFileError, PinclearError, RankLossError)
from pinclear.model.mechanism import Mechanism, Workspace  # noqa: E402
from pinclear.io.sidecar import load  # noqa: E402
from pinclear.dynamics.simulate import simulate  # noqa: E402
from pinclear.analysis.sweeps import sweep  # noqa: E402
from pinclear.dynamics.trajectory import Trajectory  # noqa: E402

from pinclear.core import aliases as _aliases  # noqa: E402
from pinclear.core.version import __version__  # noqa: E402

# The old module names keep working (pinclear.core.aliases). pinclear.simulate is both the face's
# function and an old module name: registered here, ``import pinclear.simulate`` finds the module
# without the import system setting it as this package's attribute over the function.
_aliases.install()
import sys as _sys  # noqa: E402

_sys.modules.setdefault("pinclear.simulate", _sys.modules["pinclear.dynamics.simulate"])


def __getattr__(name):
    """``pinclear.sidecar`` and the other old submodule names, imported when first asked for."""
    full = f"{__name__}.{name}"
    if full in _aliases.MOVED or full in _aliases.SPLIT:
        import importlib

        return importlib.import_module(full)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["load", "simulate", "sweep", "Trajectory", "Mechanism", "Workspace", "kinematics", "errors",
           "PinclearError", "ModelFileError", "AssemblyError", "RankLossError", "IntegrationError",
           "ContactSetupError", "InputError", "__version__"]
