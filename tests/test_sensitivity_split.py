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
