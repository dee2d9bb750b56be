"""Load the generated C source and expose it with the NumPy backend's interface.

``load_c_kernels(robot, numpy_module)`` compiles ``eigentwist/generated/<robot>_c.c``
with the system C compiler (``$CC``, else ``cc`` or ``gcc`` on ``PATH``) into a shared
library cached by content hash (:mod:`eigentwist.runtime.ccompile`), loads it with
:mod:`ctypes` and returns a :class:`CKernels` whose ``inverse_kinematics``,
``matrices``, ``jacobians`` and ``gravity`` take and return exactly what the generated
NumPy module's functions do. :meth:`CKernels.fused_frequencies` is the fast path for
sweeps: poses and parameters to natural frequencies in one C call.

Compiling is tried with vectorising flags first (``-march=native -fopenmp-simd
-fno-math-errno -fno-trapping-math``, gcc's ``-fdisable-tree-sincos`` and glibc's vector maths
library on x86-64 Linux), then with the vectorising flags alone (a compiler that refuses gcc's:
clang), then with portable ones (``-O3 -fPIC -shared``); a failure of all raises with the
compiler's messages (:func:`~eigentwist.runtime.ccompile.flag_sets`).
"""

from __future__ import annotations

import ctypes
import json
import re
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..generated import generated_name
from . import eigen, validity
from .addresses import address
from .ccompile import (
    BuildError,
    CompilerNotFoundError,
    build_library,
    cache_dir,
    find_compiler,
    flag_sets,
    read_shipped,
)
from .threads import run_ranges, threads_for
from .validity import LEVER_SCALE, STATUS

#: the names under which a 6-DoF robot's rotation vector (rad) reaches the fused pass
ROTATION_VECTOR = ("rot_x", "rot_y", "rot_z")

__all__ = [
    "load_c_kernels",
    "CKernels",
    "CompilerNotFoundError",
    "CompileError",
    "find_compiler",
    "cache_dir",
    "build_library",
    "flag_sets",
    "source_path",
]

ABI_VERSION = 3
GENERATED = Path(__file__).resolve().parent.parent / "generated"


class CompileError(BuildError):
    """The compiler failed on every flag set (the message holds its output)."""


def source_path(robot: str) -> Path:
    """The checked-in C source of ``robot``: ``eigentwist/generated/<robot>_c.c``."""
    return GENERATED / generated_name(robot, "c")


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
    fused.argtypes = [
        ctypes.c_int64,
        ctypes.c_int64,
        _PTRS,
        _I64P,
        ctypes.c_int,
        _PTRS,
        _PTRS,
        _PTRS,
        ctypes.c_void_p,
        ctypes.c_void_p,
        ctypes.c_void_p,
        _F64P,
    ]
    fused.restype = ctypes.c_int
    eigh = getattr(lib, sig["eigh"]["function"])
    eigh.argtypes = [ctypes.c_int64, ctypes.c_int, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
    eigh.restype = ctypes.c_int
    fns["fused"], fns["eigh"] = fused, eigh
    return fns


def _load(path: Path, robot: str):
    lib = ctypes.CDLL(str(path))  # RTLD_NOW: a missing vector-maths symbol fails here
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
        source = read_shipped(path).decode("utf-8")
    errors = []
    for name, flags in flag_sets():
        try:
            lib_path = build_library(source, f"{robot}_c", cc, flags, directory)
        except subprocess.CalledProcessError as exc:
            errors.append(f"[{name}] {' '.join(exc.cmd)}\n{(exc.stderr or '').strip()[-2000:]}")
            continue
        except OSError as exc:  # e.g. an unwritable cache directory
            errors.append(f"[{name}] building failed: {exc}")
            continue
        try:
            lib, sig = _load(lib_path, robot)
        except OSError as exc:  # e.g. no vector maths library at run time
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
        # the followers kernel of legs solved numerically is NumPy's alone
        want = {
            k: {o: tuple(s) for o, s in v.items()}
            for k, v in getattr(numpy_module, "OUTPUTS", {}).items()
            if k != "followers" or k in kernels.OUTPUTS
        }
        if want and want != kernels.OUTPUTS:
            raise RuntimeError(
                f"the C library of {robot!r} and the NumPy module disagree on their outputs: run `eigentwist generate`"
            )
    return kernels


# ------------------------------------------------------------------ kernels
def _inputs(values, lead: tuple, keep: list) -> tuple[list, list]:
    """(addresses, strides) of the inputs ``values`` (an iterable), each broadcast to ``lead``
    poses: the scalars (most parameters and switches) share one array, read with stride 0;
    a strided 1-D view, such as one column of an (N, 3) pose array, is read in place; other
    arrays are copied only if needed."""
    arrays = [np.asarray(v, dtype=np.float64) for v in values]
    scalar = [a.size == 1 for a in arrays]
    packed = np.array([a.reshape(-1)[0] if sc else 0.0 for a, sc in zip(arrays, scalar)], dtype=np.float64)
    keep.append(packed)
    base = address(packed)
    addresses, strides = [], []
    for k, (arr, sc) in enumerate(zip(arrays, scalar)):
        if sc:
            addresses.append(base + 8 * k)
            strides.append(0)
        elif arr.ndim == 1 and arr.shape == lead and arr.strides[0] > 0 and arr.strides[0] % 8 == 0:
            keep.append(arr)
            addresses.append(address(arr))
            strides.append(arr.strides[0] // 8)
        else:
            flat = np.ascontiguousarray(np.broadcast_to(arr, lead)).reshape(-1)
            keep.append(flat)
            addresses.append(address(flat))
            strides.append(1)
    return addresses, strides


def _driver_inputs(names: list, p: dict, n: int, keep: list) -> tuple[list, list]:
    """``(addresses, strides)`` of a C driver's kernel inputs: input k read from
    ``p[names[k]]`` for ``n`` poses (:func:`_inputs`), or, where ``names[k]`` is None, filled
    by the driver itself (address and stride 0)."""
    external = [name for name in names if name is not None]
    found = iter(zip(*_inputs((p[name] for name in external), (n,), keep))) if external else iter(())
    pairs = [next(found) if name is not None else (0, 0) for name in names]
    return [a for a, _ in pairs], [st for _, st in pairs]


def _fixed(v) -> bool:
    """Whether input ``v`` is a scalar that cannot change after the call (a Python or NumPy
    number, or a 0-d float64 array that owns its data and is read-only, as the evaluator's
    resolved parameters are): its packed value may be reused while the same object is passed."""
    t = type(v)
    if t is float or t is int or t is np.float64:
        return True
    return t is np.ndarray and v.ndim == 0 and v.dtype == np.float64 and v.base is None and not v.flags.writeable


class _Packed:
    """The scalar inputs of one call packed once, with the ctypes arrays of addresses and
    strides: reused by a later call that passes the very same (immutable, :func:`_fixed`)
    objects at the same positions, which then fills in only its per-pose arrays."""

    __slots__ = (
        "size",
        "fixed",
        "ids",
        "refs",
        "packed",
        "addresses",
        "strides",
        "others",
        "array",
        "at",
        "fixed_at",
        "offsets",
    )

    def __init__(self, values: list):
        self.size = len(values)
        self.fixed = [i for i, v in enumerate(values) if _fixed(v)]
        self.refs = tuple(values[i] for i in self.fixed)  # keeps the ids valid
        self.ids = tuple(map(id, self.refs))
        self.packed = np.array([float(v) for v in self.refs], dtype=np.float64)
        base = address(self.packed)
        addresses = [0] * self.size
        for k, i in enumerate(self.fixed):
            addresses[i] = base + 8 * k
        self.addresses = _ptrs(addresses)
        self.strides = _strides([0] * self.size)
        fixed = set(self.fixed)
        self.others = [i for i in range(self.size) if i not in fixed]
        self.array = np.array(addresses, dtype=np.uint64)  # the addresses, for a kernel's call (_run)
        self.at = np.array(self.others, dtype=np.intp)
        self.fixed_at = np.array(self.fixed, dtype=np.intp)
        self.offsets = np.arange(len(self.fixed), dtype=np.uint64) * np.uint64(8)  # bytes into packed

    def matches(self, values: list) -> bool:
        return len(values) == self.size and tuple(map(id, map(values.__getitem__, self.fixed))) == self.ids

    def renewed(self, values: list):
        """``values`` packed like this call's inputs (the same positions fixed): a new
        :class:`_Packed` with a copy of this one's scalars, of which only the positions holding
        other objects are read again (a fit's new parameter values among unchanged ones); this
        one stays as it is. None where the number of inputs differs, or an object at a fixed
        position is not :func:`_fixed` (then pack anew)."""
        if len(values) != self.size or not self.size:
            return None
        refs = tuple(map(values.__getitem__, self.fixed))
        changed = [k for k, (new, old) in enumerate(zip(refs, self.refs)) if new is not old]
        if not all(_fixed(refs[k]) for k in changed):
            return None
        out = _Packed.__new__(_Packed)
        out.size, out.fixed, out.others, out.at = self.size, self.fixed, self.others, self.at
        out.strides, out.fixed_at, out.offsets = self.strides, self.fixed_at, self.offsets  # never written
        out.refs, out.ids = refs, tuple(map(id, refs))
        out.packed = self.packed.copy()
        if changed:
            out.packed[changed] = [float(refs[k]) for k in changed]
        out.array = np.zeros(self.size, dtype=np.uint64)
        out.array[self.fixed_at] = np.uint64(address(out.packed)) + self.offsets
        out.addresses = type(self.addresses).from_buffer_copy(out.array)
        return out


def _repacked(packed, values: list) -> _Packed:
    """The :class:`_Packed` of ``values``: renewed from the previous call's ``packed`` (None:
    none) where the layout holds (:meth:`_Packed.renewed`), else packed anew."""
    return (packed is not None and packed.renewed(values)) or _Packed(values)


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
        self.N_LEGS, self.JOINTS_PER_LEG = self.OUTPUTS["inverse_kinematics"]["q"]
        self.BLOCK = int(signature["block"])
        self.FUSED_MATRICES = {o: tuple(s) for o, s in signature["fused"]["matrices"]}
        self._fused_names = [name for _, name in signature["fused"]["inputs"]]
        # a 6-DoF robot's pass computes its R_ij inputs from the rotation vector (given by
        # the pose coordinates' names ROTATION_VECTOR) after its named inputs
        self._rotation = bool(signature["fused"].get("rotation"))
        self._unread = {n for n in self._fused_names if re.fullmatch(r"R_[0-2][0-2]", n)} if self._rotation else set()
        self._packed: _Packed | None = None
        self._kernel_packed: dict = {}  # kernel -> the _Packed scalars of its last call (_run)
        self._layouts: dict = {}  # kernel -> its inputs' layout (_layout)
        self._scale_index = self._fused_names.index(LEVER_SCALE) if LEVER_SCALE in self._fused_names else -1
        self._opts: dict = {}  # the fused pass's option arrays (read only by C)
        if signature["fused"]["status"] != STATUS:
            raise RuntimeError(
                f"the C library of {self.ROBOT!r} has status codes {signature['fused']['status']}, "
                f"expected {STATUS}: run `eigentwist generate`"
            )

    def __repr__(self) -> str:
        return f"<eigentwist C kernels {self.ROBOT!r} ({self.build.flags_name}) {self.build.path}>"

    # ------------------------------------------------------------ plumbing
    def _layout(self, kernel: str) -> tuple:
        """``(params, at_params, at_q, q_offsets, outputs, count)`` of a kernel's inputs: the
        non-joint input names and their positions, the joint inputs' positions and byte
        offsets in a row of q, the outputs' (name, shape) and the number of inputs."""
        layout = self._layouts.get(kernel)
        if layout is None:
            spec, nq = self._spec[kernel], self.JOINTS_PER_LEG
            inputs = spec["inputs"]
            layout = self._layouts[kernel] = (
                [name for group, name, _ in inputs if group != "q"],
                np.array([i for i, (group, _, _) in enumerate(inputs) if group != "q"], dtype=np.intp),
                np.array([i for i, (group, _, _) in enumerate(inputs) if group == "q"], dtype=np.intp),
                np.array([8 * (j[0] * nq + j[1]) for group, _, j in inputs if group == "q"], dtype=np.uint64),
                [(name, tuple(shape)) for name, shape in spec["outputs"]],
                len(inputs),
            )
        return layout

    def _run(self, kernel: str, lead: tuple, values: dict, q=None, threads: int = 1) -> dict:
        """One generated kernel over ``lead`` poses: its outputs by name. ``threads`` > 1 runs
        block-aligned ranges of the poses on that many threads (:func:`threads_for` bounds
        it); every pose is computed on its own, so the results are bit-identical."""
        params, at_params, at_q, q_offsets, outputs, count = self._layout(kernel)
        n = int(np.prod(lead, dtype=np.int64))
        outs = {name: np.empty(lead + shape) for name, shape in outputs}
        if n == 0:
            return outs
        keep: list = []
        addresses, strides = np.zeros(count, dtype=np.uint64), np.zeros(count, dtype=np.int64)
        addresses[at_params], strides[at_params] = self._kernel_inputs(kernel, [values[k] for k in params], lead, keep)
        if q is not None:
            legs, nq = self.N_LEGS, self.JOINTS_PER_LEG
            qa = np.ascontiguousarray(np.broadcast_to(np.asarray(q, dtype=np.float64), lead + (legs, nq)))
            qa = qa.reshape(n, legs * nq)
            keep.append(qa)
            addresses[at_q] = np.uint64(address(qa)) + q_offsets
            strides[at_q] = qa.shape[1]
        out_ptrs = np.array([address(o) for o in outs.values()], dtype=np.uint64)
        out_rows = np.array([8 * int(np.prod(shape, dtype=np.int64)) for _, shape in outputs], dtype=np.uint64)
        fn, steps = self._fn[kernel], strides.astype(np.uint64) * np.uint64(8)  # bytes per pose

        def call(begin: int, end: int) -> int:
            at = addresses + np.uint64(begin) * steps
            out = out_ptrs + np.uint64(begin) * out_rows
            return fn(end - begin, at.ctypes.data_as(_PTRS), strides.ctypes.data_as(_I64P), out.ctypes.data_as(_PTRS))

        for rc in run_ranges(call, n, self.BLOCK, threads_for(n, self.BLOCK, threads)):
            _check_rc(rc, kernel)
        return outs

    def _kernel_inputs(self, kernel: str, values: list, lead: tuple, keep: list) -> tuple:
        """(addresses, strides) arrays of one kernel's non-joint inputs, as :func:`_inputs`
        gives them: the scalars packed by the kernel's previous call are reused when the very
        same immutable objects come again (:class:`_Packed`), only the per-pose arrays marshalled."""
        if not values:
            return np.zeros(0, dtype=np.uint64), np.zeros(0, dtype=np.int64)
        packed = self._kernel_packed.get(kernel)
        if packed is None or not packed.matches(values):
            packed = self._kernel_packed[kernel] = _repacked(packed, values)
        keep.append(packed)
        addresses, strides = packed.array.copy(), np.zeros(packed.size, dtype=np.int64)
        if packed.others:
            a, st = _inputs([values[i] for i in packed.others], lead, keep)
            addresses[packed.at], strides[packed.at] = a, st
        return addresses, strides

    @staticmethod
    def _lead(shapes) -> tuple:
        return tuple(np.broadcast_shapes(*shapes))

    def _params(self, kernel: str, p: dict) -> dict:
        return {name: p[name] for group, name, _ in self._spec[kernel]["inputs"] if group == "param"}

    def _q_kernel(self, kernel: str, q, p: dict, threads: int = 1) -> dict:
        q = np.asarray(q, dtype=np.float64)
        if q.ndim < 2 or q.shape[-2:] != (self.N_LEGS, self.JOINTS_PER_LEG):
            raise InputError(
                f"q has shape {q.shape}: expected (..., {self.N_LEGS}, {self.JOINTS_PER_LEG}) joint coordinates"
            )
        params = self._params(kernel, p)
        lead = self._lead([q.shape[:-2]] + [np.shape(v) for v in params.values()])
        return self._run(kernel, lead, params, q=q, threads=threads)

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

    def jacobians(self, q, p: dict, threads: int = 1) -> dict:
        """Inverse-Jacobian rows ``J_rows`` (..., legs, 4, 6) and levers ``lever`` (..., legs), m;
        ``threads`` > 1 splits the poses on block boundaries (bit-identical results)."""
        return self._q_kernel("jacobians", q, p, threads)

    def lever(self, q, p: dict, threads: int = 1) -> dict:
        """Each leg's actuation lever ``lever`` (..., legs), m, alone (the ``jacobians`` kernel's
        output) of legs solved numerically; absent for closed-form IK."""
        if "lever" not in self._spec:
            raise AttributeError("lever")
        return self._q_kernel("lever", q, p, threads)

    def loop_closure(self, q, p: dict) -> dict:
        """Loop-closure ``residual`` (..., legs, rows) and its Jacobian ``dresidual`` of legs
        solved numerically (:mod:`eigentwist.runtime.levenberg_marquardt`); absent for closed-form IK."""
        if "loop_closure" not in self._spec:
            raise AttributeError("loop_closure")
        return self._q_kernel("loop_closure", q, p)

    def newton(self, q, p: dict, iterations: int, tol: float, threads: int = 1, lambda0: float | None = None):
        """``(q, |r|)``: the damped Newton iterations of :mod:`.levenberg_marquardt` on this library's
        ``loop_closure`` kernel, run in C (:mod:`.c_levenberg_marquardt`); ``q`` (n, legs, n_q) starting
        coordinates, ``p`` the kernel's inputs ((n,) arrays or scalars); ``threads`` > 1
        runs ranges of whole blocks on threads (same results); ``lambda0`` the first damping
        (None: :data:`~.levenberg_marquardt.LAMBDA0`). None where the C driver cannot be built."""
        from . import c_levenberg_marquardt

        if "loop_closure" not in self._spec or c_levenberg_marquardt.driver() is None:
            return None
        n, legs, nq = np.shape(q)
        keep: list = []
        address, addresses, strides, q_of, rows, block = self._closure_tables(p, n, legs, nq, keep)
        return c_levenberg_marquardt.iterate(
            address,
            block,
            q_of,
            addresses,
            strides,
            np.asarray(q, dtype=np.float64),
            rows,
            iterations,
            tol,
            threads,
            *(() if lambda0 is None else (lambda0,)),
        )

    def branch_solver(self, p: dict, n: int, signs):
        """The Newton iterations and the branch check of numeric IK on a batch of ``n`` poses
        with the kernels' inputs ``p`` ((n,) arrays or scalars), in C on the threads
        (:class:`.c_levenberg_marquardt.BranchSolver`; ``signs`` (legs,) the assembly branch's
        lever signs, 0 for either); None where the library has no ``loop_closure`` or
        one-output ``lever`` kernel or the C driver cannot be built."""
        from . import c_levenberg_marquardt

        spec, lever = self._spec.get("loop_closure"), self._spec.get("lever")
        if spec is None or lever is None or [o for o, _ in lever["outputs"]] != ["lever"]:
            return None
        if c_levenberg_marquardt.branch_driver() is None:
            return None
        legs, nq = self.N_LEGS, self.JOINTS_PER_LEG
        keep: list = []
        *closure, rows, block = self._closure_tables(p, n, legs, nq, keep)
        at, l_addresses, l_strides, l_q_of, _, l_keep = self.kernel_arguments("lever", p, n)
        keep += l_keep
        return c_levenberg_marquardt.BranchSolver(
            closure, block, (at, l_addresses, l_strides, l_q_of), legs, rows, nq, signs, keep
        )

    def _closure_tables(self, p: dict, n: int, legs: int, nq: int, keep: list) -> tuple:
        """The ``loop_closure`` kernel's call for the Newton driver on ``n`` poses: ``(address,
        addresses, strides, q_of, rows, block)``, its C address, its inputs' addresses and
        strides from ``p`` (a joint coordinate's 0: the driver fills it), the entry of the
        pose's row of q each joint input reads (-1 for the others), its closure rows per leg
        and its block function (:meth:`_block`); the arrays pointed into appended to ``keep``."""
        spec = self._spec["loop_closure"]
        q_of = [joint[0] * nq + joint[1] if group == "q" else -1 for group, _, joint in spec["inputs"]]
        names = [None if group == "q" else name for group, name, _ in spec["inputs"]]
        addresses, strides = _driver_inputs(names, p, n, keep)
        rows = dict((o, s) for o, s in spec["outputs"])["residual"][-1]
        block = self._block(spec, spec["outputs"] == [["residual", [legs, rows]], ["dresidual", [legs, rows, nq]]])
        address = ctypes.cast(self._fn["loop_closure"], ctypes.c_void_p).value
        return address, addresses, strides, q_of, rows, block

    def _block(self, spec: dict, driver_rows: bool) -> int | None:
        """The C address of a kernel's exported block function (``spec``: its signature
        entry), where it has one and its outputs are laid out as the driver's rows
        (``driver_rows``); else None (the driver calls the exported kernel)."""
        if "block" not in spec or not driver_rows:
            return None
        return ctypes.cast(getattr(self._lib, spec["block"]), ctypes.c_void_p).value

    def follow(self, q, p: dict, followers: list, iterations: int, tol: float, threads: int = 1):
        """``(q, |r|)``: the damped Newton iterations of :mod:`.levenberg_marquardt` on a
        platform's followers (``followers``: indices into x, y, z, rot_x, rot_y, rot_z), run in
        C on this library's ``followers`` kernel (:func:`.c_levenberg_marquardt.follow`);
        ``q`` (n, 1, followers) their starting values, ``p`` the kernel's parameters ((n,)
        arrays or scalars) and ``p["_full"]`` the commanded full poses (n, 6). None where the
        library has no such kernel (legs solved numerically) or the C driver cannot be built."""
        from . import c_levenberg_marquardt

        spec = self._spec.get("followers")
        if spec is None or any(g == "q" for g, _, _ in spec["inputs"]):
            return None
        shapes = dict((o, tuple(s)) for o, s in spec["outputs"])
        if [o for o, _ in spec["outputs"]] != ["closure", "closure_rate"]:
            raise RuntimeError(
                f"the followers kernel of {self.ROBOT!r} has outputs {list(shapes)}, expected closure and "
                "closure_rate: run `eigentwist generate`"
            )
        if c_levenberg_marquardt.followers_driver() is None:
            return None
        n = len(q)
        keep: list = []
        pose_role = {"x": 0, "y": 1, "z": 2}
        rotation = {f"R_{i}{j}": 3 + 3 * i + j for i in range(3) for j in range(3)}
        roles = [pose_role.get(name, rotation.get(name, -1)) for _, name, _ in spec["inputs"]]
        names = [name if r < 0 else None for (_, name, _), r in zip(spec["inputs"], roles)]
        addresses, strides = _driver_inputs(names, p, n, keep)
        rows = int(np.prod(shapes["closure"], dtype=np.int64))
        block = self._block(spec, shapes["closure_rate"] == shapes["closure"] + (6,))
        return c_levenberg_marquardt.follow(
            ctypes.cast(self._fn["followers"], ctypes.c_void_p).value,
            block,
            roles,
            addresses,
            strides,
            list(followers),
            p["_full"],
            np.asarray(q, dtype=np.float64),
            rows,
            iterations,
            tol,
            threads,
        )

    def gravity(self, q, p: dict) -> dict:
        """Gravity-preload terms ``G``, ``Kqe``, ``k_act`` and ``W`` (see the NumPy module)."""
        return self._q_kernel("gravity", q, p)

    def legs(self, q, p: dict) -> dict:
        """Each leg's elastic-joint rows ``Je``, their compliance ``Cq`` without the rigid
        penalty, ``K_ground`` and the couplings' ``G_c``, ``K_c`` (see the NumPy module)."""
        return self._q_kernel("legs", q, p)

    # ------------------------------------------------------- fast paths
    def generalized_eigh(self, K, M, vectors: bool = True, threads: int = 1, post=None):
        """``K v = lambda M v`` for (N, n, n) pairs, n = 6 or 3, in C (Cholesky + Jacobi).

        Same contract as :func:`eigentwist.runtime.eigen.generalized_eigh`: eigenvalues
        omega^2 in (rad/s)^2 ascending (N, n) and M-orthonormal eigenvectors as columns
        (N, n, n) (None when ``vectors`` is False). Only the upper triangles are read.
        ``threads`` > 1 splits the batch on block boundaries (bit-identical results).
        ``post(lam, V, rows)``, if given, runs after each range's C call on the thread that
        ran it, ``rows`` that range's slice (work on the solved rows that then runs side by
        side, not after the whole batch on the calling thread).
        """
        K = np.ascontiguousarray(K, dtype=np.float64)
        M = np.ascontiguousarray(M, dtype=np.float64)
        if (
            K.shape != M.shape
            or K.ndim != 3
            or K.shape[1] != K.shape[2]
            or K.shape[1] not in self.signature["eigh"]["dims"]
        ):
            raise InputError(
                f"K {K.shape} and M {M.shape}: expected equal shapes (N, n, n) with n in "
                f"{self.signature['eigh']['dims']}"
            )
        n, dim = K.shape[0], K.shape[1]
        lam = np.empty((n, dim))
        V = np.empty((n, dim, dim)) if vectors else None
        fn, mat = self._fn["eigh"], 8 * dim * dim

        def call(a: int, b: int) -> int:
            rc = fn(
                b - a,
                dim,
                address(K) + a * mat,
                address(M) + a * mat,
                address(lam) + a * 8 * dim,
                address(V) + a * mat if vectors else None,
            )
            if post is not None and rc == 0:
                post(lam, V, slice(a, b))
            return rc

        for rc in run_ranges(call, n, self.BLOCK, threads_for(n, self.BLOCK, threads)):
            _check_rc(rc, "eigh")
        if not np.isfinite(lam).all():  # one pass over the batch; per pair only on failure
            k = int(np.argmax(~np.isfinite(lam).all(axis=1)))
            raise np.linalg.LinAlgError(f"pair {k}: M is not positive definite (or K, M are not finite)")
        return lam, V

    def _pack(self, values: list) -> tuple:
        """``(keep, addresses, strides, lead)`` of the fused pass's inputs (ctypes arrays):
        the scalars of the previous call reused when the same immutable objects come again
        (the evaluator's resolved parameters), only the per-pose arrays marshalled anew."""
        packed = self._packed
        if packed is None or not packed.matches(values):
            packed = self._packed = _repacked(packed, values)
        others = [values[i] for i in packed.others]
        shapes = {np.shape(v) for v in others}
        lead = shapes.pop() if len(shapes) == 1 and len(next(iter(shapes))) <= 1 else self._lead(shapes or [()])
        keep: list = [packed]
        addresses = type(packed.addresses).from_buffer_copy(packed.addresses)
        strides = type(packed.strides).from_buffer_copy(packed.strides)
        if others:
            a, st = _inputs(others, lead, keep)
            for i, ai, si in zip(packed.others, a, st):
                addresses[i], strides[i] = ai, si
        return keep, addresses, strides, lead

    def fused(self, x, y, z, p: dict, *, threads: int = 1, **options) -> dict:
        """Poses (m) and parameters to the requested outputs in one C pass; ``options`` are
        :meth:`fused_arguments`' keywords (defaults: ``matrices=("M", "K_F")``, nothing else).

        ``matrices``, ``ik`` and ``jacobians`` name the kernel outputs to return (shapes as
        in :attr:`OUTPUTS`; ``matrices`` may also name ``lever``); ``model`` (``"flexible"``:
        M and K_F, 6x6; ``"rigid"``: the lower-right 3x3 of M and K_R) adds ``freq_hz``
        (N, n), ascending, and with ``vectors`` the eigentwists as columns (N, n, n): ``V``,
        M-orthonormal, or with ``normalize`` ``eigentwists``, scaled so that each column's
        entry of largest magnitude is +1 (Eqs. 57, 65). An unstable mode (eigenvalue below
        ``-ROUNDOFF_EPS * max|lambda|``) has NaN Hz; round-off clips to 0 Hz.

        ``status`` adds ``status`` (N,) int8 from the same pass (:data:`STATUS`): 1 when a
        pose is unreachable, 2 singular (a lever ``|w_a1.t_a1| / l1 <= LEVER_TOL``), 3 when
        its eigenvalues are not finite (these three get NaN frequencies and eigentwists),
        4 when a mode is unstable, else 0. Without ``status`` nothing is checked.

        A 6-DoF robot's pass reads its rotation from ``p``'s rotation vector ``rot_x, rot_y,
        rot_z`` (rad; :data:`ROTATION_VECTOR`) where ``p`` has it, computing the rotation
        matrix entries ``R_ij`` per block; otherwise it reads ``p``'s ``R_ij``.

        ``out`` maps output names to preallocated C-contiguous arrays of the result's shape
        and dtype, written in place (no other copy is made). ``screen`` (> 0, with ``model``
        and ``status``): the result's ``clean`` says whether every pose has status 0 and its
        lowest frequency above ``screen`` times its highest, counted in the pass (absent where
        the blocks run by ranges). ``threads`` > 1 runs the blocks
        on that many threads (bounded by :func:`threads_for`; handed out in C,
        :func:`.c_schedule.run_pass`, else by ranges); the results are bit-identical to one
        thread.
        """
        from .c_schedule import run_pass

        screen = options.pop("screen", 0.0)
        result, n, keep, args = self.fused_arguments(x, y, z, p, **options)
        fn = self._fn["fused"]
        check = screen > 0.0 and "freq_hz" in result and "status" in result
        dim = result["freq_hz"].shape[-1] if check else 0
        sched = run_pass(fn, n, self.BLOCK, threads, args, dim=dim, screen=screen)
        if sched is not None:
            _check_rc(int(sched.rc), "fused")
            if check:
                result["clean"] = sched.unclean == 0
            return result

        def call(begin: int, end: int) -> int:
            return fn(begin, end, *args)

        for rc in run_ranges(call, n, self.BLOCK, threads_for(n, self.BLOCK, threads)):
            _check_rc(rc, "fused")
        return result

    def fused_arguments(
        self,
        x,
        y,
        z,
        p: dict,
        *,
        matrices=("M", "K_F"),
        ik=(),
        jacobians=(),
        model=None,
        vectors: bool = False,
        status: bool = False,
        normalize: bool = False,
        out: dict | None = None,
    ) -> tuple:
        """:meth:`fused`'s call prepared, not run: ``(result, n, keep, args)``, the output
        arrays it fills (uninitialised), the number of poses, the objects the arguments point
        into (held while they are used) and the C arguments after ``(begin, end)`` (for a
        driver that runs the pass block by block itself, :mod:`.c_damped`)."""
        spec = self.signature["fused"]
        given = {**p, "x": x, "y": y, "z": z}
        by_vector = self._rotation and all(k in given for k in ROTATION_VECTOR)
        if by_vector:  # R_ij come from the rotation vector in C: not read, placeholders
            values = [0.0 if n in self._unread else given[n] for n in self._fused_names]
            values += [given[k] for k in ROTATION_VECTOR]
        else:
            values = list(map(given.__getitem__, self._fused_names))
            values += [0.0] * (3 if self._rotation else 0)
        keep, ins, ins_stride, lead = self._pack(values)
        if self._rotation and not by_vector:
            ins[len(self._fused_names)] = None  # the pass reads R_ij
        n = lead[0] if len(lead) == 1 else int(np.prod(lead, dtype=np.int64))
        result: dict = {}
        given = dict(out or {})

        def alloc(name: str, shape: tuple, dtype=np.float64) -> int:
            arr = given.pop(name, None)
            if arr is None:
                arr = np.empty(lead + shape, dtype=dtype)
            elif (
                not isinstance(arr, np.ndarray)
                or arr.shape != lead + shape
                or arr.dtype != dtype
                or not arr.flags.c_contiguous
                or not arr.flags.writeable
            ):
                raise InputError(
                    f"out[{name!r}]: expected a writeable C-contiguous {np.dtype(dtype).name} array "
                    f"of shape {lead + shape}, got {getattr(arr, 'shape', None)} "
                    f"{getattr(arr, 'dtype', type(arr).__name__)}"
                )
            result[name] = arr
            return address(arr)

        def outputs(kernel: str, table: dict, names):
            if not names:
                return None
            unknown = sorted(set(names) - set(table))
            if unknown:
                raise KeyError(f"{kernel} has no output(s) {unknown}: expected {list(table)}")
            return _ptrs([alloc(name, shape) if name in names else None for name, shape in table.items()])

        ik_p = outputs("inverse_kinematics", self.OUTPUTS["inverse_kinematics"], ik)
        mat_p = outputs("matrices", self.FUSED_MATRICES, matrices)
        jac_p = outputs("jacobians", self.OUTPUTS["jacobians"], jacobians)
        freq = vec = st_p = None
        model_id = 0
        if model is not None:
            if model not in spec["models"]:
                raise InputError(f"model {model!r}: expected one of {spec['models']}")
            model_id = spec["models"].index(model)
            dim = spec.get("dims", self.signature["eigh"]["dims"])[model_id]
            freq = alloc("freq_hz", (dim,))
            if vectors:
                vec = alloc("eigentwists" if normalize else "V", (dim, dim))
        if status:
            st_p = alloc("status", (), np.int8)
        if given:
            raise KeyError(f"out has arrays for {sorted(given)}, which this call does not compute")
        # lever tolerance, scale input, round-off, normalize (read when called: they may be set)
        key = (validity.LEVER_TOL, eigen.ROUNDOFF_EPS, bool(normalize))
        opts = self._opts.get(key)
        if opts is None:
            opts = self._opts[key] = (ctypes.c_double * 4)(key[0], self._scale_index, key[1], 1.0 if normalize else 0.0)
        keep += [ins, ins_stride, ik_p, mat_p, jac_p]
        return result, n, keep, (ins, ins_stride, model_id, ik_p, mat_p, jac_p, freq, vec, st_p, opts)

    def kernel_arguments(self, kernel: str, p: dict, n: int) -> tuple:
        """One kernel's call on n poses prepared for a C driver that reads the joint
        coordinates from its own array: ``(address, inputs, strides, q_of, outputs, keep)``,
        the kernel's function address, its inputs' addresses and strides (doubles; a joint
        coordinate's entry 0), ``q_of`` (the entry ``leg * n_q + coordinate`` of a pose's row
        of q each joint input reads, -1 for the others), the outputs allocated ((n,) + shape,
        uninitialised) and the objects the addresses point into."""
        params, at_params, at_q, q_offsets, outputs, count = self._layout(kernel)
        keep: list = []
        addresses, strides = np.zeros(count, dtype=np.uint64), np.zeros(count, dtype=np.int64)
        addresses[at_params], strides[at_params] = self._kernel_inputs(kernel, [p[k] for k in params], (n,), keep)
        q_of = np.full(count, -1, dtype=np.intc)
        q_of[at_q] = (q_offsets // 8).astype(np.intc)
        outs = {name: np.empty((n,) + shape) for name, shape in outputs}
        return self.address(kernel), addresses, strides, q_of, outs, keep

    def address(self, function: str) -> int:
        """The C address of a kernel (its name) or of ``"fused"``, the fused pass."""
        return ctypes.cast(self._fn[function], ctypes.c_void_p).value

    def fused_options(self, normalize: bool) -> ctypes.Array:
        """The fused pass's option array (lever tolerance, scale input, round-off bound,
        normalize), read from :mod:`.validity` and :mod:`.eigen` when called (they may be set)."""
        key = (validity.LEVER_TOL, eigen.ROUNDOFF_EPS, bool(normalize))
        opts = self._opts.get(key)
        if opts is None:
            opts = self._opts[key] = (ctypes.c_double * 4)(key[0], self._scale_index, key[1], 1.0 if normalize else 0.0)
        return opts

    def prepare_fused(self, p: dict, pose_inputs: dict, *, model: str, vectors: bool = False, matrices=()):
        """:meth:`fused` with ``status=True, normalize=True`` for the scalar inputs ``p``,
        prepared once for calls on new poses (:class:`~.fused_call.FusedCall`: the same C
        function, inputs and options, so the same bits). ``pose_inputs`` maps the inputs
        taken from the poses to their stride in doubles; ``model``, ``vectors`` and
        ``matrices`` as in :meth:`fused`. Raises ``InputError`` for an input per pose in ``p``."""
        from .fused_call import FusedCall

        spec = self.signature["fused"]
        model_id = spec["models"].index(model)
        unknown = sorted(set(matrices) - set(self.FUSED_MATRICES))
        if unknown:
            raise KeyError(f"matrices has no output(s) {unknown}: expected {list(self.FUSED_MATRICES)}")
        names = self._fused_names + (list(ROTATION_VECTOR) if self._rotation else [])
        return FusedCall(
            self._lib[spec["function"]],  # a function object of its own (FusedCall sets its argtypes)
            names,
            p,
            pose_inputs,
            unread=(
                self._unread
                if all(k in pose_inputs for k in ROTATION_VECTOR)
                else set(ROTATION_VECTOR)
                if self._rotation
                else set()
            ),
            model_id=model_id,
            dim=spec.get("dims", self.signature["eigh"]["dims"])[model_id],
            vectors=vectors,
            matrices=(
                len(self.FUSED_MATRICES),
                tuple((k, n, s) for k, (n, s) in enumerate(self.FUSED_MATRICES.items()) if n in matrices),
            ),
            options=lambda: self.fused_options(True),
            block=self.BLOCK,
            check=_check_rc,
        )

    def fused_frequencies(
        self, x, y, z, p: dict, model: str = "flexible", vectors: bool = False, check: bool = True, threads: int = 1
    ) -> dict:
        """Natural frequencies (Hz) of poses ``x, y, z`` (m) in one C pass: the sweep fast path.

        ``p`` holds every parameter and effect switch (as the evaluator passes them to the
        kernels); ``model`` is ``"flexible"`` (M and K_F, 6 modes) or ``"rigid"`` (3x3
        translational subsets of M and K_R), Eq. 7. The gravity preload is not included
        (its switch must be off). Returns ``freq_hz`` (N, n) ascending, ``valid`` (N,),
        ``stable`` (N,) and, with ``vectors``, ``eigentwists`` (N, n, n) normalised so that
        each column's entry of largest magnitude is +1 (Eqs. 57, 65). Unreachable or
        singular poses raise the evaluator's errors when ``check``; otherwise they get NaN
        and ``valid`` False. Unstable modes are NaN with ``stable`` False (never raised).
        """
        from ..description.effects import EFFECTS, switch_name
        from .errors import InputError

        preloads = [switch_name(n) for n, e in EFFECTS.items() if e.primitive == "preload"]
        if any(np.any(np.asarray(p.get(s, 0.0)) != 0) for s in preloads):
            raise InputError("the fused C path has no gravity preload: switch it off or use Evaluator.frequencies")
        out = self.fused(
            x, y, z, p, matrices=(), model=model, vectors=vectors, normalize=True, status=True, threads=threads
        )
        st = out["status"]
        valid = (st == STATUS["ok"]) | (st == STATUS["unstable"])
        if check and not valid.all():
            self.raise_invalid(int(np.argmax(~valid.reshape(-1))), x, y, z, p, st.shape)
        res = {"freq_hz": out["freq_hz"], "valid": valid, "stable": st != STATUS["unstable"]}
        if vectors:
            res["eigentwists"] = out["eigentwists"]
        return res

    def raise_invalid(self, k: int, x, y, z, p: dict, lead: tuple, legs=None, names=None) -> None:
        """Raise the evaluator's error (:mod:`.validity`) for pose ``k`` of a batch of shape
        ``lead``, recomputing its check quantities (one pose, so it costs nothing).
        ``legs``: the description's legs, named in the error (None: a shipped robot's);
        ``names``: the robot's pose coordinates, in which the pose is named
        (:func:`~.validity.pose_text`)."""
        from ..robots import get
        from .errors import UnreachablePoseError
        from .validity import LEVER_SCALE, pose_text, raise_singular, raise_unreachable

        def row(v):
            return np.broadcast_to(np.asarray(v, dtype=float), lead).reshape(-1)[k : k + 1]

        legs = get(self.ROBOT).legs if legs is None else legs
        pk = {name: row(v) for name, v in p.items()}
        pose = np.stack([row(c) for c in (x, y, z)], axis=-1)
        if "R_00" in pk:  # a 6-DoF robot: name the pose as given
            from .poses import rotation_vector

            R = np.array([[pk[f"R_{i}{j}"][0] for j in range(3)] for i in range(3)])
            pose = np.concatenate([pose, rotation_vector(R)[None, :]], axis=-1)
        ik = self.inverse_kinematics(*pose[:, :3].T, pk)
        raise_unreachable(legs, pose, ik, names)
        if "lever" in self.OUTPUTS["jacobians"]:
            lever = self.jacobians(ik["q"], pk)["lever"]
            if LEVER_SCALE in pk:
                lever = lever / pk[LEVER_SCALE][..., None]
            raise_singular(legs, pose, lever, LEVER_SCALE if LEVER_SCALE in pk else None, names)
        raise UnreachablePoseError(
            f"pose {pose_text(pose[0], names)} gives non-finite frequencies "
            "(the inertia matrix is not positive definite there)"
        )
