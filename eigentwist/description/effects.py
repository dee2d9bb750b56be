"""The catalogue of named physical effects and the model presets.

Every effect is a documented term of the closed-form model, an instance of one of a few
primitive (:data:`PRIMITIVES`) that the derivation handles generically: the effect carries
its parameters, the body or frame it acts on and a ``build`` function that returns its
term (a compliance, an inertia, a stiffness, a load) from an :class:`EffectContext`.
Its terms are multiplied by a switch symbol ``on_<effect>`` (0 or 1) in the derivation,
so one generated evaluator serves every combination of effects: switching an effect
costs no regeneration. A leg-level effect has one switch and one copy of its parameters
per leg (``on_<effect>__<N>``, ``<param>__<N>``), so that it can act on one leg alone
(``EFFECT@N``, ``NAME@N``) without regenerating either. The names below are an
interface (CLI, JSON, CSV): keep them stable.
"""

from __future__ import annotations

import functools
import warnings

from dataclasses import dataclass
from typing import Any, Callable

import sympy as sp

from ..errors import DescriptionError, InputError
from .constraints import Constraint, tube
from .names import did_you_mean
from .parameters import Parameter, sym

__all__ = [
    "Effect",
    "Term",
    "EffectContext",
    "EFFECTS",
    "PRESETS",
    "STRUCTURAL",
    "PRIMITIVES",
    "KINDS",
    "resolve_model",
    "switch_name",
    "effect_parameters",
    "split_scope",
    "scoped_name",
    "base_name",
    "leg_switch_name",
    "leg_input_name",
]

INF = float("inf")

#: The primitives every effect is an instance of: the derivation handles each
#: generically.
PRIMITIVES = {
    "joint_series": "a compliance in series with a leg's actuated joint (actuator loss, transmission)",
    "body_compliance": "a 6x6 compliance of a body of a leg's chain, in that body's frame (rods, lower-link tubes, "
    "the paper's per-leg share of the end-effector assembly)",
    "added_inertia": "inertia added to a body (payload on the platform, rotor inertia on the actuated link)",
    "platform_coupling": "a compliant coupling between two platform bodies (ee_coupling)",
    "ground_spring": "a spring between the tool and the ground (hoses, cables, a guard); no catalogue effect: "
    "a user's description adds one (README, 'Effects of your own')",
    "preload": "a static preload whose stiffness enters the first term of Eq. 13 (gravity)",
    "damping": "a dissipation (servo damping, a torque lag, a structural loss factor): no term of M or K; each "
    "mode's pole from the damped problem (eigentwist.runtime.damped)",
}
KINDS = PRIMITIVES  # the name user files may import


def _kind_alias(cls):
    """Let ``cls`` (a frozen dataclass with a ``primitive`` field) take ``kind=`` and answer
    ``.kind`` with a DeprecationWarning: user files written with that name keep working."""
    init = cls.__init__

    @functools.wraps(init)
    def __init__(self, *args, kind=None, **kwargs):
        if kind is not None:
            warnings.warn(
                f"{cls.__name__}(kind=...) is deprecated: use primitive={kind!r}", DeprecationWarning, stacklevel=2
            )
            if "primitive" in kwargs:
                raise DescriptionError(f"{cls.__name__}: give primitive or kind (its old name), not both")
            kwargs["primitive"] = kind
        init(self, *args, **kwargs)

    def kind(self) -> str:
        warnings.warn(f"{cls.__name__}.kind is deprecated: use .primitive", DeprecationWarning, stacklevel=2)
        return self.primitive

    cls.__init__ = __init__
    cls.kind = property(kind, doc="Deprecated name of ``primitive``.")
    return cls


@_kind_alias
@dataclass(frozen=True)
class Term:
    """One part of an effect of several parts: a term of one of the :data:`PRIMITIVES`,
    the body or frame it acts on and its ``build`` function (as :class:`Effect`'s
    ``primitive``, ``body`` and ``build``). A cable chain is a mass on the tool
    (``added_inertia``) and a spring to ground (``ground_spring``) under one switch."""

    primitive: str
    build: Callable[["EffectContext"], Any] | None = None
    body: str = ""

    def __post_init__(self):
        if self.primitive not in PRIMITIVES:
            raise DescriptionError(f"term primitive {self.primitive!r} is not one of {', '.join(PRIMITIVES)}")


@_kind_alias
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
    primitive : one of :data:`PRIMITIVES`.
    leg_level : True when the effect acts on each leg separately, so that it can be
        scoped to one leg (``EFFECT@N``).
    equation : the paper equation or appendix it implements.
    body : where it acts: a leg frame (``"J1"`` lower link at the actuated joint, ``"E1"``
        lower link tip, ``"C3"`` parallelogram centre, ``"L2"`` rod tips at a_i) for
        ``body_compliance`` and ``added_inertia`` of a leg's chain, ``"platform"`` for a
        term already at the EE origin in EE axes.
    build : ``build(ctx: EffectContext)`` returns the effect's term in symbols, by primitive:
        ``joint_series``: the compliance (rad/(N m)) in series with the actuated joint;
        ``body_compliance``: a 6x6 compliance in ``body``'s frame (or None: not on this leg);
        ``added_inertia``: a 6x6 spatial inertia in ``body``'s frame (or ``{body: 6x6}``
        for an effect that moves mass between bodies of a leg: ``swinging_rods``);
        ``ground_spring``: ``(K, rotation, origin)``, a 6x6 stiffness (N m/rad, N/m) in a
        frame of the tool with axes ``rotation`` (3x3, columns in EE axes) at ``origin``
        (3, m from the EE origin); ``preload``: the acceleration of gravity (3, m/s^2)
        acting on the platform's inertia. ``platform_coupling`` needs none: the robot's
        :class:`~eigentwist.description.Coupling` names the effect.
    component : the part it describes, for the diagnosis' sentences ("actuator").
    phrase : what one leg's fitted values say, formatted with the fit parameters
        (``"delivers {eta_a:.2f} of its commanded stiffness"``); "" lists the values.
    constraints : conditions its parameters must meet together (:mod:`.constraints`).
    terms : an effect of several parts: its :class:`Term` objects, each with
        its own primitive, body and build, all under the effect's one switch (``on_<effect>``)
        and fitted jointly (``fit``); ``primitive``, ``body`` and ``build`` are then taken from
        the first term. Empty: the effect is the one term ``primitive``/``body``/``build``.
    """

    name: str
    doc: str
    params: tuple[Parameter, ...]
    fit: tuple[str, ...]
    structural: bool = False
    primitive: str = "body_compliance"
    leg_level: bool = False
    equation: str = ""
    body: str = ""
    build: Callable[["EffectContext"], Any] | None = None
    component: str = ""
    phrase: str = ""

    def __post_init__(self):
        if self.terms:
            if not all(isinstance(t, Term) for t in self.terms):
                raise DescriptionError(f"effect {self.name!r}: terms must be Term objects (primitive, build, body)")
            first = self.terms[0]
            object.__setattr__(self, "primitive", first.primitive)
            object.__setattr__(self, "body", first.body)
            object.__setattr__(self, "build", first.build)
        if self.primitive not in PRIMITIVES:
            raise DescriptionError(
                f"effect {self.name!r}: primitive {self.primitive!r} is not one of {', '.join(PRIMITIVES)}"
            )
        if "@" in self.name or not self.name.isidentifier():
            raise DescriptionError(f"effect name {self.name!r}: expected a Python identifier (no '@')")

    constraints: tuple[Constraint, ...] = ()
    terms: tuple[Term, ...] = ()

    def parts(self) -> tuple["Effect", ...]:
        """The effect's terms, each as an :class:`Effect` of one primitive with this effect's
        name, parameters and switch (the derivation handles each by its primitive)."""
        if not self.terms:
            return (self,)
        from dataclasses import replace

        return tuple(replace(self, primitive=t.primitive, body=t.body, build=t.build, terms=()) for t in self.terms)

    @property
    def primitives(self) -> tuple[str, ...]:
        """The primitives of its terms (one for a single-term effect)."""
        return tuple(t.primitive for t in self.terms) or (self.primitive,)

    @property
    def parameters(self) -> tuple[str, ...]:
        """Names of this effect's parameters."""
        return tuple(p.name for p in self.params)

    def parameter(self, name: str) -> Parameter:
        for p in self.params:
            if p.name == name:
                return p
        raise KeyError(f"effect {self.name!r} has no parameter {name!r}: it has {', '.join(self.parameters)}")


@dataclass(frozen=True)
class EffectContext:
    """What an effect's ``build`` function gets from the derivation.

    robot : the :class:`~eigentwist.description.RobotDescription`.
    p : the effect's parameters as SymPy symbols, by name (each leg's own copy for a
        leg-level effect).
    index : 0-based leg index, or None for a platform-level term.
    leg : the :class:`~eigentwist.description.Leg`, or None.
    screws : the leg's screws, frames and vectors at the current joint angles
        (:class:`eigentwist.symbolic.leg.LegScrews`), or None.
    """

    robot: Any
    p: dict
    index: int | None = None
    leg: Any = None
    screws: Any = None


# ------------------------------------------------------------ catalogue terms
def _actuator_loss(ctx):
    """1/(eta k_a) = 1/k_a + (1/eta - 1)/k_a: the loss as a compliance in series (Eq. 34);
    k_a the leg's own actuator stiffness where it has one (legs that differ)."""
    own = getattr(ctx.leg, "stiffness", None)
    return (1 / ctx.p["eta_a"] - 1) / (ctx.robot.actuator_stiffness if own is None else own)


def _transmission(ctx):
    return 1 / ctx.p["k_t"]


def _rod_pair(ctx):
    from .formulas import rod_pair_compliance

    rod = ctx.robot.rod
    d_pi = rod["w_pi"] * ctx.screws.vectors["c3"]
    return rod_pair_compliance(ctx.robot.l2, rod["r_i"], rod["r_o"], ctx.p["E_rod"], ctx.p["G_rod"], d_pi)


def _ee_split(ctx):
    """The robot's own share of the EE assembly compliance for this leg (App. D), or None."""
    from .screw import compliance_to_frame

    split = ctx.robot.ee_compliance
    if split is None or ctx.index not in split.per_leg:
        return None
    return compliance_to_frame(split.per_leg[ctx.index], sp.eye(3), sp.Matrix(split.origin))


def _lower_link_tube(ctx):
    from .formulas import tube_cantilever_compliance

    p = ctx.p
    return tube_cantilever_compliance(ctx.robot.l1, p["r_i_l1"], p["r_o_l1"], p["E_l1"], p["nu_l1"])


def _payload(ctx):
    from .formulas import point_mass_inertia

    p = ctx.p
    return point_mass_inertia(p["m_p"], sp.Matrix([p["p_x"], p["p_y"], p["p_z"]]))


def _rotor(ctx):
    return sp.diag(0, ctx.p["I_add"], 0, 0, 0, 0)


def _swinging_rods(ctx):
    """The parallelogram's two rods as they move: the fictitious rod of double
    density riding on the far bar (body C3, Eqs. 26-29) taken off, half of its inertia (one
    rod, at its own centre, x along the rod) put on each real rod ``rod_a``, ``rod_b``,
    which swing with q3 about their pivots (``ChainBody.pivot``)."""
    bodies = {b.name: b for b in ctx.leg.bodies}
    if not {"C3", "rod_a", "rod_b"} <= set(bodies):
        raise DescriptionError(
            f"effect 'swinging_rods': {ctx.leg.name} has bodies {', '.join(bodies)}; expected C3, rod_a "
            "and rod_b (an RR(Pi)RR leg built by rrpirr_leg(..., w_pi=...))"
        )
    rod = bodies["C3"].inertia
    return {"C3": -rod, "rod_a": rod / 2, "rod_b": rod / 2}


def _gravity(ctx):
    return sp.Matrix([0, 0, -ctx.p["g"]])


def _p(name, default, unit, doc, effect, plausible, bounds=(0.0, INF), equation="", closed=False):
    return Parameter(name, default, unit, doc, bounds, effect, plausible, equation, closed)


# The end-effector assembly stiffnesses are one physical part described two ways
# (ee_compliance splits it over the legs, ee_coupling condenses it): one declaration.
_K_E = (
    _p(
        "k_E_rot",
        500.0,
        "N m/rad",
        "EE assembly rotational stiffness about Y (Eq. D.1; facts file: 500 reproduces Eq. 58)",
        "ee_compliance",
        (50.0, 5.0e4),
        equation="App. D, Eqs. 45-46, D.1",
    ),
    _p(
        "k_E_lin",
        100 / 0.77e-3,
        "N/m",
        "EE assembly linear stiffness along Y (Eq. D.2)",
        "ee_compliance",
        (1.0e4, 1.0e8),
        equation="App. D, Eqs. 47-48, D.2",
    ),
)

EFFECTS: dict[str, Effect] = {
    e.name: e
    for e in (
        Effect(
            "actuator_loss",
            "delivered/commanded actuator stiffness factor eta_a (Eq. 34, App. B: 0.82)",
            (
                _p(
                    "eta_a",
                    0.82,
                    "-",
                    "delivered/commanded actuator stiffness (App. B); plausible: a servo delivers "
                    "30 % to 100 % of its commanded stiffness, never more",
                    "actuator_loss",
                    (0.3, 1.0),
                    (0.0, 1.0),
                    "Eq. 34, App. B",
                ),
            ),
            ("eta_a",),
            primitive="joint_series",
            leg_level=True,
            equation="Eq. 34, App. B",
            build=_actuator_loss,
            component="actuator",
            phrase="delivers {eta_a:.2f} of its commanded stiffness",
        ),
        Effect(
            "rod_compliance",
            "bending/axial compliance of the two parallelogram rods as cantilevers (App. C, Eqs. 44, C.10)",
            (
                _p(
                    "E_rod",
                    170e9,
                    "Pa",
                    "Young's modulus of the parallelogram rods (facts file: fitted to K_F(3,3), carbon "
                    "fibre); plausible: glass fibre to steel, 40-250 GPa",
                    "rod_compliance",
                    (40e9, 250e9),
                    equation="App. C, Eq. C.10",
                ),
                _p(
                    "G_rod",
                    65e9,
                    "Pa",
                    "shear modulus of the rods (not in the paper; no influence on K_F); plausible 10-90 GPa",
                    "rod_compliance",
                    (10e9, 90e9),
                    equation="App. C",
                ),
            ),
            ("E_rod",),
            structural=True,
            primitive="body_compliance",
            leg_level=True,
            equation="App. C, Eqs. 44, C.10",
            body="L2",
            build=_rod_pair,
            component="parallelogram rods",
        ),
        Effect(
            "ee_compliance",
            "end-effector assembly compliance k_E_rot about Y and k_E_lin along Y, split over the legs "
            "(App. D, Eqs. 45-49)",
            _K_E,
            ("k_E_rot", "k_E_lin"),
            structural=True,
            primitive="body_compliance",
            equation="App. D, Eqs. 45-49",
            body="platform",
            build=_ee_split,
        ),
        Effect(
            "ee_coupling",
            "traveling plates as rigid bodies joined to the tool by compliant couplings "
            "(k_E_rot about Y, k_E_lin along Y), "
            "condensed in closed form at any pose",
            _K_E,
            ("k_E_rot", "k_E_lin"),
            structural=True,
            primitive="platform_coupling",
            equation="App. D",
        ),
        Effect(
            "lower_link_compliance",
            "bending and torsion of the lower links l1 as hollow tubes clamped at the actuated joint",
            (
                _p("r_o_l1", 0.012, "m", "outer radius of the lower link tube", "lower_link_compliance", (0.002, 0.1)),
                _p(
                    "r_i_l1",
                    0.010,
                    "m",
                    "inner radius of the lower link tube (below r_o_l1)",
                    "lower_link_compliance",
                    (0.0, 0.1),
                ),
                _p(
                    "E_l1",
                    70e9,
                    "Pa",
                    "Young's modulus of the lower link tube (aluminium); plausible: aluminium to "
                    "steel, or carbon fibre, 40-250 GPa",
                    "lower_link_compliance",
                    (40e9, 250e9),
                ),
                _p(
                    "nu_l1",
                    0.33,
                    "-",
                    "Poisson ratio of the lower link tube (G = E/(2(1+nu)))",
                    "lower_link_compliance",
                    (0.2, 0.45),
                    (0.0, 0.5),
                ),
            ),
            ("E_l1",),
            structural=True,
            primitive="body_compliance",
            leg_level=True,
            body="E1",
            build=_lower_link_tube,
            component="lower link",
            constraints=tube(sym("r_i_l1"), sym("r_o_l1"), "the lower link tube"),
        ),
        Effect(
            "transmission_compliance",
            "torsional compliance 1/k_t in series with each actuator",
            (
                _p(
                    "k_t",
                    20000.0,
                    "N m/rad",
                    "torsional stiffness of each transmission, in series with the actuator; "
                    "plausible: belts and small gearboxes to large harmonic drives, 1e3-1e6 N m/rad",
                    "transmission_compliance",
                    (1.0e3, 1.0e6),
                ),
            ),
            ("k_t",),
            primitive="joint_series",
            leg_level=True,
            build=_transmission,
            component="transmission",
        ),
        Effect(
            "payload_mass",
            "rigid point payload m_p on the end-effector at offset (p_x, p_y, p_z)",
            (
                _p(
                    "m_p", 0.2, "kg", "payload mass on the end-effector; plausible 0-20 kg", "payload_mass", (0.0, 20.0)
                ),
                _p(
                    "p_x",
                    0.0,
                    "m",
                    "payload offset from the EE origin along X",
                    "payload_mass",
                    (-0.3, 0.3),
                    (-1.0, 1.0),
                ),
                _p(
                    "p_y",
                    0.0,
                    "m",
                    "payload offset from the EE origin along Y",
                    "payload_mass",
                    (-0.3, 0.3),
                    (-1.0, 1.0),
                ),
                _p(
                    "p_z",
                    0.0,
                    "m",
                    "payload offset from the EE origin along Z",
                    "payload_mass",
                    (-0.3, 0.3),
                    (-1.0, 1.0),
                ),
            ),
            ("m_p",),
            primitive="added_inertia",
            body="platform",
            build=_payload,
        ),
        Effect(
            "rotor_inertia",
            "additional inertia I_add about each actuated axis (adds to Eq. 22)",
            (
                _p(
                    "I_add",
                    2e-3,
                    "kg m^2",
                    "additional inertia about each actuated axis; plausible 0-0.05 kg m^2 "
                    "(up to ten times a large servo rotor)",
                    "rotor_inertia",
                    (0.0, 0.05),
                    equation="Eq. 22",
                ),
            ),
            ("I_add",),
            primitive="added_inertia",
            leg_level=True,
            equation="Eq. 22",
            body="J1",
            build=_rotor,
            component="actuated link",
            phrase="carries {I_add:.3g} kg m^2 of added inertia",
        ),
        Effect(
            "swinging_rods",
            "the parallelogram's two rods as they move, swinging with q3 about their pivots (centres at the mean of "
            "their ends' velocities), instead of the paper's fictitious rod riding on the far bar (Eqs. 26-29)",
            (),
            (),
            primitive="added_inertia",
            equation="replaces Eqs. 26-29",
            body="C3",
            build=_swinging_rods,
            component="parallelogram rods",
        ),  # switched, not fitted: the rods' mass is the paper's
        Effect(
            "gravity_preload",
            "the tau_e term of Eq. 13 from the static gravity load g on the end-effector and payload",
            (
                _p(
                    "g",
                    9.81,
                    "m/s^2",
                    "gravitational acceleration (along -Z) for the static preload; a known constant "
                    "(plausible 9.78-9.84 m/s^2 on Earth)",
                    "gravity_preload",
                    (9.78, 9.84),
                    (0.0, 100.0),
                    "Eq. 13",
                ),
            ),
            (),
            primitive="preload",
            equation="Eq. 13",
            build=_gravity,
        ),  # switched, not fitted: g is known
        Effect(
            "servo_damping",
            "the servo's derivative gain c_a, delivered as eta_a c_a like the stiffness (Eq. 34, App. B): "
            "each actuator "
            "is eta_a (k_a + c_a s) in series with its leg's compliance; lowers the damped frequency "
            "omega_n sqrt(1 - zeta^2) a free decay or a step response shows (Sec. 4: 3 N m s/rad)",
            (
                _p(
                    "c_a",
                    1.0,
                    "N m s/rad",
                    "commanded actuator damping (the servo's derivative gain), delivered as "
                    "eta_a c_a; plausible 0-30 N m s/rad (the paper's Heli4: 3)",
                    "servo_damping",
                    (0.0, 30.0),
                    equation="Sec. 4",
                    closed=True,
                ),
            ),
            ("c_a",),
            primitive="damping",
            equation="Sec. 4, Eq. 34",
            component="actuator",
            phrase="delivers a damping of {c_a:.3g} N m s/rad",
        ),
        Effect(
            "servo_delay",
            "a first-order lag t_d of each actuator's torque (current loop, filter, sampling): the impedance "
            "eta_a (k_a + c_a s) / (1 + t_d s); negative damping where k_a t_d > c_a and the structure is stiff",
            (
                _p(
                    "t_d",
                    1e-3,
                    "s",
                    "time constant of the first-order lag of the actuator torque; plausible 0-20 ms",
                    "servo_delay",
                    (0.0, 0.02),
                    closed=True,
                ),
            ),
            ("t_d",),
            primitive="damping",
            component="actuator",
            phrase="lags its torque by {t_d:.3g} s",
        ),
        Effect(
            "structural_loss",
            "a hysteretic loss factor eta_s of the passive compliance in series with each actuator (rods, lower links, "
            "the EE assembly's share, a transmission): C_s / (1 + i eta_s)",
            (
                _p(
                    "eta_s",
                    0.02,
                    "-",
                    "structural loss factor of the compliant bodies (hysteretic); plausible "
                    "0.001-0.1 (metals to carbon-fibre joints)",
                    "structural_loss",
                    (0.001, 0.1),
                    (0.0, 2.0),
                    closed=True,
                ),
            ),
            ("eta_s",),
            primitive="damping",
            component="compliant bodies",
            phrase="has a loss factor of {eta_s:.3g}",
        ),
    )
}


def effect_parameters(effects, values: dict | None = None) -> tuple[Parameter, ...]:
    """The parameters of ``effects`` (names), each declared once in :data:`EFFECTS`.

    ``values`` maps a parameter name to what a robot changes: a number (its default) or a
    dict of :class:`Parameter` fields (``{"default": 0.015, "doc": ..., "plausible": ...}``).
    A parameter shared by two effects appears once.
    """
    values = dict(values or {})
    out, seen = [], set()
    for name in effects:
        effect = name if isinstance(name, Effect) else EFFECTS[name]
        for p in effect.params:
            if p.name in seen:
                continue
            seen.add(p.name)
            change = values.pop(p.name, None)
            if change is not None:
                p = p.with_values(**(change if isinstance(change, dict) else {"default": float(change)}))
            out.append(p)
    if values:
        names = ", ".join(getattr(e, "name", e) for e in effects)
        raise InputError(f"values for {', '.join(sorted(values))}: no effect among {names} has them")
    return tuple(out)


STRUCTURAL = tuple(n for n, e in EFFECTS.items() if e.structural)

PRESETS: dict[str, tuple[str, ...]] = {
    "rigid": ("actuator_loss",),
    "paper": ("actuator_loss", "rod_compliance", "ee_compliance"),
    "coupled": ("actuator_loss", "rod_compliance", "ee_coupling"),
}


def switch_name(effect: str) -> str:
    """Name of the 0/1 switch symbol of ``effect`` in the generated code (all legs, or a
    platform-level effect)."""
    return f"on_{effect}"


def leg_switch_name(effect: str, leg: int) -> str:
    """Name of the 0/1 switch of leg-level ``effect`` on leg ``leg`` (1-based): ``on_E__N``."""
    return f"on_{effect}__{leg}"


def leg_input_name(param: str, leg: int) -> str:
    """Generated-code input holding leg ``leg``'s (1-based) value of ``param``: ``P__N``."""
    return f"{param}__{leg}"


def scoped_name(name: str, leg: int | None) -> str:
    """``EFFECT@N`` / ``NAME@N`` (the user-facing spelling), or ``name`` when ``leg`` is None."""
    return name if leg is None else f"{name}@{leg}"


def split_scope(item: str, n_legs: int | None = None, what: str = "effect") -> tuple[str, int | None]:
    """``"actuator_loss@3"`` -> ``("actuator_loss", 3)``; ``"paper"`` -> ``("paper", None)``.

    Raises ``InputError`` (one line) when N is not a leg number 1..``n_legs``.
    """
    name, at, leg = item.partition("@")
    if not at:
        return item, None
    try:
        n = int(leg)
    except ValueError:
        n = None
    if n is None or n < 1 or (n_legs is not None and n > n_legs):
        legs = f"1..{n_legs}" if n_legs is not None else "1, 2, ..."
        raise InputError(
            f"{what} {item!r}: {leg!r} is not a leg number; expected {name}@N with N in {legs} "
            "(1-based, in the description's order)"
        )
    return name, n


def presets_of(robot_or_available) -> dict:
    """The presets a robot offers (a preset and its values belong to the robot that
    measured them).

    A robot description offers its own ``presets`` (the Heli4 and the Delta declare the
    catalogue's :data:`PRESETS`, whose ``actuator_loss`` is the Heli4's measured eta_a = 0.82);
    a robot that declares none (the hexapod, a user's or a gallery robot) gets every preset
    name as the bare model k_a, never another robot's measured values. Given only effect
    names (no description), the catalogue's :data:`PRESETS`.
    """
    if not hasattr(robot_or_available, "legs"):
        return dict(PRESETS)
    own = dict(getattr(robot_or_available, "presets", None) or {})
    return {**{name: () for name in PRESETS}, **own}


def _lookup(robot_or_available):
    """(names available or None, number of legs or None, name -> Effect)."""
    if robot_or_available is None:
        return None, None, dict(EFFECTS)
    if hasattr(robot_or_available, "legs"):
        robot = robot_or_available
        return tuple(robot.effects), len(robot.legs), {n: robot.effect(n) for n in robot.effects}
    names = tuple(robot_or_available)
    return names, None, {n: EFFECTS[n] for n in names if n in EFFECTS}


def resolve_model(spec, available=None) -> tuple[str, ...]:
    """Turn a model spec into a tuple of effect names in the catalogue's order.

    ``spec`` is a preset name (``"rigid"``, ``"paper"``, ``"coupled"``: :data:`PRESETS`, or the
    robot's own where its description declares ``presets``, :func:`presets_of`), a
    comma-separated list of presets and effects (``"rigid,payload_mass"``), or an
    iterable of names; ``"none"`` is the bare model without any effect. A leg-level
    effect may be scoped to one leg, ``EFFECT@N`` (N 1-based, in the description's leg
    order): ``"paper,actuator_loss@3"``; it follows its effect, legs ascending. Unknown
    names raise ``ValueError`` listing the valid ones. A preset keeps only the effects
    the robot has (``available``: effect names, or the
    :class:`~eigentwist.description.RobotDescription`, which also checks N against its
    legs and knows its own effects); an effect named explicitly that the robot lacks is
    an error.
    """
    names_available, n_legs, catalogue = _lookup(available)
    presets = presets_of(available)
    if isinstance(spec, str):
        if spec.strip().lower() in ("", "none"):
            return ()  # the bare model: no effect at all
        items = [s.strip() for s in spec.replace("+", ",").split(",") if s.strip()]
    else:
        items = list(spec)
    names: set[str] = set()
    legs: dict[str, set] = {}
    for item in items:
        name, leg = split_scope(item, n_legs)
        if leg is None and name in presets:
            preset = presets[name]
            names.update(e for e in preset if names_available is None or e in names_available)
            continue
        if name not in catalogue and name not in EFFECTS:
            valid = ["none"] + list(presets) + list(catalogue)
            raise InputError(
                f"unknown model or effect {item!r}{did_you_mean(name, valid)}: expected one of {', '.join(valid)}"
            )
        if leg is None:
            names.add(name)
            continue
        effect = catalogue.get(name) or EFFECTS[name]
        if not effect.leg_level:
            raise InputError(
                f"effect {item!r}: {name} acts on the whole platform, not on one leg (only leg-level effects take @N)"
            )
        legs.setdefault(name, set()).add(leg)
    if names_available is not None:
        missing = sorted((names | set(legs)) - set(names_available))
        if missing:
            raise InputError(
                f"effect(s) {', '.join(missing)} not available for this robot (it has: {', '.join(names_available)})"
            )
    order = list(names_available) if names_available is not None else list(EFFECTS)
    out = []
    for n in order:
        if n in names:
            out.append(n)
        out.extend(scoped_name(n, k) for k in sorted(legs.get(n, ())))
    return tuple(out)


def base_name(item: str) -> str:
    """``"actuator_loss@3"`` -> ``"actuator_loss"``."""
    return item.partition("@")[0]
