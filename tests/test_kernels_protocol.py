"""The kernels' protocol (eigentwist.runtime.kernels): both backends give what it names,
and the evaluator asks its kernels for nothing else."""

from __future__ import annotations

import ast
import types
from pathlib import Path

import pytest

import eigentwist
from eigentwist.runtime.kernels import CompiledKernels, Kernels

EVALUATOR = Path(eigentwist.__file__).parent / "runtime" / "evaluator.py"
#: kernels that only some robots have (named in OUTPUTS where present)
OPTIONAL = {"legs", "loop_closure"}


def members(protocol) -> set:
    """The names a protocol (and the protocols it extends) declares."""
    out = set()
    for cls in protocol.__mro__:
        if cls in (Kernels, CompiledKernels):
            out |= {n for n in vars(cls) if not n.startswith("_")} | set(vars(cls).get("__annotations__", {}))
    return out


@pytest.mark.parametrize("robot", ["heli4", "delta", "hexapod"])
def test_a_generated_numpy_module_is_kernels_but_not_compiled_ones(robot):
    module = eigentwist.load(robot, backend="numpy").module
    assert isinstance(module, Kernels) and not isinstance(module, CompiledKernels)


def test_kernels_without_one_of_the_protocols_functions_are_not_kernels():
    module = eigentwist.load("heli4", backend="numpy").module
    for name in members(Kernels):
        stand_in = types.SimpleNamespace(**{k: getattr(module, k) for k in members(Kernels) if k != name})
        assert not isinstance(stand_in, Kernels), name
    assert isinstance(types.SimpleNamespace(**{k: getattr(module, k) for k in members(Kernels)}), Kernels)


def test_the_evaluator_asks_its_kernels_only_for_the_protocols_names():
    tree = ast.parse(EVALUATOR.read_text(encoding="utf-8"))
    asked = {
        node.attr
        for node in ast.walk(tree)
        if isinstance(node, ast.Attribute)
        and isinstance(node.value, ast.Attribute)
        and node.value.attr == "_kernels"
        and isinstance(node.value.value, ast.Name)
        and node.value.value.id == "self"
    }
    assert asked, "no self._kernels.<name> found: the test reads the wrong file"
    assert asked <= members(CompiledKernels) | OPTIONAL, asked - members(CompiledKernels) - OPTIONAL


@pytest.mark.compiled
def test_the_c_backends_kernels_are_compiled_kernels():
    assert isinstance(eigentwist.load("heli4", backend="c").kernels, CompiledKernels)


@pytest.mark.compiled
def test_the_newton_iterations_run_in_c_only_on_the_c_backend_with_c_newton():
    numpy_ev = eigentwist.load("heli4", backend="numpy")
    assert numpy_ev._c_threads() is None and numpy_ev.completion.c_threads() is None
    ev = eigentwist.load("heli4", backend="c", threads=2)
    assert ev._c_threads() == 2 and ev.completion.c_threads() == 2
    ev.c_newton = False
    assert ev._c_threads() is None and ev.completion.c_threads() is None
