"""The generated C as a library: ``<robot>_c.h`` and the entry points behind it.

Rendering checks need no compiler; the compiled tier builds a C program (C99) and a C++
program against the header and the checked-in generated source, as a user would, and
compares their frequencies with ``Evaluator.frequencies`` of the NumPy backend (LAPACK:
an independent eigen-solver) at 20 random poses.
"""

from __future__ import annotations

import re
import shutil
import subprocess

import numpy as np
import pytest

import eigentwist
from eigentwist.codegen import c_library
from eigentwist.codegen.generate import GENERATED
from eigentwist.robots import NAMES, get
from eigentwist.runtime import InputError, ccompile

from .conftest import random_poses, skip_tier

ROOT = GENERATED.parent.parent


def test_library_options_are_the_runtimes():
    from eigentwist.runtime.eigen import ROUNDOFF_EPS
    from eigentwist.runtime.validity import LEVER_SCALE, LEVER_TOL, STATUS

    assert (c_library.LEVER_TOL, c_library.LEVER_SCALE, c_library.ROUNDOFF_EPS) == (
        LEVER_TOL,
        LEVER_SCALE,
        ROUNDOFF_EPS,
    )
    text = (GENERATED / "heli4_c.h").read_text()
    for name, code in STATUS.items():
        assert re.search(rf"#define ET_HELI4_{name.upper()} {code}\b", text), name
    assert "#define ET_HELI4_LEVER_TOL 0.001" in text and "divided by the input l1" in text


@pytest.mark.parametrize("robot", NAMES)
def test_header_lists_the_inputs(robot):
    """The header's index macros name every input once, with the description's unit and default."""
    text = (GENERATED / f"{robot}_c.h").read_text()
    assert 'extern "C"' in text and f"#ifndef ET_{robot.upper()}_C_H" in text
    rows = re.findall(rf"#define ET_{robot.upper()}_IN_(\w+) (\d+)  /\* (\S+) \((.*?)\) = (\S+):", text)
    n = int(re.search(rf"#define ET_{robot.upper()}_N_INPUTS (\d+)", text).group(1))
    assert [int(r[1]) for r in rows] == list(range(n))
    desc = get(robot)
    params = {p.name: p for p in desc.parameters}
    ev = eigentwist.load(robot, backend="numpy")
    full = _solved_inputs(ev, "paper", {})
    for _, _, name, unit, default in rows:
        base = re.sub(r"__\d+$", "", name)
        assert float(default) == full[name], name  # the default model's value as solved
        if base in params:
            assert unit == params[base].unit, name
        else:
            assert name.startswith("on_") and unit == "-", name
    assert "restrict" not in text


def _solved_inputs(ev, model, values) -> dict:
    """The inputs ``ev.frequencies`` solves ``model`` with (its constraint route: ``c_rigid`` = 0
    where no leg of the model has a rigid direction)."""
    route, _ = ev.constraint_route(model, **values)
    return ev.inputs(model, route)


@pytest.mark.parametrize("robot", ["heli4", "delta"])
def test_defaults_are_the_exact_default_model(robot):
    """The shipped robots' default model has no rigid leg direction: the evaluator solves it
    with c_rigid = 0 (no stand-in penalty), and the header's defaults say the same."""
    ev = eigentwist.load(robot, backend="numpy")
    assert ev.parameters["c_rigid"].default > 0  # the description's penalty value ...
    route, condensed = ev.constraint_route(c_library.DEFAULT_MODEL)
    assert route == {"c_rigid": 0.0} and not condensed  # ... is not what the default model uses
    text = (GENERATED / f"{robot}_c.h").read_text()
    assert re.search(rf"#define ET_{robot.upper()}_IN_c_rigid \d+  /\* c_rigid \(rad/\(N m\)\) = 0\.0:", text)


def test_inputs_give_per_leg_names():
    """ev.inputs: the dict the NumPy module takes, per-leg copies and switches included."""
    ev = eigentwist.load("heli4", backend="numpy")  # its matrices are the module's, bit for bit
    p = ev.inputs("paper", {"eta_a@2": 0.5}, m_e=0.6)
    assert p["eta_a__2"] == 0.5 and p["eta_a__1"] == ev.defaults["eta_a"] and p["m_e"] == 0.6
    assert p["on_actuator_loss__3"] == 1.0 and p["on_payload_mass"] == 0.0 and p["on_ee_compliance"] == 1.0
    q = ev.module.inverse_kinematics(np.array([0.0]), np.array([0.0]), np.array([-0.6]), p)["q"]
    M = ev.module.matrices(q, p)["M"][0]
    np.testing.assert_allclose(
        M, ev.matrices([0.0, 0.0, -0.6], "paper", **{"eta_a@2": 0.5, "m_e": 0.6})["M"][0], rtol=1e-13, atol=0
    )
    with pytest.raises(InputError, match="eta_a@9"):
        ev.inputs("paper", {"eta_a@9": 0.5})


# ---------------------------------------------------------------- compiled tier
MAIN = r"""
#include <stdio.h>
#include <stdlib.h>
#include "{robot}_c.h"

/* argv[1]: "names" prints the inputs (name unit default); else a file with n, the poses,
   and the inputs (N_INPUTS values): prints each pose's status and frequencies. */
int main(int argc, char **argv)
{{
    double inputs[{P}_N_INPUTS];
    {p}_defaults(inputs);
    if (argc < 2)
        return 2;
    if (argv[1][0] == 'n' && argv[1][1] == 'a') {{
        for (int k = 0; k < {P}_N_INPUTS; ++k)
            printf("%s %s %.17g\n", {p}_input_names[k], {p}_input_units[k], inputs[k]);
        return 0;
    }}
    FILE *f = fopen(argv[1], "r");
    long n = 0;
    if (!f || fscanf(f, "%ld", &n) != 1)
        return 3;
    double *poses = (double *)malloc(sizeof(double) * n * {P}_POSE_WIDTH);
    double *hz = (double *)malloc(sizeof(double) * n * {P}_MODES);
    int *status = (int *)malloc(sizeof(int) * n);
    for (long i = 0; i < n * {P}_POSE_WIDTH; ++i)
        if (fscanf(f, "%lf", &poses[i]) != 1)
            return 4;
    for (int k = 0; k < {P}_N_INPUTS; ++k)
        if (fscanf(f, "%lf", &inputs[k]) != 1)
            return 5;
    fclose(f);
    int rc = {p}_frequencies(n, poses, inputs, hz, status);
    if (rc != 0)
        return 10 - rc;
    for (long i = 0; i < n; ++i) {{
        printf("%d", status[i]);
        for (int j = 0; j < {P}_MODES; ++j)
            printf(" %.17g", hz[i * {P}_MODES + j]);
        printf("\n");
    }}
    free(poses);
    free(hz);
    free(status);
    return 0;
}}
"""


def _cxx() -> str:
    for name in ("c++", "g++", "clang++"):
        path = shutil.which(name)
        if path:
            return path
    skip_tier("compiled", "no C++ compiler (c++, g++ or clang++) on PATH")


@pytest.fixture(scope="module")
def programs(tmp_path_factory):
    """{robot: (C program, C++ program)}: the generated source compiled once as C99, linked
    with a C and a C++ main that include the header from its own directory."""
    try:
        cc = ccompile.find_compiler()
    except ccompile.CompilerNotFoundError as exc:
        skip_tier("compiled", str(exc))
    cxx = _cxx()
    out = {}
    for robot in NAMES:
        d = tmp_path_factory.mktemp(f"clib-{robot}")
        shutil.copy(GENERATED / f"{robot}_c.h", d)
        shutil.copy(GENERATED / f"{robot}_c.c", d)
        main = MAIN.format(robot=robot, P=f"ET_{robot.upper()}", p=f"et_{robot}")
        (d / "main.c").write_text(main)
        (d / "main.cpp").write_text(main)

        def run(*cmd):
            res = subprocess.run(cmd, cwd=d, capture_output=True, text=True)
            assert res.returncode == 0, f"{' '.join(cmd)}:\n{res.stderr[-3000:]}"

        run(cc, "-std=c99", "-O0", "-Wall", "-Werror", "-Wno-unknown-pragmas", "-c", f"{robot}_c.c")
        run(cc, "-std=c99", "-Wall", "-Werror", "-o", "prog_c", "main.c", f"{robot}_c.o", "-lm")
        run(cxx, "-std=c++11", "-Wall", "-Werror", "-o", "prog_cpp", "main.cpp", f"{robot}_c.o", "-lm")
        out[robot] = (d / "prog_c", d / "prog_cpp")
    return out


def _run(program, *args) -> str:
    res = subprocess.run([str(program), *map(str, args)], capture_output=True, text=True)
    assert res.returncode == 0, f"{program} exited {res.returncode}: {res.stderr}"
    return res.stdout


def _scoped_values(desc) -> tuple[str, dict]:
    """A non-default model: the default one plus the payload and leg 2's own value of the
    first leg-level effect's first parameter (10 % above its default)."""
    effect = next(desc.effect(e) for e in desc.effects if desc.effect(e).leg_level)
    q = effect.params[0]
    default = next(p.default for p in desc.parameters if p.name == q.name)
    return f"paper,payload_mass,{effect.name}@2", {f"{q.name}@2": 1.1 * default}


def _library_frequencies(ev, poses, model, values):
    """What the standalone library computes: ``ev.frequencies``, except that a flexible
    model of legs with rigid constraints solves K_F with its c_rigid penalty there, where
    the evaluator condenses the constraints exactly: those agree to 1e-5."""
    from eigentwist.description.effects import resolve_model
    from eigentwist.runtime.eigen import frequencies_hz, generalized_eigh

    want = ev.frequencies(poses, model, **values)
    if ev.stiffness_model(resolve_model(model, ev.robot)) != "flexible" or not ev.constraint_route(model, **values)[1]:
        return want
    mats = ev.matrices(poses, model, **values)
    penalty = frequencies_hz(generalized_eigh(mats["K_F"], mats["M"])[0])
    np.testing.assert_allclose(penalty, want, rtol=1e-5)
    return penalty


@pytest.mark.compiled
@pytest.mark.parametrize("lang", ["c", "c++"])
@pytest.mark.parametrize("robot", NAMES)
def test_c_and_cxx_programs_reproduce_frequencies(programs, robot, lang, tmp_path):
    prog = programs[robot][0 if lang == "c" else 1]
    ev = eigentwist.load(robot, backend="numpy")
    names = [line.split()[0] for line in _run(prog, "names").splitlines()]
    defaults = [float(line.split()[-1]) for line in _run(prog, "names").splitlines()]
    full = _solved_inputs(ev, "paper", {})
    assert defaults == [full[n] for n in names]  # et_<robot>_defaults = the default model as solved
    poses = random_poses(ev.robot, 20, seed=23)
    for model, values in (("paper", {}), _scoped_values(ev.robot), ("rigid", {})):
        p = _solved_inputs(ev, model, values)
        data = tmp_path / "in.txt"
        data.write_text(
            f"{len(poses)}\n"
            + "\n".join(" ".join(repr(float(v)) for v in row) for row in poses)
            + "\n"
            + " ".join(repr(p[n]) for n in names)
            + "\n"
        )
        rows = np.array([[float(v) for v in line.split()] for line in _run(prog, data).splitlines()])
        status, hz = rows[:, 0], rows[:, 1:]
        want = _library_frequencies(ev, poses, model, values)
        assert (status == 0).all(), (model, status)
        k = want.shape[1]
        np.testing.assert_allclose(hz[:, :k], want, rtol=1e-12, atol=0, err_msg=f"{robot} {model} ({lang})")
        assert np.isnan(hz[:, k:]).all()  # a 3-DoF robot's rigid model: 3 modes


@pytest.mark.compiled
def test_status_codes_and_preload(programs, tmp_path):
    """An unreachable pose gets NaN and status 1 (as Evaluator.modes(invalid="nan")); a
    gravity preload switched on is refused (ET_HELI4_ERR_PRELOAD, exit 13 here)."""
    prog = programs["heli4"][0]
    ev = eigentwist.load("heli4", backend="numpy")
    names = [line.split()[0] for line in _run(prog, "names").splitlines()]
    poses = np.array([[0.0, 0.0, -0.6], [0.0, 0.0, -1.5], [0.02, 0.01, -0.58]])
    p = _solved_inputs(ev, "paper", {})
    data = tmp_path / "in.txt"
    data.write_text(f"3\n{' '.join(map(repr, poses.ravel().tolist()))}\n{' '.join(repr(p[n]) for n in names)}\n")
    rows = np.array([[float(v) for v in line.split()] for line in _run(prog, data).splitlines()])
    modes = ev.modes(poses, "paper", invalid="nan", vectors=False)
    assert rows[:, 0].tolist() == [0, 1, 0] and not modes.valid[1]
    assert np.isnan(rows[1, 1:]).all()
    np.testing.assert_allclose(
        rows[[0, 2], 1:], _library_frequencies(ev, poses[[0, 2]], "paper", {}), rtol=1e-12, atol=0
    )
    if "on_gravity_preload" in names:
        p = ev.inputs("paper,gravity_preload")
        data.write_text(f"1\n0 0 -0.6\n{' '.join(repr(p[n]) for n in names)}\n")
        res = subprocess.run([str(prog), str(data)], capture_output=True, text=True)
        assert res.returncode == 13


@pytest.mark.compiled
def test_generated_source_compiles_as_cxx(tmp_path):
    """``restrict`` does not stop the source compiling as C++ (a macro, ``__restrict`` there)."""
    cxx = _cxx()
    res = subprocess.run(
        [cxx, "-fsyntax-only", "-x", "c++", str(GENERATED / "heli4_c.c")], capture_output=True, text=True
    )
    assert res.returncode == 0, res.stderr[-3000:]


@pytest.mark.compiled
def test_readme_c_example_builds_and_runs(tmp_path):
    """The README's C example, built with the README's build line, prints the six frequencies
    that Python's default model gives, to 1e-12 (its defaults are that model: no penalty)."""
    text = (ROOT / "README.md").read_text()
    block = re.search(r"```c\n(.*?)```", text, re.S).group(1)
    line = re.search(r"^\s*(cc .*?-lm)$", text, re.M).group(1)
    (tmp_path / "example.c").write_text(block)
    # -O0 instead of -O2: the same program, compiled in a third of the time
    cmd = [a.replace("-O2", "-O0") for a in line.replace("eigentwist/generated", str(GENERATED)).split()]
    res = subprocess.run(cmd, cwd=tmp_path, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr[-3000:]
    out = subprocess.run([str(tmp_path / cmd[cmd.index("-o") + 1])], capture_output=True, text=True).stdout
    want = eigentwist.load("heli4", backend="numpy").frequencies([0.0, 0.0, -0.6], k_a=2000.0)[0]
    got = np.array([float(v) for v in re.findall(r"\d+\.\d+", out)])
    assert len(got) == 6
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=0)
