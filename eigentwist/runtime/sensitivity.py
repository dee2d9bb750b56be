"""Design sensitivities of the natural frequencies: generated kernels and eigenvalue derivatives.

``sensitivity_kernels(evaluator, wrt)`` returns a callable ``(x, y, z, p) -> dict`` with
M, K_R, K_F and their derivatives dM, dK_R, dK_F (N, P, 6, 6) with respect to the
parameters ``wrt``. The code is generated on demand (forward mode through the
straight-line program, :mod:`eigentwist.symbolic.sensitivity`) and cached by content
hash in :func:`~eigentwist.runtime.ccompile.cache_dir`: the key hashes the robot's
generated evaluator (its source hash), the parameter list and the code that derives and
renders the kernel, so a cache hit needs no SymPy at all. The C backend compiles the same
kernel with :func:`~eigentwist.runtime.ccompile.build_library`. With ``kind="rigid"`` or
``"flexible"`` it is the reverse-mode kernel of that stiffness model
(:mod:`eigentwist.codegen.adjoint`): the derivative of a weighted M and K with respect to
every parameter, which :func:`adjoint_eigen_derivatives` weights by each mode.

:func:`eigenvalue_derivatives` turns them into dλ/dp for ``K v = λ M v``:
dλ = vᵀ(dK − λ dM)v for M-orthonormal v; inside a cluster of (nearly) repeated
eigenvalues, the eigenvalues of the cluster's projected derivative
V_cᵀ(dK − λ dM)V_c, sorted ascending (the one-sided derivatives of the sorted eigenvalues
for an increasing p), never their mean.
"""

from __future__ import annotations

import ctypes
import inspect
import json
import types
from pathlib import Path

import numpy as np

from ..hashing import canonical, content_hash, package_digest
from .addresses import address
from .ccompile import private_directory, read_verified, write_verified
from .memo import NewestKept

__all__ = [
    "sensitivity_kernels",
    "eigenvalue_derivatives",
    "cache_key",
    "CLUSTER_RTOL",
    "DIFFERENCE_STEP",
    "clusters",
    "cluster_spans",
    "adjoint_eigen_derivatives",
    "weighted_derivatives",
    "check_wrt",
    "check_lowest",
    "kernel_flags",
    "LOOP_DATAREFS",
    "NATIVE_SKIPPED",
    "own_legs",
    "kernel_wrt",
    "shared_columns",
    "check_model",
    "frequency_derivatives",
    "frequency_sensitivities",
    "difference_step",
    "DIFFERENCE_STEP",
]

CLUSTER_RTOL = 1e-6  # frequencies closer than this (relative) form one cluster
#: relative step of ``method="differences"`` (central differences of M, K_R, K_F): truncation
#: ~1e-10 and round-off ~1e-11 of the matrices' derivatives
DIFFERENCE_STEP = 1e-5
_MEMORY: dict = {}
# the generated sensitivity kernels (before rendering) by cache key, the newest last: the
# other backend's text is rendered from them without deriving again
KERNELS_KEPT = 2  # a robot's NumPy and C kernels are usually asked for in turn, not interleaved with many others
_KERNELS = NewestKept(KERNELS_KEPT)
_ROBOTS: dict = {}


def difference_step(ev, name: str, params: dict) -> tuple[np.ndarray, np.ndarray]:
    """``(value, h)`` of parameter ``name`` (``P`` or a leg's own ``P@N``) for a finite
    difference: its value in ``params`` (else the shared ``P``'s, else the default) and the
    step :data:`DIFFERENCE_STEP` times the larger of that value and the default (1 where
    both are 0), in the parameter's SI unit."""
    base = name.partition("@")[0]
    value = np.asarray(params.get(name, params.get(base, ev.defaults[base])), dtype=float)
    scale = np.maximum(np.abs(value), abs(ev.defaults[base]))
    return value, DIFFERENCE_STEP * np.where(scale > 0, scale, 1.0)


#: the kinds of sensitivity kernel: ``"forward"`` (M, K_R, K_F and their derivatives, forward
#: mode) and, per stiffness model, the reverse-mode kernel of a weighted M and K
KINDS = ("forward", "rigid", "flexible")


def cache_key(ev, wrt, kind: str = "forward") -> str:
    """Content hash of what the kernel is made from (:func:`eigentwist.hashing.content_hash`): the
    evaluator's source hash, the robot's description (its functions by their code), ``wrt``, the
    kernel's ``kind`` (:data:`KINDS`) and the code that derives and renders the kernel (read from
    its files: no SymPy is imported)."""
    return content_hash(
        ev.robot.name,
        getattr(ev.module, "SOURCE_HASH", ""),
        _description_text(ev.robot),
        tuple(wrt),
        kind,
        package_digest(),
    )


def _generate(model, wrt, kind: str, progress):
    """The kernel of ``kind`` (:data:`KINDS`) for a derived model."""
    if kind == "forward":
        from ..codegen.sensitivity import sensitivity_kernel

        return sensitivity_kernel(model, wrt, progress=progress)
    from ..codegen.adjoint import adjoint_kernel

    return adjoint_kernel(model, wrt, kind, progress=progress)


def _source(ev, wrt, backend: str, progress, kind: str = "forward") -> str:
    """The ``backend`` (``"numpy"`` or ``"c"``) text of the kernel of ``kind`` from the cache, or
    generated and cached; the other backend's text is rendered when first asked for,
    from the same process's derivation where it is kept (:data:`KERNELS_KEPT`)."""
    key = cache_key(ev, wrt, kind)
    suffix = {"numpy": "py", "c": "c"}[backend]
    tag = "sens" if kind == "forward" else f"adjoint_{kind}"
    path = private_directory("sensitivities") / f"{ev.robot.name}_{tag}_{key}.{suffix}"
    found = read_verified(path)
    if found is not None:
        return found.decode("utf-8")
    from ..codegen.adjoint import METHOD
    from ..codegen.sensitivity import render_c_sensitivity, render_numpy_sensitivity

    say = progress or (lambda msg: None)
    kernel = _KERNELS.pop(key, None)
    if kernel is None:
        from ..symbolic import derive

        say(f"{ev.robot.name}: generating sensitivity code for {', '.join(wrt)} (once; cached in {path.parent})")
        say(f"{ev.robot.name}: derive")
        model = derive(ev.robot)
        kernel = _generate(model, wrt, kind, lambda m: say(f"{ev.robot.name}: {m}"))
    say(f"{ev.robot.name}: render")
    if backend == "numpy":
        text = render_numpy_sensitivity(ev.robot, kernel, wrt)
    else:
        text = render_c_sensitivity(ev.robot, kernel, wrt, *(() if kind == "forward" else (METHOD,)))
    write_verified(path, text.encode("utf-8"))
    _KERNELS.put(key, kernel)
    return text


def _numpy_kernel(text: str, name: str, function: str = "sensitivities"):
    module = types.ModuleType(name)
    exec(compile(text, name, "exec"), module.__dict__)
    fn = getattr(module, function)
    if "x" in inspect.signature(fn).parameters:
        return fn
    # a kernel that reads no pose argument (a 6-DoF robot's pose comes by name in ``p``)
    return lambda x, y, z, p: fn(p)


class _CKernel:
    """ctypes wrapper of the generated C sensitivity kernel (same calling convention as the evaluator's)."""

    def __init__(self, path: Path):
        self._lib = ctypes.CDLL(str(path))
        self.path = path
        self.signature = None

    def bind(self, prefix: str):
        sig = getattr(self._lib, f"{prefix}_signature")
        sig.restype = ctypes.c_char_p
        self.signature = json.loads(sig().decode())
        fn = getattr(self._lib, self.signature["function"])
        fn.argtypes = [
            ctypes.c_int64,
            ctypes.POINTER(ctypes.c_void_p),
            ctypes.POINTER(ctypes.c_int64),
            ctypes.POINTER(ctypes.c_void_p),
        ]
        fn.restype = ctypes.c_int
        self._fn = fn
        return self

    def __call__(self, x, y, z, p):
        values = dict(p, x=x, y=y, z=z)
        names = [name for _, name, _ in self.signature["inputs"]]
        lead = tuple(np.broadcast_shapes(*[np.shape(values[n]) for n in names]))
        n = int(np.prod(lead, dtype=np.int64))
        outs = {name: np.empty(lead + tuple(shape)) for name, shape in self.signature["outputs"]}
        if n == 0:
            return outs
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
            addr.append(address(arr))
        ins = (ctypes.c_void_p * len(addr))(*addr)
        st = (ctypes.c_int64 * len(strides))(*strides)
        out_ptrs = (ctypes.c_void_p * len(outs))(*[address(o) for o in outs.values()])
        rc = self._fn(n, ins, st, out_ptrs)
        if rc != 0:
            raise (
                MemoryError("C sensitivities: out of memory for the block buffers")
                if rc == -2
                else RuntimeError(f"C sensitivities returned {rc}")
            )
        return outs


#: data references gcc's dependence analysis takes in one loop: four per statement of a
#: kernel part (``codegen.sensitivity.CHUNK`` statements, each reading a few values, the
#: values crossing parts stored and loaded; tests/test_sensitivity_split.py holds the two
#: together). A part's pose loop has more than gcc's default of 1 000, and a loop it gives
#: up on is not vectorised, ``omp simd`` or not. A number, not read from ``codegen``: a
#: cached kernel is loaded without importing the code generator
LOOP_DATAREFS = 20_000
#: gcc passes the sensitivity kernel is compiled without (:func:`kernel_flags`)
NATIVE_SKIPPED = ("-fno-ivopts", "-fno-predictive-commoning")


def kernel_flags(name: str, flags: list) -> list:
    """The compiler flags of the sensitivity kernel from a flag set ``(name, flags)`` of
    :func:`.ccompile.flag_sets`: ``-O2`` for ``-O3`` (the kernel's split parts compile in
    time linear in their number; -O3 adds time, not speed, on this straight-line code) and,
    in the ``native`` (gcc) set, gcc's bound on a loop's data references raised to
    :data:`LOOP_DATAREFS`, so that every part's pose loop
    vectorises (under gcc's default a full-size part's loop stays scalar), and gcc's
    induction-variable optimisation and predictive commoning left out (:data:`NATIVE_SKIPPED`:
    on a vectorised part, with its thousands of memory references, they are about half of the
    compile and add no speed: ``benchmarks/README.md``)."""
    flags = ["-O2" if f == "-O3" else f for f in flags]
    if name == "native":
        flags += ["--param", f"loop-max-datarefs-for-datadeps={LOOP_DATAREFS}", *NATIVE_SKIPPED]
    return flags


def _c_kernel(text: str, robot: str):
    import re
    import subprocess

    from .ccompile import build_library, find_compiler, flag_sets

    cc = find_compiler()
    prefix = "et_" + re.sub(r"\W", "_", robot) + "_sens"
    errors = []
    for name, flags in flag_sets():
        flags = kernel_flags(name, flags)
        try:
            path = build_library(text, f"{robot}_sens", cc, flags)
            return _CKernel(path).bind(prefix)
        except (subprocess.CalledProcessError, OSError) as exc:
            errors.append(f"[{name}] {getattr(exc, 'stderr', '') or exc}"[-2000:])
    raise RuntimeError(f"could not build the C sensitivity kernel of {robot!r}:\n" + "\n".join(errors))


def _select(kern, columns):
    """A kernel that returns only the derivative rows ``columns`` of ``kern``'s outputs."""
    idx = np.asarray(columns)

    def run(x, y, z, p):
        out = kern(x, y, z, p)
        return {k: (v[:, idx] if k.startswith("d") or k == "g" else v) for k, v in out.items()}

    return run


def _description_text(robot) -> str:
    """The canonical text of a description (:func:`eigentwist.hashing.canonical`), once per robot object."""
    held = _ROBOTS.get(id(robot))
    if held is None or held[0] is not robot:
        held = _ROBOTS[id(robot)] = (robot, canonical(robot))  # tens of ms for a description
    return held[1]


def _base(ev, kind: str = "forward") -> tuple:
    """What identifies an evaluator's kernels of ``kind`` in memory."""
    return ev.robot.name, getattr(ev.module, "SOURCE_HASH", ""), _description_text(ev.robot), ev.backend, kind


def sensitivity_kernels(ev, wrt, progress=None, kind: str = "forward"):
    """The sensitivity kernel of evaluator ``ev`` for parameters ``wrt`` (its backend).

    ``kind`` (:data:`KINDS`): ``"forward"`` gives ``(x, y, z, p) -> {M, K_R, K_F, dM, dK_R,
    dK_F}``; ``"rigid"`` or ``"flexible"`` the reverse-mode kernel ``(x, y, z, p) -> {g}`` of
    that stiffness model, ``p`` holding the weights ``w_M_i_j``, ``w_K_i_j``
    (:mod:`eigentwist.codegen.adjoint`). Generated once per content hash (seconds to a
    minute, ``progress`` called with messages), then loaded from the cache; kept in memory
    for the process. A kernel already loaded for a superset of ``wrt`` is reused (its rows
    selected).
    """
    from .errors import InputError

    if kind not in KINDS:
        raise InputError(f"kind={kind!r}: expected one of {', '.join(KINDS)}")
    wrt = tuple(wrt)
    base = _base(ev, kind)
    if (base, wrt) in _MEMORY:
        return _MEMORY[base, wrt]
    for (b, w), kern in list(_MEMORY.items()):
        if b == base and set(wrt) <= set(w):
            _MEMORY[base, wrt] = _select(kern, [w.index(name) for name in wrt])
            return _MEMORY[base, wrt]
    key = cache_key(ev, wrt, kind)
    text = _source(ev, wrt, "c" if ev.backend == "c" else "numpy", progress, kind)
    if ev.backend == "c":
        if progress:
            progress(f"{ev.robot.name}: compile (cached by content hash)")
        kern = _c_kernel(text, ev.robot.name)
    else:
        function = "sensitivities" if kind == "forward" else "adjoint"
        kern = _numpy_kernel(text, f"eigentwist_sens_{ev.robot.name}_{key}", function)
    _MEMORY[base, wrt] = kern
    return kern


# ------------------------------------------------------------ eigenvalue derivatives
def clusters(lam: np.ndarray, rtol: float = CLUSTER_RTOL) -> np.ndarray:
    """(N, n-1) bool: eigenvalues k and k+1 (ascending) belong to one cluster.

    Neighbours are joined when their frequencies differ by less than ``rtol`` relative
    (on omega^2: ``lam[k+1] - lam[k] <= 2 rtol lam[k+1]``).
    """
    lam = np.asarray(lam)
    scale = np.maximum(np.abs(lam[:, 1:]), np.finfo(float).tiny)
    return (lam[:, 1:] - lam[:, :-1]) <= 2 * rtol * scale


def eigenvalue_derivatives(lam, V, dK, dM, rtol: float = CLUSTER_RTOL) -> np.ndarray:
    """dλ/dp of ``K v = λ M v`` for every mode and parameter: (N, n, P).

    lam : (N, n) ascending; V : (N, n, n) M-orthonormal eigenvectors (columns);
    dK, dM : (N, P, n, n) derivatives of K and M. Clusters (:func:`clusters`) get the
    sorted eigenvalues of V_cᵀ(dK − λ̄ dM)V_c (λ̄ the cluster's mean eigenvalue).
    """
    Vb = V[:, None]  # (N, 1, n, n)
    dK_d = np.sum(Vb * (dK @ Vb), axis=-2)  # (N, P, n): v_k^T dK v_k
    dM_d = np.sum(Vb * (dM @ Vb), axis=-2)
    out = np.swapaxes(dK_d - lam[:, None, :] * dM_d, 1, 2).copy()
    for r, sl in cluster_spans(clusters(lam, rtol)):
        mean = lam[r, sl].mean()
        Vc = V[r][:, sl]
        P = Vc.T @ dK[r] @ Vc - mean * (Vc.T @ dM[r] @ Vc)
        P = 0.5 * (P + np.swapaxes(P, -1, -2))
        out[r, sl, :] = np.linalg.eigvalsh(P).T
    return out


def cluster_spans(joined: np.ndarray):
    """``(row, slice)`` of every cluster of two or more eigenvalues, from :func:`clusters`'
    (N, n-1) flags."""
    n = joined.shape[1] + 1
    for r in np.flatnonzero(joined.any(axis=1)):
        k = 0
        while k < n:
            e = k
            while e < n - 1 and joined[r, e]:
                e += 1
            if e > k:
                yield int(r), slice(k, e + 1)
            k = e + 1


def _weights(W: np.ndarray, matrix: str) -> dict:
    """The kernel's weight inputs of symmetric (R, 6, 6) weights ``W`` of ``matrix`` ("M"
    or "K"): W_ii on the diagonal, W_ij + W_ji = 2 W_ij above it."""
    from ..description.weights import weight_name

    return {weight_name(matrix, i, j): W[:, i, j] * (1.0 if i == j else 2.0) for i in range(6) for j in range(i, 6)}


def weighted_derivatives(kern, x, y, z, p: dict, W_M: np.ndarray, W_K: np.ndarray, extra=None) -> np.ndarray:
    """(N, R, P): d/dp of <W_M, M> + <W_K, K> (the sums of W_ij X_ij) for R symmetric
    weightings per pose (``W_M``, ``W_K``: (N, R, 6, 6)), by the reverse-mode kernel ``kern``
    (its inputs ``x, y, z, p`` for N poses; one kernel row per pose and weighting, each giving
    every parameter at once) plus ``extra`` (dM, dK) (N, P, 6, 6) contracted alike."""
    from .completion import user_rows

    n, r = W_M.shape[:2]
    rows = user_rows(p, np.repeat(np.arange(n), r), n)  # each pose's values on its R rows
    rows.update(_weights(W_K.reshape(n * r, 6, 6), "K"))
    rows.update(_weights(W_M.reshape(n * r, 6, 6), "M"))
    g = kern(np.repeat(x, r), np.repeat(y, r), np.repeat(z, r), rows)["g"].reshape(n, r, -1)
    if extra is not None:
        dM, dK = extra
        g = g + np.einsum("nrij,npij->nrp", W_K, dK) + np.einsum("nrij,npij->nrp", W_M, dM)
    return g


def _weighted(kern, x, y, z, p: dict, U: np.ndarray, UT: np.ndarray, lam: np.ndarray, extra) -> np.ndarray:
    """(N, R, P): d/dp of u_rᵀ K t_r − λ_r u_rᵀ M t_r, symmetrised, for R pairs of twists per
    pose (``U``, ``UT``: (N, 6, R); ``lam`` (N, R)): :func:`weighted_derivatives` with
    W_K = (u tᵀ + t uᵀ) / 2 and W_M = −λ W_K."""
    W = 0.5 * (np.einsum("nir,njr->nrij", U, UT) + np.einsum("nir,njr->nrij", UT, U))  # (N, R, 6, 6)
    return weighted_derivatives(kern, x, y, z, p, -lam[:, :, None, None] * W, W, extra)


def adjoint_eigen_derivatives(
    kern, x, y, z, p: dict, M, K, E, rtol: float = CLUSTER_RTOL, extra=None, lowest=None, eigh=None
):
    """``(lam, V, dlam)`` of ``Eᵀ K E v = λ Eᵀ M E v`` from the reverse-mode kernel.

    ``kern``: :func:`sensitivity_kernels` of kind ``"rigid"`` or ``"flexible"``; ``x, y, z, p``
    its inputs for N poses; ``M``, ``K`` (N, 6, 6) the matrices at those inputs; ``E`` (6, n)
    or (N, 6, n) the twists the eigenproblem is posed on (the identity, the translations, a
    point platform's allowed twists); ``extra``: further (dM, dK) (N, P, 6, 6) to add (a
    lower-mobility platform's followers). dλ_k/dp = u_kᵀ(dK − λ_k dM)u_k with u_k = E v_k, each
    mode one weighting of the kernel: every parameter in one reverse sweep; a cluster of
    repeated eigenvalues (:func:`clusters`) gets the sorted eigenvalues of its pairs'
    projected derivative u_aᵀ(dK − λ̄ dM)u_b, as :func:`eigenvalue_derivatives`. ``lowest``:
    the derivatives of the lowest ``lowest`` modes only (``dlam`` (N, lowest, P); one kernel
    row a pose and mode, so the kernel's work falls in proportion); a cluster across that cut
    is solved whole and its lowest members kept. None: every mode. ``eigh``: the batch solver
    of the reduced pencil, ``(K, M) -> (lam, V)`` (None: LAPACK's,
    :func:`~eigentwist.runtime.eigen.generalized_eigh`).
    """
    from .completion import take
    from .eigen import generalized_eigh

    E = np.asarray(E, dtype=float)
    Mr = np.swapaxes(E, -1, -2) @ M @ E
    Kr = np.swapaxes(E, -1, -2) @ K @ E
    lam, V = (eigh or generalized_eigh)(Kr, Mr)
    U = E @ V  # (N, 6, n): the modes as twists
    k = lam.shape[1] if lowest is None else min(int(lowest), lam.shape[1])
    dlam = _weighted(kern, x, y, z, p, U[:, :, :k], U[:, :, :k], lam[:, :k], extra)
    for r, sl in cluster_spans(clusters(lam, rtol)):
        if sl.start >= k:
            continue
        a, b = np.triu_indices(sl.stop - sl.start)
        one = take({name: np.asarray(v) for name, v in p.items()}, slice(r, r + 1))
        Ur = U[r : r + 1, :, sl]
        mean = np.full((1, len(a)), lam[r, sl].mean())
        more = None if extra is None else tuple(d[r : r + 1] for d in extra)
        g = _weighted(kern, x[r : r + 1], y[r : r + 1], z[r : r + 1], one, Ur[:, :, a], Ur[:, :, b], mean, more)[0]
        P = np.zeros((dlam.shape[2], len(Ur[0, 0]), len(Ur[0, 0])))
        P[:, a, b] = g.T
        P[:, b, a] = g.T
        stop = min(sl.stop, k)
        dlam[r, sl.start : stop, :] = np.linalg.eigvalsh(P).T[: stop - sl.start]
    return lam, V, dlam


# ------------------------------------------------------------ frequencies
def check_wrt(ev, wrt) -> tuple:
    """``wrt`` as a tuple of distinct parameter names of ``ev`` (None: every parameter)."""
    from .errors import InputError

    if wrt is None:
        return tuple(ev.parameters)
    if isinstance(wrt, str):
        wrt = tuple(w.strip() for w in wrt.split(",") if w.strip())
    wrt = tuple(wrt)
    unknown = [w for w in wrt if w not in ev.parameters and not ev.accepts(w)]
    if unknown or not wrt or len(set(wrt)) != len(wrt):
        what = (
            f"unknown parameter(s) {', '.join(map(repr, unknown))}"
            if unknown
            else "an empty list"
            if not wrt
            else f"repeated names in {list(wrt)}"
        )
        legs = (
            f" (NAME@N, N in 1..{ev.n_legs}, for one leg's own value of {', '.join(ev.leg_parameters)})"
            if ev.leg_parameters
            else ""
        )
        raise InputError(
            f"wrt: {what} for {ev.robot.name}: expected distinct names from {', '.join(ev.parameters)}{legs}"
        )
    return wrt


def own_legs(wrt, params: dict) -> dict:
    """``{P: [P@N, ...]}``: shared parameters in ``wrt`` that some legs override in ``params``.

    The kernel's derivative with respect to a shared P moves every leg's copy with P; a leg
    given its own value (``P@N`` in ``params``) does not follow P, so its column
    d/dP@N is subtracted (:func:`shared_columns`).
    """
    out: dict = {}
    for key in params:
        name, at, _ = key.partition("@")
        if at and name in wrt:
            out.setdefault(name, []).append(key)
    return {k: sorted(v) for k, v in out.items()}


def kernel_wrt(wrt, own: dict) -> tuple:
    """``wrt`` and the one-leg names that :func:`shared_columns` needs, without repeats."""
    extra = [n for name in wrt for n in own.get(name, ()) if n not in wrt]
    return tuple(wrt) + tuple(dict.fromkeys(extra))


def shared_columns(dfdp: np.ndarray, wrt, full, own: dict) -> np.ndarray:
    """Columns ``wrt`` of ``dfdp`` (computed for ``full``): d/dP less d/dP@N of legs with their own P."""
    out = dfdp[..., [full.index(n) for n in wrt]].copy()
    for j, name in enumerate(wrt):
        for leg_name in own.get(name, ()):
            out[..., j] -= dfdp[..., full.index(leg_name)]
    return out


def check_model(effects) -> None:
    """Raise :class:`InputError` for a model whose sensitivities are not generated."""
    from .errors import InputError

    if "gravity_preload" in effects:
        raise InputError(
            "sensitivities of a model with gravity_preload are not available: its stiffness is solved "
            "at run time (a static solve), not generated; drop gravity_preload from the model"
        )
    from ..description.effects import EFFECTS, base_name

    damping = [e for e in effects if base_name(e) in EFFECTS and EFFECTS[base_name(e)].primitive == "damping"]
    if damping:
        raise InputError(
            f"sensitivities of a model with {', '.join(damping)} are not available: its damped modes are "
            "solved at run time (runtime.damped), not generated; use central differences"
        )


def frequency_derivatives(out: dict, rigid: bool, rtol: float = CLUSTER_RTOL, translational: bool = True, basis=None):
    """``(freq_hz, eigentwists, dfdp)`` from one sensitivity-kernel output.

    df/dp = (1/2π) dω/dp with dω/dp = φᵀ(dK − ω² dM)φ / (2ω φᵀMφ) (Hz per SI unit,
    (N, n_modes, P)); clusters of repeated frequencies (relative ``rtol``) get individual
    derivatives (:func:`eigenvalue_derivatives`). Rigid models use the 3x3 translational
    subsets of M and K_R (the full 6x6 for a 6-DoF robot: ``translational=False``),
    flexible ones M and K_F. ``basis`` (6 x n, constant: a pose space's fixed allowed
    twists, e.g. a point platform's translations in the plane) reduces a rigid model to
    ``B^T M B`` and ``B^T K_R B`` instead (and their derivatives alike).
    """
    from .eigen import frequencies_hz, generalized_eigh, normalize_eigentwists

    kname = "K_R" if rigid else "K_F"
    if rigid and basis is not None:
        B = np.asarray(basis, dtype=float)
        M, K = B.T @ out["M"] @ B, B.T @ out[kname] @ B
        dM, dK = B.T @ out["dM"] @ B, B.T @ out["d" + kname] @ B
    else:
        sub = slice(3, 6) if rigid and translational else slice(0, 6)
        M, K = out["M"][:, sub, sub], out[kname][:, sub, sub]
        dM, dK = out["dM"][:, :, sub, sub], out["d" + kname][:, :, sub, sub]
    lam, V = generalized_eigh(K, M)
    dlam = eigenvalue_derivatives(lam, V, dK, dM, rtol)
    omega = np.sqrt(np.clip(lam, 0.0, None))
    with np.errstate(divide="ignore", invalid="ignore"):
        dfdp = dlam / (2 * omega[..., None]) / (2 * np.pi)
    return frequencies_hz(lam), normalize_eigentwists(V), dfdp


def frequency_sensitivities(
    ev,
    poses,
    wrt=None,
    model="paper",
    params=None,
    *,
    rtol: float = CLUSTER_RTOL,
    progress=None,
    method: str = "exact",
    lowest=None,
):
    """``(Modes, dfdp)`` of evaluator ``ev``: see :meth:`Evaluator.modes_and_sensitivities`."""
    return ev.modes_and_sensitivities(
        poses, wrt, model, rtol=rtol, progress=progress, method=method, lowest=lowest, **(params or {})
    )


def check_lowest(lowest):
    """``lowest``, the number of lowest modes whose derivatives are asked for, checked: None
    (every mode) or a whole number >= 1 (a model with fewer modes gives all of its own)."""
    from .errors import InputError

    if lowest is None:
        return None
    if isinstance(lowest, bool) or not isinstance(lowest, (int, np.integer)) or lowest < 1:
        raise InputError(f"lowest = {lowest!r}: expected None (every mode) or a whole number of modes >= 1")
    return int(lowest)
