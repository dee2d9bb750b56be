"""C backend: render the kernels and a fused pose-to-frequency pipeline as one C source.

Render only (a string comes back; nothing is written or compiled here: see
``eigentwist.runtime.c_kernels`` for compiling and loading). The source has

* one exported function per :class:`~eigentwist.codegen.kernel.Kernel`
  (``et_<robot>_<kernel>``), evaluating a batch of poses in blocks of ``ET_BLOCK``
  with the CSE temporaries as ``const double`` locals inside a ``#pragma omp simd``
  loop over the poses of a block (structure-of-arrays);
* a batched symmetric-definite eigen-solver ``et_<robot>_eigh`` (Cholesky reduction and
  cyclic Jacobi, :mod:`eigentwist.codegen.c_eigen`) for 6x6 and 3x3 pairs;
* ``et_<robot>_fused``: poses and parameters -> joint angles -> M, K_R, K_F -> natural
  frequencies (and eigentwists) in one pass over each block, nothing but the requested
  outputs leaving the cache, with a per-pose status code (reachable, not singular,
  finite, stable) computed in the same pass; it works on a range of blocks, so callers
  can run disjoint ranges on several threads with results bit-identical to one call;
* ``et_<robot>_signature()``: a JSON description of every function's inputs and outputs,
  which the loader reads so that nothing robot-specific is hard-coded in Python;
* the library entry points of ``<robot>_c.h`` (:mod:`eigentwist.codegen.c_library`):
  the model inputs' names, units and defaults and ``et_<robot>_frequencies``.
"""

from __future__ import annotations

import json
import re

import sympy as sp
from sympy.printing.c import C99CodePrinter
from sympy.printing.precedence import PRECEDENCE

from . import c_eigen
from .c_library import ROTATION, fused_input_names, library_context
from .kernel import Kernel, UndeclaredSymbolError
from .render import PRINT_ORDER, environment, header

__all__ = ["render_c", "CCodePrinter", "c_identifiers", "ABI_VERSION", "BLOCK", "EIGEN_MODELS"]

ABI_VERSION = 3
BLOCK = 64  # poses per block: inputs, outputs and temporaries stay in L1/L2
# eigenproblems of the fused pipeline: (model, dimension, first index, inertia, stiffness).
# The flexible model uses the full 6x6 M and K_F (Eq. 13); the rigid one the lower-right
# 3x3 translational blocks of M and K_R (Eq. 14), as the paper does (Eqs. 54-56).
EIGEN_MODELS = (("flexible", 6, 0, "M", "K_F"), ("rigid", 3, 3, "M", "K_R"))
# a 6-DoF robot (six pose coordinates): the rigid model is the full 6x6 M and K_R
EIGEN_MODELS_6DOF = (("flexible", 6, 0, "M", "K_F"), ("rigid", 6, 0, "M", "K_R"))
# what the C comments say of a 6-DoF robot's pose inputs read from the parameter dict
POSE_DOCS = {
    **{f"R_{i}{j}": f"platform rotation matrix entry ({i}, {j}) (-)" for i in range(3) for j in range(3)},
    "x": "platform origin x (m)",
    "y": "platform origin y (m)",
    "z": "platform origin z (m)",
}
EIGEN_DIMS = tuple(n for _, n, _, _, _ in EIGEN_MODELS)
JACOBI_MAX_SWEEPS = 20
JACOBI_TOL = 1e-30  # sum of squared off-diagonals relative to the squared diagonal
# kernels rendered only for the fused pass (not exported, not in the signature's kernels)
FUSED_ONLY = ("matrices_lever",)
# kernels whose block function is also exported (``<function>_block``, the signature's
# ``block``): a C driver that iterates them keeps the block's inputs and outputs in its own
# structure-of-arrays buffers (:mod:`eigentwist.runtime.c_levenberg_marquardt`)
BLOCK_ENTRIES = ("loop_closure", "followers")
# per-pose status codes of the fused pass, in order of precedence (0: evaluated and stable)
STATUS = {"ok": 0, "unreachable": 1, "singular": 2, "not_finite": 3, "unstable": 4}

C_RESERVED = frozenset(
    """
auto break case char const continue default do double else enum extern float for goto if
inline int long register restrict return short signed sizeof static struct switch typedef
union unsigned void volatile while bool true false NULL main errno _Bool _Complex _Imaginary
_Alignas _Alignof _Atomic _Generic _Noreturn _Static_assert _Thread_local
acos asin atan atan2 cos sin tan acosh asinh atanh cosh sinh tanh exp exp2 exp10 expm1 frexp
ilogb ldexp log log10 log1p log2 logb modf scalb scalbn scalbln cbrt fabs hypot pow pow10
sqrt erf erfc lgamma tgamma gamma ceil floor nearbyint rint lrint llrint round lround llround
trunc fmod remainder remquo drem copysign nan nextafter nexttoward fdim fmax fmin fma j0 j1
jn y0 y1 yn signgam significand finite isnan isinf isfinite signbit fpclassify sincos
HUGE_VAL INFINITY NAN M_PI int64_t int32_t size_t ptrdiff_t
""".split()
)
_IDENT = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*$")


def c_identifiers(names) -> dict[str, str]:
    """Map symbol names to unique C identifiers that clash with no C or ``math.h`` name.

    Names that are already valid and free are kept (readable code); others get
    invalid characters replaced and ``_`` appended until free. ``et_``/``ET_`` is
    reserved for the generated scaffolding.
    """
    out: dict[str, str] = {}
    taken: set[str] = set()
    for name in names:
        c = name if _IDENT.match(name) else re.sub(r"\W", "_", name)
        if not _IDENT.match(c) or c.lower().startswith("et_"):
            c = "v_" + c
        while c in C_RESERVED or c in taken:
            c += "_"
        out[name] = c
        taken.add(c)
    return out


class CCodePrinter(C99CodePrinter):
    """C99 printer for kernel expressions.

    Symbols print as their C identifiers (``names``); an unknown symbol raises
    :class:`UndeclaredSymbolError`. Small integer powers are products, parenthesised
    because they may stand in a denominator (``a/(b*b)``, never ``a/b*b``); square
    roots use ``sqrt``; ``pi`` is ``ET_PI``; anything else falls back to ``pow``. Terms and
    factors print in the order SymPy stores them (:data:`~eigentwist.codegen.render.PRINT_ORDER`).
    """

    def __init__(self, names: dict[str, str]):
        super().__init__({"allow_unknown_functions": False, "order": PRINT_ORDER})
        self._names = names

    def _print_Symbol(self, expr):
        try:
            return self._names[expr.name]
        except KeyError:
            raise UndeclaredSymbolError(f"symbol {expr.name!r} is not an input or a temporary of this kernel") from None

    def _print_Pi(self, expr):
        return "ET_PI"

    def _product(self, base, k: int) -> str:
        b = self.parenthesize(base, PRECEDENCE["Pow"])
        return "(" + "*".join([b] * k) + ")"

    def _print_Pow(self, expr, rational=False):
        base, exp = expr.args
        if exp.is_Integer and 2 <= exp <= 4:
            return self._product(base, int(exp))
        if exp.is_Integer and -4 <= exp <= -1:
            inner = self._product(base, -int(exp)) if exp < -1 else self.parenthesize(base, PRECEDENCE["Pow"])
            return f"(1.0/{inner})"
        if exp == sp.Rational(1, 2):
            return f"sqrt({self._print(base)})"
        if exp == -sp.Rational(1, 2):
            return f"(1.0/sqrt({self._print(base)}))"
        if exp == sp.Rational(3, 2):
            return f"({self.parenthesize(base, PRECEDENCE['Pow'])}*sqrt({self._print(base)}))"
        return f"pow({self._print(base)}, {self._print(sp.Float(exp, 17))})"


# ------------------------------------------------------------------ kernels
def _entries(kern: Kernel) -> list[dict]:
    """Output entries in body-independent order: one row of the block buffer each."""
    rows = []
    for k, out in enumerate(kern.outputs):
        for idx, flat in out.entries():
            mirror = -1
            if out.symmetric and idx[-2] != idx[-1]:
                mirror = flat + (idx[-1] - idx[-2]) * (out.shape[-1] - 1)
            rows.append(dict(output=k, name=out.name, idx=idx, pos=flat, mirror=mirror))
    return rows


def _size(shape) -> int:
    n = 1
    for s in shape:
        n *= s
    return n


def _input_doc(name: str, group: str, joint, units: dict, per_leg: int = 3) -> str:
    if group == "q" and per_leg != 3:
        return f"{name}: actuated coordinate of leg {joint[0] + 1} (m for a prismatic actuator)"
    if group == "q":
        return f"{name}: joint angle of leg {joint[0] + 1}, joint {joint[1] + 1} (rad)"
    if group == "pose":
        return f"{name}: end-effector position (m)"
    if name in POSE_DOCS:
        return f"{name}: {POSE_DOCS[name]}"
    if name in units:
        return f"{name}: parameter ({units[name]})"
    return f"{name}: effect switch (0 or 1)"


def _kernel_context(kern: Kernel, prefix: str, units: dict) -> dict:
    names = c_identifiers(kern.input_names + [item[1].name for item in kern.body if item[0] == "let"])
    printer = CCodePrinter(names)
    entries = _entries(kern)
    row = {(e["name"], e["idx"]): r for r, e in enumerate(entries)}
    lines = []
    for item in kern.body:
        if item[0] == "let":
            lines.append(f"const double {names[item[1].name]} = {printer.doprint(item[2])};")
        else:
            _, out, idx, expr = item
            lines.append(f"et_o{row[(out.name, idx)]}[et_i] = {printer.doprint(expr)};")
    inputs = []
    for name in kern.input_names:
        group = next(g for g, ns in kern.inputs if name in ns)
        where = None
        if group == "q":
            where = list(kern.joint_index(name))
        inputs.append(
            dict(
                name=name,
                cname=names[name],
                group=group,
                joint=where,
                doc=_input_doc(name, group, where, units, kern.joints_per_leg),
            )
        )
    return dict(
        name=kern.name,
        doc=kern.doc,
        cname=f"{prefix}_{kern.name}",
        inputs=inputs,
        entries=entries,
        outputs=[dict(name=o.name, shape=list(o.shape), size=_size(o.shape)) for o in kern.outputs],
        lines=lines,
        n_in=len(inputs),
        n_ent=len(entries),
        export=kern.name not in FUSED_ONLY,
        block_entry=kern.name in BLOCK_ENTRIES,
        via=None,
    )


# a kernel whose outputs lead a fused-only kernel's, on the same inputs: its exported
# function runs that kernel's block and drops the further outputs (one block compiled, not two)
SHARED_BLOCKS = (("matrices", "matrices_lever"),)


def _share_blocks(by_name: dict) -> None:
    """Mark each kernel of :data:`SHARED_BLOCKS` to run its fused-only partner's block
    (``via``) where the partner takes the same inputs in the same order and its output
    rows begin with the kernel's own rows, so the kernel's block function is not rendered.
    The partner's CSE covers the further outputs too, so the shared outputs may differ
    from the kernel's own CSE in the last bits."""
    for name, partner in SHARED_BLOCKS:
        k, p = by_name.get(name), by_name.get(partner)
        if k is None or p is None:
            continue
        same_inputs = [i["name"] for i in k["inputs"]] == [i["name"] for i in p["inputs"]]
        leading = p["entries"][: k["n_ent"]] == k["entries"] and p["outputs"][: len(k["outputs"])] == k["outputs"]
        if same_inputs and leading:
            k["via"] = p


# ------------------------------------------------------------------- fused
def eigen_models(robot) -> tuple:
    """The fused pass's eigenproblems for ``robot``: the rigid model is the translational
    3x3 of a 3-DoF robot, the full 6x6 of a 6-DoF one, and a point platform's block of its
    translations where they are consecutive twist coordinates (``x, y`` of a planar
    five-bar: the 2x2 at [v_x, v_y]); any other point keeps the 3x3 (its rigid model is
    reduced outside the pass)."""
    if len(getattr(robot, "pose", "xyz")) == 6:
        return EIGEN_MODELS_6DOF
    if not _point_models(robot):
        return EIGEN_MODELS
    n, off = point_block(robot.pose_space)
    return (EIGEN_MODELS[0], ("rigid", n, off, "M", "K_R"))


def point_block(space) -> tuple | None:
    """``(n, offset)`` when the pose space ``space`` is a point whose allowed twists are the
    unit twists of n >= 2 consecutive twist coordinates from ``offset`` ([omega; v] order:
    v_x is 3), else None (a point on a line: its 1x1 model is solved outside the pass)."""
    basis = getattr(space, "basis", None)
    if basis is None or not getattr(space, "point", False):
        return None
    cols = [tuple(float(basis[i][j]) for i in range(6)) for j in range(len(basis[0]))]
    offsets = [c.index(1.0) if sorted(c) == [0.0] * 5 + [1.0] else -1 for c in cols]
    if len(cols) < 2 or offsets[0] < 0 or offsets != list(range(offsets[0], offsets[0] + len(cols))):
        return None
    return len(cols), offsets[0]


def eigen_dims(robot) -> tuple:
    """The sizes of the batched eigen-solver rendered for ``robot``: :data:`EIGEN_DIMS` and
    any other size of its fused pass's models (a point platform's), largest first."""
    return tuple(sorted({*EIGEN_DIMS, *(n for _, n, _, _, _ in eigen_models(robot))}, reverse=True))


def _fused_context(kctx: dict, models=EIGEN_MODELS) -> dict:
    """Wire the IK outputs into the matrices and jacobians kernels; index M, K_R, K_F.

    The matrices stage is ``matrices_lever`` where rendered (M, K_R, K_F and the levers);
    every IK output but ``q`` is a reachability quantity that must lie in [-1, 1].
    """
    ik, jac = kctx["inverse_kinematics"], kctx["jacobians"]
    mats = kctx.get("matrices_lever", kctx["matrices"])
    inputs: list[dict] = []
    seen: dict[str, int] = {}

    def source(inp) -> str:
        if inp["group"] == "q":
            leg, j = inp["joint"]
            r = next(r for r, e in enumerate(ik["entries"]) if e["name"] == "q" and tuple(e["idx"]) == (leg, j))
            return f"et_ikb[{r}]"
        if inp["name"] not in seen:
            seen[inp["name"]] = len(inputs)
            inputs.append(dict(name=inp["name"], group=inp["group"], doc=inp["doc"]))
        return f"et_ip[{seen[inp['name']]}]"

    wiring = {
        k: [source(inp) for inp in kc["inputs"]] for k, kc in (("ik", ik), ("matrices", mats), ("jacobians", jac))
    }
    row = {(e["name"], tuple(e["idx"])): r for r, e in enumerate(mats["entries"])}
    eig = []
    for model, n, off, mname, kname in models:
        eig.append(
            dict(
                n=n,
                off=off,
                model=model,
                M=mname,
                K=kname,
                m_src=[f"et_mb[{row[(mname, (i + off, j + off))]}]" for i, j in c_eigen.upper(n)],
                k_src=[f"et_mb[{row[(kname, (i + off, j + off))]}]" for i, j in c_eigen.upper(n)],
            )
        )
    n = max(EIGEN_DIMS)
    work = max(_eigen_work(d) for d in EIGEN_DIMS)
    blocks = len(inputs) + ik["n_ent"] + mats["n_ent"] + jac["n_ent"] + n + n * n + work + 2
    # a 6-DoF robot's rotation matrix entries R_ij among the inputs: (input, entry 3 i + j),
    # computed from the rotation vector per block when the caller passes it (et_rotation)
    rotation = [
        (k, 3 * ROTATION[i["name"]][0] + ROTATION[i["name"]][1]) for k, i in enumerate(inputs) if i["name"] in ROTATION
    ]
    if rotation:
        blocks += 3
    reach = [f"et_ikb[{r}]" for r, e in enumerate(ik["entries"]) if e["name"] != "q"]
    lever = [f"et_mb[{r}]" for r, e in enumerate(mats["entries"]) if e["name"] == "lever"]
    return dict(
        inputs=inputs,
        wiring=wiring,
        eigen=eig,
        n_in=len(inputs),
        max_n=n,
        max_up=len(c_eigen.upper(n)),
        n_blocks=blocks,
        work=work,
        mats=mats["name"],
        reach=reach,
        lever=lever,
        rotation=rotation,
        mat_outputs=[[o["name"], o["shape"]] for o in mats["outputs"]],
        status=STATUS,
    )


def _eigen_work(n: int) -> int:
    """Scratch blocks of the eigen-solver: L (lower), A (upper) and W (n x n)."""
    return len(c_eigen.lower(n)) + len(c_eigen.upper(n)) + n * n


def _eigen_context(n: int) -> dict:
    return dict(
        n=n,
        n_up=len(c_eigen.upper(n)),
        n_low=len(c_eigen.lower(n)),
        work=_eigen_work(n),
        reduce=c_eigen.reduce_lines(n),
        sweep=c_eigen.sweep_lines(n, False),
        sweepv=c_eigen.sweep_lines(n, True),
        finish=c_eigen.finish_lines(n, False),
        finishv=c_eigen.finish_lines(n, True),
        upper=c_eigen.upper(n),
    )


def _signature(robot, prefix: str, kernels: list[dict], fused: dict, digest: str) -> dict:
    return dict(
        abi=ABI_VERSION,
        robot=robot.name,
        prefix=prefix,
        block=BLOCK,
        source_hash=digest,
        kernels={
            k["name"]: dict(
                function=k["cname"],
                inputs=[[i["group"], i["name"], i["joint"]] for i in k["inputs"]],
                outputs=[[o["name"], o["shape"]] for o in k["outputs"]],
                **({"block": f"{k['cname']}_block_entry"} if k["block_entry"] else {}),
            )
            for k in kernels
            if k["name"] not in FUSED_ONLY
        },
        fused=dict(
            function=f"{prefix}_fused",
            inputs=[[i["group"], i["name"]] for i in fused["inputs"]],
            models=[e["model"] for e in fused["eigen"]],
            matrices=fused["mat_outputs"],
            status=fused["status"],
            lever_check=bool(fused["lever"]),
            # inputs n_in .. n_in + 2: the rotation vector, read where the first is not NULL
            rotation=bool(fused["rotation"]),
            # each model's dimension, where it differs from eigh's dims (a 6-DoF robot, a point)
            **({"dims": [e["n"] for e in fused["eigen"]]} if eigen_models(robot) is not EIGEN_MODELS else {}),
            # a point platform's rigid block: the twist coordinate it starts at
            **({"offsets": [e["off"] for e in fused["eigen"]]} if _point_models(robot) else {}),
        ),
        eigh=dict(function=f"{prefix}_eigh", dims=list(eigen_dims(robot))),
    )


def _point_models(robot) -> bool:
    """Whether ``robot``'s fused pass solves a point platform's own block (:func:`eigen_models`)."""
    return point_block(getattr(robot, "pose_space", None)) not in (None, (3, 3))


def _c_string(text: str, width: int = 96) -> list[str]:
    """``text`` as adjacent C string literals (escaped), one per line."""
    chunks = [text[i : i + width] for i in range(0, len(text), width)] or [""]
    return ['"' + c.replace("\\", "\\\\").replace('"', '\\"') + '"' for c in chunks]


def render_c(robot, kernels: list[Kernel], digest: str) -> str:
    """Render the C source for ``kernels`` of ``robot`` (pure: returns a string)."""
    prefix = "et_" + re.sub(r"\W", "_", robot.name)
    from ..symbolic.model import EffectSymbols

    units = {p.name: p.unit for p in robot.parameters} | EffectSymbols(robot).units()
    kctx = [_kernel_context(k, prefix, units) for k in kernels]
    by_name = {k["name"]: k for k in kctx}
    _share_blocks(by_name)
    fused = _fused_context(by_name, eigen_models(robot))
    sig = _signature(robot, prefix, kctx, fused, digest)
    lib = library_context(robot, kernels, prefix)
    if fused_input_names(kernels) != [i["name"] for i in fused["inputs"]]:
        raise RuntimeError(f"{robot.name}: the library's input order differs from the fused pass's")
    env = environment()
    tmpl = env.get_template("c/module.c.jinja")
    return tmpl.render(
        header=header(robot.name, digest, comment="//"),
        robot=robot,
        prefix=prefix,
        hash=digest,
        abi=ABI_VERSION,
        block=BLOCK,
        kernels=kctx,
        k=by_name,
        fused=fused,
        eigen=[_eigen_context(n) for n in eigen_dims(robot)],
        max_sweeps=JACOBI_MAX_SWEEPS,
        tol=repr(JACOBI_TOL),
        signature=_c_string(json.dumps(sig, sort_keys=True, separators=(",", ":"))),
        lib=lib,
    )


# Public names for other C renderers (the on-demand sensitivity kernel reuses the kernel template).
kernel_context = _kernel_context
c_string_literals = _c_string
