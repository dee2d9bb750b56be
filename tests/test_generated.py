"""Generated NumPy code equals the SymPy expressions; regeneration is byte-identical."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from eigentwist.codegen.generate import GENERATED, PROGRESS_STEPS, render_robot, stale
from eigentwist.robots import NAMES
from eigentwist.codegen.kernel import Output, UndeclaredSymbolError, build_kernel
from eigentwist.description import sym
from eigentwist.errors import DescriptionError
from eigentwist.symbolic import Program

from .conftest import effect_inputs, random_poses


def _random_params(robot, rng):
    """Defaults perturbed by up to +-20 %, every effect switched on."""
    vals = {}
    for p in robot.parameters:
        v = p.default * (1 + 0.4 * (rng.random() - 0.5)) if p.default != 0 else 0.02 * (rng.random() - 0.5)
        vals[p.name] = v
    # every effect on; each leg its own value of the leg-level parameters (tube radii kept ordered)
    vals = {
        k: float(v) for k, v in effect_inputs(robot, vals, robot.effects, lambda: 0.1 * (rng.random() - 0.5)).items()
    }
    for k in range(1, len(robot.legs) + 1):
        vals[f"r_i_l1__{k}"] = min(vals[f"r_i_l1__{k}"], 0.9 * vals[f"r_o_l1__{k}"])
    return vals


@pytest.mark.parametrize("seed", [1, 2])
def test_numpy_equals_sympy(ev, derived, seed):
    rng = np.random.default_rng(seed)
    robot = derived.robot
    pose = random_poses(robot, 1, seed)[0]
    params = _random_params(robot, rng)
    ik_vals = dict(params, x=pose[0], y=pose[1], z=pose[2])
    q_sym = np.array(derived.ik.evaluate(ik_vals, sp.Matrix(derived.ik_outputs["q"][1])), dtype=float)
    mod = ev.module
    p = {k: np.asarray(v) for k, v in params.items()}
    ik = mod.inverse_kinematics(pose[0:1], pose[1:2], pose[2:3], p)
    np.testing.assert_allclose(ik["q"][0].ravel(), q_sym.ravel(), rtol=1e-12, atol=1e-13)
    q = ik["q"]
    env = dict(params)
    env.update({s_: v for s_, v in zip(derived.joints, q_sym.ravel())})
    groups = ("matrices", "jacobians", "gravity")
    outputs = [(g, name, shape, list(ex)) for g in groups for name, (shape, ex) in derived.outputs[g].items()]
    # every output in one walk of the program (each intermediate evaluated once)
    values = np.array(derived.program.evaluate(env, sp.Matrix([e for *_, ex in outputs for e in ex])), dtype=float)
    start = 0
    got = {g: getattr(mod, g)(q, p) for g in groups}
    for group, name, shape, exprs in outputs:
        want = values[start : start + len(exprs)].reshape(shape)
        start += len(exprs)
        scale = max(np.abs(want).max(), 1e-300)
        err = np.abs(got[group][name][0] - want).max() / scale
        assert err < 1e-10, f"{group}.{name}: relative error {err:.2e}"


def test_checked_in_code_is_fresh(rendered_with_progress):
    files, messages = rendered_with_progress
    bad = stale(files)
    assert not bad, f"stale generated files {bad}: run `eigentwist generate` (make generate)"
    # every step says what it does before it starts (else 36 s of CSE and emitting would be
    # silent on the first use of a description file)
    for robot in NAMES:
        steps = [m for m in messages if m.startswith(f"{robot}: ")]
        assert len(steps) == PROGRESS_STEPS, steps
        assert {f"{robot}: CSE matrices", f"{robot}: emit {robot}_c.c", f"{robot}: emit {robot}_c.h"} <= set(steps)


def test_regeneration_is_deterministic(rendered):
    # within one process, after the shipped robots' renders (the freshness test above compares
    # their render with another process's, the checked-in files): a gallery robot rendered
    # twice more, both backends (the same derivation, CSE and printers as every robot's; the
    # quickest to derive)
    from eigentwist.runtime.userfile import describe_file

    assert rendered
    description = describe_file(Path(__file__).resolve().parent.parent / "examples" / "robots" / "rrr3.py")
    first = render_robot(description)
    assert {"rrr3_numpy.py", "rrr3_c.c"} <= set(first)
    assert render_robot(description) == first


def test_header_names_command_and_hash():
    text = (GENERATED / "heli4_numpy.py").read_text()
    head = text.splitlines()[:3]
    assert "eigentwist generate" in head[0]
    assert head[2].startswith("# Source hash: sha256:") and len(head[2].split(":")[-1]) == 64


def test_undeclared_symbol_fails_fast():
    prog = Program()
    a = prog.declare(sym("a"))
    t = prog.let("t", a * sym("mystery"))
    with pytest.raises(UndeclaredSymbolError, match="mystery"):
        build_kernel("k", "", prog, [Output("y", (), [t])], [], [], ["a"])


def _run_kernel(kernel, values: dict) -> dict:
    """A kernel's outputs evaluated statement by statement with SymPy (``values``: input name
    -> number): {output name: [entries in the order of the body]}."""
    env = {sym(n): values[n] for n in kernel.input_names}
    out: dict = {}
    for item in kernel.body:
        if item[0] == "let":
            env[item[1]] = item[2].subs(env)
        else:
            out.setdefault(item[1].name, []).append(float(item[3].subs(env)))
    return out


def test_sub_kernel_computes_its_outputs_from_the_statements_they_need():
    """A part of a CSE'd kernel: the same values as the whole kernel's for its outputs, no
    statement or input the outputs do not read, and an output the kernel lacks named."""
    from eigentwist.codegen.kernel import sub_kernel

    prog = Program()
    a, b, c = (prog.declare(sym(n)) for n in "abc")
    s = prog.let("s", sp.sin(a) * b + b**2)
    u = prog.let("u", s * c + sp.cos(c))
    outs = [Output("m", (2,), [s + a * b, s * b]), Output("lever", (), [u * s]), Output("only_c", (), [c**3])]
    whole = build_kernel("whole", "", prog, outs, [], [a, b], ["c"], joints_per_leg=2)
    part = sub_kernel(whole, "m", "M only", ["m"])
    assert [o.name for o in part.outputs] == ["m"] and part.doc == "M only"
    assert part.inputs == [("pose", []), ("q", ["a", "b"]), ("param", [])]  # c: read by the dropped outputs only
    assert part.joint_order == ["a", "b"] and part.joints_per_leg == 2 and part.joint_index("b") == (0, 1)
    values = {"a": 0.3, "b": -1.7, "c": 2.2}
    want = _run_kernel(whole, values)
    assert _run_kernel(part, values) == {"m": want["m"]}
    s_ = np.sin(0.3) * -1.7 + 1.7**2
    assert want["m"] == pytest.approx([s_ + 0.3 * -1.7, s_ * -1.7], rel=1e-14)
    lets = [item[1] for item in part.body if item[0] == "let"]
    assert set(lets) < {item[1] for item in whole.body if item[0] == "let"}
    reads = {f for item in part.body for f in (item[2] if item[0] == "let" else item[3]).free_symbols}
    assert set(lets) <= reads  # every statement kept is read by a kept statement or output
    two = sub_kernel(whole, "two", "", ["lever", "m"])
    assert [o.name for o in two.outputs] == ["lever", "m"] and _run_kernel(two, values) == {
        k: want[k] for k in ("m", "lever")
    }
    with pytest.raises(DescriptionError, match="'K_R'"):
        sub_kernel(whole, "x", "", ["m", "K_R"])


def test_printer_keeps_powers_in_denominators():
    from eigentwist.codegen.numpy_backend import NumpyCodePrinter

    a, b = sp.symbols("a b", real=True)
    for expr in (a / b**2, a / b**-2, a * b**2 / (a + b) ** 2, 1 / sp.sqrt(a) / b**2):
        text = NumpyCodePrinter().doprint(expr)
        got = eval(text, {"sqrt": np.sqrt}, {"a": 1.7, "b": 0.3})
        assert np.isclose(got, float(expr.subs({a: 1.7, b: 0.3}))), text
