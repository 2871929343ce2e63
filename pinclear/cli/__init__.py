"""Layer 9, cli: the ``pinclear`` command. One module per command family (main holds the
parser and the run commands); every other layer is importable without it.

Imports any layer below (docs/design.md, "Layers").
"""
from pinclear.cli.commands import main

__all__ = ["main"]
