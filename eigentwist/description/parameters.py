"""Design parameters: a symbol, a unit, a default value and physical bounds."""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

from ..errors import InputError
import sympy as sp

__all__ = ["Parameter", "sym"]


def sym(name: str) -> sp.Symbol:
    """The one way eigentwist makes a SymPy symbol (real-valued, so substitution matches)."""
    return sp.Symbol(name, real=True)


@dataclass(frozen=True)
class Parameter:
    """A design parameter that stays a symbol through derivation and code generation.

    Attributes
    ----------
    name : str
        Python identifier; also the CSV column and keyword argument that overrides it.
    default : float
        Value of the embedded design (SI units).
    unit : str
        SI unit, e.g. ``"m"``, ``"N m/rad"``.
    doc : str
        What it is, with the paper equation or table it comes from.
    bounds : tuple
        Physically admissible open interval ``(low, high)``; evaluation rejects values
        outside it and fits stay inside it.
    effect : str or None
        Name of the effect this parameter belongs to (None: the base model).
    plausible : tuple or None
        Documented physically plausible range ``(low, high)`` in the same unit (e.g. the
        Young's modulus of aluminium to steel tubes). ``bounds`` is what the mathematics
        admits; ``plausible`` is what a real robot can have. The diagnosis searches
        beyond it and reports a fit outside it as implausible; joint parameter checks use
        it too. None: the same as ``bounds``. Overridable per robot
        (:meth:`with_values`).
    equation : str
        The paper equation or appendix the parameter enters (``"Eq. 34, App. B"``), or "".
    """

    name: str
    default: float
    unit: str
    doc: str
    bounds: tuple[float, float] = (0.0, math.inf)
    effect: str | None = None
    plausible: tuple[float, float] | None = None
    equation: str = ""

    @property
    def symbol(self) -> sp.Symbol:
        return sym(self.name)

    @property
    def plausible_range(self) -> tuple[float, float]:
        """The plausible range, ``bounds`` when none is documented."""
        return tuple(self.plausible) if self.plausible is not None else tuple(self.bounds)

    def is_plausible(self, value: float) -> bool:
        """True when ``value`` lies inside :attr:`plausible_range` (closed interval)."""
        lo, hi = self.plausible_range
        return bool(lo <= float(value) <= hi)

    def with_values(self, **changes) -> "Parameter":
        """A copy with some fields changed (a robot's own default, doc or plausible range)."""
        return replace(self, **changes)

    def check(self, value, where: str = "") -> None:
        """Raise ``ValueError`` naming the parameter when ``value`` is outside ``bounds``."""
        import numpy as np

        arr = np.asarray(value, dtype=float)
        lo, hi = self.bounds
        bad = ~np.isfinite(arr) | (arr <= lo) | (arr >= hi) if lo == 0.0 else ~np.isfinite(arr) | (arr < lo) | (arr > hi)
        if np.any(bad):
            first = arr.reshape(-1)[np.argmax(bad.reshape(-1))]
            rng = (f"a finite value > {lo:g}" if lo == 0.0 and hi == math.inf else
                   f"a finite value in ({lo:g}, {hi:g})" if lo == 0.0 else f"a finite value in [{lo:g}, {hi:g}]")
            raise InputError(f"{where}parameter {self.name!r} = {float(first)!r} {self.unit}: expected {rng}")
