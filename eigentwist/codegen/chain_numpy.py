"""NumPy source straight from a chain model's program (issue 15, interim backend).

``render_chain(model)`` prints every named intermediate of
:func:`eigentwist.symbolic.chain.derive_chain` as one NumPy statement (no CSE);
:func:`eigentwist.runtime.chain.compile_chain` loads it.
"""
from __future__ import annotations

from sympy.printing.numpy import NumPyPrinter

__all__ = ["render_chain"]


def render_chain(model) -> str:
    """Source text of ``evaluate_program(env) -> {output: list of arrays}``."""
    pr = NumPyPrinter({"fully_qualified_modules": False, "inline": True})
    lines = ["from numpy import sqrt, sin, cos, pi, arcsin, arccos, arctan2", "", "",
             "def evaluate_program(env):"]
    lines += [f"    {s.name} = env[{s.name!r}]" for s in model.program.inputs]
    lines += [f"    {s.name} = {pr.doprint(e)}" for s, e in model.program.assignments]
    lines.append("    out = {}")
    for group in model.outputs.values():
        for name, (_, exprs) in group.items():
            lines.append(f"    out[{name!r}] = [{', '.join(pr.doprint(x) for x in exprs)}]")
    lines.append("    return out")
    return "\n".join(lines) + "\n"
