"""Runtime: load generated evaluators, evaluate batches, solve for frequencies."""
from .errors import EigentwistError, InputError, SingularPoseError, UnreachablePoseError, UnstablePoseError
from .evaluator import AXES, Evaluator, Modes
from .loader import load

__all__ = ["load", "Evaluator", "Modes", "AXES", "EigentwistError", "InputError",
           "SingularPoseError", "UnreachablePoseError", "UnstablePoseError"]
