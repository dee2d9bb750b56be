"""Errors raised on bad input: each names the value and what was expected."""

from ..errors import DescriptionError, EigentwistError, InputError

__all__ = [
    "EigentwistError",
    "UnreachablePoseError",
    "SingularPoseError",
    "UnstablePoseError",
    "InputError",
    "DescriptionError",
    "AssemblyError",
]


class AssemblyError(InputError):
    """A leg's reference configuration names no assembly branch at the robot's x_ref: it
    does not close its loop there and Newton's method from it lands elsewhere."""


class UnreachablePoseError(EigentwistError):
    """The end-effector position cannot be reached by one of the legs."""


class SingularPoseError(EigentwistError):
    """A serial singularity (a leg's actuation lever is nearly zero: its unit twists are
    dependent) or a parallel one (the legs' actuation and constraint wrenches leave a
    platform twist free)."""


class UnstablePoseError(EigentwistError):
    """The stiffness is not positive semi-definite at a pose: a mode has omega^2 < 0."""
