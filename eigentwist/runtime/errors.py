"""Errors raised on bad input: each names the value and what was expected."""

__all__ = ["EigentwistError", "UnreachablePoseError", "SingularPoseError", "InputError", "BackendUnavailableError"]


class EigentwistError(ValueError):
    """Base class of eigentwist's input errors (a ValueError)."""


class InputError(EigentwistError):
    """A pose, parameter or option is malformed (shape, NaN, unknown name, bounds)."""


class UnreachablePoseError(EigentwistError):
    """The end-effector position cannot be reached by one of the legs."""


class SingularPoseError(EigentwistError):
    """A leg's actuation lever is (nearly) zero: the Jacobian is singular there."""


class BackendUnavailableError(RuntimeError):
    """``backend="c"`` was asked for and cannot be had: no C compiler, or compiling or
    loading failed (the message's first line says which; the cause is chained)."""
