"""SymPy derivation of the closed-form natural-frequency model."""

from .model import DerivedModel, derive, POSE
from .program import Program, derivative

__all__ = ["DerivedModel", "derive", "POSE", "Program", "derivative"]
