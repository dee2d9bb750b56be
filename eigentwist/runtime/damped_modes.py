"""The damped modes of an evaluator's model: its legs and parameters into :mod:`.damped`."""

from __future__ import annotations

import numpy as np

from ..description.effects import leg_input_name, leg_switch_name
from .damped import (
    AMBIGUOUS,
    ELIMINATE,
    RIGID,
    UNSTABLE_ZETA,
    Damping,
    distinct_rows,
    actuator_wrenches,
    coupled_wrenches,
    damped_modes,
)
from .errors import InputError
from .threads import resolve_threads

__all__ = [
    "damped_of",
    "actuator_values",
    "solver_of",
    "one_pass_takes",
    "fused_damped",
    "pass_damping",
    "fused_exact",
    "exact_merge",
]


def actuator_values(ev, p: dict, effects, n: int):
    """``(k_d, c_d, t_d, eta_s)``: each leg's delivered stiffness eta_a k_a (N m/rad),
    delivered damping eta_a c_a (N m s/rad) and torque lag (s), (n, legs), and the
    structural loss factor (n,) or None, from the generated code's inputs ``p``
    (:meth:`Evaluator.parameter_values`) and the effects that are on."""
    on = set(effects)
    legs = ev.n_legs
    col = lambda v: np.reshape(np.asarray(v, dtype=float), (-1, 1))  # noqa: E731  (n, 1) or (1, 1)
    eta = np.ones((n, legs))
    if "actuator_loss" in ev.effects:
        for i in range(legs):
            switch = np.asarray(p[leg_switch_name("actuator_loss", i + 1)], dtype=float)
            eta[:, i] = np.where(switch > 0, np.asarray(p[leg_input_name("eta_a", i + 1)], dtype=float), 1.0)
    k_d = eta * col(p["k_a"])
    c_d = eta * col(p["c_a"]) if "servo_damping" in on else np.zeros((n, legs))
    t_d = np.zeros((n, legs)) + (col(p["t_d"]) if "servo_delay" in on else 0.0)
    loss = np.broadcast_to(np.asarray(p["eta_s"], dtype=float), (n,)) if "structural_loss" in on else None
    return k_d, c_d, t_d, loss


def solver_of(ev) -> str:
    """The damped solver for ``ev`` (:func:`.damped.damped_modes`' ``solver``): ``"c"`` on
    the C backend (where its driver builds), ``"numpy"`` on the NumPy one."""
    return "c" if ev.backend == "c" else "numpy"


def damped_of(ev, effects, inputs: dict | None, modes, shapes: bool) -> Damping:
    """The :class:`~.damped.Damping` of ``modes`` (the undamped modes of ``effects``,
    :meth:`Evaluator.modes`): each actuator's impedance in series with its leg's joint
    compliance (the generated ``legs`` kernel), solved by :func:`.damped.damped_modes` on
    the model's coordinates (a rigid model: its allowed twists and the actuated joints
    alone; a flexible one: the twists the legs' rigid constraints admit; coupled platform
    bodies: condensed). ``inputs``: the evaluator's kernel outputs of the valid rows
    (``ModeSolver.damping_inputs``, :mod:`.mode_solver`), None where no row is valid; those rows stay NaN."""
    from . import condense

    N, size = modes.freq_hz.shape
    out = Damping(
        np.array(modes.freq_hz, dtype=float),
        np.array(modes.freq_hz, dtype=float),
        np.full((N, size), np.nan),
        np.full((N, size), np.nan + 0j),
        np.full((N, size, size), np.nan + 0j) if shapes else None,
        np.array(modes.stable, dtype=bool),
    )
    if inputs is None:
        return out
    rows, pr, sub, p, legs, mats = (inputs[k] for k in ("rows", "poses", "params", "p", "legs", "mats"))
    n = len(pr)
    M = np.broadcast_to(mats["M"], (n, 6, 6))
    k_d, c_d, t_d, loss = actuator_values(ev, p, effects, n)
    Je = np.broadcast_to(legs["Je"], (n,) + np.shape(legs["Je"])[-3:])
    Cq = np.broadcast_to(legs["Cq"], (n,) + np.shape(legs["Cq"])[-3:])
    rigid = ev.stiffness_model(effects) == "rigid"
    if rigid:  # the allowed twists and the actuated joints alone (K_R, Eq. 14)
        B = ev.allowed_twists(pr, **sub)
        Je, Cq = Je[:, :, :1, :], Cq[:, :, :1, :1]
        K_model = np.broadcast_to(mats["K_R"], (n, 6, 6))
    else:
        # rigid joint combinations only where the evaluator's route condenses them (ModeSolver.route)
        B = inputs.get("B")
        if B is None:
            B = _admissible(Je, Cq, condense) if inputs["exact"] else np.broadcast_to(np.eye(6), (n, 6, 6))
        K_model = np.broadcast_to(mats["K_F"], (n, 6, 6)) if B.shape[-1] == 6 and "K_F" in mats else None
    coupled = _couplings(ev, effects, legs, n) if not rigid else None
    K_G = None
    if inputs["preloaded"]:  # the gravity preload's stiffness, in parallel
        from .gravity import gravity_stiffness

        full = {k: np.broadcast_to(mats[k], (n, 6, 6)) for k in ("M", "K_R", "K_F")}
        K_G = gravity_stiffness(ev, pr, effects, sub, full, rigid, B if rigid else None)
    d = None
    if coupled is None and loss is None and K_G is None and not shapes and solver_of(ev) == "c":
        # in one C call from the legs' outputs (None where it does not take the problem)
        K_ground = None if rigid else legs["K_ground"]
        d = _from_legs(M, K_model, K_ground, Je, Cq, B, k_d, c_d, t_d, resolve_threads(ev.threads))
    if d is None and coupled is not None:  # legs on platform bodies: condense the couplings
        Mr, Kc, Wr, h, G, B = _coupled_reduction(Je, Cq, k_d, M, K_G, *coupled, condense, loss)
        Kr, K_loss = Kc.real, (Kc.imag if loss is not None else None)
    elif d is None:
        G = None
        K_legs, W, h = actuator_wrenches(Je, Cq, 1.0 / k_d, loss, solver=solver_of(ev))
        if K_model is None or loss is not None:  # rigid directions (the legs' finite springs on B), a loss factor
            K_model = K_legs.real + (np.asarray(legs["K_ground"], dtype=float) if not rigid else 0.0)
        Bt = np.swapaxes(B, -1, -2)
        Kr = Bt @ K_model @ B
        if K_G is not None:
            Kr = Kr + (K_G if rigid else Bt @ K_G @ B)
        Mr = Bt @ M @ B
        Wr = W @ B
        K_loss = (Bt @ K_legs.imag @ B) if loss is not None else None
    if d is None:
        d = damped_modes(
            Mr,
            Kr,
            Wr,
            h,
            k_d,
            c_d,
            t_d,
            shapes=shapes,
            K_loss=K_loss,
            G=G,
            solver=solver_of(ev),
            threads=resolve_threads(ev.threads),
        )
    m = B.shape[-1]
    for name in ("natural_hz", "damped_hz", "damping_ratio", "poles"):
        arr = getattr(out, name)
        block = arr[rows]
        block[:, :m] = getattr(d, name)
        if name == "damping_ratio":
            block[:, m:] = 0.0
        arr[rows] = block
    if shapes:
        X = np.full((n, size, size), np.nan + 0j)
        X[:, :, :m] = d.shapes if rigid else B @ d.shapes
        k = np.argmax(np.abs(X[:, :, :m]), axis=-2)
        X[:, :, :m] /= np.take_along_axis(X[:, :, :m], k[..., None, :], axis=-2)
        if m < size and modes.eigentwists is not None:
            X[:, :, m:] = np.asarray(modes.eigentwists)[rows][:, :, m:]
        out.shapes[rows] = X
    out.stable[rows] &= d.stable
    return out


def _shared(v, n: int):
    """``v`` (n, ...) as one array where its rows are one broadcast row (stride 0), else as is."""
    v = np.asarray(v, dtype=float)
    return v[0] if v.ndim == 3 and (v.strides[0] == 0 or len(v) == 1) and n >= 1 else v


def _from_legs(M, K, K_ground, Je, Cq, B, k_d, c_d, t_d, threads: int) -> Damping | None:
    """The damped modes of n poses from the legs' kernel outputs in one C call
    (:func:`.c_damped.solve_legs`), each distinct row once: M (n, 6, 6), K (n, 6, 6) the
    model's stiffness or None (the legs' J_e^T C_q^+ J_e plus ``K_ground``), Je, Cq (n, legs,
    e, ...), B (n, 6, r), k_d, c_d, t_d (n, legs); the poses the driver leaves undecided by
    the NumPy route. None where the driver does not take the problem (size, no compiler)."""
    from . import c_damped

    n, L, e = np.shape(Je)[:3]
    r = np.shape(B)[-1]
    if L > c_damped.MAX_LEGS or e > c_damped.MAX_MODES or r > 6 or c_damped.driver() is None:
        return None
    M, K, Kg, B = (None if v is None else _shared(v, n) for v in (M, K, K_ground, B))
    M = np.broadcast_to(M, (n, 6, 6))
    k_d, c_d, t_d = (np.broadcast_to(np.asarray(v, dtype=float), (n, L)) for v in (k_d, c_d, t_d))
    rows = [M, Je, Cq, k_d, c_d, t_d] + [v for v in (K, Kg, B) if v is not None and v.ndim == 3]
    first, inverse = distinct_rows(np.concatenate([np.reshape(v, (n, -1)) for v in rows], axis=1))
    pick = (lambda v: v) if first is None else (lambda v: v if v is None or v.ndim < 3 else v[first])  # noqa: E731
    M, K, Kg, Je, Cq, B = (pick(v) for v in (M, K, Kg, np.asarray(Je), np.asarray(Cq), B))
    k_d, c_d, t_d = ((v if first is None else v[first]) for v in (k_d, c_d, t_d))
    rules = (RIGID, ELIMINATE, UNSTABLE_ZETA, AMBIGUOUS)
    wn, zeta, wd, poles, stable, redo = c_damped.solve_legs(M, K, Kg, Je, Cq, e, B, k_d, c_d, t_d, rules, threads)
    out = [wn / (2 * np.pi), wd / (2 * np.pi), zeta, poles, stable]
    if redo.any():  # the NumPy route for the driver's undecided poses
        sel = lambda v: v if v is None or v.ndim < 3 else v[redo]  # noqa: E731
        K_legs, W, h = actuator_wrenches(Je[redo], Cq[redo], None)
        Km = sel(K) if K is not None else K_legs + (0.0 if Kg is None else sel(Kg))
        Bs = np.broadcast_to(np.eye(6) if B is None else sel(B), (int(redo.sum()), 6, r))
        Bt = np.swapaxes(Bs, -1, -2)
        dn = damped_modes(Bt @ M[redo] @ Bs, Bt @ Km @ Bs, W @ Bs, h, k_d[redo], c_d[redo], t_d[redo])
        for arr, name in zip(out, ("natural_hz", "damped_hz", "damping_ratio", "poles", "stable")):
            arr[redo] = getattr(dn, name)
    if first is not None:
        out = [arr[inverse] for arr in out]
    return Damping(*out[:4], None, out[4])


def one_pass_takes(ev, effects) -> bool:
    """Whether the fused C pass of ``ev`` can solve the damped modes of ``effects`` in the same
    call (:func:`fused_damped`): the C backend with a generated ``legs`` kernel of at most
    :data:`.c_damped.MAX_LEGS` legs and :data:`.c_damped.MAX_MODES` elastic joints each, real
    and uncoupled (no structural loss factor, no couplings of platform bodies on) and the
    damped driver built. The caller also checks the model's route (``ModeSolver.one_pass``)."""
    from . import c_damped

    on = set(effects)
    if "structural_loss" in on or any(c.effect in on for c in ev.robot.couplings):
        return False
    legs = getattr(ev.kernels, "OUTPUTS", {}).get("legs", {})
    if "Je" not in legs or "Cq" not in legs or not hasattr(ev.kernels, "fused_arguments"):
        return False
    L, e, c = legs["Je"]
    if L > c_damped.MAX_LEGS or e > c_damped.MAX_MODES or c != 6:
        return False
    return c_damped.driver() is not None


def fused_damped(ev, effects, poses, p: dict, pk: dict, vectors: bool, basis, threads: int):
    """The fused pass of the C kernels and the damped modes of ``effects`` in one C call per
    range of blocks (:func:`.c_damped.one_pass`): ``(out, solved)``, ``out`` as
    ``CKernels.fused`` gives it (``q``, ``M``, the model's stiffness, ``freq_hz``, the
    eigentwists with ``vectors``, ``status``) and ``solved`` the damped poles on the model's
    coordinates with what :func:`pass_damping` needs. ``p``: the validated inputs of every
    pose (``Evaluator.parameter_values``), ``pk`` with the pose; ``basis``: the rigid model's
    fixed allowed twists (6, r) (the flexible model: the six twists, unused)."""
    from . import c_damped

    kernels = ev.kernels
    rigid = ev.stiffness_model(effects) == "rigid"
    k_name = "K_R" if rigid else "K_F"
    out, n, keep, args = kernels.fused_arguments(
        poses[:, 0],
        poses[:, 1],
        poses[:, 2],
        pk,
        matrices=("M", k_name),
        ik=("q",),
        model="rigid" if rigid else "flexible",
        vectors=vectors,
        normalize=True,
        status=True,
    )
    legs = kernels.kernel_arguments("legs", pk, n)
    k_d, c_d, t_d, _ = actuator_values(ev, p, effects, n)
    B = np.asarray(basis, dtype=float) if rigid else None
    Je, Cq = legs[4]["Je"], legs[4]["Cq"]
    result = c_damped.one_pass(
        (kernels.address("fused"), args),
        legs,
        kernels.BLOCK,
        n,
        out["q"],
        out["M"],
        out[k_name],
        Je,
        Cq,
        1 if rigid else Je.shape[2],
        B,
        k_d,
        c_d,
        t_d,
        (RIGID, ELIMINATE, UNSTABLE_ZETA, AMBIGUOUS),
        threads,
    )
    del keep
    return out, {"poles": result, "legs": legs[4], "stiffness": k_name, "M": out["M"], "K": out[k_name]}


def pass_damping(ev, effects, poses, params: dict, p: dict, solved: dict, modes) -> Damping:
    """The :class:`~.damped.Damping` of the fused pass's damped poles (:func:`fused_damped`)
    for ``modes``, its undamped modes with the evaluator's checks done: the rows not valid
    NaN as :func:`damped_of` leaves them, and the poses the C driver left undecided solved by
    :func:`damped_of` from the pass's kernel outputs (no kernel runs again; the driver's
    undecided poses go on to NumPy there)."""
    wn, zeta, wd, poles, stable, redo = solved["poles"]
    N = len(modes.freq_hz)
    valid = np.ones(N, dtype=bool) if modes.valid is None else np.asarray(modes.valid, dtype=bool)
    bad = ~valid
    natural, damped = wn / (2 * np.pi), wd / (2 * np.pi)
    natural[bad], damped[bad] = modes.freq_hz[bad], modes.freq_hz[bad]
    zeta[bad], poles[bad] = np.nan, np.nan
    out = Damping(natural, damped, zeta, poles, None, np.asarray(modes.stable, dtype=bool) & (stable | bad))
    rows = valid & redo
    if rows.any():  # the driver's undecided poses, on the pass's outputs
        mats = {"M": solved["M"], solved["stiffness"]: solved["K"]}
        _undecided(ev, effects, rows, poses, params, p, solved, mats, False, modes, out)
    return out


def _undecided(ev, effects, rows, poses, params: dict, p: dict, solved: dict, mats: dict, exact: bool, modes, out):
    """The damped modes of the poses ``rows`` (N,) a C pass left undecided, by
    :func:`damped_of` from the pass's outputs (``solved["legs"]``, ``mats``), written into
    ``out`` (a :class:`.damped.Damping` of all N poses)."""
    N = len(rows)

    def take(d: dict) -> dict:
        return {k: (v[rows] if np.ndim(v) and np.shape(v)[0] == N > 1 else v) for k, v in d.items()}

    inputs = {
        "rows": rows,
        "poses": np.asarray(poses, dtype=float)[rows],
        "params": take(params),
        "p": take(p),
        "legs": take(solved["legs"]),
        "mats": take(mats),
        "B": None,
        "exact": exact,
        "preloaded": False,
    }
    d = damped_of(ev, effects, inputs, modes, False)
    for name in ("natural_hz", "damped_hz", "damping_ratio", "poles", "stable"):
        getattr(out, name)[rows] = getattr(d, name)[rows]


def fused_exact(ev, effects, poses, p: dict, pk: dict, vectors: bool, damped: bool, threads: int):
    """The fused pass of the C kernels, the legs kernel, the exact condensation of the legs'
    rigid directions and, with ``damped``, the damped modes of ``effects`` in one C call per
    range of blocks (:func:`.c_damped.exact_pass`): ``(out, solved)``, ``out`` as
    ``CKernels.fused`` gives it (``q``, ``M``, K_F's ``freq_hz``, the eigentwists with
    ``vectors``, ``status``) and ``solved`` what :func:`exact_merge` needs. ``p``: the
    validated inputs of every pose (``Evaluator.parameter_values``), ``pk`` with the pose."""
    from . import c_damped, condense

    kernels = ev.kernels
    out, n, keep, args = kernels.fused_arguments(
        poses[:, 0],
        poses[:, 1],
        poses[:, 2],
        pk,
        matrices=("M",),
        ik=("q",),
        model="flexible",
        vectors=vectors,
        normalize=True,
        status=True,
    )
    legs = kernels.kernel_arguments("legs", pk, n)
    k_d = c_d = t_d = None
    if damped:
        k_d, c_d, t_d, _ = actuator_values(ev, p, effects, n)
    solved = c_damped.exact_pass(
        (kernels.address("fused"), args),
        legs,
        kernels.BLOCK,
        n,
        out["q"],
        out["M"],
        k_d,
        c_d,
        t_d,
        (RIGID, ELIMINATE, UNSTABLE_ZETA, AMBIGUOUS),
        condense.RIGID_RTOL * condense.NULL_FACTOR,
        vectors,
        threads,
    )
    del keep
    solved["legs"], solved["M"] = legs[4], out["M"]
    return out, solved


def exact_merge(ev, effects, poses, params: dict, p: dict, solved: dict, modes, vectors: bool):
    """``modes`` (the fused pass's K_F modes, the evaluator's checks done) with the exact
    condensation's finite modes of :func:`fused_exact` on its valid rows
    (:func:`.condense.merge_modes`, as ``ModeSolver.exact_modes`` does) and, where the pass
    solved them, ``modes.damping`` (:class:`~.damped.Damping` as :func:`damped_of` gives it;
    the poses the driver leaves undecided solved by :func:`damped_of` from the pass's kernel
    outputs). None, with ``modes`` untouched, where the pass does not stand for the
    condensation: no valid row, valid rows with different numbers of admissible twists (the
    damped modes take one for the batch) or a row whose undamped modes it did not solve."""
    from . import condense
    from .eigen import frequencies_hz

    N = len(modes.freq_hz)
    valid = np.ones(N, dtype=bool) if modes.valid is None else np.asarray(modes.valid, dtype=bool)
    if not valid.any():
        return None
    rows = slice(None) if valid.all() else valid  # every row valid: views of the pass's arrays, no row copies
    nb, code = solved["nb"][rows], solved["code"][rows]
    if np.any(nb != nb[0]) or np.any(code == 2):
        return None
    r = int(nb[0])
    f = np.full((len(nb), 6), np.inf)
    f[:, :r] = frequencies_hz(solved["lam"][rows][:, :r])
    modes = condense.merge_modes(modes, rows, f, solved["V"][rows] if vectors else None, vectors)
    if "damped" not in solved:
        return modes
    wn, zeta, wd, poles, stable = solved["damped"]
    freq = np.array(modes.freq_hz, dtype=float)
    out = Damping(
        freq.copy(),
        freq.copy(),
        np.full((N, 6), np.nan),
        np.full((N, 6), np.nan + 0j),
        None,
        np.array(modes.stable, dtype=bool),
    )
    block = (slice(None), slice(0, r))
    for name, value in (("natural_hz", wn / (2 * np.pi)), ("damped_hz", wd / (2 * np.pi)), ("damping_ratio", zeta)):
        arr = getattr(out, name)
        arr[rows] = np.where(np.arange(6) < r, value[rows], 0.0 if name == "damping_ratio" else arr[rows])
    sub = poles[rows]
    pr = out.poles[rows]
    pr[block] = sub[block]
    out.poles[rows] = pr
    out.stable[rows] &= stable[rows]
    redo = valid & (solved["code"] == 1)
    if redo.any():  # the driver's undecided poses, on the pass's outputs
        _undecided(ev, effects, redo, poses, params, p, solved, {"M": solved["M"]}, True, modes, out)
    modes.damping = out
    return modes


def _couplings(ev, effects, legs: dict, n: int):
    """``(T, K_x)`` of the couplings of platform bodies that are on: each leg's map T_i
    (n, 6, d) from ``x = [t; theta]`` to its body's twist and the couplings' stiffness on
    theta (n, d, d), as :func:`.condense.condensed_compliance` assembles them; None without."""
    couplings = sorted(ev.robot.couplings, key=lambda c: c.body)
    active = [k for k, c in enumerate(couplings) if c.effect in set(effects)]
    if not active:
        return None
    index = {couplings[k].body: j for j, k in enumerate(active)}
    bodies = [index.get(leg.platform_body, -1) for leg in ev.robot.legs]
    G_c = np.broadcast_to(
        legs["G_c"][:, active] if np.ndim(legs["G_c"]) == 4 else legs["G_c"][active],
        (n, len(active)) + np.shape(legs["G_c"])[-2:],
    )
    K_c = np.broadcast_to(
        legs["K_c"][:, active] if np.ndim(legs["K_c"]) == 3 else legs["K_c"][active],
        (n, len(active), np.shape(legs["K_c"])[-1]),
    )
    nc, m = G_c.shape[1], G_c.shape[3]
    d = 6 + nc * m
    K_x = np.zeros((n, d, d))
    K_x[:, :6, :6] = np.asarray(legs["K_ground"], dtype=float)
    T = {-1: np.broadcast_to(np.eye(6, d), (n, 6, d))}
    for k in range(nc):
        Tk = np.zeros((n, 6, d))
        Tk[:, :, :6] = np.eye(6)
        Tk[:, :, 6 + k * m : 6 + (k + 1) * m] = -G_c[:, k]
        T[k] = Tk
        idx = np.arange(6 + k * m, 6 + (k + 1) * m)
        K_x[:, idx, idx] = K_c[:, k]
    return [T[b] for b in bodies], K_x


def _coupled_reduction(Je, Cq, k_d, M, K_G, T, K_x, condense, loss=None):
    """The damped problem of legs on platform bodies joined by compliant couplings:
    ``(M, K, W, h, G, P)`` on the platform's massive admissible coordinates ``a`` (the twist
    ``t = P a``, P (n, 6, r)) for :func:`.damped.damped_modes`.

    On ``x = [t; theta]`` (the tool's twist and the couplings' massless coordinates) each
    leg adds its finite springs and actuator wrench moved by its map ``T_i``; the legs'
    rigid joint combinations restrict x to an orthonormal basis B_x; the inertia there,
    ``B_x^T diag(M, 0) B_x``, splits the coordinates into massive ones (its positive
    eigenvalues) and massless ones, which :func:`.damped.coupled_wrenches` condenses (complex
    with a structural ``loss`` factor)."""
    n, d = K_x.shape[0], K_x.shape[-1]
    K_x = np.array(K_x, dtype=float if loss is None else complex)
    if K_G is not None:
        K_x[:, :6, :6] += K_G
    Ws, hs, rows = [], [], []
    for i in range(Je.shape[1]):
        Ki, Wi, hi = actuator_wrenches(Je[:, i : i + 1], Cq[:, i : i + 1], 1.0 / k_d[:, i : i + 1], loss)
        K_x += np.swapaxes(T[i], -1, -2) @ Ki @ T[i]
        Ws.append((Wi @ T[i])[:, 0])
        hs.append(hi[:, 0])
        rows.append(condense.leg_condensation(Je[:, i], Cq[:, i])[1] @ T[i])
    W_x = np.stack(Ws, axis=1)
    B = _null_space(np.concatenate(rows, axis=1), d, condense)
    M_x = np.zeros((n, d, d))
    M_x[:, :6, :6] = M
    Bt = np.swapaxes(B, -1, -2)
    mu, U = np.linalg.eigh(Bt @ M_x @ B)  # real: B spans the real rigid rows' null space
    massive = mu > 1e-12 * mu.max(axis=-1, keepdims=True)
    r = int(massive.sum(axis=-1)[0])
    if np.any(massive.sum(axis=-1) != r):
        raise InputError(
            "damped modes: the platform's massive coordinates change in number across the poses; "
            "evaluate the poses in groups"
        )
    U = U[:, :, ::-1]  # massive first
    Q = B @ U
    Qt = np.swapaxes(Q, -1, -2)
    K, W, G = coupled_wrenches(Qt @ K_x @ Q, W_x @ Q, r)
    Mr = np.zeros((n, r, r))
    Mr[:, np.arange(r), np.arange(r)] = mu[:, ::-1][:, :r]
    return Mr, K, W, np.stack(hs, axis=1), G, Q[:, :6, :r]


def _null_space(A: np.ndarray, d: int, condense) -> np.ndarray:
    """(n, d, m) orthonormal basis of the x no row of A (n, rows, d) forbids; one rank for the batch."""
    n = len(A)
    if not np.any(A):
        return np.broadcast_to(np.eye(d), (n, d, d))
    _, sv, Vt = np.linalg.svd(A, full_matrices=True)
    rank = (sv > condense.RIGID_RTOL * sv.max(axis=-1, keepdims=True)).sum(axis=-1)
    if np.any(rank != rank[0]):
        raise InputError(
            "damped modes: the legs' rigid constraints change rank across the poses; evaluate the "
            "poses in groups of one rank"
        )
    return np.swapaxes(Vt[:, int(rank[0]) :, :], -1, -2)


def _admissible(Je: np.ndarray, Cq: np.ndarray, condense) -> np.ndarray:
    """(n, 6, m) orthonormal twists that no leg's rigid joint combination forbids (the
    identity where every direction is compliant), one rank for the batch."""
    n = len(Je)
    rows = [condense.leg_condensation(Je[:, i], Cq[:, i])[1] for i in range(Je.shape[1])]
    A = np.concatenate(rows, axis=1)
    if not np.any(A):
        return np.broadcast_to(np.eye(6), (n, 6, 6))
    _, sv, Vt = np.linalg.svd(A, full_matrices=True)
    rank = (sv > condense.RIGID_RTOL * sv.max(axis=-1, keepdims=True)).sum(axis=-1)
    if np.any(rank != rank[0]):
        raise InputError(
            "damped modes: the legs' rigid constraints change rank across the poses; evaluate the "
            "poses in groups of one rank"
        )
    return np.swapaxes(Vt[:, int(rank[0]) :, :], -1, -2)
