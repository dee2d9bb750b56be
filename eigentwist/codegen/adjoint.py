"""The reverse-mode sensitivity kernel: every parameter's derivative of a weighted M and K.

One kernel, ``adjoint``: a pose, the parameters and the weights ``w_M_i_j``, ``w_K_i_j``
(i ≤ j, :func:`~eigentwist.description.weights.weight_name`) to ``g`` (P,), the derivative of
``Σ w_M_i_j M_ij + w_K_i_j K_ij`` with respect to each of the P requested parameters (per SI
unit), K the stiffness model's (K_R, Eq. 14, or K_F, Eq. 13), chained through the inverse
kinematics. With W_K = φφᵀ and W_M = −ω²φφᵀ of an M-orthonormal mode φ it is dω²/dp.

The sweep runs over the CSE'd code of M and K (the same statements the evaluator's
``matrices`` kernel computes) after the inverse kinematics' program, so its size is a small
multiple of that code's, whatever the number of parameters
(:func:`~eigentwist.symbolic.adjoint.reverse_sweep`).
"""

from __future__ import annotations

import sympy as sp

from ..description.effects import switch_name
from ..errors import DescriptionError, InputError
from ..description.weights import weight_name
from ..symbolic import POSE
from ..symbolic.adjoint import reverse_sweep
from ..symbolic.program import Program
from ..symbolic.sensitivity import seeds_of
from .kernel import Kernel, Output, build_kernel

__all__ = ["KERNEL", "STIFFNESS", "adjoint_kernel", "METHOD"]

KERNEL = "adjoint"
#: the stiffness matrix of each stiffness model
STIFFNESS = {"rigid": "K_R", "flexible": "K_F"}
METHOD = "derivatives by reverse mode over the CSE'd code of M and K (one sweep per weighting)"
DOC = (
    "Derivative of sum_(i<=j) w_M_i_j M_ij + w_K_i_j {k}_ij (M: Eq. 12, {k}: Eq. {eq}, at the EE origin) with "
    "respect to the design parameters {wrt} (per SI unit of each), chained through the inverse kinematics "
    "(reverse mode)."
)


def _program(model, stiffness: str) -> tuple[Program, list]:
    """The inverse kinematics' program, then the CSE'd statements of M and K, and the
    weighted outputs ``[(weight symbol, expression), ...]`` (upper triangles)."""
    from .generate import pose_split, joints_per_leg

    position, rotation = pose_split(model)
    params = list(model.inputs) + [s.name for s in position] + rotation
    outs = [Output(k, *model.outputs["matrices"][k], symmetric=True) for k in ("M", STIFFNESS[stiffness])]
    kern = build_kernel("m", "", model.program, outs, [], model.joints, params, joints_per_leg(model))
    prog = Program()
    for s_ in model.ik.inputs:
        prog.declare(s_)
    joints = set(model.joints)
    declared = {s_.name for s_ in prog.inputs} | {j.name for j in joints}
    # every input of the model (a parameter that M and K do not read has derivative 0)
    for name in [s_.name for s_ in model.program.inputs] + kern.input_names:
        if name not in declared:
            prog.declare(sp.Symbol(name, real=True))
            declared.add(name)
    # the inverse kinematics' intermediates get their own names (a 6-DoF leg's geometry is
    # computed in both programs); the joint coordinates keep theirs (the kernel reads them)
    rename = {s_: sp.Symbol(f"ik_{s_.name}", real=True) for s_, _ in model.ik.assignments if s_ not in joints}
    for s_, rhs in model.ik.assignments:
        prog.assign(rename.get(s_, s_), rhs.xreplace(rename))
    missing = joints - {s_ for s_, _ in prog.assignments}
    if missing:
        raise DescriptionError(f"the IK program does not assign joint angles {sorted(s.name for s in missing)}")
    for item in kern.body:
        if item[0] == "let":
            prog.assign(item[1], item[2])
    weighted = []
    for item in kern.body:
        if item[0] == "out":
            _, out, idx, expr = item
            w = prog.declare(sp.Symbol(weight_name("M" if out.name == "M" else "K", *idx), real=True))
            weighted.append((w, expr))
    return prog, weighted


def adjoint_kernel(model, wrt, stiffness: str, progress=None) -> Kernel:
    """The reverse-mode kernel of a derived model for parameters ``wrt`` and the
    ``stiffness`` model (``"rigid"``: K_R, ``"flexible"``: K_F); ``P@N`` is leg N's own
    value of a leg-level parameter P."""
    if stiffness not in STIFFNESS:
        raise InputError(f"stiffness={stiffness!r}: expected one of {', '.join(STIFFNESS)}")
    if progress:
        progress("CSE of M and K")
    prog, weighted = _program(model, stiffness)
    declared = {s_.name: s_ for s_ in prog.inputs}
    seeds = {w: seeds_of(w, declared) for w in wrt}
    unknown = [w for w, s in seeds.items() if s is None]
    if unknown:
        raise InputError(
            f"cannot differentiate with respect to {unknown}: not inputs of the model "
            f"(expected names from {', '.join(model.parameters)})"
        )
    inputs = list(dict.fromkeys(s_ for w in wrt for s_ in seeds[w]))
    swept, grads = reverse_sweep(prog, weighted, inputs, progress)
    of = dict(zip(inputs, grads))
    g = [sp.Add(*[of[s_] for s_ in seeds[w]]) for w in wrt]
    robot = model.robot
    params = list(robot.parameter_names) + [switch_name(e) for e in robot.effects]
    params += [s_.name for s_ in swept.inputs if s_.name not in params and s_ not in POSE]
    k = STIFFNESS[stiffness]
    doc = DOC.format(k=k, eq=14 if k == "K_R" else 13, wrt=", ".join(wrt))
    if progress:
        progress(f"{len(swept.assignments)} statements")
    return build_kernel(KERNEL, doc, swept, [Output("g", (len(wrt),), g)], list(POSE), [], params, cse=False)
