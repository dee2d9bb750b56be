"""The pipelines the benchmark compares, each from poses (N, 3) in m to M + K_F and to
the six natural frequencies (Hz) of the paper's flexible model (Heli4, ``"paper"``).

(a) ``per_pose``: benchmarks/reference_loop.py, a Python loop over poses with numeric 6x6
    products and ``scipy.linalg.eigh`` per pose;
(b) ``lambdify``: ``sympy.lambdify(..., cse=True)`` of the fully expanded closed forms
    (``Program.expand``), called on chunks of 4096 poses;
(c) ``numpy``: the generated NumPy module's kernels on chunks of 4096 poses, then the
    batched eigen-solver (``generalized_eigvalsh``);
(d) ``c``: the generated C library's fused pipeline in one call.

Extra end-to-end rows: the validated evaluator API on both backends and the checked C
fast path ``fused_frequencies``. Every pipeline writes full (N, 6, 6) M and K_F arrays (or
(N, 6) frequencies), so memory figures compare like with like.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

import reference_loop as ref

CHUNK = 4096


@dataclass
class Pipeline:
    """A named pipeline: ``matrices(poses) -> {"M", "K_F"}``, ``frequencies(poses) -> (N, 6)``."""

    key: str
    label: str
    matrices: Callable | None
    frequencies: Callable | None
    setup: dict = field(default_factory=dict)  # generation / compile times, s


def _upper_to_full(vals, n_poses):
    A = np.empty((n_poses, 6, 6))
    k = 0
    for i in range(6):
        for j in range(i, 6):
            A[:, i, j] = vals[k]
            A[:, j, i] = vals[k]
            k += 1
    return A


def per_pose(params: dict) -> Pipeline:
    """(a) The reference loop; ``timed(poses)`` splits matrices and eigen time in one pass."""
    from scipy.linalg import eigh

    def timed(poses):
        n = len(poses)
        M, K, F = np.empty((n, 6, 6)), np.empty((n, 6, 6)), np.empty((n, 6))
        t_mat = t_eig = 0.0
        clock = time.perf_counter
        for k, pose in enumerate(poses):
            t0 = clock()
            m = ref.matrices(pose, params)
            t1 = clock()
            lam = eigh(m["K_F"], m["M"], eigvals_only=True)
            F[k] = np.sqrt(np.clip(lam, 0, None)) / (2 * np.pi)
            t2 = clock()
            M[k], K[k] = m["M"], m["K_F"]
            t_mat += t1 - t0
            t_eig += t2 - t1
        return {"M": M, "K_F": K, "freq": F}, t_mat, t_mat + t_eig

    pipe = Pipeline(
        "per_pose",
        "(a) per-pose NumPy loop (reference_loop.py)",
        lambda poses: ref.matrices_loop(poses, params),
        lambda poses: ref.frequencies_loop(poses, params),
    )
    pipe.timed = timed
    return pipe


def lambdify_pipeline(derived, params: dict) -> Pipeline:
    """(b) ``sympy.lambdify`` (cse=True) of the expanded IK and upper triangles of M, K_F."""
    import sympy as sp

    from eigentwist.runtime.eigen import frequencies_hz, generalized_eigvalsh

    t0 = time.perf_counter()
    q_exprs = derived.ik.expand(sp.Matrix(derived.ik_outputs["q"][1]))
    (_, M), (_, K) = derived.outputs["matrices"]["M"], derived.outputs["matrices"]["K_F"]
    upper = [M[i * 6 + j] for i in range(6) for j in range(i, 6)] + [
        K[i * 6 + j] for i in range(6) for j in range(i, 6)
    ]
    mk_exprs = derived.program.expand(sp.Matrix(upper))
    t1 = time.perf_counter()
    pose_syms = list(derived.ik.inputs[:3])
    names = [s.name for s in derived.program.inputs if s not in derived.joints]
    ik_args = pose_syms + [s for s in derived.ik.inputs[3:]]
    ik_f = sp.lambdify(ik_args, list(q_exprs), modules="numpy", cse=True)
    mk_f = sp.lambdify(
        list(derived.joints) + [sp.Symbol(n, real=True) for n in names], list(mk_exprs), modules="numpy", cse=True
    )
    t2 = time.perf_counter()
    ik_vals = [params[s.name] for s in derived.ik.inputs[3:]]
    mk_vals = [params[n] for n in names]

    def matrices(poses):
        n = len(poses)
        out = {"M": np.empty((n, 6, 6)), "K_F": np.empty((n, 6, 6))}
        for s in range(0, n, CHUNK):
            P = poses[s : s + CHUNK]
            m = len(P)
            q = [np.broadcast_to(v, (m,)) for v in ik_f(P[:, 0], P[:, 1], P[:, 2], *ik_vals)]
            vals = [np.broadcast_to(v, (m,)) for v in mk_f(*q, *mk_vals)]
            out["M"][s : s + m] = _upper_to_full(vals[:21], m)
            out["K_F"][s : s + m] = _upper_to_full(vals[21:], m)
        return out

    def frequencies(poses):
        out = np.empty((len(poses), 6))
        for s in range(0, len(poses), CHUNK):
            m = matrices(poses[s : s + CHUNK])
            out[s : s + CHUNK] = frequencies_hz(generalized_eigvalsh(m["K_F"], m["M"]))
        return out

    return Pipeline(
        "lambdify",
        "(b) sympy.lambdify(cse=True), chunks of 4096",
        matrices,
        frequencies,
        {"expand_s": t1 - t0, "lambdify_s": t2 - t1},
    )


def numpy_pipeline(module, params: dict) -> Pipeline:
    """(c) The generated NumPy module on chunks, then the batched eigen-solver."""
    from eigentwist.runtime.eigen import frequencies_hz, generalized_eigvalsh

    def matrices(poses):
        n = len(poses)
        out = {"M": np.empty((n, 6, 6)), "K_F": np.empty((n, 6, 6))}
        for s in range(0, n, CHUNK):
            P = poses[s : s + CHUNK]
            q = module.inverse_kinematics(P[:, 0], P[:, 1], P[:, 2], params)["q"]
            m = module.matrices(q, params)
            out["M"][s : s + len(P)] = m["M"]
            out["K_F"][s : s + len(P)] = m["K_F"]
        return out

    def frequencies(poses):
        out = np.empty((len(poses), 6))
        for s in range(0, len(poses), CHUNK):
            P = poses[s : s + CHUNK]
            q = module.inverse_kinematics(P[:, 0], P[:, 1], P[:, 2], params)["q"]
            m = module.matrices(q, params)
            out[s : s + len(P)] = frequencies_hz(generalized_eigvalsh(m["K_F"], m["M"]))
        return out

    return Pipeline("numpy", "(c) generated NumPy module, chunks of 4096", matrices, frequencies)


def c_pipeline(kernels, params: dict) -> Pipeline:
    """(d) The generated C library's fused pipeline, one call for all poses."""

    def matrices(poses):
        x, y, z = (np.ascontiguousarray(poses[:, k]) for k in range(3))
        return kernels.fused(x, y, z, params, matrices=("M", "K_F"))

    def frequencies(poses):
        x, y, z = (np.ascontiguousarray(poses[:, k]) for k in range(3))
        return kernels.fused(x, y, z, params, matrices=(), model="flexible")["freq_hz"]

    return Pipeline(
        "c",
        "(d) generated C library, fused (IK, M, K_F, Cholesky + Jacobi)",
        matrices,
        frequencies,
        {"compile_s": getattr(kernels, "compile_s", float("nan"))},
    )


def extra_pipelines(ev_numpy, ev_c, kernels, params: dict) -> list[Pipeline]:
    """End-to-end rows through the validated APIs (input, reachability and lever checks)."""

    def checked(poses):
        x, y, z = (np.ascontiguousarray(poses[:, k]) for k in range(3))
        return kernels.fused_frequencies(x, y, z, params)["freq_hz"]

    return [
        Pipeline(
            "evaluator_numpy",
            "Evaluator.frequencies, NumPy backend (validated)",
            None,
            lambda poses: ev_numpy.frequencies(poses),
        ),
        Pipeline(
            "evaluator_c",
            "Evaluator.frequencies, C backend (validated, checks in the C pass, one thread)",
            None,
            lambda poses: ev_c.frequencies(poses),
        ),
        Pipeline("c_checked", "C fused_frequencies (reachability and lever checked)", None, checked),
    ]
