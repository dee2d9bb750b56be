"""Check the joint parameter conditions of a description (:mod:`eigentwist.description.constraints`)."""
from __future__ import annotations

import numpy as np
import sympy as sp

from .errors import InputError

__all__ = ["CompiledConstraint", "compile_constraints", "check_constraints"]


class CompiledConstraint:
    """A constraint with a NumPy function of its parameters (compiled once per evaluator)."""

    def __init__(self, constraint, effect: str | None = None, units: dict | None = None):
        self.constraint = constraint
        self.effect = effect
        self.units = units or {}
        self.names = constraint.names
        self._fn = sp.lambdify([sp.Symbol(n, real=True) for n in self.names], constraint.relation, "numpy")

    def holds(self, values: dict) -> np.ndarray:
        """Boolean array: where the relation holds for ``values`` (arrays broadcast)."""
        return np.asarray(self._fn(*(np.asarray(values[n], dtype=float) for n in self.names)), dtype=bool)


def compile_constraints(robot) -> list[CompiledConstraint]:
    """The robot's own constraints and those of its effects, compiled."""
    units = {p.name: p.unit for p in robot.parameters}
    out = [CompiledConstraint(c, None, units) for c in getattr(robot, "constraints", ())]
    for name in robot.effects:
        out += [CompiledConstraint(c, name, units) for c in getattr(robot.effect(name), "constraints", ())]
    return out


def check_constraints(compiled, values: dict, effects) -> None:
    """Raise :class:`InputError` naming the values when a constraint fails.

    Constraints of an effect apply only when the effect is in the model (``effects``).
    """
    for c in compiled:
        if c.effect is not None and c.effect not in effects:
            continue
        ok = c.holds(values)
        if not np.all(ok):
            k = int(np.argmin(np.broadcast_to(ok, np.broadcast(*(np.asarray(values[n]) for n in c.names)).shape)
                              .reshape(-1))) if np.ndim(ok) else 0
            shown = ", ".join(f"{n} = {float(np.asarray(values[n]).reshape(-1)[k if np.size(values[n]) > 1 else 0]):g}"
                              f" {c.units.get(n, '')}".rstrip() for n in c.names)
            row = f" (row {k})" if np.ndim(ok) else ""
            raise InputError(f"parameters {shown}{row}: {c.constraint.doc}: expected {c.constraint}")
