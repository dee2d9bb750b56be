"""Errors raised on bad input: each names the value and what was expected."""

__all__ = ["EigentwistError", "UnreachablePoseError", "SingularPoseError", "UnstablePoseError", "InputError"]


class EigentwistError(ValueError):
    """Base class of eigentwist's input errors (a ValueError)."""


class InputError(EigentwistError):
    """A pose, parameter or option is malformed (shape, NaN, unknown name, bounds)."""


class UnreachablePoseError(EigentwistError):
    """The end-effector position cannot be reached by one of the legs."""


class SingularPoseError(EigentwistError):
    """A leg's actuation lever is (nearly) zero: the Jacobian is singular there."""


class UnstablePoseError(EigentwistError):
    """The stiffness is not positive semi-definite at a pose: a mode has omega^2 < 0."""
