"""Design sensitivities of M, K_R and K_F by forward mode on the straight-line program.

The derivative of every output with respect to a design parameter p is derived through
the named intermediates, one tangent per intermediate (``d_<name>__<p>``), so the code
stays linear in the size of the program: for an intermediate ``v = f(a, b, ...)``,

    dv/dp = sum over its arguments a of (df/da) . da/dp,

with the local partials ``df/da`` named once (``D_<v>__<a>``) and shared by every
parameter. The joint angles depend on the design through the inverse kinematics, so the
IK program is prepended and q is an intermediate like any other (dq/dp is chained).

Local partials come from reverse accumulation over each (small) right-hand side's
expression tree: :func:`gradient`. SymPy's ``diff`` is not used: it costs ~10 ms per
call on these expressions, which for ~7000 (intermediate, argument) pairs is minutes.
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass

import sympy as sp

from ..errors import DescriptionError, InputError
from .program import Program

__all__ = ["gradient", "SensitivityModel", "sensitivity_program", "combined_program", "OUTPUTS"]

#: The matrices whose design derivatives are generated (names of ``DerivedModel.outputs["matrices"]``).
OUTPUTS = ("M", "K_R", "K_F")


def postorder(expr) -> list:
    """Unique nodes of ``expr``'s tree, children before parents (iterative DFS)."""
    order, seen, stack = [], set(), [(expr, False)]
    while stack:
        node, done = stack.pop()
        if done:
            order.append(node)
            continue
        if node in seen:
            continue
        seen.add(node)
        stack.append((node, True))
        for a in node.args:
            if a not in seen:
                stack.append((a, False))
    return order


def local_partial(node, i: int):
    """d node / d node.args[i] as an expression in the node's arguments."""
    args = node.args
    if isinstance(node, sp.Add):
        return sp.Integer(1)
    if isinstance(node, sp.Mul):
        return sp.Mul(*(a for j, a in enumerate(args) if j != i))
    if isinstance(node, sp.Pow):
        base, ex = args
        if i == 0:
            return ex * base ** (ex - 1)
        return sp.log(base) * node
    if isinstance(node, sp.Function):
        return node.fdiff(i + 1)
    raise NotImplementedError(f"no derivative rule for {type(node).__name__} in {node}")


def gradient(expr) -> dict:
    """``{symbol: d expr / d symbol}`` for every free symbol, by reverse accumulation.

    Each node's adjoint is the sum of its parents' contributions, so shared subtrees are
    visited once; the result is an expression in the same symbols as ``expr``.
    """
    expr = sp.sympify(expr)
    if expr.is_Symbol:
        return {expr: sp.Integer(1)}
    order = postorder(expr)
    adj: dict = defaultdict(list)
    adj[expr].append(sp.Integer(1))
    grad = {}
    for node in reversed(order):
        if node not in adj:
            continue
        a = sp.Add(*adj.pop(node))
        if node.is_Symbol:
            grad[node] = a
            continue
        if node.is_Number or a == 0 or not node.free_symbols:
            continue
        for i, child in enumerate(node.args):
            if child.is_Number or not child.free_symbols:
                continue
            adj[child].append(a * local_partial(node, i))
    return grad


def combined_program(model) -> Program:
    """One program from pose and design to M, K_R, K_F: the IK program, then the model's.

    The joint-angle symbols are intermediates here (assigned by the IK program); every
    other input of the model's program (parameters, effect switches) is declared.
    """
    prog = Program()
    rename: dict = {}
    joints = set(model.joints)
    for s_ in model.ik.inputs:
        prog.declare(s_)
    declared = {s_.name for s_ in model.ik.inputs}
    for s_ in model.program.inputs:
        if s_ not in joints and s_.name not in declared:
            prog.declare(s_)
            declared.add(s_.name)
    ik_names = {s_.name for s_, _ in model.ik.assignments}
    for s_, rhs in model.ik.assignments:
        prog.let(s_.name, rhs)
    for s_, rhs in model.program.assignments:
        # a name both programs assign (a 6-DoF leg's geometry, computed from the pose in
        # the IK and again in the model's program) gets a program-side copy
        name = f"{s_.name}_m" if s_.name in ik_names else s_.name
        new = prog.let(name, rhs.xreplace(rename) if rename else rhs)
        if name != s_.name:
            rename[s_] = new
    missing = joints - {s_ for s_, _ in prog.assignments}
    if missing:
        raise DescriptionError(f"the IK program does not assign joint angles {sorted(s.name for s in missing)}")
    prog.renamed = rename
    return prog


@dataclass
class SensitivityModel:
    """The program and the outputs of the sensitivity kernel.

    ``outputs``: ``{name: (shape, expressions)}`` with ``M``, ``K_R``, ``K_F`` (6, 6) and
    ``dM``, ``dK_R``, ``dK_F`` (P, 6, 6), row k the derivative with respect to ``wrt[k]``
    (per SI unit of that parameter).
    """

    program: Program
    outputs: dict
    wrt: tuple
    pose: tuple
    inputs: tuple


def _tangent(prog: Program, partials: dict, tangents: dict, sym_, rhs, wrt):
    """Name d(sym_)/d(wrt) from the named local partials of ``rhs`` (zero stays 0)."""
    terms = []
    for dep in sorted(rhs.free_symbols, key=lambda s: s.name):
        t = tangents.get(dep, 0)
        if t == 0:
            continue
        terms.append(_partial(prog, partials, sym_, rhs, dep) * t)
    if not terms:
        return sp.Integer(0)
    return prog.let(f"d_{sym_.name}__{wrt.name}", sp.Add(*terms))


def _partial(prog: Program, partials: dict, sym_, rhs, dep):
    """The local partial d rhs / d dep, named once as ``D_<sym>__<dep>``."""
    key = (sym_, dep)
    if key not in partials:
        grads = partials.setdefault(("gradient", sym_), None) or gradient(rhs)
        partials[("gradient", sym_)] = grads
        partials[key] = prog.let(f"D_{sym_.name}__{dep.name}", grads[dep])
    return partials[key]


def seeds_of(name: str, declared: dict):
    """The program inputs whose tangent is 1 for a derivative with respect to ``name``.

    ``P``: P itself and, for a leg-level parameter, each leg's own input ``P__N``
    (a copy of P per leg): with every leg at the shared value, d(P__N)/dP = 1 for each of them.
    ``P@N`` (one leg's own value): ``P__N`` alone. None when ``name`` is no input.
    """
    base, at, leg = name.partition("@")
    if at:
        own = f"{base}__{leg}"
        return [declared[own]] if leg.isdigit() and own in declared else None
    if name not in declared:
        return None
    copies = [s_ for nm, s_ in declared.items() if nm.startswith(f"{name}__") and nm[len(name) + 2 :].isdigit()]
    return [declared[name], *copies]


def sensitivity_program(model, wrt, progress=None) -> SensitivityModel:
    """Forward-mode derivatives of M, K_R and K_F with respect to the parameters ``wrt``.

    Parameters
    ----------
    model : :class:`~eigentwist.symbolic.DerivedModel`.
    wrt : parameter names (inputs of the model's programs), in the order of the outputs;
        ``P@N`` is leg N's own value of a leg-level parameter P (the input ``P__N``).
    progress : optional callable taking a message string.
    """
    prog = combined_program(model)
    declared = {s_.name: s_ for s_ in prog.inputs}
    unknown = [w for w in wrt if seeds_of(w, declared) is None]
    if unknown:
        raise InputError(
            f"cannot differentiate with respect to {unknown}: not inputs of the model "
            f"(expected names from {', '.join(model.parameters)})"
        )
    base = list(prog.assignments)
    mats = {
        k: (shape, [sp.sympify(e).xreplace(prog.renamed) for e in exprs])
        for k, (shape, exprs) in model.outputs["matrices"].items()
    }
    out_grad: dict = {}
    partials: dict = {}
    d_out = {k: [] for k in OUTPUTS}
    for n, name in enumerate(wrt, start=1):
        if progress:
            progress(f"forward mode {n}/{len(wrt)}: {name}")
        seeds = seeds_of(name, declared)
        tag = sp.Symbol(name.replace("@", "_at_"))
        tangents = {c: sp.Integer(1) for c in seeds}
        for sym_, rhs in base:
            t = _tangent(prog, partials, tangents, sym_, rhs, tag)
            if t != 0:
                tangents[sym_] = t
        for k in OUTPUTS:
            shape, exprs = mats[k]
            for idx, e in enumerate(exprs):
                e = sp.sympify(e)
                if idx not in out_grad.setdefault(k, {}):
                    out_grad[k][idx] = sorted(gradient(e).items(), key=lambda kv: kv[0].name)
                terms = [g * tangents[s_] for s_, g in out_grad[k][idx] if tangents.get(s_, 0) != 0]
                d_out[k].append(sp.Add(*terms))
    outputs = {k: (mats[k][0], list(mats[k][1])) for k in OUTPUTS}
    for k in OUTPUTS:
        outputs["d" + k] = ((len(wrt),) + tuple(mats[k][0]), d_out[k])
    pose = tuple(model.ik.inputs[:3])
    return SensitivityModel(prog, outputs, tuple(wrt), pose, tuple(s_.name for s_ in prog.inputs[3:]))
