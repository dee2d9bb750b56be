"""Design studies on the generated model: worst-case frequency optimisation with exact gradients."""

from .optimize import Constraint, OptimizationResult, Vary, moving_mass, optimize_worst_case

__all__ = ["Constraint", "OptimizationResult", "Vary", "moving_mass", "optimize_worst_case"]
