"""Runtime: load generated evaluators, evaluate batches, solve for frequencies."""

from .errors import (
    AssemblyError,
    EigentwistError,
    InputError,
    SingularPoseError,
    UnreachablePoseError,
    UnstablePoseError,
)
from .c_route import CPassRoute
from .checks import PoseChecks
from .completion import PoseCompletion
from .evaluator import AXES, Evaluator, Modes
from .inputs import InputResolver
from .kernels import CompiledKernels, Kernels
from .loader import evaluator_from_description, load
from .mode_solver import ModeSolver
from .routes import ROUTES, Route
from .sensitivity_route import SensitivityRoute
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
    "InputResolver",
    "PoseCompletion",
    "PoseChecks",
    "CPassRoute",
    "ModeSolver",
    "SensitivityRoute",
    "Kernels",
    "CompiledKernels",
    "ROUTES",
    "Route",
]
