"""The C sensitivity kernel split into bounded functions.

gcc's time on one straight-line function grows faster than its length, so the generated
code is cut into parts of at most ``CHUNK`` statements, values crossing a cut passing
through a block buffer. Cut very finely here (every 40 statements: dozens of parts, most
values crossing several cuts), the C kernel must still equal the unsplit NumPy kernel.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

import eigentwist
from eigentwist.codegen import sensitivity as codegen
from eigentwist.symbolic import derive

from .conftest import random_poses

WRT = ("k_a", "E_rod")


@pytest.fixture(scope="module")
def kernel():
    ev = eigentwist.load("delta", backend="numpy")
    return ev, codegen.sensitivity_kernel(derive(ev.robot), WRT)


def test_parts_are_bounded_and_every_crossing_value_is_stored_before_it_is_read(kernel, monkeypatch):
    ev, kern = kernel
    monkeypatch.setattr(codegen, "CHUNK", 40)
    text = codegen.render_c_sensitivity(ev.robot, kern, WRT)
    bodies = re.findall(r"_part(\d+)\(const double[^{]*\{(.*?)\n\}\n", text, flags=re.S)
    n_statements = len(kern.body)
    assert len(bodies) == -(-n_statements // 40) > 10
    stored: set = set()
    for _, body in bodies:
        loads = set(re.findall(r"= et_s\[(\d+) \* ET_SPILL_STRIDE \+ et_i\];", body))
        assert loads <= stored  # defined by an earlier part
        stored |= set(re.findall(r"et_s\[(\d+) \* ET_SPILL_STRIDE \+ et_i\] =", body))
        own = len(re.findall(r"^        (?:const double \w+ = (?!et_)|et_o\d+\[et_i\] =)", body, flags=re.M))
        assert own - body.count("= et_x") <= 40


@pytest.mark.compiled
def test_finely_split_c_kernel_equals_numpy(kernel, monkeypatch):
    from eigentwist.runtime.ccompile import build_library, find_compiler, flag_sets
    from eigentwist.runtime.sensitivity import _CKernel, _numpy_kernel

    ev, kern = kernel
    monkeypatch.setattr(codegen, "CHUNK", 40)
    text = codegen.render_c_sensitivity(ev.robot, kern, WRT)
    # the cuts' data flow is under test, not the optimiser: -O0 compiles the dozens of parts fastest
    flags = ["-O0" if f == "-O3" else f for f in flag_sets()[0][1]]
    c = _CKernel(build_library(text, "delta_sens_split_test", find_compiler(), flags)).bind("et_delta_sens")
    py = _numpy_kernel(codegen.render_numpy_sensitivity(ev.robot, kern, WRT), "delta_sens_split_test")
    poses = random_poses(ev.robot, 70, seed=8)  # more than one block of 64
    p = ev.resolver.resolve(len(poses), {"E_rod": 1.5e11}, "paper")
    a, b = py(poses[:, 0], poses[:, 1], poses[:, 2], p), c(poses[:, 0], poses[:, 1], poses[:, 2], p)
    assert np.abs(a["dK_F"]).max() > 0 and np.abs(a["M"]).max() > 0
    for name in a:
        scale = np.abs(a[name]).max()
        assert np.allclose(b[name], a[name], rtol=1e-12, atol=1e-12 * scale), name


def test_gccs_flags_raise_its_data_reference_bound_to_the_parts_size():
    from eigentwist.runtime.sensitivity import LOOP_DATAREFS, NATIVE_SKIPPED, kernel_flags

    native = kernel_flags("native", ["-O3", "-march=native"])
    assert native[:2] == ["-O2", "-march=native"]
    assert native[2:] == ["--param", f"loop-max-datarefs-for-datadeps={LOOP_DATAREFS}", *NATIVE_SKIPPED]
    assert LOOP_DATAREFS >= 4 * codegen.CHUNK  # four references a statement of a full-size part
    assert all(f.startswith("-fno-") for f in NATIVE_SKIPPED)
    # the other sets are for compilers that refuse gcc's options (clang): no --param there
    assert kernel_flags("vector", ["-O3", "-march=native"]) == ["-O2", "-march=native"]
    assert kernel_flags("portable", ["-O3"]) == ["-O2"]


@pytest.mark.compiled
def test_every_part_of_the_kernel_vectorises_under_gcc(kernel, tmp_path):
    """gcc gives up on a loop with more data references than its bound and leaves it scalar
    (``omp simd`` or not); with the kernel's flags every part's pose loop is reported
    vectorised (``-fopt-info-vec``), and with a bound below a part's references, as gcc's
    default of 1 000 is below a full-size part's, the same loops are not. Needs gcc, as the
    flags do."""
    import subprocess

    from eigentwist.runtime.ccompile import find_compiler, flag_sets
    from eigentwist.runtime.sensitivity import kernel_flags

    cc = find_compiler()
    version = subprocess.run([cc, "--version"], capture_output=True, text=True).stdout.lower()
    name, flags = flag_sets()[0]
    if "free software foundation" not in version or name != "native":
        pytest.skip(f"{cc} is not gcc with its native flag set: the kernel's flags are another set")
    ev, kern = kernel
    text = codegen.render_c_sensitivity(ev.robot, kern, WRT)
    parts = len(re.findall(r"_part\d+\(const double", text))
    source = tmp_path / "kernel.c"
    source.write_text(text)

    def report(extra):
        cmd = [cc, *extra, "-fopt-info-vec-all", "-c", "-o", str(tmp_path / "k.o"), str(source)]
        out = subprocess.run(cmd, capture_output=True, text=True, check=True).stderr
        return len(re.findall(r"optimized: loop vectorized", out)), len(re.findall(r"exceeded param", out))

    vectorised, exceeded = report(kernel_flags(name, flags))
    assert parts >= 1 and exceeded == 0 and vectorised >= parts
    low, over = report(kernel_flags(name, flags) + ["--param", "loop-max-datarefs-for-datadeps=8"])
    assert over >= parts and low <= vectorised - parts
