"""The catalogue of named physical effects and the model presets.

Every effect is a documented term of the closed-form model. Its terms are multiplied
by a switch symbol ``on_<effect>`` (0 or 1) in the derivation, so one generated
evaluator serves every combination of effects: switching an effect costs no
regeneration. The names below are an interface (CLI, JSON, CSV): keep them stable.
"""
from __future__ import annotations

from dataclasses import dataclass

from .names import did_you_mean

__all__ = ["Effect", "EFFECTS", "PRESETS", "STRUCTURAL", "resolve_model", "switch_name"]


@dataclass(frozen=True)
class Effect:
    """A named physical effect.

    name : interface name (``rod_compliance``).
    doc : one-line physical meaning with the paper reference.
    parameters : names of the parameters this effect brings (looked up in the robot).
    fit : the subset that ``diagnose`` fits to measurements.
    structural : True when it adds compliance in the legs' constrained directions, so
        that the model needs the full-rank flexible stiffness K_F (Eq. 13) instead of
        the 3x3 rigid-body K_R (Eq. 14).
    """

    name: str
    doc: str
    parameters: tuple[str, ...]
    fit: tuple[str, ...]
    structural: bool = False


EFFECTS: dict[str, Effect] = {e.name: e for e in (
    Effect("actuator_loss",
           "delivered/commanded actuator stiffness factor eta_a (Eq. 34, App. B: 0.82)",
           ("eta_a",), ("eta_a",)),
    Effect("rod_compliance",
           "bending/axial compliance of the two parallelogram rods as cantilevers (App. C, Eqs. 44, C.10)",
           ("E_rod", "G_rod"), ("E_rod",), structural=True),
    Effect("ee_compliance",
           "end-effector assembly compliance k_E_rot about Y and k_E_lin along Y, split over the legs (App. D, Eqs. 45-49)",
           ("k_E_rot", "k_E_lin"), ("k_E_rot", "k_E_lin"), structural=True),
    Effect("ee_coupling",
           "traveling plates as rigid bodies joined to the tool by compliant couplings (k_E_rot about Y, k_E_lin along Y), condensed in closed form at any pose (issue 7)",
           ("k_E_rot", "k_E_lin"), ("k_E_rot", "k_E_lin"), structural=True),
    Effect("lower_link_compliance",
           "bending and torsion of the lower links l1 as hollow tubes clamped at the actuated joint",
           ("r_o_l1", "r_i_l1", "E_l1", "nu_l1"), ("E_l1",), structural=True),
    Effect("transmission_compliance",
           "torsional compliance 1/k_t in series with each actuator",
           ("k_t",), ("k_t",)),
    Effect("payload_mass",
           "rigid point payload m_p on the end-effector at offset (p_x, p_y, p_z)",
           ("m_p", "p_x", "p_y", "p_z"), ("m_p",)),
    Effect("rotor_inertia",
           "additional inertia I_add about each actuated axis (adds to Eq. 22)",
           ("I_add",), ("I_add",)),
    Effect("gravity_preload",
           "the tau_e term of Eq. 13 from the static gravity load g on the end-effector and payload",
           ("g",), ("g",)),
)}

STRUCTURAL = tuple(n for n, e in EFFECTS.items() if e.structural)

PRESETS: dict[str, tuple[str, ...]] = {
    "rigid": ("actuator_loss",),
    "paper": ("actuator_loss", "rod_compliance", "ee_compliance"),
    "coupled": ("actuator_loss", "rod_compliance", "ee_coupling"),
}


def switch_name(effect: str) -> str:
    """Name of the 0/1 switch symbol of ``effect`` in the generated code."""
    return f"on_{effect}"


def resolve_model(spec, available=None) -> tuple[str, ...]:
    """Turn a model spec into a sorted-by-catalogue tuple of effect names.

    ``spec`` is a preset name (``"rigid"``, ``"paper"``, ``"coupled"``), a
    comma-separated list of presets and effects (``"rigid,payload_mass"``), or an
    iterable of names; ``"none"`` is the bare model without any effect. Unknown names
    raise ``ValueError`` listing the valid ones. A
    preset keeps only the effects the robot has (``available``); an effect named
    explicitly that the robot lacks is an error.
    """
    if isinstance(spec, str):
        if spec.strip().lower() in ("", "none"):
            return ()                      # the bare model: no effect at all
        items = [s.strip() for s in spec.replace("+", ",").split(",") if s.strip()]
    else:
        items = list(spec)
    names: set[str] = set()
    for item in items:
        if item in PRESETS:
            preset = PRESETS[item]
            names.update(e for e in preset if available is None or e in available)
        elif item in EFFECTS:
            names.add(item)
        else:
            valid = list(PRESETS) + list(EFFECTS)
            raise ValueError(f"unknown model or effect {item!r}{did_you_mean(item, valid)}: "
                             f"expected one of {', '.join(valid)}")
    if available is not None:
        missing = sorted(names - set(available))
        if missing:
            raise ValueError(f"effect(s) {', '.join(missing)} not available for this robot (it has: {', '.join(available)})")
    return tuple(n for n in EFFECTS if n in names)
