"""The catalogue's rules (``eigentwist/description/effects.py``) on stand-ins: no derivation.

The deprecated ``kind`` spelling, the checks of a term and an effect, an effect's parts and
parameters, each catalogue term's formula from made-up inputs, the parameters a robot changes,
the generated names, the leg scope and the model specs (presets, effects, legs) against a
stand-in robot. The derivations that use the terms are tested by tests/test_mechanisms.py and
the pinned derivations.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from types import SimpleNamespace as NS

import pytest
import sympy as sp

from eigentwist.description import effects as fx
from eigentwist.description import formulas, screw
from eigentwist.errors import DescriptionError, InputError

# ------------------------------------------------------------------ terms and effects


def test_the_old_kind_spelling_warns_and_means_the_primitive():
    with pytest.warns(DeprecationWarning, match=r"^Term\(kind=\.\.\.\) is deprecated: use primitive='preload'$") as w:
        t = fx.Term(kind="preload")
    assert t.primitive == "preload" and w[0].filename == __file__  # the warning points at the caller
    with pytest.warns(DeprecationWarning, match=r"^Term\.kind is deprecated: use \.primitive$") as w:
        assert t.kind == "preload"
    assert w[0].filename == __file__
    with (
        pytest.warns(DeprecationWarning),
        pytest.raises(DescriptionError, match=r"^Term: give primitive or kind \(its old name\), not both$"),
    ):
        fx.Term(kind="preload", primitive="preload")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert fx.Term("damping").primitive == "damping"  # the new spelling: no warning
    with pytest.warns(DeprecationWarning, match=r"^Effect\(kind=\.\.\.\) is deprecated: use primitive='damping'$"):
        assert fx.Effect("e", "doc", (), (), kind="damping").primitive == "damping"


def test_the_kind_alias_applies_to_any_dataclass_with_a_primitive():
    @fx._kind_alias
    @dataclass(frozen=True)
    class Part:
        primitive: str = "x"
        size: int = 0

    with pytest.warns(DeprecationWarning, match=r"^Part\(kind=\.\.\.\) is deprecated: use primitive='y'$") as w:
        part = Part(kind="y", size=2)
    assert (part.primitive, part.size) == ("y", 2) and w[0].filename == __file__
    with pytest.warns(DeprecationWarning, match=r"^Part\.kind is deprecated: use \.primitive$") as w:
        assert part.kind == "y"
    assert w[0].filename == __file__ and w[0].category is DeprecationWarning
    assert Part.kind.__doc__ == "Deprecated name of ``primitive``." and Part.__init__.__name__ == "__init__"
    assert Part().primitive == "x"


def test_a_term_of_an_unknown_primitive_is_refused():
    with pytest.raises(DescriptionError) as err:
        fx.Term("spring")
    assert str(err.value) == f"term primitive 'spring' is not one of {', '.join(fx.PRIMITIVES)}"


def _build(ctx):
    return "built"


def test_an_effect_of_terms_takes_its_primitive_body_and_build_from_the_first():
    first, second = fx.Term("added_inertia", _build, "platform"), fx.Term("ground_spring", None, "tool")
    e = fx.Effect("cable", "doc", (), (), terms=(first, second))
    assert (e.primitive, e.body, e.build) == ("added_inertia", "platform", _build)
    assert e.primitives == ("added_inertia", "ground_spring")
    parts = e.parts()
    assert [(p.name, p.primitive, p.body, p.build, p.terms) for p in parts] == [
        ("cable", "added_inertia", "platform", _build, ()),
        ("cable", "ground_spring", "tool", None, ()),
    ]
    single = fx.Effect("one", "doc", (), (), primitive="preload", body="b")
    assert single.parts() == (single,) and single.primitives == ("preload",) and single.body == "b"


def test_an_effect_is_checked_for_its_terms_primitive_and_name():
    with pytest.raises(DescriptionError) as err:
        fx.Effect("e", "doc", (), (), terms=(fx.Term("preload"), "x"))
    assert str(err.value) == "effect 'e': terms must be Term objects (primitive, build, body)"
    with pytest.raises(DescriptionError) as err:
        fx.Effect("e", "doc", (), (), primitive="spring")
    assert str(err.value) == f"effect 'e': primitive 'spring' is not one of {', '.join(fx.PRIMITIVES)}"
    for name in ("e@2", "two words", "2e"):
        with pytest.raises(DescriptionError) as err:
            fx.Effect(name, "doc", (), ())
        assert str(err.value) == f"effect name {name!r}: expected a Python identifier (no '@')"
    assert fx.Effect("e_2", "doc", (), ()).name == "e_2"


def test_an_effect_names_its_parameters_and_refuses_another():
    a, b = (
        fx._p("a", 1.0, "m", "A", "e", (0.5, 2.0)),
        fx._p("b", 2.0, "s", "B", "e", (1.0, 3.0), (1.0, 9.0), "Eq. 3", True),
    )
    assert (a.name, a.default, a.unit, a.doc, a.bounds, a.effect, a.plausible) == (
        "a",
        1.0,
        "m",
        "A",
        (0.0, fx.INF),
        "e",
        (0.5, 2.0),
    )
    assert (a.equation, a.closed, b.bounds, b.equation, b.closed) == ("", False, (1.0, 9.0), "Eq. 3", True)
    e = fx.Effect("e", "doc", (a, b), ("a",))
    assert e.parameters == ("a", "b") and e.parameter("b") is b
    with pytest.raises(KeyError) as err:
        e.parameter("c")
    assert err.value.args[0] == "effect 'e' has no parameter 'c': it has a, b"


# ------------------------------------------------------------------ the catalogue's terms


def test_the_actuator_loss_is_a_compliance_in_series_with_the_legs_own_stiffness():
    """1 / (eta k_a) - 1 / k_a (Eq. 34) with eta = 0.8: 0.25 / k_a."""
    robot = NS(actuator_stiffness=100.0)
    assert fx._actuator_loss(NS(p={"eta_a": 0.8}, robot=robot, leg=NS())) == pytest.approx(0.25 / 100.0)
    assert fx._actuator_loss(NS(p={"eta_a": 0.8}, robot=robot, leg=NS(stiffness=50.0))) == pytest.approx(0.25 / 50.0)
    assert fx._actuator_loss(NS(p={"eta_a": 0.8}, robot=robot, leg=None)) == pytest.approx(0.25 / 100.0)
    assert fx._transmission(NS(p={"k_t": 400.0})) == 1 / 400.0


def test_the_rod_and_tube_terms_read_their_geometry_and_moduli(monkeypatch):
    monkeypatch.setattr(formulas, "rod_pair_compliance", lambda *a: ("rod",) + a)
    monkeypatch.setattr(formulas, "tube_cantilever_compliance", lambda *a: ("tube",) + a)
    robot = NS(l2=0.5, l1=0.3, rod={"w_pi": 2.0, "r_i": 0.004, "r_o": 0.005})
    ctx = NS(robot=robot, p={"E_rod": 7e10, "G_rod": 2.6e10}, screws=NS(vectors={"c3": 3.0}))
    assert fx._rod_pair(ctx) == ("rod", 0.5, 0.004, 0.005, 7e10, 2.6e10, 6.0)
    ctx = NS(robot=robot, p={"r_i_l1": 0.01, "r_o_l1": 0.012, "E_l1": 7e10, "nu_l1": 0.33})
    assert fx._lower_link_tube(ctx) == ("tube", 0.3, 0.01, 0.012, 7e10, 0.33)


def test_the_end_effector_share_is_the_legs_own_or_none(monkeypatch):
    monkeypatch.setattr(screw, "compliance_to_frame", lambda c, r, o: (c, r, o))
    split = NS(per_leg={0: "C0", 2: "C2"}, origin=(0.0, 0.0, 0.1))
    assert fx._ee_split(NS(robot=NS(ee_compliance=None), index=0)) is None
    assert fx._ee_split(NS(robot=NS(ee_compliance=split), index=1)) is None
    c, r, o = fx._ee_split(NS(robot=NS(ee_compliance=split), index=2))
    assert c == "C2" and r == sp.eye(3) and o == sp.Matrix([0.0, 0.0, 0.1])


def test_the_inertia_terms_of_a_payload_a_rotor_and_the_swinging_rods(monkeypatch):
    monkeypatch.setattr(formulas, "point_mass_inertia", lambda m, offset: (m, offset))
    m, offset = fx._payload(NS(p={"m_p": 2.0, "p_x": 0.1, "p_y": -0.2, "p_z": 0.3}))
    assert m == 2.0 and offset == sp.Matrix([0.1, -0.2, 0.3])
    assert fx._rotor(NS(p={"I_add": 5.0})) == sp.diag(0, 5.0, 0, 0, 0, 0)
    assert fx._gravity(NS(p={"g": 9.81})) == sp.Matrix([0, 0, -9.81])
    rod = sp.diag(2, 4, 6, 8, 10, 12)
    leg = NS(name="leg1", bodies=[NS(name="C3", inertia=rod), NS(name="rod_a"), NS(name="rod_b")])
    assert fx._swinging_rods(NS(leg=leg)) == {"C3": -rod, "rod_a": rod / 2, "rod_b": rod / 2}
    leg = NS(name="leg1", bodies=[NS(name="C3", inertia=rod), NS(name="rod_a")])
    with pytest.raises(DescriptionError) as err:
        fx._swinging_rods(NS(leg=leg))
    assert str(err.value) == (
        "effect 'swinging_rods': leg1 has bodies C3, rod_a; expected C3, rod_a and rod_b "
        "(an RR(Pi)RR leg built by rrpirr_leg(..., w_pi=...))"
    )


# ------------------------------------------------------------------ parameters and names


def test_a_robot_changes_a_parameters_default_or_fields_and_shares_it_once():
    out = fx.effect_parameters(
        ["ee_compliance", "ee_coupling", "actuator_loss"], {"eta_a": 0.5, "k_E_rot": {"doc": "mine"}}
    )
    assert [p.name for p in out] == ["k_E_rot", "k_E_lin", "eta_a"]
    assert (
        out[2].default == 0.5
        and out[0].doc == "mine"
        and out[0].default == fx.EFFECTS["ee_compliance"].params[0].default
    )
    own = fx.Effect("own", "doc", (fx._p("q", 1.0, "-", "Q", "own", (0, 2)),), ("q",))
    assert [p.default for p in fx.effect_parameters([own, "actuator_loss"], {"q": 3})] == [
        3.0,
        fx.EFFECTS["actuator_loss"].params[0].default,
    ]
    assert fx.effect_parameters(["actuator_loss"]) == fx.EFFECTS["actuator_loss"].params
    eta = fx.EFFECTS["actuator_loss"].params[0]
    after = fx.Effect("after", "doc", (eta, fx._p("w", 1.0, "-", "W", "after", (0, 2))), ("w",))
    assert [p.name for p in fx.effect_parameters(["actuator_loss", after])] == ["eta_a", "w"]  # a shared one skipped
    with pytest.raises(InputError) as err:
        fx.effect_parameters([own, "actuator_loss"], {"z": 1, "m_p": 2, "q": 1})
    assert str(err.value) == "values for m_p, z: no effect among own, actuator_loss has them"


def test_the_generated_names_of_switches_and_leg_inputs():
    assert fx.switch_name("payload_mass") == "on_payload_mass"
    assert fx.leg_switch_name("actuator_loss", 3) == "on_actuator_loss__3"
    assert fx.leg_input_name("eta_a", 2) == "eta_a__2"
    assert fx.scoped_name("eta_a", None) == "eta_a" and fx.scoped_name("eta_a", 4) == "eta_a@4"
    assert fx.base_name("actuator_loss@3") == "actuator_loss" and fx.base_name("m_p") == "m_p"
    assert (
        fx.STRUCTURAL == tuple(n for n, e in fx.EFFECTS.items() if e.structural) and "rod_compliance" in fx.STRUCTURAL
    )


@pytest.mark.parametrize(
    "item, n_legs, expected",
    [
        ("actuator_loss@3", None, ("actuator_loss", 3)),
        ("paper", 4, ("paper", None)),
        ("a@1", 1, ("a", 1)),
        ("a@4", 4, ("a", 4)),
    ],
)
def test_a_scope_names_a_leg_from_1(item, n_legs, expected):
    assert fx.split_scope(item, n_legs) == expected


def test_a_scope_of_two_legs_is_refused_and_the_default_word_is_effect():
    with pytest.raises(
        InputError, match=r"^effect 'a@b@3': 'b@3' is not a leg number; expected a@N with N in 1, 2, \.\.\."
    ):
        fx.split_scope("a@b@3")


@pytest.mark.parametrize(
    "item, n_legs, what, legs",
    [
        ("a@0", 4, "effect", "1..4"),
        ("a@5", 4, "effect", "1..4"),
        ("a@x", None, "parameter", "1, 2, ..."),
        ("a@", 3, "effect", "1..3"),
    ],
)
def test_a_scope_outside_the_legs_is_refused(item, n_legs, what, legs):
    name, _, leg = item.partition("@")
    with pytest.raises(InputError) as err:
        fx.split_scope(item, n_legs, what)
    assert str(err.value) == (
        f"{what} {item!r}: {leg!r} is not a leg number; expected {name}@N with N in {legs} "
        "(1-based, in the description's order)"
    )


# ------------------------------------------------------------------ model specs


def _robot(effects=("actuator_loss", "rod_compliance", "own", "payload_mass"), presets=None, legs=3):
    own = fx.Effect("own", "doc", (), (), leg_level=True)
    table = {**fx.EFFECTS, "own": own}
    return NS(legs=[None] * legs, effects=effects, effect=lambda n: table[n], presets=presets)


def test_a_robot_offers_its_own_presets_and_every_other_name_as_the_bare_model():
    assert fx.presets_of(None) == fx.PRESETS and fx.presets_of(("actuator_loss",)) == fx.PRESETS
    assert fx.presets_of(("x",)) is not fx.PRESETS
    assert fx.presets_of(_robot()) == {"rigid": (), "paper": (), "coupled": ()}
    own = fx.presets_of(_robot(presets={"rigid": ("own",), "mine": ("payload_mass",)}))
    assert own == {"rigid": ("own",), "paper": (), "coupled": (), "mine": ("payload_mass",)}
    assert fx.presets_of(NS(legs=[None])) == {"rigid": (), "paper": (), "coupled": ()}  # no presets attribute


def test_the_lookup_of_a_robot_a_list_of_names_or_nothing():
    assert fx._lookup(None) == (None, None, dict(fx.EFFECTS))
    names, legs, table = fx._lookup(_robot(legs=3))
    assert (
        names == ("actuator_loss", "rod_compliance", "own", "payload_mass") and legs == 3 and table["own"].name == "own"
    )
    assert fx._lookup(["payload_mass", "own"]) == (
        ("payload_mass", "own"),
        None,
        {"payload_mass": fx.EFFECTS["payload_mass"]},
    )


def test_a_model_spec_reads_presets_effects_and_legs_in_the_robots_order():
    robot = _robot(presets={"rigid": ("actuator_loss", "gravity_preload")})
    assert fx.resolve_model(" payload_mass + rigid , own@3,own@1,,", robot) == (
        "actuator_loss",
        "own@1",
        "own@3",
        "payload_mass",
    )  # the preset keeps only what the robot has
    assert fx.resolve_model(["own", "own@2", "rod_compliance@2"], robot) == ("rod_compliance@2", "own", "own@2")
    assert fx.resolve_model("None", robot) == () and fx.resolve_model("  ", robot) == ()
    assert fx.resolve_model("mine", _robot(presets={"mine": ("own",)})) == ("own",)  # the robot's own preset
    assert fx.resolve_model("paper") == fx.PRESETS["paper"]  # the catalogue's order without a robot
    assert fx.resolve_model("rod_compliance,actuator_loss", ("rod_compliance", "actuator_loss")) == (
        "rod_compliance",
        "actuator_loss",
    )


def test_a_model_spec_refuses_unknown_names_platform_effects_on_a_leg_and_missing_effects():
    robot = _robot(presets={})
    with pytest.raises(InputError) as err:
        fx.resolve_model("payload_mas", robot)
    valid = ["none", "rigid", "paper", "coupled", "actuator_loss", "rod_compliance", "own", "payload_mass"]
    assert str(err.value) == (
        f"unknown model or effect 'payload_mas' (did you mean payload_mass?): expected one of {', '.join(valid)}"
    )
    with pytest.raises(InputError) as err:
        fx.resolve_model("payload_mass@2", robot)
    assert str(err.value) == (
        "effect 'payload_mass@2': payload_mass acts on the whole platform, not on one leg "
        "(only leg-level effects take @N)"
    )
    with pytest.raises(InputError) as err:
        fx.resolve_model("ee_compliance,transmission_compliance@1,own", robot)
    assert str(err.value) == (
        "effect(s) ee_compliance, transmission_compliance not available for this robot "
        "(it has: actuator_loss, rod_compliance, own, payload_mass)"
    )
    with pytest.raises(InputError, match="'own@4': '4' is not a leg number; expected own@N with N in 1..3"):
        fx.resolve_model("own@4", robot)
    with pytest.raises(InputError, match="^unknown model or effect 'rigid@1' \\(did you mean rigid\\?\\)"):
        fx.resolve_model("rigid@1", robot)  # a preset takes no leg
