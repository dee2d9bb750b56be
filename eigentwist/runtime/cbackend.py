"""Load the generated C source and expose it with the NumPy backend's interface.

``load_c_kernels(robot, numpy_module)`` compiles ``eigentwist/generated/<robot>_c.c``
with the system C compiler (``$CC``, else ``cc`` or ``gcc`` on ``PATH``) into a shared
library cached by content hash (:mod:`eigentwist.runtime.ccompile`), loads it with
:mod:`ctypes` and returns a :class:`CKernels` whose ``inverse_kinematics``,
``matrices``, ``jacobians`` and ``gravity`` take and return exactly what the generated
NumPy module's functions do. :meth:`CKernels.fused_frequencies` is the fast path for
sweeps: poses and parameters to natural frequencies in one C call.

Compiling is tried with vectorising flags first (``-march=native -fopenmp-simd
-fno-math-errno``, glibc's vector maths library on x86-64 Linux) and then with portable
ones (``-O3 -fPIC -shared``); a failure of both raises with the compiler's message.
"""
from __future__ import annotations

import ctypes
import json
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .ccompile import CompilerNotFoundError, build_library, cache_dir, find_compiler, flag_sets
from .eigen import normalize_eigentwists

__all__ = ["load_c_kernels", "CKernels", "CompilerNotFoundError", "CompileError", "find_compiler",
           "cache_dir", "build_library", "flag_sets", "source_path"]

ABI_VERSION = 1
GENERATED = Path(__file__).resolve().parent.parent / "generated"


class CompileError(RuntimeError):
    """The compiler failed on every flag set (the message holds its output)."""


def source_path(robot: str) -> Path:
    """The checked-in C source of ``robot``: ``eigentwist/generated/<robot>_c.c``."""
    return GENERATED / f"{robot}_c.c"


# ------------------------------------------------------------------- library
_F64P = ctypes.POINTER(ctypes.c_double)
_PTRS = ctypes.POINTER(ctypes.c_void_p)
_I64P = ctypes.POINTER(ctypes.c_int64)


def _bind(lib: ctypes.CDLL, sig: dict) -> dict:
    fns = {}
    for name, spec in sig["kernels"].items():
        fn = getattr(lib, spec["function"])
        fn.argtypes = [ctypes.c_int64, _PTRS, _I64P, _PTRS]
        fn.restype = ctypes.c_int
        fns[name] = fn
    fused = getattr(lib, sig["fused"]["function"])
    fused.argtypes = [ctypes.c_int64, _PTRS, _I64P, ctypes.c_int, _PTRS, _PTRS, _PTRS, _F64P, _F64P]
    fused.restype = ctypes.c_int
    eigh = getattr(lib, sig["eigh"]["function"])
    eigh.argtypes = [ctypes.c_int64, ctypes.c_int, _F64P, _F64P, _F64P, _F64P]
    eigh.restype = ctypes.c_int
    fns["fused"], fns["eigh"] = fused, eigh
    return fns


def _load(path: Path, robot: str):
    lib = ctypes.CDLL(str(path))           # RTLD_NOW: a missing vector-maths symbol fails here
    prefix = "et_" + "".join(c if c.isalnum() else "_" for c in robot)
    abi = getattr(lib, f"{prefix}_abi_version")
    abi.restype = ctypes.c_int
    if abi() != ABI_VERSION:
        raise OSError(f"{path}: ABI version {abi()} (expected {ABI_VERSION}): regenerate with `eigentwist generate`")
    sig_fn = getattr(lib, f"{prefix}_signature")
    sig_fn.restype = ctypes.c_char_p
    sig = json.loads(sig_fn().decode())
    return lib, sig


@dataclass
class Build:
    """Where a library came from: its path, the flag set's name and the flags."""

    path: Path
    flags_name: str
    flags: list


def compile_and_load(robot: str, source: str | None = None, directory: Path | None = None):
    """Compile (or reuse) and load the C library of ``robot``: ``(lib, signature, Build)``.

    Tries each of :func:`flag_sets` in turn; a flag set whose compilation or loading
    fails falls through to the next. Raises :class:`CompilerNotFoundError` or
    :class:`CompileError` (with the compiler's output) when nothing works.
    """
    cc = find_compiler()
    if source is None:
        path = source_path(robot)
        if not path.exists():
            raise FileNotFoundError(f"{path} does not exist: run `eigentwist generate`")
        source = path.read_text()
    errors = []
    for name, flags in flag_sets():
        try:
            lib_path = build_library(source, f"{robot}_c", cc, flags, directory)
        except subprocess.CalledProcessError as exc:
            errors.append(f"[{name}] {' '.join(exc.cmd)}\n{(exc.stderr or '').strip()[-2000:]}")
            continue
        except OSError as exc:                          # e.g. an unwritable cache directory
            errors.append(f"[{name}] building failed: {exc}")
            continue
        try:
            lib, sig = _load(lib_path, robot)
        except OSError as exc:                          # e.g. no vector maths library at run time
            errors.append(f"[{name}] loading {lib_path} failed: {exc}")
            continue
        return lib, sig, Build(lib_path, name, flags)
    raise CompileError(f"could not build the C backend of {robot!r} with {cc}:\n" + "\n".join(errors))


def load_c_kernels(robot: str, numpy_module=None, source: str | None = None) -> "CKernels":
    """The C kernels of ``robot``, with the generated NumPy module's interface.

    ``numpy_module`` (optional) is checked for the same outputs, so that a C source that
    is out of step with the NumPy module is reported instead of silently used. ``source``
    is the C text (default: the checked-in ``eigentwist/generated/<robot>_c.c``).
    """
    lib, sig, build = compile_and_load(robot, source)
    kernels = CKernels(lib, sig, build)
    if numpy_module is not None:
        want = {k: {o: tuple(s) for o, s in v.items()} for k, v in getattr(numpy_module, "OUTPUTS", {}).items()}
        if want and want != kernels.OUTPUTS:
            raise RuntimeError(f"the C library of {robot!r} and the NumPy module disagree on their outputs: "
                               "run `eigentwist generate`")
    return kernels


# ------------------------------------------------------------------ kernels
def _as_input(value, lead: tuple, keep: list) -> tuple[int, int]:
    """(address, stride) of one input broadcast to ``lead`` poses (copies only if needed)."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.size == 1:
        arr = np.ascontiguousarray(arr).reshape(1)
        keep.append(arr)
        return arr.ctypes.data, 0
    flat = np.ascontiguousarray(np.broadcast_to(arr, lead)).reshape(-1)
    keep.append(flat)
    return flat.ctypes.data, 1


def _check_rc(rc: int, what: str) -> None:
    if rc == -2:
        raise MemoryError(f"C {what}: out of memory for its block buffers")
    if rc != 0:
        raise RuntimeError(f"C {what} returned {rc}")


def _ptrs(addresses) -> ctypes.Array:
    return (ctypes.c_void_p * max(len(addresses), 1))(*addresses)


def _strides(values) -> ctypes.Array:
    return (ctypes.c_int64 * max(len(values), 1))(*values)


class CKernels:
    """The generated C library of one robot, with the NumPy module's four functions.

    ``inverse_kinematics(x, y, z, p)``, ``matrices(q, p)``, ``jacobians(q, p)`` and
    ``gravity(q, p)`` take arrays that broadcast against each other (``q``: (..., legs, 3)
    joint angles in rad; ``p``: parameter name -> scalar or array, SI units) and return
    dicts of float64 arrays of shape (...,) + output shape, as the NumPy backend does.
    """

    def __init__(self, lib: ctypes.CDLL, signature: dict, build: Build):
        self._lib = lib
        self.signature = signature
        self.build = build
        self.ROBOT = signature["robot"]
        self.SOURCE_HASH = signature["source_hash"]
        self._fn = _bind(lib, signature)
        self._spec = signature["kernels"]
        self.OUTPUTS = {k: {o: tuple(s) for o, s in v["outputs"]} for k, v in self._spec.items()}
        self.N_LEGS = self.OUTPUTS["inverse_kinematics"]["q"][0]

    def __repr__(self) -> str:
        return f"<eigentwist C kernels {self.ROBOT!r} ({self.build.flags_name}) {self.build.path}>"

    # ------------------------------------------------------------ plumbing
    def _run(self, kernel: str, lead: tuple, values: dict, q=None) -> dict:
        spec = self._spec[kernel]
        n = int(np.prod(lead, dtype=np.int64))
        outs = {name: np.empty(lead + tuple(shape)) for name, shape in spec["outputs"]}
        if n == 0:
            return outs
        keep: list = []
        addresses, strides = [], []
        if q is not None:
            legs = self.N_LEGS
            qa = np.ascontiguousarray(np.broadcast_to(np.asarray(q, dtype=np.float64), lead + (legs, 3)))
            qa = qa.reshape(n, legs * 3)
            keep.append(qa)
        for group, name, joint in spec["inputs"]:
            if group == "q":
                addresses.append(qa.ctypes.data + 8 * (joint[0] * 3 + joint[1]))
                strides.append(qa.shape[1])
            else:
                a, s = _as_input(values[name], lead, keep)
                addresses.append(a)
                strides.append(s)
        out_ptrs = _ptrs([o.ctypes.data for o in outs.values()])
        _check_rc(self._fn[kernel](n, _ptrs(addresses), _strides(strides), out_ptrs), kernel)
        return outs

    @staticmethod
    def _lead(shapes) -> tuple:
        return tuple(np.broadcast_shapes(*shapes))

    def _params(self, kernel: str, p: dict) -> dict:
        return {name: p[name] for group, name, _ in self._spec[kernel]["inputs"] if group == "param"}

    def _q_kernel(self, kernel: str, q, p: dict) -> dict:
        q = np.asarray(q, dtype=np.float64)
        if q.ndim < 2 or q.shape[-2:] != (self.N_LEGS, 3):
            raise ValueError(f"q has shape {q.shape}: expected (..., {self.N_LEGS}, 3) joint angles in rad")
        params = self._params(kernel, p)
        lead = self._lead([q.shape[:-2]] + [np.shape(v) for v in params.values()])
        return self._run(kernel, lead, params, q=q)

    # ------------------------------------------------- the NumPy interface
    def inverse_kinematics(self, x, y, z, p: dict) -> dict:
        """Joint angles ``q`` (..., legs, 3) in rad and the reachability quantities."""
        params = self._params("inverse_kinematics", p)
        values = dict(params, x=x, y=y, z=z)
        lead = self._lead([np.shape(v) for v in values.values()])
        return self._run("inverse_kinematics", lead, values)

    def matrices(self, q, p: dict) -> dict:
        """``M`` (kg, kg m, kg m^2), ``K_R``, ``K_F`` (N/m, N, N m/rad) at the EE origin, (..., 6, 6)."""
        return self._q_kernel("matrices", q, p)

    def jacobians(self, q, p: dict) -> dict:
        """Inverse-Jacobian rows ``J_rows`` (..., legs, 4, 6) and levers ``lever`` (..., legs), m."""
        return self._q_kernel("jacobians", q, p)

    def gravity(self, q, p: dict) -> dict:
        """Gravity-preload terms ``G``, ``Kqe``, ``k_act`` and ``W`` (see the NumPy module)."""
        return self._q_kernel("gravity", q, p)

    # ------------------------------------------------------- fast paths
    def generalized_eigh(self, K, M, vectors: bool = True):
        """``K v = lambda M v`` for (N, n, n) pairs, n = 6 or 3, in C (Cholesky + Jacobi).

        Same contract as :func:`eigentwist.runtime.eigen.generalized_eigh`: eigenvalues
        omega^2 in (rad/s)^2 ascending (N, n) and M-orthonormal eigenvectors as columns
        (N, n, n) (None when ``vectors`` is False). Only the upper triangles are read.
        """
        K = np.ascontiguousarray(K, dtype=np.float64)
        M = np.ascontiguousarray(M, dtype=np.float64)
        if K.shape != M.shape or K.ndim != 3 or K.shape[1] != K.shape[2] or K.shape[1] not in self.signature["eigh"]["dims"]:
            raise ValueError(f"K {K.shape} and M {M.shape}: expected equal shapes (N, n, n) with n in "
                             f"{self.signature['eigh']['dims']}")
        n, dim = K.shape[0], K.shape[1]
        lam = np.empty((n, dim))
        V = np.empty((n, dim, dim)) if vectors else None
        if n:
            rc = self._fn["eigh"](n, dim, K.ctypes.data_as(_F64P), M.ctypes.data_as(_F64P), lam.ctypes.data_as(_F64P),
                                  V.ctypes.data_as(_F64P) if vectors else None)
            _check_rc(rc, "eigh")
        bad = ~np.isfinite(lam).all(axis=1)
        if bad.any():
            k = int(np.argmax(bad))
            raise np.linalg.LinAlgError(f"pair {k}: M is not positive definite (or K, M are not finite)")
        return lam, V

    def fused(self, x, y, z, p: dict, *, matrices=("M", "K_F"), ik=(), jacobians=(), model=None,
              vectors: bool = False) -> dict:
        """Poses (m) and parameters to the requested outputs in one C call.

        ``matrices``, ``ik`` and ``jacobians`` name the kernel outputs to return (shapes as
        in :attr:`OUTPUTS`); ``model`` (``"flexible"``: M and K_F, 6x6; ``"rigid"``: the
        lower-right 3x3 of M and K_R) adds ``freq_hz`` (N, n), ascending, and with
        ``vectors`` the M-orthonormal eigentwists ``V`` (N, n, n) as columns. No input
        checks: use :meth:`fused_frequencies` or the evaluator for validated results.
        """
        spec = self.signature["fused"]
        values = {}
        for group, name in spec["inputs"]:
            values[name] = {"x": x, "y": y, "z": z}[name] if group == "pose" else p[name]
        lead = self._lead([np.shape(v) for v in values.values()])
        n = int(np.prod(lead, dtype=np.int64))
        keep: list = []
        addresses, strides = [], []
        for name in values:
            a, s = _as_input(values[name], lead, keep)
            addresses.append(a)
            strides.append(s)
        result: dict = {}

        def outputs(kernel, names):
            if not names:
                return None
            unknown = sorted(set(names) - set(self.OUTPUTS[kernel]))
            if unknown:
                raise KeyError(f"{kernel} has no output(s) {unknown}: expected {list(self.OUTPUTS[kernel])}")
            ptrs = []
            for name, shape in self.OUTPUTS[kernel].items():
                if name in names:
                    result[name] = np.empty(lead + shape)
                    ptrs.append(result[name].ctypes.data)
                else:
                    ptrs.append(None)
            return _ptrs(ptrs)

        ik_p, mat_p, jac_p = outputs("inverse_kinematics", ik), outputs("matrices", matrices), outputs("jacobians", jacobians)
        freq = vec = None
        model_id = 0
        if model is not None:
            if model not in spec["models"]:
                raise ValueError(f"model {model!r}: expected one of {spec['models']}")
            model_id = spec["models"].index(model)
            dim = self.signature["eigh"]["dims"][model_id]
            result["freq_hz"] = np.empty(lead + (dim,))
            freq = result["freq_hz"].ctypes.data_as(_F64P)
            if vectors:
                result["V"] = np.empty(lead + (dim, dim))
                vec = result["V"].ctypes.data_as(_F64P)
        if n:
            rc = self._fn["fused"](n, _ptrs(addresses), _strides(strides), model_id, ik_p, mat_p, jac_p, freq, vec)
            _check_rc(rc, "fused")
        return result

    def fused_frequencies(self, x, y, z, p: dict, model: str = "flexible", vectors: bool = False,
                          check: bool = True) -> dict:
        """Natural frequencies (Hz) of poses ``x, y, z`` (m) in one C call: the sweep fast path.

        ``p`` holds every parameter and effect switch (as the evaluator passes them to the
        kernels); ``model`` is ``"flexible"`` (M and K_F, 6 modes) or ``"rigid"`` (3x3
        translational subsets of M and K_R), Eq. 7. The gravity preload is not included
        (its switch must be off). Returns ``freq_hz`` (N, n) ascending, ``valid`` (N,) and,
        with ``vectors``, ``eigentwists`` (N, n, n) normalised so that each column's entry
        of largest magnitude is +1 (Eqs. 57, 65). Unreachable or singular poses raise the
        evaluator's errors when ``check``; otherwise they get NaN and ``valid`` False.
        """
        from ..description.effects import EFFECTS, switch_name
        from .errors import InputError

        preloads = [switch_name(n) for n, e in EFFECTS.items() if e.kind == "preload"]
        if any(np.any(np.asarray(p.get(s, 0.0)) != 0) for s in preloads):
            raise InputError("the fused C path has no gravity preload: switch it off or use Evaluator.frequencies")
        ik_names = [k for k in self.OUTPUTS["inverse_kinematics"] if k != "q"]
        jac_names = ["lever"] if "lever" in self.OUTPUTS["jacobians"] else []
        out = self.fused(x, y, z, p, matrices=(), ik=ik_names, jacobians=jac_names, model=model, vectors=vectors)
        valid = _validity(out, ik_names, p)
        if check and not valid.all():
            _raise_invalid(self.ROBOT, out, valid, ik_names, p, x, y, z)
        res = {"freq_hz": out["freq_hz"], "valid": valid}
        if vectors:
            res["eigentwists"] = normalize_eigentwists(out["V"])
        if not valid.all():
            res["freq_hz"][~valid] = np.nan
            if vectors:
                res["eigentwists"][~valid] = np.nan
        return res


def _lever_ratio(out: dict, p: dict) -> np.ndarray:
    """w_a1.t_a1 / l1 per leg, as the evaluator checks it."""
    return out["lever"] / np.asarray(p["l1"], dtype=float)[..., None]


def _validity(out: dict, ik_names: list, p: dict) -> np.ndarray:
    """Reachable, not singular (:mod:`.validity`) and finite; NaN counts as invalid."""
    from .validity import lever_mask, reachable_mask

    ok = np.isfinite(out["freq_hz"]).all(axis=-1)
    ik = {name: np.reshape(out[name], ok.shape + (-1,)) for name in ik_names}
    reach = reachable_mask(ik)
    if reach is not None:
        ok &= reach
    if "lever" in out:
        ok &= lever_mask(_lever_ratio(out, p))
    return ok


def _raise_invalid(robot: str, out: dict, valid: np.ndarray, ik_names: list, p: dict, x, y, z) -> None:
    """Raise the evaluator's error (:mod:`.validity`) for the first invalid pose."""
    from ..robots import get
    from .errors import UnreachablePoseError
    from .validity import raise_singular, raise_unreachable

    legs = get(robot).legs
    shape = valid.shape
    poses = np.stack([np.broadcast_to(c, shape).reshape(-1) for c in (x, y, z)], axis=-1)
    ik = {name: np.reshape(out[name], (poses.shape[0], -1)) for name in ik_names}
    raise_unreachable(legs, poses, ik)
    if "lever" in out:
        raise_singular(legs, poses, np.reshape(_lever_ratio(out, p), (poses.shape[0], -1)))
    k = int(np.argmax(~valid.reshape(-1)))
    raise UnreachablePoseError(f"pose {poses[k].tolist()} m gives non-finite frequencies")
