"""Backend-neutral kernels: pruned, CSE'd straight-line code with named outputs.

A :class:`Kernel` is what every backend template renders: ordered statements
``name = expression`` over declared inputs, and output entries placed right after the
statement that completes them (so dead temporaries can be freed early).
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass, field

import sympy as sp

from ..errors import DescriptionError
from ..hashing import canonical
from ..symbolic.program import Program, reachable

__all__ = ["Output", "Kernel", "build_kernel", "sub_kernel", "UndeclaredSymbolError", "source_hash"]


class UndeclaredSymbolError(DescriptionError):
    """An expression uses a symbol that is neither an input nor an intermediate."""


@dataclass
class Output:
    """One output array: ``shape`` per pose and its flattened entry expressions.

    ``symmetric`` outputs (square in their last two axes) are emitted for the upper
    triangle only and mirrored.
    """

    name: str
    shape: tuple
    exprs: list
    symmetric: bool = False

    def entries(self):
        """Yield ``(index tuple, flat position)`` of the entries to compute."""
        import itertools

        for flat, idx in enumerate(itertools.product(*[range(n) for n in self.shape])):
            if self.symmetric and idx[-2] > idx[-1]:
                continue
            yield idx, flat


@dataclass
class Kernel:
    """CSE'd code for one function.

    ``inputs`` is a list of ``(group, names)``: ``"pose"`` (x, y, z arrays), ``"q"``
    (joint coordinate names in (leg, joint) order, ``joints_per_leg`` per leg),
    ``"param"`` (parameter and switch names; a 6-DoF robot's rotation ``R_ij`` and, in
    the kernels after the inverse kinematics, its position ``x, y, z`` are passed here).
    ``body`` is a list of ``("let", symbol, expr)`` and ``("out", output, index, expr)``.
    """

    name: str
    doc: str
    inputs: list
    outputs: list
    body: list = field(default_factory=list)
    joint_order: list = field(default_factory=list)
    joints_per_leg: int = 3
    _canonical: bytes | None = field(default=None, init=False, repr=False, compare=False)

    def canonical_text(self) -> bytes:
        """The kernel as canonical text (name, inputs, every statement and output as
        :func:`eigentwist.hashing.canonical`), computed once: :func:`source_hash` hashes it
        for each backend."""
        if self._canonical is None:
            lines = [f"kernel {self.name} {self.input_names}\n"]
            for item in self.body:
                if item[0] == "let":
                    lines.append(f"{item[1].name}={canonical(item[2])}\n")
                else:
                    lines.append(f"{item[1].name}{item[2]}={canonical(item[3])}\n")
            self._canonical = "".join(lines).encode()
        return self._canonical

    def joint_index(self, name: str) -> tuple[int, int]:
        """(leg, joint) of joint coordinate ``name``, 0-based."""
        return divmod(self.joint_order.index(name), self.joints_per_leg)

    @property
    def input_names(self) -> list[str]:
        return [n for _, names in self.inputs for n in names]

    @property
    def params_used(self) -> list[str]:
        return [n for g, names in self.inputs if g == "param" for n in names]


def _sorted_syms(expr) -> list:
    return sorted(expr.free_symbols, key=lambda s: s.name)


def build_kernel(
    name: str,
    doc: str,
    program: Program,
    outputs: list[Output],
    pose: list,
    joints: list,
    params: list,
    joints_per_leg: int = 3,
    cse: bool = True,
) -> Kernel:
    """Prune ``program`` to what ``outputs`` need, run CSE and order the statements.

    ``cse=False`` keeps the program's own statements (one already CSE'd, e.g. a reverse
    sweep over a CSE'd kernel: a second CSE would cost more than it finds).

    Raises :class:`UndeclaredSymbolError` naming the symbol when an expression uses
    anything that is not a declared input (style: fail fast, as pydy does).
    """
    out_exprs = [sp.sympify(out.exprs[flat]) for out in outputs for _, flat in out.entries()]
    # prune: intermediates reachable from the outputs
    needed = reachable(program.definitions(), [s for e in out_exprs for s in e.free_symbols])
    lets = [(s_, r) for s_, r in program.assignments if s_ in needed]
    declared = {s.name for s in list(pose) + list(joints)} | set(params)
    used_inputs = set()
    for e in [r for _, r in lets] + out_exprs:
        for s_ in e.free_symbols:
            if s_ in needed:
                continue
            if s_.name not in declared:
                raise UndeclaredSymbolError(
                    f"kernel {name!r}: symbol {s_.name!r} is not a declared input "
                    f"(declare it as a parameter of the robot description)"
                )
            used_inputs.add(s_.name)

    exprs = [r for _, r in lets] + out_exprs
    replacements, reduced = sp.cse(exprs, symbols=sp.numbered_symbols("t", real=True)) if cse else ([], exprs)
    stmts = {s_: e for s_, e in replacements}
    stmts.update({s_: red for (s_, _), red in zip(lets, reduced[: len(lets)])})
    order: list = []
    done: set = set()

    def visit(s_):
        if s_ in done or s_ not in stmts:
            return
        done.add(s_)
        for dep in _sorted_syms(stmts[s_]):
            visit(dep)
        order.append(s_)

    for s_, _ in lets:
        visit(s_)
    out_reduced = reduced[len(lets) :]
    for e in out_reduced:
        for dep in _sorted_syms(e):
            visit(dep)
    position = {s_: k for k, s_ in enumerate(order)}
    placed: dict[int, list] = {}
    k = 0
    for out in outputs:
        for idx, _ in out.entries():
            e = out_reduced[k]
            k += 1
            at = max((position[d] for d in e.free_symbols if d in position), default=-1)
            placed.setdefault(at, []).append(("out", out, idx, e))
    body = list(placed.get(-1, []))
    for pos, s_ in enumerate(order):
        body.append(("let", s_, stmts[s_]))
        body.extend(placed.get(pos, []))
    inputs = [
        ("pose", [s.name for s in pose if s.name in used_inputs]),
        ("q", [s.name for s in joints if s.name in used_inputs]),
        ("param", [p for p in params if p in used_inputs]),
    ]
    return Kernel(name, doc, inputs, outputs, body, [s.name for s in joints], joints_per_leg)


def sub_kernel(kernel: Kernel, name: str, doc: str, outputs: list[str]) -> Kernel:
    """The part of a CSE'd ``kernel`` that computes the outputs named in ``outputs`` (in that
    order): its statements those outputs need, in the kernel's order, and only the inputs they
    read. No CSE runs again (a kernel of fewer outputs costs nothing to build); the statements
    are those of the larger kernel, so where the smaller one was CSE'd alone its temporaries
    could differ, its values not.

    Raises :class:`~eigentwist.errors.DescriptionError` naming an output the kernel does not have."""
    have = {out.name: out for out in kernel.outputs}
    missing = [n for n in outputs if n not in have]
    if missing:
        raise DescriptionError(f"kernel {kernel.name!r} has no output {missing[0]!r} (it has {sorted(have)})")
    keep_outputs = [have[n] for n in outputs]
    kept = {id(out) for out in keep_outputs}
    lets = {item[1]: item[2] for item in kernel.body if item[0] == "let"}
    read = [s for item in kernel.body if item[0] == "out" and id(item[1]) in kept for s in item[3].free_symbols]
    needed = reachable(lets, read)
    body = [
        item
        for item in kernel.body
        if (item[0] == "let" and item[1] in needed) or (item[0] == "out" and id(item[1]) in kept)
    ]
    used = {s_.name for item in body for s_ in (item[2] if item[0] == "let" else item[3]).free_symbols}
    inputs = [(group, [n for n in names if n in used]) for group, names in kernel.inputs]
    return Kernel(name, doc, inputs, keep_outputs, body, list(kernel.joint_order), kernel.joints_per_leg)


def source_hash(kernels: list[Kernel], extra: str = "") -> str:
    """SHA-256 over a canonical text of the kernels (statements, outputs) and ``extra``."""
    h = hashlib.sha256()
    for kern in kernels:
        h.update(kern.canonical_text())
    h.update(extra.encode())
    return h.hexdigest()
