"""Runtime: load generated evaluators, evaluate batches, solve for frequencies."""

from .errors import (
    AssemblyError,
    EigentwistError,
    InputError,
    SingularPoseError,
    UnreachablePoseError,
    UnstablePoseError,
)
from .evaluator import AXES, Evaluator, Modes
from .loader import evaluator_from_description, load
from .validity import CONDITIONING_TOL, POSE_STATUS

__all__ = [
    "load",
    "evaluator_from_description",
    "Evaluator",
    "Modes",
    "AXES",
    "EigentwistError",
    "InputError",
    "SingularPoseError",
    "UnreachablePoseError",
    "UnstablePoseError",
    "AssemblyError",
    "CONDITIONING_TOL",
    "POSE_STATUS",
]
