"""Runtime: load generated evaluators, evaluate batches, solve for frequencies."""
from .errors import EigentwistError, InputError, SingularPoseError, UnreachablePoseError, UnstablePoseError
from .evaluator import AXES, Evaluator, Modes
from .loader import evaluator_from_description, load

__all__ = ["load", "evaluator_from_description", "Evaluator", "Modes", "AXES", "EigentwistError", "InputError",
           "SingularPoseError", "UnreachablePoseError", "UnstablePoseError"]
