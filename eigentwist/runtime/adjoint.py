"""Design sensitivities of the natural frequencies by reverse mode: one backward sweep per mode.

For ``K φ = λ M φ`` with M-orthonormal φ, dλ/dp = φᵀ(∂K/∂p − λ ∂M/∂p)φ (Hoevenaars,
Krut, Herder 2020, Eq. 6 differentiated; λ = ω² in (rad/s)²): the contraction of the
matrices' derivatives with the seeds S_K = φφᵀ, S_M = −λφφᵀ. The generated adjoint kernel
(:mod:`eigentwist.codegen.adjoint`) returns the gradient of that contraction with respect
to every design parameter in one backward sweep of the straight-line program, so the cost
per mode does not grow with the number of parameters. Clusters of (nearly) repeated
eigenvalues get the eigenvalues of V_cᵀ(∂K − λ̄∂M)V_c, its entries from the seeds
sym(φ_i φ_jᵀ) of every pair in the cluster (as :func:`.sensitivity.eigenvalue_derivatives`).

The kernel is generated once per robot (``M``, ``K_R`` and ``K_F``: every model, every
parameter) and cached by content hash like the forward kernels
(:func:`.sensitivity.cache_key`), verified by its SHA-256 on reading: a NumPy module by
default (no compiler), or C through :func:`.ccompile.build_library` on request.
"""

from __future__ import annotations

import ctypes
import json
import re
import types

import numpy as np

from ..hashing import content_hash, package_digest
from .ccompile import private_directory, read_verified, write_verified
from .memo import NewestKept

__all__ = [
    "OUTPUTS",
    "adjoint_kernel",
    "adjoint_cache_key",
    "adjoint_frequency_derivatives",
    "seed_matrices",
    "parameter_columns",
    "TRIU",
]

#: upper-triangle indices (a <= b, row-major) of a 6x6 seed, the order of the kernel's seed inputs
TRIU = np.triu_indices(6)
_MEMORY: dict = {}
_KERNELS = NewestKept(2)
#: gcc's optimisation level for the C adjoint kernel (-O3 adds time, not speed, on straight-line code)
C_OPT = "-O2"


def adjoint_cache_key(ev, outputs) -> str:
    """Content hash of what the adjoint kernel is made from: the evaluator's source hash, the
    description, the matrices ``outputs`` and the package's code."""
    from .sensitivity import description_text

    return content_hash(
        "adjoint",
        ev.robot.name,
        getattr(ev.module, "SOURCE_HASH", ""),
        description_text(ev.robot),
        tuple(outputs),
        package_digest(),
    )


def _source(ev, outputs, backend: str, progress) -> str:
    key = adjoint_cache_key(ev, outputs)
    suffix = {"numpy": "py", "c": "c"}[backend]
    path = private_directory("sensitivities") / f"{ev.robot.name}_adj_{key}.{suffix}"
    found = read_verified(path)
    if found is not None:
        return found.decode("utf-8")
    from ..codegen.adjoint import adjoint_kernels, render_c_adjoint, render_numpy_adjoint

    say = progress or (lambda msg: None)
    held = _KERNELS.pop(key, None)
    if held is None:
        from ..symbolic import derive

        say(f"{ev.robot.name}: generating the adjoint sensitivity code (once; cached in {path.parent})")
        held = adjoint_kernels(derive(ev.robot), outputs, progress=lambda m: say(f"{ev.robot.name}: {m}"))
    k_m, k_g, k_c, targets = held
    say(f"{ev.robot.name}: render")
    if backend == "c":
        text = render_c_adjoint(ev.robot, k_c, outputs, targets)
    else:
        text = render_numpy_adjoint(ev.robot, (k_m, k_g), outputs, targets)
    write_verified(path, text.encode("utf-8"))
    _KERNELS.put(key, held)
    return text


class _NumpyAdjoint:
    """The NumPy adjoint kernel: ``matrices(x, y, z, p)`` and ``gradient(x, y, z, p, seed)``."""

    def __init__(self, text: str, name: str, outputs):
        module = types.ModuleType(name)
        exec(compile(text, name, "exec"), module.__dict__)
        self._m = module
        self.targets = module.TARGETS
        self.outputs = tuple(outputs)

    def matrices(self, x, y, z, p) -> dict:
        return self._m.adjoint_matrices(x, y, z, p)

    def gradient(self, x, y, z, p, seed) -> np.ndarray:
        seed = np.asarray(seed, dtype=float)  # (N, S, n_seed)
        names = [f"bar_{k}_{a}_{b}" for k in self.outputs for a, b in zip(*TRIU)]
        bars = {n: np.ascontiguousarray(seed[:, :, j].T) for j, n in enumerate(names)}
        g = self._m.adjoint_gradient(x, y, z, {**p, **bars})["grad"]  # (S, N, G)
        return np.moveaxis(np.broadcast_to(g, (seed.shape[1], seed.shape[0], len(self.targets))), 0, 1)


class _CAdjoint:
    """ctypes wrapper of the generated C adjoint kernel."""

    def __init__(self, path, prefix: str):
        self._lib = ctypes.CDLL(str(path))
        self.path = path
        sig = getattr(self._lib, f"{prefix}_signature")
        sig.restype = ctypes.c_char_p
        self.signature = json.loads(sig().decode())
        fn = getattr(self._lib, self.signature["function"])
        fn.argtypes = [
            ctypes.c_int64,
            ctypes.c_int64,
            ctypes.POINTER(ctypes.c_void_p),
            ctypes.POINTER(ctypes.c_int64),
            ctypes.c_void_p,
            ctypes.POINTER(ctypes.c_void_p),
        ]
        fn.restype = ctypes.c_int
        self._fn = fn
        self.targets = tuple(self.signature["targets"])
        self.outputs = tuple(self.signature["outputs_of"])

    def _call(self, x, y, z, p, seed):
        values = dict(p, x=x, y=y, z=z)
        names = [name for _, name, _ in self.signature["inputs"]]
        lead = tuple(np.broadcast_shapes(*[np.shape(values[n]) for n in names]))
        n = int(np.prod(lead, dtype=np.int64))
        S = 0 if seed is None else seed.shape[1]
        outs = {k: np.empty(lead + (6, 6)) for k in self.outputs}
        grad = np.empty(lead + (S, len(self.targets)))
        if n == 0:
            return outs, grad
        keep, addr, strides = [], [], []
        for name in names:
            arr = np.asarray(values[name], dtype=np.float64)
            if arr.size == 1:
                arr = np.ascontiguousarray(arr).reshape(1)
                strides.append(0)
            else:
                arr = np.ascontiguousarray(np.broadcast_to(arr, lead)).reshape(-1)
                strides.append(1)
            keep.append(arr)
            addr.append(arr.ctypes.data)
        if seed is not None:
            seed = np.ascontiguousarray(np.broadcast_to(seed, lead + seed.shape[-2:]), dtype=np.float64)
        ins = (ctypes.c_void_p * len(addr))(*addr)
        st = (ctypes.c_int64 * len(strides))(*strides)
        ptrs = [o.ctypes.data for o in outs.values()] + [grad.ctypes.data]
        out_ptrs = (ctypes.c_void_p * len(ptrs))(*ptrs)
        rc = self._fn(n, S, ins, st, None if seed is None else seed.ctypes.data, out_ptrs)
        if rc != 0:
            raise (
                MemoryError("C adjoint sensitivities: out of memory for the block buffers")
                if rc == -2
                else RuntimeError(f"C adjoint sensitivities returned {rc}")
            )
        return outs, grad

    def matrices(self, x, y, z, p) -> dict:
        return self._call(x, y, z, p, None)[0]

    def gradient(self, x, y, z, p, seed) -> np.ndarray:
        return self._call(x, y, z, p, np.asarray(seed, dtype=float))[1]


def _c_adjoint(text: str, robot: str):
    import subprocess

    from .ccompile import build_library, find_compiler, flag_sets

    cc = find_compiler()
    prefix = "et_" + re.sub(r"\W", "_", robot) + "_adj"
    errors = []
    for name, flags in flag_sets():
        flags = [C_OPT if f == "-O3" else f for f in flags]
        try:
            return _CAdjoint(build_library(text, f"{robot}_adj", cc, flags), prefix)
        except (subprocess.CalledProcessError, OSError) as exc:
            errors.append(f"[{name}] {getattr(exc, 'stderr', '') or exc}"[-2000:])
    raise RuntimeError(f"could not build the C adjoint kernel of {robot!r}:\n" + "\n".join(errors))


#: the matrices of the adjoint kernel: one kernel serves the rigid (K_R) and flexible (K_F) models
OUTPUTS = ("M", "K_R", "K_F")


def adjoint_kernel(ev, outputs=OUTPUTS, progress=None, backend: str = "numpy"):
    """The adjoint kernel of evaluator ``ev`` for the matrices ``outputs``.

    Generated once per content hash (``progress`` called with messages), then loaded from
    the cache; kept in memory for the process. ``.matrices(x, y, z, p)`` returns the
    matrices (N, 6, 6); ``.gradient(x, y, z, p, seed)`` with ``seed`` (N, S, 21 per
    matrix, :data:`TRIU` order) returns (N, S, G), G over ``.targets`` (program inputs).

    ``backend="numpy"`` (the default, whatever ``ev``'s backend): the NumPy module, no
    compiler. ``"c"`` compiles the C kernel, which gcc takes minutes to optimise (the
    backward sweep reads most forward values through the spill buffer; see
    benchmarks/README.md): an opt-in for long runs on one cache.
    """
    from .sensitivity import evaluator_key

    outputs = tuple(outputs)
    if backend not in ("numpy", "c"):
        from .errors import InputError

        raise InputError(f"backend={backend!r}: expected 'numpy' or 'c'")
    mem = (evaluator_key(ev)[:3], outputs, backend)
    if mem in _MEMORY:
        return _MEMORY[mem]
    text = _source(ev, outputs, backend, progress)
    if backend == "c":
        if progress:
            progress(f"{ev.robot.name}: compile (cached by content hash)")
        kern = _c_adjoint(text, ev.robot.name)
    else:
        kern = _NumpyAdjoint(text, f"eigentwist_adj_{ev.robot.name}_{adjoint_cache_key(ev, outputs)}", outputs)
    _MEMORY[mem] = kern
    return kern


def prepare_sensitivities(ev, wrt, effects, progress=None) -> None:
    """Load (or generate) the kernel that :meth:`Evaluator.modes_and_sensitivities` with
    ``method="exact"`` uses for the model ``effects`` (resolved names): the adjoint kernel
    of a closed-form robot (every parameter at once), the forward kernel for ``wrt`` (a
    superset of the names later asked for: their rows are selected) where the followers of
    a lower-mobility platform move with the parameters; nothing for the routes that
    generate no code (legs solved by Newton, rigid models on turning allowed twists)."""
    rigid = ev.stiffness_model(effects) == "rigid"
    space = getattr(ev, "space", None)
    if ev.numeric_ik or (rigid and getattr(space, "basis", 0) is None):
        return
    if not rigid and getattr(space, "followers", ()):
        from .sensitivity import sensitivity_kernels

        sensitivity_kernels(ev, tuple(wrt), progress)
        return
    adjoint_kernel(ev, progress=progress)


def seed_matrices(u: np.ndarray, w: np.ndarray, lam: np.ndarray, outputs, kname: str) -> np.ndarray:
    """Seeds (..., 21 len(outputs)) of sym(u wᵀ) contracted with ∂K − λ∂M: S_M = −λ sym(u wᵀ)
    and S_K = sym(u wᵀ) for the stiffness ``kname``, zero for the other matrices of
    ``outputs``, each as its upper triangle (:data:`TRIU`). ``u``, ``w`` (..., 6)."""
    a, b = TRIU
    s = 0.5 * (u[..., a] * w[..., b] + w[..., a] * u[..., b])
    blocks = {"M": -lam[..., None] * s, kname: s}
    return np.concatenate([blocks.get(k, np.zeros_like(s)) for k in outputs], axis=-1)


def parameter_columns(targets, names) -> np.ndarray:
    """(G, len(names)) map from program-input gradients to d/dP (P and its legs' copies
    ``P__N``) or d/dP@N (the copy ``P__N`` alone)."""
    index = {t: i for i, t in enumerate(targets)}
    A = np.zeros((len(targets), len(names)))
    for j, name in enumerate(names):
        base, at, leg = name.partition("@")
        if at:
            rows = [index.get(f"{base}__{leg}")]
        else:
            rows = [index.get(name)] + [
                i for t, i in index.items() if t.startswith(f"{name}__") and t[len(name) + 2 :].isdigit()
            ]
        for r in rows:
            if r is not None:
                A[r, j] = 1.0
    return A


def adjoint_frequency_derivatives(
    kern, x, y, z, p, names, rigid: bool, rtol: float, translational: bool = True, basis=None
):
    """``(freq_hz, eigentwists, dfdp)`` as :func:`.sensitivity.frequency_derivatives`, by reverse mode.

    df/dp = dλ/dp / (2ω) / 2π in Hz per SI unit, (N, n_modes, len(names)); dλ/dp =
    φᵀ(∂K − λ∂M)φ per mode from one backward sweep each, clusters (relative ``rtol``)
    from the seeds of every pair in the cluster. Rigid models use the translational 3x3
    (``translational``) or the constant ``basis`` (6 x n) of the allowed twists.
    """
    from .eigen import frequencies_hz, generalized_eigh, normalize_eigentwists
    from .sensitivity import clusters

    out = kern.matrices(x, y, z, p)
    kname = "K_R" if rigid else "K_F"
    M, K = out["M"], out[kname]
    if rigid and basis is not None:
        B = np.asarray(basis, dtype=float)
    elif rigid and translational:
        B = np.eye(6)[:, 3:]
    else:
        B = np.eye(6)
    lam, V = generalized_eigh(B.T @ K @ B, B.T @ M @ B)
    phi = B @ V  # (N, 6, n): the modes as twists
    N, n = lam.shape
    joined = clusters(lam, rtol)
    lam_use = lam.copy()
    pairs = {}
    for r in np.flatnonzero(joined.any(axis=1)):
        label = np.concatenate([[0], np.cumsum(~joined[r])])
        for c in np.unique(label):
            members = np.flatnonzero(label == c)
            if len(members) > 1:
                lam_use[r, members] = lam[r, members].mean()
                pairs.setdefault(r, []).extend((i, j) for k, i in enumerate(members) for j in members[k + 1 :])
    extra = max((len(v) for v in pairs.values()), default=0)
    u = np.zeros((N, n + extra, 6))
    w = np.zeros((N, n + extra, 6))
    lam_s = np.zeros((N, n + extra))
    u[:, :n] = w[:, :n] = np.swapaxes(phi, 1, 2)
    lam_s[:, :n] = lam_use
    for r, pr in pairs.items():
        for k, (i, j) in enumerate(pr):
            u[r, n + k], w[r, n + k], lam_s[r, n + k] = phi[r, :, i], phi[r, :, j], lam_use[r, i]
    g = kern.gradient(x, y, z, p, seed_matrices(u, w, lam_s, kern.outputs, kname)) @ parameter_columns(
        kern.targets, names
    )  # (N, S, P)
    dlam = g[:, :n].copy()
    for r, pr in pairs.items():
        label = np.concatenate([[0], np.cumsum(~joined[r])])
        for c in np.unique(label):
            members = np.flatnonzero(label == c)
            if len(members) < 2:
                continue
            P = np.zeros((g.shape[-1], len(members), len(members)))
            for a_, i in enumerate(members):
                P[:, a_, a_] = g[r, i]
            for k, (i, j) in enumerate(pr):
                if i in members:
                    a_, b_ = int(np.flatnonzero(members == i)[0]), int(np.flatnonzero(members == j)[0])
                    P[:, a_, b_] = P[:, b_, a_] = g[r, n + k]
            dlam[r, members] = np.linalg.eigvalsh(P).T
    omega = np.sqrt(np.clip(lam, 0.0, None))
    with np.errstate(divide="ignore", invalid="ignore"):
        dfdp = dlam / (2 * omega[..., None]) / (2 * np.pi)
    return frequencies_hz(lam), normalize_eigentwists(V), dfdp
