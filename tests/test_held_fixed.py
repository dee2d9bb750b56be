"""Which masses and inertias a design study holds fixed (``design/fixed.py``), on a made-up robot:
only while a length moves, only those acting in the model, the line's wording, a body's
inertias by name, and a mass ranked zero on both sides of ``ZERO_SENSITIVITY``."""

from __future__ import annotations

from types import SimpleNamespace as NS

import pytest

from eigentwist.design import fixed

PARAMS = {
    "l1": NS(unit="m", effect=None),
    "l2": NS(unit="m", effect=None),
    "k_a": NS(unit="N m/rad", effect=None),
    "m_1": NS(unit="kg", effect=None),
    "mx_1": NS(unit="kg m", effect=None),
    "I1_xx": NS(unit="kg m^2", effect=None),
    "I1_yy": NS(unit="kg m^2", effect=None),
    "I_e_xx": NS(unit="kg m^2", effect=None),
    "m_p": NS(unit="kg", effect="payload"),  # acts only with the payload effect
}
DEFAULTS = {"m_1": 0.25, "mx_1": 0.0125, "I1_xx": 1e-4, "I1_yy": 2e-4, "I_e_xx": 3e-4, "m_p": 0.35}
EV = NS(parameters=PARAMS, defaults=DEFAULTS, parameter=lambda n: PARAMS[n.partition("@")[0]])
HELD = ["m_1", "mx_1", "I1_xx", "I1_yy", "I_e_xx"]


def test_nothing_is_held_fixed_unless_a_length_moves():
    assert fixed.held_fixed(EV, ["k_a", "m_1"]) == []
    assert fixed.held_fixed(EV, ["l1"]) == HELD
    assert fixed.held_fixed(EV, ["l1@2", "k_a"]) == HELD  # a leg's own length
    assert fixed.held_fixed(EV, ["l1", "m_1"]) == HELD[1:]  # a moving mass is not held
    assert fixed.held_fixed(EV, ["l1", "nonsense"]) == HELD
    assert fixed.held_fixed(EV, ["l1"], ("payload",)) == HELD + ["m_p"]
    assert fixed.held_fixed(EV, ["l1"], ("payload@1",)) == HELD + ["m_p"]


def test_the_held_fixed_line_names_the_lengths_and_the_values():
    line = fixed.held_fixed_line(EV, ["l1", "k_a"], values={"m_1": 0.5})
    assert line == (
        "held fixed while l1 moves: m_1 = 0.5 kg, mx_1 = 0.0125 kg m, I1_xx = 0.0001 kg m^2, I1_yy = 0.0002 kg m^2, "
        "I_e_xx = 0.0003 kg m^2 (parameters of their own, not functions of the lengths; vary them too or set them "
        "with --set)"
    )
    two = fixed.held_fixed_line(EV, ["l1", "l2@3"])
    assert two.startswith("held fixed while l1, l2@3 move: m_1 = 0.25 kg, ")
    assert fixed.held_fixed_line(EV, ["k_a"]) is None
    assert fixed.held_fixed_line(EV, ["l1"], ("payload",)).endswith(
        ", m_p = 0.35 kg (parameters of their own, not functions of the lengths; vary them too or set them with --set)"
    )


def test_a_bodys_inertias_by_name_else_every_inertia():
    assert fixed.inertias_of(EV, "m_1") == ["I1_xx", "I1_yy"]
    assert fixed.inertias_of(EV, "m_1@2") == ["I1_xx", "I1_yy"]
    assert fixed.inertias_of(EV, "m_e") == ["I_e_xx"]
    assert fixed.inertias_of(EV, "m1") == ["I1_xx", "I1_yy"]  # a mass named without the underscore
    assert fixed.inertias_of(EV, "m_q") == ["I1_xx", "I1_yy", "I_e_xx"]
    assert fixed.inertias_of(EV, "m") == ["I1_xx", "I1_yy", "I_e_xx"]  # no body name: every inertia


@pytest.mark.parametrize("factor, ranked_zero", [(0.99, True), (1.01, False)])
def test_a_mass_ranked_zero_below_zero_sensitivity(factor, ranked_zero):
    s = fixed.ZERO_SENSITIVITY * factor
    rows = [
        {"name": "m_1", "unit": "kg", "dlnf1_dlnp": -s},
        {"name": "I1_xx", "unit": "kg m^2", "dlnf1_dlnp": 0.0},  # not a mass
    ]
    lines = fixed.zero_mass_lines(EV, rows)
    if ranked_zero:
        assert lines == [
            "m_1 ranks +0: the model takes its body's inertia from separate parameters (I1_xx, I1_yy), which do "
            "not follow m_1; a heavier body moves them too"
        ]
    else:
        assert lines == []
