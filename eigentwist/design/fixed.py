"""Which masses and inertias a design study holds fixed while lengths move.

A description's masses (kg), first moments (kg m) and inertias (kg m^2) are parameters of
their own unless it computes them from dimensions (a tube's mass from its density and
length): when ``optimize`` or ``sensitivity`` moves a length, they stay at their values.
These functions name them, and name the inertias that make a mass rank +0 (a body turning
about a fixed joint axis has its kinetic energy from its inertia about that axis, a
parameter of its own that does not follow the mass).
"""

from __future__ import annotations

__all__ = ["MASS_UNITS", "ZERO_SENSITIVITY", "held_fixed", "held_fixed_line", "inertias_of", "zero_mass_lines"]

#: units of the parameters that are masses, first moments of mass and inertias
MASS_UNITS = ("kg", "kg m", "kg m^2")
#: a relative sensitivity |d ln f1 / d ln p| below this is zero: the central differences of
#: the matrices agree with the exact derivatives to about 1e-9, far below it
ZERO_SENSITIVITY = 1e-6


def _acting(ev, model) -> dict:
    """The parameters that act in ``model`` (those of effects it switches off do not)."""
    from ..description.effects import base_name

    on = {base_name(e) for e in model}
    return {n: p for n, p in ev.parameters.items() if p.effect is None or p.effect in on}


def held_fixed(ev, moving, model=()) -> list[str]:
    """Names of the mass and inertia parameters (units :data:`MASS_UNITS`) acting in
    ``model`` that stay at their values while the parameters ``moving`` move; empty when
    no length (m) moves."""
    moving = {m.partition("@")[0] for m in moving}
    if not any(ev.parameters[m].unit == "m" for m in moving if m in ev.parameters):
        return []
    return [n for n, p in _acting(ev, model).items() if p.unit in MASS_UNITS and n not in moving]


def held_fixed_line(ev, moving, model=(), values=None) -> str | None:
    """One line naming the masses and inertias held fixed while the lengths in ``moving``
    move (their values from ``values``, else the defaults), or None."""
    names = held_fixed(ev, moving, model)
    if not names:
        return None
    values = values or {}
    lengths = [m for m in moving if ev.parameters.get(m.partition("@")[0]) and ev.parameter(m).unit == "m"]
    listed = ", ".join(f"{n} = {float(values.get(n, ev.defaults[n])):.4g} {ev.parameters[n].unit}" for n in names)
    return (
        f"held fixed while {', '.join(lengths)} move{'s' if len(lengths) == 1 else ''}: {listed} "
        "(parameters of their own, not functions of the lengths; vary them too or set them with --set)"
    )


def inertias_of(ev, mass: str) -> list[str]:
    """The inertia parameters (kg m^2) of the body whose mass is ``mass``, matched by name
    (``m_1`` -> ``I1_xx, I1_yy, I1_zz``; ``m_e`` -> ``I_e_xx, ...``; ``m_cyl_hub`` ->
    ``I_cyl_hub``); every inertia parameter where no name matches."""
    name = mass.partition("@")[0]
    key = name[2:] if name.startswith("m_") else name[1:]
    inertias = [n for n, p in ev.parameters.items() if p.unit == "kg m^2"]
    named = [n for n in inertias if key and (key in n[1:].split("_") or f"{n[1:]}_".startswith(f"{name[1:]}_"))]
    return named or inertias


def zero_mass_lines(ev, rows) -> list[str]:
    """For each mass (kg) ranked zero (``rows``: the sensitivity table's dicts with
    ``name``, ``unit``, ``dlnf1_dlnp``), the line that says why: its body's inertia is a
    separate parameter that does not follow it."""
    out = []
    for r in rows:
        if r["unit"] == "kg" and abs(r["dlnf1_dlnp"]) < ZERO_SENSITIVITY:
            inertias = inertias_of(ev, r["name"])
            out.append(
                f"{r['name']} ranks +0: the model takes its body's inertia from separate parameters "
                f"({', '.join(inertias)}), which do not follow {r['name']}; a heavier body moves them too"
            )
    return out
