"""Argument types and help formatting shared by every ``pinclear`` subcommand's parser.

Every numeric option goes through :func:`number` or :func:`count`: ``float("nan")`` and
``float("inf")`` parse as numbers, and a budget or a tolerance of nan compares false with
everything, so ``--max-cpu nan`` was accepted and silently ignored. The types refuse non-finite
values and values outside the option's range; argparse names the option in the one-line error
(``argument --max-cpu: ...``).
"""
from __future__ import annotations

import argparse
import math

_BOUNDS = {"positive": lambda x: x > 0, "nonnegative": lambda x: x >= 0, "any": lambda x: True}


def number(kind: str = "positive", unit: str = ""):
    """An argparse ``type=``: a finite float, > 0 (``positive``), >= 0 (``nonnegative``) or any
    finite value (``any``); ``unit`` is only shown in the error."""
    ok = _BOUNDS[kind]

    def parse(text):
        what = {"positive": "a positive finite number", "nonnegative": "a finite number >= 0",
                "any": "a finite number"}[kind] + (f" [{unit}]" if unit else "")
        try:
            x = float(text)
        except (TypeError, ValueError):
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}") from None
        if not math.isfinite(x) or not ok(x):
            raise argparse.ArgumentTypeError(f"expected {what}, got {text!r}")
        return x
    parse.__name__ = f"{kind} number"
    return parse


def count(minimum: int = 1):
    """An argparse ``type=``: a whole number >= ``minimum`` ("2.5", "nan", "inf" refused)."""
    def parse(text):
        try:
            n = int(text)
        except (TypeError, ValueError):
            raise argparse.ArgumentTypeError(f"expected a whole number >= {minimum}, got {text!r}") from None
        if n < minimum:
            raise argparse.ArgumentTypeError(f"expected a whole number >= {minimum}, got {text!r}")
        return n
    parse.__name__ = "whole number"
    return parse


class HelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """Shows each option's default after its help, except where there is no value to show (None,
    a flag's False, an empty list) or the help already says it: those options say in words what
    happens when they are not given."""

    def _get_help_string(self, action):
        text = action.help or ""
        d = action.default
        if "default" in text or d is None or d is False or d == [] or d is argparse.SUPPRESS:
            return text
        return super()._get_help_string(action)


class OneLineParser(argparse.ArgumentParser):
    """The parser of a subcommand that parses its own arguments (view, plot, analyse,
    inverse-dynamics, reproduce): defaults shown in --help, no abbreviated options, and a bad
    argument is one line ``pinclear: error: ...`` and exit 2 instead of argparse's usage block."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)   # "--h" must not silently mean "--help"
        kwargs.setdefault("formatter_class", HelpFormatter)
        super().__init__(*args, **kwargs)

    def error(self, message):
        import sys

        print(f"pinclear: error: {self.prog}: {' '.join(message.split())} (see {self.prog} --help)",
              file=sys.stderr)
        sys.exit(2)


#: help of --mech (alias --file): plot, view and analyse poincare name a run's mechanism file with it
MECH_HELP = ("the mechanism sidecar the run was made with: needed for a run of your own mechanism; a bundled "
             "mechanism's run reopens by the name it records (a path recorded in a run is never opened)")


def add_mech_option(ap, help=MECH_HELP):
    """``--mech FILE.yaml``, ``--file`` kept as an alias: the one option name for the mechanism
    file in plot, view, analyse poincare and analyse bifurcation."""
    return ap.add_argument("--mech", "--file", dest="mech", default=None, metavar="FILE.yaml", help=help)


def run_choices():
    """(methods, integrators) as registered (pinclear.dynamics.formulations.METHODS,
    pinclear.dynamics.stepping.INTEGRATORS): a new formulation appears in every --method at once."""
    from pinclear.dynamics.formulations import METHODS
    from pinclear.dynamics.stepping import INTEGRATORS

    return list(METHODS), list(INTEGRATORS)
