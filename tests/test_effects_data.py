"""Effects own their parameters: declared once, with a plausible range."""

from __future__ import annotations

import math

import pytest

from eigentwist.description.effects import EFFECTS, PRIMITIVES, effect_parameters
from eigentwist.robots import NAMES, get


@pytest.mark.parametrize("effect", list(EFFECTS))
def test_every_effect_parameter_is_documented_with_a_plausible_range(effect):
    e = EFFECTS[effect]
    assert e.primitive in PRIMITIVES
    assert set(e.fit) <= set(e.parameters)
    for p in e.params:
        assert p.unit and p.doc, p.name
        lo, hi = p.plausible_range
        blo, bhi = p.bounds
        assert blo <= lo < hi <= bhi, f"{p.name}: plausible {p.plausible_range} outside bounds {p.bounds}"
        assert lo <= p.default <= hi, f"{p.name}: default {p.default} outside its plausible range"
        if p.name in e.fit:
            assert p.plausible is not None and math.isfinite(hi), f"fitted {p.name} needs a finite plausible range"


@pytest.mark.parametrize("robot", NAMES)
def test_robots_do_not_redeclare_catalogue_parameters(robot):
    from importlib import import_module

    module = import_module(f"eigentwist.robots.{robot}")
    own = {p.name for p in module.PARAMETERS}
    catalogue = {p.name for e in EFFECTS.values() for p in e.params}
    assert not own & catalogue
    desc = get(robot)
    names = [p.name for p in desc.parameters]
    assert len(names) == len(set(names))
    for e in desc.effects:
        assert set(desc.effect(e).parameters) <= set(names)  # a robot's own effects too (hexapod)


def test_a_robot_passes_only_the_values_that_differ():
    ps = {
        p.name: p
        for p in effect_parameters(("lower_link_compliance",), {"r_o_l1": 0.02, "E_l1": {"plausible": (60e9, 80e9)}})
    }
    assert ps["r_o_l1"].default == 0.02 and ps["r_o_l1"].unit == "m"
    assert ps["E_l1"].plausible == (60e9, 80e9) and ps["E_l1"].default == 70e9
    assert ps["E_l1"].is_plausible(70e9) and not ps["E_l1"].is_plausible(3.3e12)
    with pytest.raises(ValueError, match="k_t"):
        effect_parameters(("lower_link_compliance",), {"k_t": 1.0})


def test_shared_parameters_appear_once():
    names = [p.name for p in effect_parameters(("ee_compliance", "ee_coupling"))]
    assert names == ["k_E_rot", "k_E_lin"]
