"""Conditions that several parameters must meet together.

One parameter at a time, ``Parameter.bounds`` rejects a negative radius; only together can
one say that a tube's inner radius must stay below its outer radius (otherwise its area
and mass turn negative and the model still prints numbers), or that a body's principal
moments of inertia satisfy the triangle inequality. A :class:`Constraint` is a SymPy
relation in parameter symbols; robots and effects declare theirs, the runtime checks
them with every evaluation (:mod:`eigentwist.runtime.constraints`).
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

__all__ = ["Constraint", "tube", "triangle_inequality"]


@dataclass(frozen=True)
class Constraint:
    """A relation between parameters, e.g. ``r_i < r_o``.

    relation : a SymPy relational (``<``, ``<=``, ``>``, ``>=``) in parameter symbols.
    doc : what it means physically, said in the error when it fails.
    """

    relation: sp.Basic
    doc: str

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the parameters it involves, sorted."""
        return tuple(sorted(s.name for s in self.relation.free_symbols))

    def __str__(self) -> str:
        return str(self.relation)


def tube(inner: sp.Symbol, outer: sp.Symbol, what: str) -> tuple[Constraint, ...]:
    """A hollow tube: inner radius below the outer radius (m)."""
    return (Constraint(sp.StrictLessThan(inner, outer), f"the inner radius of {what} must be below its outer radius"),)


def triangle_inequality(ixx: sp.Symbol, iyy: sp.Symbol, izz: sp.Symbol, what: str) -> tuple[Constraint, ...]:
    """Principal moments of inertia of a rigid body (kg m^2): each at most the sum of the
    other two (a physical mass distribution cannot violate it)."""
    doc = f"the moments of inertia of {what} must satisfy the triangle inequality"
    return tuple(
        Constraint(sp.LessThan(a, b + c), doc) for a, b, c in ((ixx, iyy, izz), (iyy, izz, ixx), (izz, ixx, iyy))
    )
