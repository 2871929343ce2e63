"""Exception types. Every error says what went wrong, where, and what would be valid."""


class PinclearError(Exception):
    """Base class of all pinclear errors."""


class ModelFileError(PinclearError, ValueError):
    """A URDF or sidecar file is malformed or names something that does not exist."""

    def __init__(self, file, key, message, choices=None):
        self.file, self.key, self.choices = str(file), key, choices
        text = f"{file}: {key}: {message}"
        if choices is not None:
            shown = sorted(map(str, choices))
            if len(shown) > 25:
                shown = shown[:25] + [f"... ({len(choices) - 25} more)"]
            text += f" (valid: {', '.join(shown)})"
        super().__init__(text)


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
    """A clearance joint is specified inconsistently (sizes, materials, initial penetration)."""


class InputError(PinclearError, ValueError):
    """A bad argument to a pinclear function (method name, tolerance, step...)."""
