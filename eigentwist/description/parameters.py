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
        Hard physical bounds ``(low, high)``: what the physics admits (a stiffness or a
        mass > 0, an efficiency in (0, 1]). ``low`` is excluded when it is 0 and included
        otherwise; a finite ``high`` is included. Evaluation rejects a value outside them,
        and every fit, difference step and optimisation stays inside them (the diagnosis
        fits ``ln p`` for a positive parameter and never steps across a bound). Conditions
        between parameters (``r_i < r_o``, the inertia triangle inequality) are
        :mod:`.constraints`.
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
    closed : bool
        True: the lower bound itself is admitted (``c_a >= 0``: no damping is a value).
    """

    name: str
    default: float
    unit: str
    doc: str
    bounds: tuple[float, float] = (0.0, math.inf)
    effect: str | None = None
    plausible: tuple[float, float] | None = None
    equation: str = ""
    closed: bool = False

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

    def admits(self, value) -> bool:
        """True when every element of ``value`` lies inside the hard :attr:`bounds`."""
        import numpy as np

        return not bool(np.any(self._outside(np.asarray(value, dtype=float))))

    def _outside(self, arr):
        import numpy as np

        lo, hi = self.bounds
        below = arr <= lo if lo == 0.0 and not self.closed else arr < lo
        return ~np.isfinite(arr) | below | (arr > hi)

    def with_values(self, **changes) -> "Parameter":
        """A copy with some fields changed (a robot's own default, doc or plausible range)."""
        return replace(self, **changes)

    def check(self, value, where: str = "") -> None:
        """Raise ``ValueError`` naming the parameter when ``value`` is outside ``bounds``."""
        import numpy as np

        arr = np.asarray(value, dtype=float)
        lo, hi = self.bounds
        bad = self._outside(arr)
        if np.any(bad):
            first = arr.reshape(-1)[np.argmax(bad.reshape(-1))]
            rng = (
                f"a finite value >= {lo:g}"
                if self.closed and hi == math.inf
                else f"a finite value > {lo:g}"
                if lo == 0.0 and hi == math.inf
                else f"a finite value in ({lo:g}, {hi:g}]"
                if lo == 0.0 and not self.closed
                else f"a finite value in [{lo:g}, {hi:g}]"
            )
            raise InputError(f"{where}parameter {self.name!r} = {float(first)!r} {self.unit}: expected {rng}")
