"""Exception types. Every error says what went wrong, where, and what would be valid."""


def format_message(message, file=None, key=None, choices=None) -> str:
    """The one layout of pinclear's error text: ``FILE: KEY: message (valid: a, b, ...)``."""
    text = message
    if key is not None:
        text = f"{key}: {text}"
    if file is not None:
        text = f"{file}: {text}"
    if choices is not None:
        shown = sorted(map(str, choices))
        if len(shown) > 25:
            shown = shown[:25] + [f"... ({len(shown) - 25} more)"]
        text += f" (valid: {', '.join(shown) or 'none'})"
    # one line, whatever a file's keys or values contain
    return text.replace("\r", "\\r").replace("\n", "\\n")


class PinclearError(Exception):
    """Base class of all pinclear errors."""


class ModelFileError(PinclearError, ValueError):
    """A URDF or sidecar file is malformed or names something that does not exist."""

    def __init__(self, file, key, message, choices=None):
        self.file, self.key, self.choices = str(file), key, choices
        super().__init__(format_message(message, file, key, choices))


class AssemblyError(PinclearError):
    """The loop closures cannot be satisfied from the given guess."""

    def __init__(self, message, residual=None, q=None):
        self.residual, self.q = residual, q
        super().__init__(message)


class RankLossError(PinclearError):
    """The constraint Jacobian lost rank where the formulation cannot cope."""

    def __init__(self, message, t=None, rank=None, rows=None, cond=None):
        self.t, self.rank, self.rows, self.cond = t, rank, rows, cond
        super().__init__(message)


class IntegrationError(PinclearError):
    """An integration stopped early; the partial trajectory is attached."""

    def __init__(self, message, trajectory=None):
        self.trajectory = trajectory
        super().__init__(message)


class ContactSetupError(PinclearError, ValueError):
    """A clearance joint is specified inconsistently (sizes, materials, initial penetration).

    ``ContactSetupError(message)`` or ``ContactSetupError(message, file=..., key=..., choices=...)``."""

    def __init__(self, message, file=None, key=None, choices=None):
        self.file, self.key, self.choices = file, key, choices
        super().__init__(format_message(message, file, key, choices))


class InputError(PinclearError, ValueError):
    """A bad argument to a pinclear function (method name, tolerance, step...)."""

    def __init__(self, message, key=None, choices=None):
        self.key, self.choices = key, choices
        super().__init__(format_message(message, None, key, choices))
