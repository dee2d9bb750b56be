"""Reverse mode on a straight-line program: a weighted sum's derivative for every input at once.

The eigenvalue derivative of ``K φ = ω² M φ`` with M-orthonormal φ is

    dω²/dp = φᵀ (∂K/∂p − ω² ∂M/∂p) φ = d/dp [ <W_K, K> + <W_M, M> ],   W_K = φφᵀ,  W_M = −ω² φφᵀ,

with the weights W held fixed: the derivative of one scalar of the program's outputs. Reverse
accumulation (an adjoint per intermediate, swept from the outputs back to the inputs) gives
that scalar's derivative with respect to every input at once, for a few evaluations of the
program whatever the number of parameters; forward mode (:mod:`.sensitivity`) pays one
tangent sweep per parameter. The weights are inputs of the generated code, so one kernel
serves every mode, and a cluster of repeated eigenvalues takes the weights of its pairs.

The program is first put in elementary form: a subexpression whose value a local partial
reads (an argument of a product, a power or a function) is named, so that every local
partial is a short expression of named values. Each adjoint is accumulated as its terms
arise (``b<n>_<v>``, a running sum), so one value per pending adjoint is live, not every
term until the sum.
"""

from __future__ import annotations

from collections import defaultdict

import sympy as sp

from .program import Program
from .sensitivity import local_partial, postorder

__all__ = ["elementary", "reverse_sweep", "named_subexpressions"]


def _inline(node) -> bool:
    """A node whose value is cheap to recompute where a partial reads it: an atom, or a
    numeric power of an atom."""
    return node.is_Atom or (isinstance(node, sp.Pow) and node.args[0].is_Atom and node.args[1].is_Number)


def named_subexpressions(prog: Program, expr, active: set, owner: str, count: list):
    """``expr`` with its active subexpressions that a partial reads assigned in ``prog``
    (``e<k>_<owner>``); the terms of a sum stay in place (their partial is 1)."""

    def build(node, parent_sum: bool):
        if node.is_Atom:
            return node
        args = [build(a, isinstance(node, sp.Add)) for a in node.args]
        new = node.func(*args) if any(a is not b for a, b in zip(args, node.args)) else node
        if parent_sum or _inline(new) or not (new.free_symbols & active):
            return new
        count[0] += 1
        named = prog.let(f"e{count[0]}_{owner}", new)
        if named.is_Symbol:
            active.add(named)
        return named

    return build(expr, True)


def elementary(prog: Program, active: set) -> Program:
    """``prog`` in elementary form: each statement's active subexpressions that a local
    partial reads are named before it (:func:`named_subexpressions`). ``active`` (the symbols
    that depend on the differentiated inputs) grows by the new names and active statements."""
    out = Program()
    for s_ in prog.inputs:
        out.declare(s_)
    for s_, rhs in prog.assignments:
        new = named_subexpressions(out, rhs, active, s_.name, [0]) if rhs.free_symbols & active else rhs
        out.assign(s_, new)  # the statement keeps its own name
        if new.free_symbols & active:
            active.add(s_)
    return out


def _accumulate(prog: Program, terms: dict, counts: dict, s_, contribution) -> None:
    """Add ``contribution`` to the running adjoint of ``s_`` (``b<n>_<s>``)."""
    held = terms.get(s_)
    n = counts[s_] = counts.get(s_, 0) + 1
    new = contribution if held is None else held + contribution
    terms[s_] = new if new.is_Atom else prog.let(f"b{n}_{s_.name}", new)


def _sweep(prog: Program, expr, adjoint, terms: dict, counts: dict, active: set) -> None:
    """Add ``adjoint`` × d expr / d s to the adjoint of every active symbol s of ``expr``,
    by reverse accumulation over its (elementary) tree. A node's adjoint is written out
    where its partials read it: in elementary form it is ``adjoint``, its negative or a
    product with short local partials."""
    order = postorder(expr)
    adj: dict = defaultdict(list)
    adj[expr].append(adjoint)
    for node in reversed(order):
        if node not in adj:
            continue
        parts = adj.pop(node)
        a = parts[0] if len(parts) == 1 else sp.Add(*parts)
        if node.is_Symbol:
            if node in active:
                _accumulate(prog, terms, counts, node, a)
            continue
        kids = [i for i, c in enumerate(node.args) if not c.is_Number and c.free_symbols & active]
        for i in kids:
            local = sp.Integer(1) if isinstance(node, sp.Add) else local_partial(node, i)
            adj[node.args[i]].append(a if local == 1 else a * local)


def reverse_sweep(prog: Program, weighted: list, inputs: list, progress=None) -> tuple[Program, list]:
    """``(program, derivatives)``: ``prog`` in elementary form (:func:`elementary`, a new
    program) followed by the statements of the sweep, and the derivative of ``Σ w · e`` over
    ``weighted`` (``(weight symbol, expression)`` pairs in ``prog``'s symbols) with respect to
    each symbol of ``inputs`` (declared inputs of ``prog``), as expressions in its symbols."""
    active = set(inputs)
    for s_, rhs in prog.assignments:
        if rhs.free_symbols & active:
            active.add(s_)
    if progress:
        progress(f"elementary form ({len(prog.assignments)} statements)")
    out = elementary(prog, active)
    terms: dict = {}
    counts: dict = {}
    for k, (w, e) in enumerate(weighted):
        if e.free_symbols & active:
            root = named_subexpressions(out, e, active, f"o{k}", [0])
            _sweep(out, root, w, terms, counts, active)
    if progress:
        progress(f"reverse sweep ({len(out.assignments)} statements)")
    for s_, rhs in reversed(list(out.assignments)):
        if s_ in terms:
            _sweep(out, rhs, terms.pop(s_), terms, counts, active)
    return out, [terms.get(s_, sp.Integer(0)) for s_ in inputs]
