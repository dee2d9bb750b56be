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
from eigentwist.robots import delta, heli4, hexapod, lower_link, strut_bodies


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


# ---------------------------------------------------------------- the hexapod's struts
# ``hexapod.describe(bodies="shapes")``: each strut's cylinder (from the base U joint) and
# piston (from the platform S joint, along -x of its frame) a hub at the joint and a uniform
# rod along the strut, fitted to the declared bodies at l_cyl = 0.32 m, l_pis = 0.21 m.
PARTS = (("cyl", 0, 1.0), ("pis", 1, -1.0))  # part, body index in the leg, direction along x


def _strut_numbers(robot, body, **values) -> np.ndarray:
    d = {q.symbol: q.default for q in robot.parameters}
    d.update({sym(k): v for k, v in values.items()})
    return np.array(robot.legs[0].bodies[body].inertia.subs(d), dtype=float)


def test_hexapod_shape_form_is_the_declared_struts_at_the_default_lengths():
    measured, shapes = hexapod.describe(), hexapod.describe(bodies="shapes")
    assert measured.name == "hexapod" and set(strut_bodies.MEASURED) <= {q.name for q in measured.parameters}
    names = {q.name for q in shapes.parameters}
    assert shapes.name == "hexapod_shapes" and not names & set(strut_bodies.MEASURED)
    assert {"l_cyl", "lambda_cyl", "m_cyl_hub", "I_cyl_hub", "l_pis", "lambda_pis", "m_pis_hub", "I_pis_hub"} <= names
    v = measured.defaults
    for part, body, sign in PARTS:
        m, d, i = v[f"m_{part}"], v[f"d_{part}"], v[f"I_{part}"]
        # the declared body written here: mass m, centre sign d along x, transverse I + m d^2 at the joint
        I = _strut_numbers(measured, body)
        assert I[3, 3] == m and I[2, 4] == pytest.approx(sign * m * d, rel=1e-15)
        assert I[1, 1] == I[2, 2] == pytest.approx(i + m * d**2, rel=1e-15) and I[0, 0] == 0
        np.testing.assert_allclose(_strut_numbers(shapes, body), I, rtol=0, atol=1e-15)
        assert all(shapes.legs[k].bodies[body].inertia == shapes.legs[0].bodies[body].inertia for k in range(6))
    with pytest.raises(InputError, match="bodies 'cad': expected one of measured, shapes"):
        hexapod.describe(bodies="cad")


@pytest.mark.parametrize("part, body, sign", PARTS)
def test_hexapod_struts_move_with_their_lengths(part, body, sign):
    shapes = hexapod.describe(bodies="shapes")
    lam, length = shapes.defaults[f"lambda_{part}"], shapes.defaults[f"l_{part}"]
    values = {q.symbol: q.default for q in shapes.parameters}
    inertia = shapes.legs[0].bodies[body].inertia
    exact = np.array(sp.diff(inertia, sym(f"l_{part}")).subs(values), dtype=float)
    # a uniform rod of lambda kg/m from the joint: m = lambda l, m c = sign lambda l^2/2, I = lambda l^3/3
    assert exact[3, 3] == pytest.approx(lam, rel=1e-14)  # d m / d l
    assert exact[2, 4] == pytest.approx(sign * lam * length, rel=1e-14)  # d (m c_x) / d l
    assert exact[1, 1] == exact[2, 2] == pytest.approx(lam * length**2, rel=1e-14) and exact[0, 0] == 0
    h = 1e-6
    fd = (
        _strut_numbers(shapes, body, **{f"l_{part}": length + h})
        - _strut_numbers(shapes, body, **{f"l_{part}": length - h})
    ) / (2 * h)
    np.testing.assert_allclose(fd, exact, rtol=0, atol=1e-9 * np.abs(exact).max())
    other = "pis" if part == "cyl" else "cyl"
    assert not np.array(sp.diff(inertia, sym(f"l_{other}")), dtype=float).any()


@pytest.mark.parametrize(
    "lengths, refused",
    [
        # the cylinder (2 kg, centre 0.15 m, 0.065 kg m^2 at the joint) fits a non-negative hub
        # for 2 c <= l <= 3 I / (2 m c), 0.30-0.325 m; the piston (1 kg, 0.10 m, 0.015) for 0.20-0.225 m
        ({"cyl": 0.30, "pis": 0.21}, None),  # an empty hub (mass 0)
        ({"cyl": 0.2999, "pis": 0.21}, "cylinder"),  # a negative hub mass
        ({"cyl": 0.325, "pis": 0.21}, None),  # a hub of no inertia
        ({"cyl": 0.3251, "pis": 0.21}, "cylinder"),  # a negative hub inertia
        ({"cyl": 0.32, "pis": 0.20}, None),
        ({"cyl": 0.32, "pis": 0.1999}, "piston"),
        ({"cyl": 0.32, "pis": 0.225}, None),
        ({"cyl": 0.32, "pis": 0.2251}, "piston"),
    ],
)
def test_hexapod_strut_fit_refuses_a_negative_hub(lengths, refused):
    if refused:
        part = {"cylinder": "cyl", "piston": "pis"}[refused]
        at = f"the hexapod's {refused} at l_{part} = {lengths[part]:g} m: hub_and_rod_fit"
        with pytest.raises(DescriptionError, match=f"^{at}.*expected non-negative"):
            strut_bodies.parameters(hexapod.PARAMETERS, "shapes", lengths)
    else:
        v = {q.name: q.default for q in strut_bodies.parameters(hexapod.PARAMETERS, "shapes", lengths)}
        assert min(v["m_cyl_hub"], v["I_cyl_hub"], v["m_pis_hub"], v["I_pis_hub"]) >= 0


def test_hexapod_shape_form_names_its_hubs_held_fixed():
    from types import SimpleNamespace

    from eigentwist.design.fixed import held_fixed, inertias_of

    def study(robot):  # what the design notes read of an evaluator: its parameters and defaults
        params = {q.name: q for q in robot.parameters}
        return SimpleNamespace(parameters=params, defaults=robot.defaults, parameter=lambda n: params[n])

    shapes, measured = study(hexapod.describe(bodies="shapes")), study(hexapod.describe())
    fixed = held_fixed(shapes, ["l_cyl"])
    assert {"m_cyl_hub", "I_cyl_hub", "m_pis_hub", "I_pis_hub", "m_pl", "I_pl_zz"} <= set(fixed)
    assert not {"l_cyl", "lambda_cyl", "m_cyl", "I_cyl"} & set(fixed)
    assert {"m_cyl", "I_cyl", "m_pis", "I_pis"} <= set(held_fixed(measured, ["R_b"]))
    assert inertias_of(shapes, "m_cyl_hub") == ["I_cyl_hub"] and inertias_of(shapes, "m_pis_hub") == ["I_pis_hub"]
    assert inertias_of(shapes, "m_pl") == ["I_pl_xx", "I_pl_yy", "I_pl_zz"]
    assert inertias_of(measured, "m_cyl") == ["I_cyl"]


@pytest.mark.parametrize("module", [heli4, delta, hexapod], ids=["heli4", "delta", "hexapod"])
@pytest.mark.parametrize("bodies", ["measured", "shapes"])
def test_every_default_is_inside_its_hard_bounds(module, bodies):
    # a description whose own defaults its bounds refuse could not be evaluated as shipped
    robot = module.describe(bodies=bodies)
    refused = [(q.name, q.default, q.bounds) for q in robot.parameters if not q.admits(q.default)]
    assert not refused


def test_a_hub_may_be_empty_but_not_negative():
    # the Delta's arm is all rod: its fitted hub is exactly zero, and zero is a hub
    hubs = [q for q in delta.describe(bodies="shapes").parameters if "hub" in q.name]
    assert hubs and any(q.default == 0.0 for q in hubs)
    for q in hubs:
        assert q.admits(0.0) and not q.admits(-1e-12 * max(q.default, 1e-6))
