"""A straight-line program of named SymPy assignments.

The derivation names its intermediate quantities (joint axes, unit twists, reciprocal
wrenches, inverse-Jacobian rows) instead of substituting them into every matrix entry.
That keeps each expression small, which makes common-subexpression elimination fast
and the generated code readable. :meth:`Program.expand` gives the fully substituted
closed form of any expression when it is wanted (notebooks, tests).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..errors import DescriptionError
import sympy as sp

__all__ = ["Program", "derivative", "reachable"]


@dataclass
class Program:
    """Ordered assignments ``symbol = expression`` over declared input symbols."""

    inputs: list[sp.Symbol] = field(default_factory=list)
    assignments: list[tuple[sp.Symbol, sp.Expr]] = field(default_factory=list)
    _names: set[str] = field(default_factory=set)

    def declare(self, symbol: sp.Symbol) -> sp.Symbol:
        """Declare an input symbol (a joint angle, a pose coordinate or a parameter)."""
        if symbol.name in self._names:
            raise DescriptionError(f"symbol {symbol.name!r} declared twice")
        self._names.add(symbol.name)
        self.inputs.append(symbol)
        return symbol

    def let(self, name: str, expr) -> sp.Expr:
        """Assign ``expr`` to a new symbol ``name`` and return the symbol.

        Constants and single symbols are returned as they are (nothing to name).
        """
        expr = sp.sympify(expr)
        if expr.is_Atom or (
            isinstance(expr, sp.Mul) and len(expr.args) == 2 and expr.args[0] == -1 and expr.args[1].is_Symbol
        ):
            return expr
        return self.assign(sp.Symbol(name, real=True), expr)

    def assign(self, symbol: sp.Symbol, expr) -> sp.Symbol:
        """Append ``symbol = expr`` under the symbol's own name (a statement carried over from
        another program); raises :class:`DescriptionError` when the name is taken."""
        if symbol.name in self._names:
            raise DescriptionError(f"intermediate {symbol.name!r} assigned twice")
        self._names.add(symbol.name)
        self.assignments.append((symbol, expr))
        return symbol

    def let_matrix(self, name: str, matrix: sp.Matrix) -> sp.Matrix:
        """Assign every entry of ``matrix`` to ``name_i`` (vectors) or ``name_i_j``."""
        rows, cols = matrix.shape
        if cols == 1:
            return sp.Matrix([self.let(f"{name}_{i}", matrix[i]) for i in range(rows)])
        return sp.Matrix(rows, cols, lambda i, j: self.let(f"{name}_{i}_{j}", matrix[i, j]))

    def definitions(self) -> dict[sp.Symbol, sp.Expr]:
        """Mapping from intermediate symbol to its (unexpanded) expression."""
        return dict(self.assignments)

    def expand(self, expr):
        """Substitute every intermediate recursively: the closed form in inputs only.

        The table of expanded intermediates is built once and extended when the program
        grows, so expanding many entries one by one stays cheap.
        """
        defs = self.__dict__.setdefault("_expanded", {})
        for sym, rhs in self.assignments[len(defs) :]:
            defs[sym] = rhs.xreplace(defs)
        if isinstance(expr, sp.MatrixBase):
            return expr.applyfunc(lambda e: sp.sympify(e).xreplace(defs))
        return sp.sympify(expr).xreplace(defs)

    def evaluate(self, values: dict, exprs, precision: int = 30):
        """Evaluate ``exprs`` by exact substitution, step by step, in ``precision`` digits.

        This is the symbolic reference that generated code is checked against: it uses
        SymPy's own arithmetic (``evalf``), not the code generator.
        """
        env = {sp.Symbol(k, real=True) if isinstance(k, str) else k: sp.Float(v, precision) for k, v in values.items()}
        needed = reachable(self.definitions(), sp.sympify(exprs).free_symbols)  # only what ``exprs`` depend on
        for sym, rhs in self.assignments:
            if sym in needed:
                env[sym] = rhs.xreplace(env).evalf(precision)
        if isinstance(exprs, sp.MatrixBase):
            return exprs.applyfunc(lambda e: sp.sympify(e).xreplace(env).evalf(precision))
        return sp.sympify(exprs).xreplace(env).evalf(precision)


def reachable(definitions: dict, symbols) -> set:
    """The symbols of ``definitions`` (symbol -> expression) that ``symbols`` depend on,
    transitively, including those of ``symbols`` it defines."""
    seen, stack = set(), list(symbols)
    while stack:
        s_ = stack.pop()
        if s_ in seen or s_ not in definitions:
            continue
        seen.add(s_)
        stack.extend(definitions[s_].free_symbols)
    return seen


def derivative(prog: Program, expr, wrt: sp.Symbol):
    """d(expr)/d(wrt) through the program's intermediates (chain rule, closed form).

    Forward mode over the intermediates that ``expr`` depends on; each derivative of an
    intermediate is appended to ``prog`` once (as ``d_<name>__<wrt>``) and reused.
    """
    cache = prog.__dict__.setdefault("_derivative_cache", {})
    deriv = cache.setdefault(wrt, {wrt: sp.Integer(1)})
    exprs = list(expr) if isinstance(expr, sp.MatrixBase) else [sp.sympify(expr)]
    needed = reachable(prog.definitions(), set().union(*(e.free_symbols for e in exprs)))
    for sym_, rhs in list(prog.assignments):
        if sym_ not in needed or sym_ in deriv:
            continue
        total = sp.Integer(0)
        for dep in rhs.free_symbols:
            dd = deriv.get(dep, 0)
            if dd != 0:
                total += sp.diff(rhs, dep) * dd
        deriv[sym_] = prog.let(f"d_{sym_.name}__{wrt.name}", total) if total != 0 else sp.Integer(0)

    def one(e):
        out = sp.Integer(0)
        for dep in sp.sympify(e).free_symbols:
            dd = deriv.get(dep, 0)
            if dd != 0:
                out += sp.diff(e, dep) * dd
        return out

    if isinstance(expr, sp.MatrixBase):
        return expr.applyfunc(one)
    return one(expr)
