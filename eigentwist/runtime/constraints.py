"""Check the joint parameter conditions of a description (:mod:`eigentwist.description.constraints`)."""

from __future__ import annotations

import numpy as np
import sympy as sp

from .errors import InputError

__all__ = ["CompiledConstraint", "compile_constraints", "check_constraints", "interval"]


class CompiledConstraint:
    """A constraint with a NumPy function of its parameters (compiled once per evaluator)."""

    def __init__(self, constraint, effect: str | None = None, units: dict | None = None):
        self.constraint = constraint
        self.effect = effect
        self.units = units or {}
        self.names = constraint.names
        symbols = [sp.Symbol(n, real=True) for n in self.names]
        self._fn = sp.lambdify(symbols, constraint.relation, "numpy")
        rel = constraint.relation
        slack = rel.rhs - rel.lhs if isinstance(rel, (sp.StrictLessThan, sp.LessThan)) else rel.lhs - rel.rhs
        self.strict = isinstance(rel, (sp.StrictLessThan, sp.StrictGreaterThan))
        self._linear = {}  # name -> (d slack/d name, slack at name = 0), where slack is linear in it
        for x in symbols:
            a = sp.diff(slack, x)
            if not a.has(x):
                self._linear[x.name] = (
                    sp.lambdify(symbols, a, "numpy"),
                    sp.lambdify(symbols, slack.subs(x, 0), "numpy"),
                )

    def interval(self, name: str, values: dict) -> tuple[float, float]:
        """The values of ``name`` for which the relation holds with the other parameters at
        ``values`` (scalars): ``(low, high)`` (an end excluded when the relation is strict;
        ``(-inf, inf)`` where ``name`` is not in it or enters it nonlinearly)."""
        if name not in self._linear:
            return -np.inf, np.inf
        args = [float(values[n]) for n in self.names]
        a, b = (float(f(*args)) for f in self._linear[name])
        if a > 0:
            return -b / a, np.inf  # slack = a x + b >= 0
        if a < 0:
            return -np.inf, -b / a
        return -np.inf, np.inf

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
            k = (
                int(
                    np.argmin(
                        np.broadcast_to(ok, np.broadcast(*(np.asarray(values[n]) for n in c.names)).shape).reshape(-1)
                    )
                )
                if np.ndim(ok)
                else 0
            )
            shown = ", ".join(
                f"{n} = {float(np.asarray(values[n]).reshape(-1)[k if np.size(values[n]) > 1 else 0]):g}"
                f" {c.units.get(n, '')}".rstrip()
                for n in c.names
            )
            row = f" (row {k})" if np.ndim(ok) else ""
            raise InputError(f"parameters {shown}{row}: {c.constraint.doc}: expected {c.constraint}")


def interval(compiled, name: str, values: dict, effects) -> tuple[float, float]:
    """The interval of parameter ``name`` (a base name) that every constraint of ``compiled``
    in force for ``effects`` leaves it, the other parameters at ``values``: ``(low, high)``."""
    lo, hi = -np.inf, np.inf
    for c in compiled:
        if name not in c.names or (c.effect is not None and c.effect not in effects):
            continue
        a, b = c.interval(name, values)
        lo, hi = max(lo, a), min(hi, b)
    return lo, hi
