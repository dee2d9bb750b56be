"""NumPy backend: render kernels into a Python module (render only, no I/O)."""

from __future__ import annotations

import sympy as sp
from sympy.printing.numpy import NumPyPrinter

from .kernel import Kernel
from .render import PRINT_ORDER, environment, header

__all__ = ["render_numpy", "NumpyCodePrinter"]


class NumpyCodePrinter(NumPyPrinter):
    """Prints ``x**2`` as ``(x*x)`` and ``x**-1`` as ``1/x`` (cheaper in NumPy); terms in
    SymPy's stored order (:data:`~eigentwist.codegen.render.PRINT_ORDER`)."""

    def __init__(self):
        super().__init__({"fully_qualified_modules": False, "allow_unknown_functions": False, "order": PRINT_ORDER})

    def _print_Pow(self, expr, rational=False):
        base, exp = expr.args
        if exp == 2:
            b = self.parenthesize(base, 60)
            return f"({b}*{b})"  # parenthesised: it may stand in a denominator
        if exp == -1:
            return f"1/{self.parenthesize(base, 60)}"
        if exp == -2:
            b = self.parenthesize(base, 60)
            return f"1/({b}*{b})"
        if exp == sp.Rational(1, 2):
            return f"sqrt({self._print(base)})"
        if exp == -sp.Rational(1, 2):
            return f"1/sqrt({self._print(base)})"
        return super()._print_Pow(expr, rational=rational)


def _index(idx) -> str:
    if not idx:
        return "[...]"
    return "[..., " + ", ".join(str(i) for i in idx) + "]"


def kernel_lines(kern: Kernel, printer: NumpyCodePrinter) -> list[str]:
    """Statements of ``kern`` as Python lines, with ``del`` after each last use."""
    last_use: dict = {}
    for pos, item in enumerate(kern.body):
        expr = item[2] if item[0] == "let" else item[3]
        for s_ in expr.free_symbols:
            last_use[s_] = pos
    inputs = {sp.Symbol(n, real=True) for n in kern.input_names}
    dying: dict[int, list] = {}
    for s_, pos in last_use.items():
        if s_ not in inputs:
            dying.setdefault(pos, []).append(s_.name)
    lines = []
    for pos, item in enumerate(kern.body):
        if item[0] == "let":
            lines.append(f"{item[1].name} = {printer.doprint(item[2])}")
        else:
            _, out, idx, expr = item
            lines.append(f"out_{out.name}{_index(idx)} = {printer.doprint(expr)}")
            if out.symmetric and idx[-2] != idx[-1]:
                mirror = idx[:-2] + (idx[-1], idx[-2])
                lines.append(f"out_{out.name}{_index(mirror)} = out_{out.name}{_index(idx)}")
        if pos in dying:
            lines.append("del " + ", ".join(sorted(dying[pos])))
    return lines


def _kernel_context(kern: Kernel, printer) -> dict:
    pose = dict(kern.inputs)["pose"]
    joints = dict(kern.inputs)["q"]
    params = kern.params_used
    args, unpack, shape_args = [], [], []
    if pose:
        args += ["x", "y", "z"]
        shape_args += ["shape(x)", "shape(y)", "shape(z)"]
    if joints or kern.joint_order:  # the runtime passes q to every kernel after the IK
        args.append("q")
        shape_args.append("shape(q)[:-2]")
    args.append("p")
    for name in joints:
        leg, j = kern.joint_index(name)
        unpack.append(f"{name} = q[..., {leg}, {j}]")
    for name in params:
        unpack.append(f"{name} = p[{name!r}]")
        shape_args.append(f"shape({name})")
    arg_doc = []
    if pose:
        arg_doc.append("x, y, z: end-effector position in the base frame (m)")
    if joints and kern.joints_per_leg == 3:
        arg_doc.append("q: joint angles (rad), shape (N, legs, 3) as (q1, q2, q3) per leg")
    elif joints:
        arg_doc.append(
            f"q: joint coordinates, shape (N, legs, {kern.joints_per_leg}) (leg lengths in m for prismatic actuators)"
        )
    arg_doc.append("p: parameters")
    return dict(
        name=kern.name,
        doc=kern.doc,
        outputs=kern.outputs,
        signature=", ".join(args),
        unpack=unpack,
        shape_args=", ".join(shape_args) if shape_args else "()",
        lines=kernel_lines(kern, printer),
        arg_doc="; ".join(arg_doc),
        param_doc=", ".join(params) if params else "none",
    )


def render_numpy(robot, kernels: list[Kernel], digest: str, switches) -> str:
    """Render the NumPy module text for ``kernels`` (pure: returns a string)."""
    printer = NumpyCodePrinter()
    env = environment()
    tmpl = env.get_template("numpy/module.py.jinja")
    return tmpl.render(
        header=header(robot.name, digest),
        robot=robot,
        n_legs=len(robot.legs),
        hash=digest,
        switches=switches,
        kernels=[_kernel_context(k, printer) for k in kernels],
    )
