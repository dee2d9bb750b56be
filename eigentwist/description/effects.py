"""The catalogue of named physical effects and the model presets.

Every effect is a documented term of the closed-form model. Its terms are multiplied
by a switch symbol ``on_<effect>`` (0 or 1) in the derivation, so one generated
evaluator serves every combination of effects: switching an effect costs no
regeneration. The names below are an interface (CLI, JSON, CSV): keep them stable.
"""
from __future__ import annotations

from dataclasses import dataclass

from .constraints import Constraint, tube
from .parameters import Parameter, sym

__all__ = ["Effect", "EFFECTS", "PRESETS", "STRUCTURAL", "KINDS", "resolve_model", "switch_name",
           "effect_parameters"]

INF = float("inf")

#: The primitive kinds every effect is an instance of (issue 11): the derivation handles
#: each kind generically.
KINDS = {
    "joint_series": "a compliance in series with a leg's actuated joint (actuator loss, transmission)",
    "body_compliance": "a 6x6 compliance of a body of a leg's chain, in that body's frame (rods, lower-link tubes, "
                       "the paper's per-leg share of the end-effector assembly)",
    "added_inertia": "inertia added to a body (payload on the platform, rotor inertia on the actuated link)",
    "platform_coupling": "a compliant coupling between two platform bodies (ee_coupling)",
    "ground_spring": "a spring between the platform and the ground (hoses, cables, a guard)",
    "preload": "a static preload whose stiffness enters the first term of Eq. 13 (gravity)",
}


@dataclass(frozen=True)
class Effect:
    """A named physical effect that owns its parameters.

    name : interface name (``rod_compliance``).
    doc : one-line physical meaning with the paper reference.
    params : the :class:`Parameter` objects this effect brings, declared once here with
        unit, default, plausible range, doc and paper equation; a robot passes only the
        values that differ (:func:`effect_parameters`).
    fit : the subset that ``diagnose`` always fits to measurements (more join when the data
        identify them, :mod:`eigentwist.diagnose.identifiable`); empty for an effect that is
        switched on or off with known parameter values (``gravity_preload``: g is known).
    structural : True when it adds compliance in the legs' constrained directions, so
        that the model needs the full-rank flexible stiffness K_F (Eq. 13) instead of
        the 3x3 rigid-body K_R (Eq. 14).
    kind : one of :data:`KINDS`.
    leg_level : True when the effect acts on each leg separately, so that it can be
        scoped to one leg (``EFFECT@N``).
    equation : the paper equation or appendix it implements.
    constraints : conditions its parameters must meet together (:mod:`.constraints`).
    """

    name: str
    doc: str
    params: tuple[Parameter, ...]
    fit: tuple[str, ...]
    structural: bool = False
    kind: str = "body_compliance"
    leg_level: bool = False
    equation: str = ""
    constraints: tuple[Constraint, ...] = ()

    @property
    def parameters(self) -> tuple[str, ...]:
        """Names of this effect's parameters."""
        return tuple(p.name for p in self.params)

    def parameter(self, name: str) -> Parameter:
        for p in self.params:
            if p.name == name:
                return p
        raise KeyError(f"effect {self.name!r} has no parameter {name!r}: it has {', '.join(self.parameters)}")


def _p(name, default, unit, doc, effect, plausible, bounds=(0.0, INF), equation=""):
    return Parameter(name, default, unit, doc, bounds, effect, plausible, equation)


# The end-effector assembly stiffnesses are one physical part described two ways
# (ee_compliance splits it over the legs, ee_coupling condenses it): one declaration.
_K_E = (
    _p("k_E_rot", 500.0, "N m/rad", "EE assembly rotational stiffness about Y (Eq. D.1; facts file: 500 reproduces Eq. 58)",
       "ee_compliance", (50.0, 5.0e4), equation="App. D, Eqs. 45-46, D.1"),
    _p("k_E_lin", 100 / 0.77e-3, "N/m", "EE assembly linear stiffness along Y (Eq. D.2)",
       "ee_compliance", (1.0e4, 1.0e8), equation="App. D, Eqs. 47-48, D.2"),
)

EFFECTS: dict[str, Effect] = {e.name: e for e in (
    Effect("actuator_loss",
           "delivered/commanded actuator stiffness factor eta_a (Eq. 34, App. B: 0.82)",
           (_p("eta_a", 0.82, "-", "delivered/commanded actuator stiffness (App. B); plausible: a servo delivers "
               "30 % to 105 % of its commanded stiffness", "actuator_loss", (0.3, 1.05), (0.05, 1.5), "Eq. 34, App. B"),),
           ("eta_a",), kind="joint_series", leg_level=True, equation="Eq. 34, App. B"),
    Effect("rod_compliance",
           "bending/axial compliance of the two parallelogram rods as cantilevers (App. C, Eqs. 44, C.10)",
           (_p("E_rod", 170e9, "Pa", "Young's modulus of the parallelogram rods (facts file: fitted to K_F(3,3), carbon "
               "fibre); plausible: glass fibre to steel, 40-250 GPa", "rod_compliance", (40e9, 250e9),
               equation="App. C, Eq. C.10"),
            _p("G_rod", 65e9, "Pa", "shear modulus of the rods (not in the paper; no influence on K_F); plausible "
               "10-90 GPa", "rod_compliance", (10e9, 90e9), equation="App. C")),
           ("E_rod",), structural=True, kind="body_compliance", leg_level=True, equation="App. C, Eqs. 44, C.10"),
    Effect("ee_compliance",
           "end-effector assembly compliance k_E_rot about Y and k_E_lin along Y, split over the legs (App. D, Eqs. 45-49)",
           _K_E, ("k_E_rot", "k_E_lin"), structural=True, kind="body_compliance", equation="App. D, Eqs. 45-49"),
    Effect("ee_coupling",
           "traveling plates as rigid bodies joined to the tool by compliant couplings (k_E_rot about Y, k_E_lin along Y), "
           "condensed in closed form at any pose (issue 7)",
           _K_E, ("k_E_rot", "k_E_lin"), structural=True, kind="platform_coupling", equation="App. D (issue 7)"),
    Effect("lower_link_compliance",
           "bending and torsion of the lower links l1 as hollow tubes clamped at the actuated joint",
           (_p("r_o_l1", 0.012, "m", "outer radius of the lower link tube", "lower_link_compliance", (0.002, 0.1)),
            _p("r_i_l1", 0.010, "m", "inner radius of the lower link tube (below r_o_l1)", "lower_link_compliance",
               (0.0, 0.1)),
            _p("E_l1", 70e9, "Pa", "Young's modulus of the lower link tube (aluminium); plausible: aluminium to "
               "steel, or carbon fibre, 40-250 GPa", "lower_link_compliance", (40e9, 250e9)),
            _p("nu_l1", 0.33, "-", "Poisson ratio of the lower link tube (G = E/(2(1+nu)))", "lower_link_compliance",
               (0.2, 0.45), (0.0, 0.5))),
           ("E_l1",), structural=True, kind="body_compliance", leg_level=True,
           constraints=tube(sym("r_i_l1"), sym("r_o_l1"), "the lower link tube")),
    Effect("transmission_compliance",
           "torsional compliance 1/k_t in series with each actuator",
           (_p("k_t", 20000.0, "N m/rad", "torsional stiffness of each transmission, in series with the actuator; "
               "plausible: belts and small gearboxes to large harmonic drives, 1e3-1e6 N m/rad",
               "transmission_compliance", (1.0e3, 1.0e6)),),
           ("k_t",), kind="joint_series", leg_level=True),
    Effect("payload_mass",
           "rigid point payload m_p on the end-effector at offset (p_x, p_y, p_z)",
           (_p("m_p", 0.2, "kg", "payload mass on the end-effector; plausible 0-20 kg", "payload_mass", (0.0, 20.0)),
            _p("p_x", 0.0, "m", "payload offset from the EE origin along X", "payload_mass", (-0.3, 0.3), (-1.0, 1.0)),
            _p("p_y", 0.0, "m", "payload offset from the EE origin along Y", "payload_mass", (-0.3, 0.3), (-1.0, 1.0)),
            _p("p_z", 0.0, "m", "payload offset from the EE origin along Z", "payload_mass", (-0.3, 0.3), (-1.0, 1.0))),
           ("m_p",), kind="added_inertia"),
    Effect("rotor_inertia",
           "additional inertia I_add about each actuated axis (adds to Eq. 22)",
           (_p("I_add", 2e-3, "kg m^2", "additional inertia about each actuated axis; plausible 0-0.05 kg m^2 "
               "(up to ten times a large servo rotor)", "rotor_inertia", (0.0, 0.05), equation="Eq. 22"),),
           ("I_add",), kind="added_inertia", leg_level=True, equation="Eq. 22"),
    Effect("gravity_preload",
           "the tau_e term of Eq. 13 from the static gravity load g on the end-effector and payload",
           (_p("g", 9.81, "m/s^2", "gravitational acceleration (along -Z) for the static preload; a known constant "
               "(plausible 9.78-9.84 m/s^2 on Earth)", "gravity_preload", (9.78, 9.84), (0.0, 100.0), "Eq. 13"),),
           (), kind="preload", equation="Eq. 13"),   # switched, not fitted: g is known (issue 10)
)}


def effect_parameters(effects, values: dict | None = None) -> tuple[Parameter, ...]:
    """The parameters of ``effects`` (names), each declared once in :data:`EFFECTS`.

    ``values`` maps a parameter name to what a robot changes: a number (its default) or a
    dict of :class:`Parameter` fields (``{"default": 0.015, "doc": ..., "plausible": ...}``).
    A parameter shared by two effects appears once.
    """
    values = dict(values or {})
    out, seen = [], set()
    for name in effects:
        for p in EFFECTS[name].params:
            if p.name in seen:
                continue
            seen.add(p.name)
            change = values.pop(p.name, None)
            if change is not None:
                p = p.with_values(**(change if isinstance(change, dict) else {"default": float(change)}))
            out.append(p)
    if values:
        raise ValueError(f"values for {', '.join(sorted(values))}: no effect among {', '.join(effects)} has them")
    return tuple(out)


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
            valid = ", ".join(list(PRESETS) + list(EFFECTS))
            raise ValueError(f"unknown model or effect {item!r}: expected one of {valid}")
    if available is not None:
        missing = sorted(names - set(available))
        if missing:
            raise ValueError(f"effect(s) {', '.join(missing)} not available for this robot (it has: {', '.join(available)})")
    return tuple(n for n in EFFECTS if n in names)
