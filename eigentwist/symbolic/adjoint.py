"""Design gradients of seeded matrix contractions by reverse mode on the straight-line program.

For symmetric seeds S_X (6, 6) of the chosen outputs X (e.g. ``M`` and ``K_F``), the
generated code returns the gradient of the scalar

    L = sum over X of  sum_ab S_X[a, b] X[a, b]

with respect to every design parameter at once: one forward sweep (the IK and model
programs of :func:`~eigentwist.symbolic.sensitivity.combined_program`), then one
backward sweep that accumulates the adjoint v̄ = dL/dv of each intermediate in reverse
order of assignment,

    v̄ = sum over the intermediates u = f(..., v, ...) that read v of  ū . (df/dv),

each assignment first cut into operations over atoms (``<u>_<k>``, :func:`_flatten`), so
the local partials df/dv are products of forward values. The code is linear in the size
of the program and independent of the number of parameters. With S_K = φ_i φ_jᵀ (symmetrised)
and S_M = −λ S_K, L's gradient is φ_iᵀ(∂K − λ∂M)φ_j: the derivative of an eigenvalue
λ = ω² of K φ = λ M φ for M-orthonormal φ (Hoevenaars, Krut, Herder 2020, Eq. 15 with
Eqs. 12–14 differentiated).

The seeds are inputs ``bar_<X>_<a>_<b>`` (upper triangle, a <= b; the kernel counts an
off-diagonal seed for both of its entries); the gradient is returned per program input
(``P`` and each leg's own copy ``P__N`` separately: d/dP of a shared parameter is their
sum, see :func:`~eigentwist.symbolic.sensitivity.sensitivity_program`).
"""

from __future__ import annotations

from collections import defaultdict
from dataclasses import dataclass

import sympy as sp

from .program import Program
from .sensitivity import combined_program, local_partial, postorder

__all__ = ["AdjointModel", "adjoint_program", "seed_name"]


def seed_name(output: str, a: int, b: int) -> str:
    """The input name of the seed of entry (a, b), a <= b, of output ``output``."""
    return f"bar_{output}_{a}_{b}"


@dataclass
class AdjointModel:
    """The reverse-mode program of :func:`adjoint_program`.

    ``program``: forward assignments, then backward ones (``n_forward`` of them first);
    ``matrices``: ``{X: 36 expressions}`` of the forward outputs (named entries);
    ``grad``: ``(input names, expressions)`` of dL/d(input); ``seeds``: the seed inputs
    in order (X, a, b with a <= b); ``inputs``: pose and model inputs, without seeds.
    """

    program: Program
    n_forward: int
    matrices: dict
    grad: tuple
    seeds: tuple
    inputs: tuple


def _active(prog: Program, targets: set) -> set:
    """Intermediates that depend on some symbol of ``targets`` (inputs), and those inputs."""
    active = set(targets)
    for s_, rhs in prog.assignments:
        if rhs.free_symbols & active:
            active.add(s_)
    return active


def _flatten(v, rhs, taken: set) -> list:
    """``v = rhs`` as assignments of one operation each over atoms (three-address code).

    Each inner node of ``rhs``'s tree is named ``<v>_<k>``, so that the local partials
    of the backward sweep (the other factors of a product, a power's base) are values of
    the forward sweep, not subtrees computed again.
    """
    if rhs.is_Atom:
        return [(v, rhs)]
    out, value, k = [], {}, 0
    for node in postorder(rhs):
        if node.is_Atom:
            value[node] = node
            continue
        new = node.func(*[value[a] for a in node.args]) if node.args else node
        if node is rhs or node == rhs:
            out.append((v, new))
            break
        if new.is_Atom or (new.is_Mul and len(new.args) == 2 and new.args[0] == -1 and new.args[1].is_Atom):
            value[node] = new
            continue
        k += 1
        name = f"{v.name}_{k}"
        while name in taken:
            name += "_"
        taken.add(name)
        value[node] = sp.Symbol(name, real=True)
        out.append((value[node], new))
    return out


def _backprop(rhs, vbar, active: set, contrib: dict, name, stem: str) -> None:
    """Add ``vbar`` times d rhs / d s to ``contrib[s]`` for every active symbol s of ``rhs``.

    Reverse accumulation over the expression tree of ``rhs``: a node's adjoint is named
    (a backward statement) where more than one of its arguments is active, so the code
    stays linear in the size of ``rhs``.
    """
    adj: dict = defaultdict(list)
    adj[rhs].append(vbar)
    k = 0
    for node in reversed(postorder(rhs)):
        terms = adj.pop(node, None)
        if not terms:
            continue
        if node.is_Symbol:
            contrib[node].extend(terms)
            continue
        kids = [i for i, c in enumerate(node.args) if c.free_symbols & active]
        if not kids:
            continue
        a = sp.Add(*terms)
        if len(kids) > 1 and not a.is_Atom and not (a.is_Mul and len(a.args) == 2 and a.args[0].is_Number):
            k += 1
            a = name(f"{stem}_{k}", a)
        for i in kids:
            adj[node.args[i]].append(a * local_partial(node, i))


def adjoint_program(model, outputs=("M", "K_F"), targets=None, progress=None) -> AdjointModel:
    """Reverse-mode gradient of seeded contractions of ``outputs`` (names in
    ``model.outputs["matrices"]``).

    ``targets``: the program inputs to differentiate with respect to (default: every
    input that is a design parameter ``P`` or a leg's copy ``P__N``; not the pose, not
    the effect switches).
    """
    prog = combined_program(model)
    names = set(model.robot.parameter_names)
    if targets is None:
        targets = [
            s_
            for s_ in prog.inputs
            if s_.name in names or s_.name.rpartition("__")[0] in names and s_.name[-1].isdigit()
        ]
    targets = list(targets)
    fwd = Program()
    for s_ in prog.inputs:
        fwd.declare(s_)
    for s_, rhs in prog.assignments:
        fwd.let(s_.name, rhs)
    mats, seeds = {}, []
    contrib: dict = defaultdict(list)
    for k in outputs:
        _, exprs = model.outputs["matrices"][k]
        exprs = [sp.sympify(e).xreplace(prog.renamed) for e in exprs]
        named = [None] * 36
        for a in range(6):
            for b in range(a, 6):
                o = fwd.let(f"o_{k}_{a}_{b}", exprs[6 * a + b])
                named[6 * a + b] = named[6 * b + a] = o
                bar = fwd.declare(sp.Symbol(seed_name(k, a, b), real=True))
                seeds.append(bar)
                if o.free_symbols:
                    contrib[o].append(bar if a == b else 2 * bar)
        mats[k] = named
    names_taken = {s_.name for s_ in fwd.inputs} | {s_.name for s_, _ in fwd.assignments}
    fwd.assignments = [a for v, rhs in fwd.assignments for a in _flatten(v, rhs, names_taken)]
    active = _active(fwd, set(targets))
    forward = list(fwd.assignments)
    backward: list = []

    def name(stem: str, expr):
        """A backward statement ``stem = expr`` (atoms are not named)."""
        if expr.is_Atom:
            return expr
        nm = stem
        while nm in names_taken:
            nm += "_"
        names_taken.add(nm)
        s_ = sp.Symbol(nm, real=True)
        backward.append((s_, expr))
        return s_

    for n, (v, rhs) in enumerate(reversed(forward)):
        if progress and n % 2000 == 0:
            progress(f"reverse sweep {n}/{len(forward)}")
        terms = contrib.pop(v, None)
        if not terms or v not in active:
            continue
        _backprop(rhs, name(f"b_{v.name}", sp.Add(*terms)), active, contrib, name, f"b_{v.name}")
    grad = tuple(sp.Add(*contrib.get(t, [])) for t in targets)
    out = Program()
    for s_ in fwd.inputs:
        out.declare(s_)
    out.assignments = forward + backward
    inputs = tuple(s_.name for s_ in prog.inputs)
    return AdjointModel(out, len(forward), mats, (tuple(t.name for t in targets), grad), tuple(seeds), inputs)
