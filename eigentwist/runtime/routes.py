"""The routes of ``Evaluator.modes``: which solver takes a model, chosen in one table.

A model's modes are solved on one of two routes:

* ``"pass"``: the fused C pass from poses to checked frequencies and eigentwists (the C
  backend, for a flexible model (K_F, Eq. 13, on the six twists) or a rigid one (K_R,
  Eq. 14) on allowed twists fixed by the pose space, without the gravity preload);
* ``"matrices"``: M and K first (Eqs. 12-14, the gravity preload added, a rigid model
  reduced to the platform's allowed twists where they turn with the pose), then the
  batched eigen-solver of det(omega^2 M - K) = 0.

On either route a flexible model whose legs have rigid constraint directions takes its
finite modes from the exact condensation (:mod:`.condense`), and a model with a damping
effect adds its poles (:mod:`.damped`). :data:`ROUTES` says, per case, what the route does
with them; :func:`choose_route` reads it.
"""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Route", "ROUTES", "choose_route"]


@dataclass(frozen=True)
class Route:
    """How ``Evaluator.modes`` solves a model.

    solver : ``"pass"`` (the fused C pass) or ``"matrices"`` (matrices, then the eigen-solver).
    how : on the ``"pass"`` route, what the same C call does besides the undamped modes:
        ``"exact"`` the exact condensation (and a damped model's poles), ``"pass"`` the
        damped modes, ``"keep"`` keeps q, M and K for the damped modes solved after it;
        None nothing (an exact condensation then runs on the pass's q and M).
    keep : on the ``"matrices"`` route, whether the joint coordinates and matrices are kept
        for the steps after the eigen-solver (the exact condensation, the damped modes).
    """

    solver: str
    how: str | None = None
    keep: bool = False


#: Any value of that condition.
ANY = None

#: The routes, first matching row wins. Conditions: (the fused C pass runs the model, the
#: model condenses rigid directions exactly, the model is damped (or complex mode shapes
#: are asked for), the C pass solves its damped modes itself, the backend is C).
ROUTES: tuple = (
    # C pass  exact  damped  pass solves  C backend  ->  route
    ((True, True, ANY, True, ANY), Route("pass", "exact")),
    ((True, True, ANY, False, ANY), Route("pass", None)),
    ((True, False, True, True, ANY), Route("pass", "pass")),
    ((True, False, True, False, ANY), Route("pass", "keep")),
    ((True, False, False, ANY, ANY), Route("pass", None)),
    ((False, True, ANY, ANY, ANY), Route("matrices", keep=True)),
    ((False, False, True, ANY, False), Route("matrices", keep=True)),
    ((False, False, True, ANY, True), Route("matrices", keep=False)),
    ((False, False, False, ANY, ANY), Route("matrices", keep=False)),
)

#: the column of the condition that is asked lazily (it may look up a compiled kernel)
_PASS_SOLVES = 3


def choose_route(c_pass: bool, exact: bool, damped: bool, pass_solves, c_backend: bool) -> Route:
    """The :data:`ROUTES` row for this case.

    c_pass : the fused C pass can run the model (C backend, K_F or fixed allowed twists,
        no gravity preload).
    exact : the finite modes come from the exact condensation (``Evaluator.constraint_route``).
    damped : the model has a damping effect, or complex mode shapes are asked for.
    pass_solves : ``() -> bool``, whether the C pass solves the damped modes itself
        (asked only where a row depends on it).
    c_backend : the evaluator runs the C backend.
    """
    known = [bool(c_pass), bool(exact), bool(damped), None, bool(c_backend)]
    for conditions, route in ROUTES:
        for k, want in enumerate(conditions):
            if want is ANY:
                continue
            if known[k] is None:
                known[k] = bool(pass_solves())
            if known[k] != want:
                break
        else:
            return route
    raise AssertionError(f"no route for {known}")  # ROUTES covers every case (tests/test_routes.py)
