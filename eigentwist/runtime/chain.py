"""Load a chain model's NumPy program and evaluate it at 6-DoF poses (issue 15, interim)."""
from __future__ import annotations

import numpy as np

from ..codegen.chain_numpy import render_chain
from .poses import rotation_matrix

__all__ = ["compile_chain", "ChainEvaluator"]


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


class ChainEvaluator:
    """Frequencies of a :class:`~eigentwist.description.chain.ChainRobot` at 6-DoF poses
    (interim: the NumPy program of :func:`compile_chain`, no CSE, no gravity preload).

    Poses are (N, 6) or (6,): position (m) and rotation vector (rad). ``model`` is an
    iterable of effect names (each on every leg); parameters are keyword arguments
    (``NAME`` for every leg). The rigid model of a 6-DoF robot is the full 6x6 M and
    actuator stiffness K_R.
    """

    def __init__(self, robot):
        from ..symbolic.chain import derive_chain

        self.robot = robot
        self.model = derive_chain(robot)
        #: ``evaluate(poses, values)``: the program on every input by name (:meth:`values`)
        self.evaluate = compile_chain(self.model)

    def values(self, model=(), **params) -> dict:
        """Every input of the program: parameters, effect switches, each leg's copies."""
        from ..description.effects import leg_input_name, leg_switch_name, switch_name

        unknown = set(params) - set(self.robot.parameter_names)
        if unknown:
            raise ValueError(f"unknown parameter(s) {', '.join(sorted(unknown))} for {self.robot.name}")
        v = {**self.robot.defaults, **params}
        for name in self.robot.effects:
            effect = self.robot.effect(name)
            if not effect.leg_level:
                v[switch_name(name)] = float(name in model)
                continue
            for k in range(1, len(self.robot.legs) + 1):
                v[leg_switch_name(name, k)] = float(name in model)
                v.update({leg_input_name(q.name, k): v[q.name] for q in effect.params})
        return v

    def matrices(self, poses, model=(), **params) -> dict:
        """``M``, ``K_R`` (N, 6, 6), actuation rows ``J_a`` (N, legs, 6), actuated
        coordinates ``q_a`` (N, legs; m for prismatic actuators) and ``lever``."""
        return self.evaluate(poses, self.values(model, **params))

    def frequencies(self, poses, model=(), **params) -> np.ndarray:
        """Natural frequencies (N, 6) in Hz, ascending."""
        from .eigen import frequencies_hz, generalized_eigh

        out = self.matrices(poses, model, **params)
        return frequencies_hz(generalized_eigh(out["K_R"], out["M"])[0])
