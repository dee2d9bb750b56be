"""Load a chain model's NumPy program and evaluate it at 6-DoF poses (issue 15, interim)."""
from __future__ import annotations

import numpy as np

from ..codegen.chain_numpy import render_chain
from .poses import rotation_matrix

__all__ = ["compile_chain"]


def compile_chain(model):
    """``evaluate(poses, values) -> {output: (N, *shape) array}`` for a chain model.

    poses : (N, 6) or (6,): position (m) and rotation vector (rad) of the platform.
    values : every input by name (parameters, switches, leg copies), scalars or (N,).
    """
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
