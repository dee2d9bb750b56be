"""The errors a user can cause: each names the bad value and what was expected.

Every one is an :class:`EigentwistError` (a :class:`ValueError`, so ``except ValueError``
keeps working); the command line prints it as one line. Anything else that escapes is a
bug: the command line prints its traceback and asks for a report. This module imports
nothing of eigentwist, so that every layer (description, symbolic, codegen, runtime,
diagnose) can raise them.
"""

__all__ = ["EigentwistError", "InputError", "DescriptionError"]


class EigentwistError(ValueError):
    """Base class of eigentwist's input errors (a ValueError)."""


class InputError(EigentwistError):
    """A pose, parameter or option is malformed (shape, NaN, unknown name, bounds)."""


class DescriptionError(EigentwistError):
    """A robot description (a shipped one or the user's ``describe()``) is malformed or
    inconsistent: a joint, effect, leg or body that the model cannot be derived from."""
