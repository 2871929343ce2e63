"""``python -m pinclear.cli ...``: the same as the ``pinclear`` command."""
import sys

from pinclear.cli.commands import main

if __name__ == "__main__":
    sys.exit(main())
