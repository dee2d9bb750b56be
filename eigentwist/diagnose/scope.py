"""Effects in a diagnosis: all legs or one leg (``EFFECT@N``), their fitted parameters,
and the per-leg candidates.

A leg-level effect is offered for all legs and for each leg alone, even when the model
already has it on all legs: ``actuator_loss@3`` fits ``eta_a@3``, leg 3's own value.
"""

from __future__ import annotations

from ..description.effects import EFFECTS, base_name, resolve_model, scoped_name, split_scope

__all__ = ["order", "rank", "fit_names", "parameter_names", "taken", "candidates", "where", "sentence"]


def order(ev, effects) -> tuple:
    """``effects`` in the robot's order (each ``EFFECT@N`` after its effect)."""
    return resolve_model(tuple(effects), ev.robot)


def rank(item: str) -> tuple:
    """Tie-break order of ``item``: the catalogue's order (a robot's own effects after it),
    all legs before leg 1, 2, ..."""
    name, leg = split_scope(item)
    names = list(EFFECTS)
    return (names.index(name) if name in names else len(names), name, leg or 0)


def _scoped(names, item: str) -> tuple:
    _, leg = split_scope(item)
    return tuple(scoped_name(n, leg) for n in names)


def fit_names(ev, item: str) -> tuple:
    """Names the diagnosis fits for ``item``: ``("eta_a",)`` or ``("eta_a@3",)``."""
    return _scoped(ev.robot.effect(base_name(item)).fit, item)


def parameter_names(ev, item: str) -> tuple:
    """Every parameter ``item`` brings, scoped like it."""
    return _scoped(ev.robot.effect(base_name(item)).parameters, item)


def taken(ev, effects) -> set:
    """Parameter names the effects in a model already own."""
    return {p for e in effects for p in parameter_names(ev, e)}


def candidates(ev, effects, per_leg: bool = True, damping: bool = True) -> list[str]:
    """Effects to try on top of ``effects``: each effect the robot has that is not in the
    model and not an alternative description of a part in it (shares a parameter), and
    with ``per_leg`` each leg-level effect on each leg alone; the damping effects only with
    ``damping`` (data that carry a damped frequency or a damping ratio)."""
    have = taken(ev, effects)
    out = []
    for e in ev.effects:
        if not damping and "damping" in ev.robot.effect(e).primitives:
            continue
        items = [e]
        if per_leg and ev.robot.effect(e).leg_level:
            items += [scoped_name(e, k) for k in range(1, ev.n_legs + 1)]
        out += [i for i in items if i not in effects and not set(parameter_names(ev, i)) & have]
    return out


def where(item: str) -> list[int]:
    """Leg numbers ``item`` acts on alone: ``[3]`` for ``EFFECT@3``, ``[]`` for all legs."""
    _, leg = split_scope(item)
    return [] if leg is None else [leg]


def sentence(ev, item: str, values: dict, model=()) -> str | None:
    """What a per-leg fit says about one component, e.g. "leg 3's actuator delivers 0.45
    of its commanded stiffness (the other legs 0.82)"; None for an all-legs item.

    ``values`` are the fitted (and fixed) values; ``model`` the effects of the model the
    item was fitted in: the other legs have the effect's shared values when it is in it.
    """
    name, leg = split_scope(item)
    if leg is None:
        return None
    effect = ev.robot.effect(name)
    names = effect.fit or effect.parameters
    own = {p: float(values.get(scoped_name(p, leg), ev.parameters[p].default)) for p in names}
    component = effect.component or name.replace("_", " ")
    if effect.phrase:
        text = f"leg {leg}'s {component} {effect.phrase.format(**own)}"
    else:
        text = f"leg {leg}'s {component}: " + ", ".join(f"{p} = {own[p]:.3g} {ev.parameters[p].unit}" for p in names)
    if name not in tuple(model):
        return text + " (the other legs without it)"
    other = ", ".join(f"{float(values.get(p, ev.parameters[p].default)):.3g}" for p in names)
    return text + f" (the other legs {other})"
