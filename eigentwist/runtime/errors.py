"""Errors raised on bad input: each names the value and what was expected."""

__all__ = ["EigentwistError", "UnreachablePoseError", "SingularPoseError", "UnstablePoseError", "InputError",
           "AssemblyError"]


class EigentwistError(ValueError):
    """Base class of eigentwist's input errors (a ValueError)."""


class InputError(EigentwistError):
    """A pose, parameter or option is malformed (shape, NaN, unknown name, bounds)."""


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
