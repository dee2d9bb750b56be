"""The fused C pass of one model and one set of scalar parameter values, prepared once.

What a call of :meth:`CKernels.fused <eigentwist.runtime.c_kernels.CKernels.fused>` works out
from the parameters alone (the packed scalar inputs, the table of input addresses and
strides, the output tables, the function's signature) does not change while the model and
the values stay the same: :class:`FusedCall` holds it, so that a call on new poses only
points the table at the poses' coordinates and at fresh output arrays. The C function, its
inputs and its options are those of ``CKernels.fused``: the results are the same, bit for
bit (``tests/test_fast_paths.py``).
"""

from __future__ import annotations

import ctypes

import numpy as np

from .addresses import address
from .errors import InputError
from .threads import run_ranges, threads_for

__all__ = ["FusedCall"]

_VOID = ctypes.c_void_p


class FusedCall:
    """``CKernels.fused(x, y, z, p, status=True, normalize=True, ...)`` for fixed scalar
    inputs ``p`` (SI units; 0-d arrays or numbers) and new poses at every call: made by
    :meth:`CKernels.prepare_fused <eigentwist.runtime.c_kernels.CKernels.prepare_fused>`.

    ``fn`` is the library's fused function (a function object of its own: its argument
    types are set here), ``names`` its inputs in order, ``pose_inputs`` the inputs that come
    from the pose (``x, y, z``, and a 6-DoF platform's rotation vector; those the pass does not
    read are dropped: :attr:`pose_inputs` keeps the others, in the order :meth:`__call__`
    receives their addresses) mapped to the distance between two poses' values in doubles;
    ``unread`` the inputs the pass does not read (a NULL address: a 6-DoF platform's ``R_ij``
    where the rotation vector is among the pose inputs, else the rotation vector); ``dim``
    the model's number of modes, ``matrices`` the size of the pass's table of
    matrix pointers and (index in it, name, shape) of each matrix asked for, ``options`` a
    function returning the pass's option array, ``block`` its block of poses and ``check``
    the function raising for a nonzero return code. Raises ``InputError`` when another input of
    ``p`` is not a scalar (values per pose are left to ``fused``).
    """

    __slots__ = (
        "fn", "scalars", "addresses", "strides", "at", "pose_inputs", "model_id", "dim",
        "vectors", "matrices", "options", "block", "check",
    )  # fmt: skip

    def __init__(
        self,
        fn,
        names: list,
        p: dict,
        pose_inputs: dict,
        *,
        model_id: int,
        dim: int,
        vectors: bool,
        matrices: tuple,
        options,
        block: int,
        check,
        unread=frozenset(),
    ):
        pose_inputs = {k: v for k, v in pose_inputs.items() if k in names and k not in unread}
        self.pose_inputs = tuple(pose_inputs)
        self.at = [names.index(n) for n in pose_inputs]
        scalars = np.zeros(len(names), dtype=np.float64)
        for k, name in enumerate(names):
            if name in pose_inputs or name in unread:
                continue
            value = np.asarray(p[name], dtype=np.float64)
            if value.size != 1:
                raise InputError(f"input {name!r}: expected one value for a prepared pass, got {value.size}")
            scalars[k] = value.reshape(-1)[0]
        scalars.flags.writeable = False
        self.scalars = scalars  # the addresses point into it: kept as long as this object
        base = address(scalars)
        self.addresses = (ctypes.c_void_p * len(names))(
            *(None if name in unread else base + 8 * k for k, name in enumerate(names))
        )
        strides = [0] * len(names)
        for k, step in zip(self.at, pose_inputs.values()):
            strides[k] = step
        self.strides = (ctypes.c_int64 * len(names))(*strides)  # read only by C
        self.model_id, self.dim, self.vectors, self.matrices = model_id, dim, vectors, matrices
        self.options, self.block, self.check = options, block, check
        self.fn = fn
        fn.argtypes = [ctypes.c_int64, ctypes.c_int64, _VOID, _VOID, ctypes.c_int] + [_VOID] * 7
        fn.restype = ctypes.c_int

    def __call__(self, addresses: list, n: int, threads: int) -> dict:
        """The pass over ``n`` poses whose pose inputs are read at ``addresses`` (bytes), one
        each, in :attr:`pose_inputs` order. Returns ``freq_hz`` (n, dim), ``status`` (n,)
        int8, with ``vectors`` ``eigentwists`` (n, dim, dim), and the ``matrices`` asked for."""
        from .c_schedule import run_pass

        result, args = self._outputs(addresses, n)
        sched = run_pass(self.fn, n, self.block, threads, args)
        if sched is not None:
            self.check(int(sched.rc), "fused")
            return result
        fn, block = self.fn, self.block

        def call(begin: int, end: int) -> int:
            return fn(begin, end, *args)

        for rc in run_ranges(call, n, block, threads_for(n, block, threads)) if n > block else (call(0, n),):
            self.check(rc, "fused")
        return result

    def screened(self, addresses: list, poses: np.ndarray, threads: int, screen: float):
        """The pass as :meth:`__call__` over ``poses`` (n, dof), C-contiguous, checked first:
        None where one is not finite, else (the result, whether every pose is clean: status 0
        and its lowest frequency above ``screen`` times its highest). The blocks are handed out
        and the checks run in C (:func:`.c_schedule.run_pass`, each thread in one call);
        without the scheduler, by ranges from Python with the checks in NumPy
        (:func:`.c_route.above_screen`)."""
        from .c_schedule import run_pass, scheduler

        n, dof = poses.shape
        if scheduler() is None:
            return self._screened_by_ranges(addresses, poses, threads, screen)
        result, args = self._outputs(addresses, n)
        sched = run_pass(self.fn, n, self.block, threads, args, address(poses), dof, self.dim, screen)
        if sched.not_finite:
            return None
        self.check(int(sched.rc), "fused")
        return result, sched.unclean == 0

    def _screened_by_ranges(self, addresses: list, poses: np.ndarray, threads: int, screen: float):
        """:meth:`screened` by ranges from Python, the checks in NumPy."""
        from .c_route import above_screen
        from .completion import map_ranges

        n = len(poses)
        if not all(map_ranges(lambda rows: bool(np.isfinite(poses[rows]).all()), n, threads)):
            return None
        result = self(addresses, n, threads)
        clean = not np.count_nonzero(result["status"]) and above_screen(result["freq_hz"], threads, screen).all()
        return result, bool(clean)

    def _outputs(self, addresses: list, n: int):
        """The result's arrays for ``n`` poses and the pass's arguments after its range."""
        ins = type(self.addresses).from_buffer_copy(self.addresses)
        for k, at in zip(self.at, addresses):
            ins[k] = at
        result = {}
        mat_p = None
        size, wanted = self.matrices
        if wanted:
            mat_p = (ctypes.c_void_p * size)()
            for k, name, shape in wanted:
                arr = result[name] = np.empty((n,) + shape)
                mat_p[k] = address(arr)
        freq = result["freq_hz"] = np.empty((n, self.dim))
        vec = None
        if self.vectors:
            vec = result["eigentwists"] = np.empty((n, self.dim, self.dim))
            vec = address(vec)
        status = result["status"] = np.empty(n, dtype=np.int8)
        opts = self.options()
        return result, (ins, self.strides, self.model_id, None, mat_p, None, address(freq), vec, address(status), opts)
