"""Bodies from shapes on the shipped robots: the lower link (upper arm) in shape form.

``heli4.describe(bodies="shapes")`` and ``delta.describe(bodies="shapes")`` write body 1 as
a uniform rod along l1 and a hub at the actuated joint, fitted to the measured body at the
default l1 (the Heli4's Eq. 23 at 0.20 m, the Delta's arm at 0.30 m): there its 6x6 spatial
inertia is the measured one, and its mass, first moment and inertia about the actuated
axis move with l1 as a rod's do (d m/d l1 = lambda, d(m c)/d l1 = lambda l1, d I_yy/d l1 =
lambda l1^2, written here from the rod's formulas; central differences agree). The
default form keeps the measured parameters. No derivation: the descriptions only (the
derived heli4_shapes model equals the paper's at its defaults: benchmarks/README.md).
"""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from eigentwist.description import sym
from eigentwist.description.shapes import Shape, compound, hub_and_rod, hub_and_rod_fit, slender_rod
from eigentwist.errors import DescriptionError, InputError
from eigentwist.robots import delta, heli4, lower_link


def _numbers(robot, **values) -> np.ndarray:
    d = {q.symbol: q.default for q in robot.parameters}
    d.update({sym(k): v for k, v in values.items()})
    return np.array(robot.lower_link_inertia.subs(d), dtype=float)


def test_heli4_keeps_its_measured_lower_link_by_default():
    measured = heli4.describe()
    assert measured.name == "heli4" and {"m_1", "l1_cog", "I1_yy"} <= {q.name for q in measured.parameters}
    I = _numbers(measured)
    assert I[3, 3] == 0.479 and I[1, 1] == 0.0044 + 4.1e-3 and I[2, 4] == pytest.approx(0.479 * 0.0612, rel=1e-15)
    with pytest.raises(InputError, match="bodies 'cad': expected one of measured, shapes"):
        heli4.describe(bodies="cad")


@pytest.mark.parametrize("robot, l1", [(heli4, 0.20), (delta, 0.30)])
def test_shape_form_is_the_measured_body_at_the_default_l1(robot, l1):
    shapes = robot.describe(bodies="shapes")
    assert shapes.name == f"{robot.describe().name}_shapes" and shapes.defaults["l1"] == l1
    names = {q.name for q in shapes.parameters}
    assert not names & set(lower_link.MEASURED) and {"lambda_1", "m_hub", "I_hub_yy"} <= names
    np.testing.assert_allclose(_numbers(shapes), _numbers(robot.describe()), rtol=0, atol=1e-15)
    # the body is hub_and_rod's (plus the rotor about the actuated axis y)
    p = {q.name: q.symbol for q in shapes.parameters}
    hub = (p["I_hub_xx"], p["I_hub_yy"], p["I_hub_zz"])
    body = hub_and_rod(p["l1"], p["lambda_1"], p["m_hub"], hub).spatial() + sp.diag(0, p["I_rotor"], 0, 0, 0, 0)
    assert sp.simplify(body - shapes.lower_link_inertia) == sp.zeros(6, 6)


@pytest.mark.parametrize("robot", [heli4, delta])
def test_shape_form_moves_with_l1(robot):
    shapes = robot.describe(bodies="shapes")
    lam, l1 = shapes.defaults["lambda_1"], shapes.defaults["l1"]
    h = 1e-6
    fd = (_numbers(shapes, l1=l1 + h) - _numbers(shapes, l1=l1 - h)) / (2 * h)
    values = {q.symbol: q.default for q in shapes.parameters}
    exact = np.array(sp.diff(shapes.lower_link_inertia, sym("l1")).subs(values), dtype=float)
    # a uniform rod of lambda kg/m from the joint: m = lambda l, m c = lambda l^2/2, I = lambda l^3/3
    assert exact[3, 3] == pytest.approx(lam, rel=1e-14)  # d m / d l1
    assert exact[2, 4] == pytest.approx(lam * l1, rel=1e-14)  # d (m c_x) / d l1
    assert exact[1, 1] == pytest.approx(lam * l1**2, rel=1e-14)  # d I_yy / d l1 (about the actuated axis)
    assert exact[2, 2] == pytest.approx(lam * l1**2, rel=1e-14) and exact[0, 0] == 0
    np.testing.assert_allclose(fd, exact, rtol=0, atol=1e-9 * np.abs(exact).max())


def test_compound_of_two_half_rods_is_the_rod():
    l, m = sp.Rational(3, 10), sp.Rational(2, 5)
    near = slender_rod(l / 2, m / 2)
    far = Shape(near.mass, sp.Matrix(near.com) + sp.Matrix([l / 2, 0, 0]), near.inertia)
    whole, rod = compound(near, far), slender_rod(l, m)
    assert whole.mass == rod.mass and sp.Matrix(whole.com) == sp.Matrix(rod.com)
    assert sp.simplify(whole.inertia - rod.inertia) == sp.zeros(3, 3)


@pytest.mark.parametrize(
    "cog, inertia_yy, refused",
    [
        (0.15, 0.012, False),  # a uniform rod exactly (the Delta's arm: c = l/2, I = m l^2/3): an empty hub
        (0.150001, 0.012, True),  # heavier away from the joint than a uniform rod: a negative hub mass
        (0.15, 0.011999, True),  # less inertia about the joint than the rod: a negative hub inertia
    ],
)
def test_hub_and_rod_fit_refuses_a_negative_hub(cog, inertia_yy, refused):
    args = (0.4, cog, (1e-5, inertia_yy, 0.012), 0.3)
    if refused:
        with pytest.raises(DescriptionError, match="expected non-negative"):
            hub_and_rod_fit(*args)
    else:
        fit = hub_and_rod_fit(*args)
        assert fit["hub_mass"] == 0 and fit["hub_inertia"][1] == 0 and fit["mass_per_length"] == sp.Rational(4, 3)
