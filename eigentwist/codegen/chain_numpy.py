"""A NumPy function straight from a chain model's program (issue 15, interim backend).

``compile_chain(model)`` prints every named intermediate of
:func:`eigentwist.symbolic.chain.derive_chain` as one NumPy statement (no CSE) and
returns ``evaluate(poses, values)``: poses (N, 6) = position (m) and rotation vector
(rad), ``values`` every input by name (parameters, switches, leg copies; scalars or
(N,) arrays). ``render_chain`` returns the source text (render and load are separate).
"""
from __future__ import annotations

import numpy as np
from sympy.printing.numpy import NumPyPrinter

from ..runtime.poses import rotation_matrix

__all__ = ["render_chain", "compile_chain"]


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


def compile_chain(model):
    """``evaluate(poses, values) -> {output: (N, *shape) array}`` for a chain model."""
    namespace: dict = {}
    exec(compile(render_chain(model), f"<{model.robot.name} chain program>", "exec"), namespace)  # noqa: S102
    program = namespace["evaluate_program"]
    shapes = {k: shape for group in model.outputs.values() for k, (shape, _) in group.items()}

    def evaluate(poses, values: dict) -> dict:
        poses = np.atleast_2d(np.asarray(poses, dtype=float))
        n = len(poses)
        env = {k: np.asarray(v, dtype=float) for k, v in values.items()}
        env.update(x=poses[:, 0], y=poses[:, 1], z=poses[:, 2])
        R = rotation_matrix(poses[:, 3:6])
        env.update({f"R_{i}{j}": R[:, i, j] for i in range(3) for j in range(3)})
        with np.errstate(divide="ignore", invalid="ignore"):
            out = program(env)
        return {k: np.stack([np.broadcast_to(np.asarray(e, dtype=float), (n,)) for e in v], axis=-1)
                .reshape((n,) + tuple(shapes[k])) for k, v in out.items()}
    return evaluate
