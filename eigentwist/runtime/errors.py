"""Errors raised on bad input: each names the value and what was expected."""

from ..errors import DescriptionError, EigentwistError, InputError

__all__ = ["EigentwistError", "UnreachablePoseError", "SingularPoseError", "UnstablePoseError", "InputError",
           "DescriptionError"]


class UnreachablePoseError(EigentwistError):
    """The end-effector position cannot be reached by one of the legs."""


class SingularPoseError(EigentwistError):
    """A leg's actuation lever is (nearly) zero: the Jacobian is singular there."""


class UnstablePoseError(EigentwistError):
    """The stiffness is not positive semi-definite at a pose: a mode has omega^2 < 0."""
