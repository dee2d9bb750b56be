"""Bodies from shapes (eigentwist.description.shapes), joint kinds as data and the
descriptions' checks on mechanisms of any mobility: expectations from the specification's
numbers and from numerical integration over the shapes' volume (a few lines of NumPy)."""

from __future__ import annotations

import dataclasses
import importlib.util
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

from eigentwist.description.chain import ChainJoint
from eigentwist.description.joints import JOINT_KINDS, joint_kind
from eigentwist.description.pose import PointPose
from eigentwist.description.serial import Joint
from eigentwist.symbolic.leg import joint_twists
from eigentwist.description.shapes import box, cylinder, point_mass, slender_rod, sphere, tube
from eigentwist.symbolic.kinematics import closures

GALLERY = Path(__file__).resolve().parent.parent / "examples" / "robots"


def _num(e) -> np.ndarray:
    return np.array(sp.Matrix(e).evalf(), dtype=float) if isinstance(e, sp.MatrixBase) else float(e)


def test_tube_is_the_specification():
    """The tube five-bar's proximal link at its defaults: m1 = 0.1236719364 kg and
    I1 = 3.453229644e-4 kg m^2 about its centre of mass, normal to the axis."""
    t = tube(sp.Float(0.18), sp.Float(0.015), sp.Float(0.012), sp.Float(2700.0))
    assert abs(_num(t.mass) - 0.1236719364) < 1e-10
    assert abs(_num(t.inertia)[1, 1] - 3.453229644e-4) < 1e-12 and abs(_num(t.inertia)[2, 2] - 3.453229644e-4) < 1e-12
    assert abs(_num(t.inertia)[0, 0] - _num(t.mass) * (0.015**2 + 0.012**2) / 2) < 1e-15
    np.testing.assert_allclose(_num(t.com).ravel(), [0.09, 0, 0])


def _integrated(inside, lo, hi, density, n=60):
    """Mass, centre of mass and inertia about it of the region ``inside`` (midpoint rule)."""
    axes = [lo[k] + (hi[k] - lo[k]) * (np.arange(n) + 0.5) / n for k in range(3)]
    X = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    X = X[inside(X)]
    dm = density * np.prod((np.asarray(hi) - np.asarray(lo)) / n)
    m = dm * len(X)
    c = X.mean(axis=0)
    r = X - c
    inertia = dm * (np.sum(r * r) * np.eye(3) - r.T @ r)
    return m, c, inertia


@pytest.mark.parametrize(
    "shape, density, inside, lo, hi, rtol",
    [
        (
            lambda: box(0.3, 0.2, 0.1, 7800.0),
            7800.0,
            lambda X: np.ones(len(X), bool),
            (-0.15, -0.1, -0.05),
            (0.15, 0.1, 0.05),
            1e-3,
        ),
        (lambda: sphere(0.1, 1000.0), 1000.0, lambda X: np.sum(X**2, axis=1) < 0.01, (-0.1,) * 3, (0.1,) * 3, 2e-2),
        (
            lambda: cylinder(0.4, 0.05, 2700.0),
            2700.0,
            lambda X: X[:, 1] ** 2 + X[:, 2] ** 2 < 0.0025,
            (0, -0.05, -0.05),
            (0.4, 0.05, 0.05),
            2e-2,
        ),
        (
            lambda: tube(0.4, 0.05, 0.03, 2700.0),
            2700.0,
            lambda X: (X[:, 1] ** 2 + X[:, 2] ** 2 < 0.0025) & (X[:, 1] ** 2 + X[:, 2] ** 2 > 0.0009),
            (0, -0.05, -0.05),
            (0.4, 0.05, 0.05),
            3e-2,
        ),
    ],
    ids=["box", "sphere", "cylinder", "tube"],
)
def test_shapes_integrate(shape, density, inside, lo, hi, rtol):
    """Mass, centre of mass and inertia of each shape against the midpoint rule over its
    volume (60^3 cells: a curved boundary's cells give the tolerance)."""
    shape = shape()  # built in the test, not at collection
    m, c, inertia = _integrated(inside, lo, hi, density)
    assert abs(_num(shape.mass) - m) < rtol * m
    np.testing.assert_allclose(_num(shape.com).ravel(), c, atol=1e-9)
    np.testing.assert_allclose(_num(shape.inertia), inertia, rtol=rtol, atol=rtol * np.abs(inertia).max())


def test_spatial_inertia_moves_to_the_frame_origin():
    """A rod along x from the origin: m l^2 / 3 about the normal axes at its end, first
    moment m l / 2; a point mass has no rotational inertia about itself."""
    rod = _num(slender_rod(sp.Float(0.5), sp.Float(2.0)).spatial())
    np.testing.assert_allclose(np.diag(rod)[:3], [0, 2 * 0.25 / 3, 2 * 0.25 / 3], rtol=1e-14)
    c_cross = np.array([[0, 0, 0], [0, 0, -0.25], [0, 0.25, 0]])  # [c]x, c = (l/2, 0, 0)
    np.testing.assert_allclose(rod[3:, :3], -2.0 * c_cross, atol=1e-15)
    np.testing.assert_array_equal(_num(point_mass(sp.Float(3.0)).spatial())[:3, :3], np.zeros((3, 3)))
    with pytest.raises(ValueError, match="slender_rod: give its mass, or its density"):
        slender_rod(sp.Float(0.5))


def test_a_slender_rod_from_its_density_and_section():
    """m = rho A l (steel, 1 cm^2, 0.5 m: 0.39 kg) and m l^2 / 12 about the normal axes at its
    centre; a density without an area, or an area without a density, is refused."""
    rod = slender_rod(sp.Float(0.5), density=sp.Float(7800.0), area=sp.Float(1e-4))
    assert abs(_num(rod.mass) - 0.39) < 1e-12
    np.testing.assert_allclose(np.diag(_num(rod.inertia)), [0, 0.39 * 0.25 / 12, 0.39 * 0.25 / 12], rtol=1e-12)
    for given in ({"density": 7800.0}, {"area": 1e-4}):
        with pytest.raises(ValueError, match=r"^slender_rod: give its mass, or its density and cross-section area$"):
            slender_rod(sp.Float(0.5), **given)


def test_point_pose_takes_translations_only():
    assert PointPose(("x", "y")).basis == tuple(tuple(int(k == j) for j in (3, 4)) for k in range(6))
    for bad in (("x", "rot_z"), ("x", "x"), ()):
        with pytest.raises(ValueError, match="expected distinct names from x, y, z"):
            PointPose(bad)


def test_closures_one_per_follower():
    """The Tricept's central leg names three closures for the three followers; one fewer is
    refused, naming both counts."""
    spec = importlib.util.spec_from_file_location("gallery_tricept_shapes", GALLERY / "tricept.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    robot = module.describe()
    prog, out = closures(robot)
    assert out["closure"][0] == (3,) and out["closure_rate"][0] == (3, 6)
    legs = robot.legs[:3] + (dataclasses.replace(robot.legs[3], closures=("spin", "axis_x")),)
    with pytest.raises(ValueError, match="has 3 followers .* and the legs name 2 closures"):
        closures(dataclasses.replace(robot, legs=legs))


def test_joint_kinds_are_one_record_each():
    """Each kind's unit twists follow its record: a rotation about the axis through the
    location ([a; p x a]) or a translation along it ([0; a]), one per freedom."""
    g = {"a": sp.Matrix([0, 0, 1]), "p": sp.Matrix([1, 2, 0])}
    for name, kind in JOINT_KINDS.items():
        axes = ("a",) * kind.freedoms
        twists = joint_twists(ChainJoint(name, axes, "p"), g, sp.zeros(3, 1))
        expected = sp.Matrix([0, 0, 1, 2, -1, 0]) if kind.motion == "rotation" else sp.Matrix([0, 0, 0, 0, 0, 1])
        assert len(twists) == kind.freedoms and all(t == expected for t in twists)
    assert Joint("S").axes == ((1, 0, 0), (0, 1, 0), (0, 0, 1)) == JOINT_KINDS["S"].default_axes
    with pytest.raises(ValueError, match="joint kind 'Q': expected one of R, P, Pi, U, S, virtual"):
        joint_kind("Q")
    for make in (ChainJoint, Joint):
        with pytest.raises(ValueError, match="an actuated joint is revolute or prismatic, not 'U'"):
            make("U", axes=((1, 0, 0), (0, 1, 0)), actuated=True)


def test_actuator_loss_uses_the_legs_own_stiffness():
    """A leg with its own actuator stiffness (the PRR leg's k_p) loses in series with that,
    the others with the robot's k_a: 1/(eta k) - 1/k."""
    from types import SimpleNamespace

    from eigentwist.description.effects import EFFECTS, EffectContext

    eta, k_a, k_p = sp.symbols("eta k_a k_p", positive=True)
    robot = SimpleNamespace(actuator_stiffness=k_a)
    build = EFFECTS["actuator_loss"].build
    own = build(EffectContext(robot, {"eta_a": eta}, 2, SimpleNamespace(stiffness=k_p)))
    shared = build(EffectContext(robot, {"eta_a": eta}, 0, SimpleNamespace(stiffness=None)))
    assert sp.simplify(own - (1 / (eta * k_p) - 1 / k_p)) == 0
    assert sp.simplify(shared - (1 / (eta * k_a) - 1 / k_a)) == 0


def test_point_platform_refuses_structural_effects():
    """A point's rotations carry neither inertia nor stiffness: the five-bar takes a
    non-structural effect (payload_mass) and refuses a structural one (rod_compliance)."""
    spec = importlib.util.spec_from_file_location("gallery_five_bar_shapes", GALLERY / "five_bar.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    robot = module.describe()
    assert dataclasses.replace(robot, effects=("payload_mass",)).effects == ("payload_mass",)
    with pytest.raises(ValueError, match=r"five_bar: effect\(s\) rod_compliance on a point platform"):
        dataclasses.replace(robot, effects=("rod_compliance",))


def test_a_leg_has_one_actuator_or_none():
    """A leg with one actuated joint, or none (passive: a constraint only); two are refused,
    and so is a stiffness on a passive leg."""
    from eigentwist.description.chain import ChainLeg

    R = lambda actuated=False: ChainJoint("R", ("a",), "p", actuated=actuated)  # noqa: E731
    assert ChainLeg("one", (R(True), R()), (), None).actuated.actuated
    assert ChainLeg("passive", (R(), R()), (), None).actuated is None
    with pytest.raises(ValueError, match="two: 2 actuated joints: expected one, or none for a passive leg"):
        ChainLeg("two", (R(True), R(True)), (), None)
    with pytest.raises(ValueError, match="a stiffness on a passive leg"):
        ChainLeg("passive", (R(), R()), (), None, stiffness=sp.Symbol("k"))


def test_legs_may_name_different_checks():
    """The Tricept's central leg without its check: the IK's ``reach`` output holds the UPS
    legs' and a 0 (within [-1, 1]) for the central leg."""
    from eigentwist.symbolic.kinematics import inverse_kinematics

    spec = importlib.util.spec_from_file_location("gallery_tricept_checks", GALLERY / "tricept.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    robot = module.describe()
    legs = robot.legs[:3] + (dataclasses.replace(robot.legs[3], checks=()),)
    _, outputs, q_all = inverse_kinematics(dataclasses.replace(robot, legs=legs))
    shape, values = outputs["reach"]
    assert shape == (4,) and values[3] == 0 and all(v != 0 for v in values[:3]) and len(q_all) == 4
