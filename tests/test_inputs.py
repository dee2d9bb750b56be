"""Bad input: each a clear error naming the value, never a NaN in the output."""

from __future__ import annotations

import numpy as np
import pytest

from eigentwist.runtime import InputError, SingularPoseError, UnreachablePoseError
import eigentwist


def test_unreachable_pose_names_pose_and_leg(ev):
    with pytest.raises(UnreachablePoseError, match=r"pose \[0.0, 0.0, -1.2\].*leg 1"):
        ev.frequencies([0.0, 0.0, -1.2])
    with pytest.raises(UnreachablePoseError, match="leg"):
        ev.frequencies([[0.0, 0.0, -0.625], [0.6, 0.0, -0.6]])


def test_singular_pose(ev):
    # z where the lower link of legs 1/2 is aligned with the parallelogram (lever -> 0)
    l1, l2, R, r, d = (ev.defaults[k] for k in ("l1", "l2", "R", "r", "d"))
    z = -np.sqrt((l1 + l2) ** 2 - (R - r) ** 2) - d + 1e-9
    with pytest.raises(SingularPoseError, match=r"leg 1.*lever"):
        ev.frequencies([0.0, 0.0, z])


@pytest.mark.parametrize("name", ["k_a", "m_e", "E_rod", "k_E_rot", "l2"])
@pytest.mark.parametrize("value", [0.0, -5.0, np.nan, np.inf])
def test_non_positive_or_nonfinite_parameter(ev, name, value):
    with pytest.raises(InputError, match=name):
        ev.frequencies(ev.robot.x_ref, **{name: value})


def test_nan_in_pose(ev):
    with pytest.raises(InputError, match="not finite"):
        ev.frequencies([[0.0, 0.0, -0.6], [0.0, np.nan, -0.6]])


@pytest.mark.parametrize("poses", [np.zeros((2, 2)), np.zeros((2, 3, 1)), np.zeros((0, 3))])
def test_wrongly_shaped_poses(ev, poses):
    with pytest.raises(InputError, match="poses|empty"):
        ev.frequencies(poses)


def test_wrongly_shaped_parameter(ev):
    with pytest.raises(InputError, match="k_a"):
        ev.frequencies(np.zeros((4, 3)) + ev.robot.x_ref, k_a=np.ones(3))


def test_unknown_parameter_and_model(ev):
    with pytest.raises(InputError, match="k_A"):
        ev.frequencies(ev.robot.x_ref, k_A=1000.0)
    with pytest.raises(ValueError, match="flux_capacitor"):
        ev.frequencies(ev.robot.x_ref, model="paper,flux_capacitor")


def test_unknown_robot_and_backend():
    with pytest.raises(ValueError, match="nonexistent"):
        eigentwist.load("nonexistent")
    with pytest.raises(ValueError, match="fortran"):
        eigentwist.load("heli4", backend="fortran")


def test_batch_outputs_are_finite(ev):
    from .conftest import random_poses

    f = ev.frequencies(random_poses(ev.robot, 200, seed=11), k_a=np.linspace(100, 5000, 200))
    assert f.shape == (200, 6) and np.isfinite(f).all()


def test_resolved_inputs_are_remembered_but_not_shared():
    """Scalar parameter values are resolved once per (model, values): a repeated call gets
    the same read-only arrays (which the C pass packs once), a changed value new ones, and
    parameter_values hands out the caller's own (writable) arrays."""
    ev = eigentwist.load("heli4", backend="numpy")
    a, b = ev.resolver.resolve(1, {"k_a": 2000.0}, "paper"), ev.resolver.resolve(1, {"k_a": 2000.0}, "paper")
    assert a is not b and a["k_a"] is b["k_a"] and not a["k_a"].flags.writeable
    c = ev.resolver.resolve(1, {"k_a": 2500.0}, "paper")
    assert float(c["k_a"]) == 2500.0 and float(a["k_a"]) == 2000.0
    mine = ev.parameter_values(1, k_a=2000.0)
    mine["k_a"][...] = 1.0
    assert float(ev.resolver.resolve(1, {"k_a": 2000.0}, "paper")["k_a"]) == 2000.0
    # an array value is resolved every time (never remembered): the caller may change it in place
    arr = np.array([2000.0, 2100.0])
    first = ev.resolver.resolve(2, {"k_a": arr}, "paper")["k_a"].copy()
    arr[0] = 2200.0
    assert ev.resolver.key({"k_a": arr}, "paper") is None
    assert ev.resolver.resolve(2, {"k_a": arr}, "paper")["k_a"][0] == 2200.0 and first[0] == 2000.0


def test_a_remembered_layout_resolves_as_in_full():
    """The inputs are laid out once per (model, names given), then each call checks and places
    its values: the same inputs, in the same order, as a full resolution, and the same error
    for a value out of bounds (just outside; just inside passes), a wrong shape, a constraint
    that a value per pose or a leg's own value breaks; an array default is never laid out."""
    ev = eigentwist.load("heli4", backend="numpy")
    r_o = ev.parameter("r_o_l1").default
    ok = dict(k_a=np.linspace(1500.0, 2500.0, 3), eta_a=0.9, r_o_l1=r_o)
    legs = dict(ok, **{"eta_a@2": np.full(3, 0.8), "eta_a@03": 0.7})
    own = dict(ok, **{"r_i_l1@2": 0.5 * r_o, "r_o_l1@2": r_o})
    model = ("paper", "lower_link_compliance@2")
    # (values that lay the names out, values then resolved by that layout, refused?)
    cases = [
        ({}, {}, False),
        (legs, legs, False),
        (own, own, False),
        (ok, dict(ok, k_a=np.array([1500.0, 1e-300, 2500.0])), False),  # k_a > 0: just inside
        (ok, dict(ok, k_a=np.array([1500.0, 0.0, 2500.0])), True),  # just outside
        (ok, dict(ok, k_a=np.ones(4)), True),
        (ok, dict(ok, r_o_l1=np.array([r_o, 1e-9, r_o])), True),  # below r_i_l1 on row 1
        (legs, dict(legs, **{"eta_a@03": np.nan}), True),
        (own, dict(own, **{"r_i_l1@2": 2.0 * r_o}), True),  # leg 2's own r_i >= r_o
    ]

    def outcome(resolve, params):
        try:
            return resolve(3, params, model)
        except InputError as exc:
            return str(exc)

    def same(a, b):
        if isinstance(a, str) or isinstance(b, str):
            return a == b
        return list(a) == list(b) and all(np.asarray(a[k]).tobytes() == np.asarray(b[k]).tobytes() for k in a)

    for first, params, refused in cases:
        assert not isinstance(outcome(ev.resolver.laid_out, first), str)  # lays the names out
        want, got = outcome(ev.resolver.resolve_in_full, params), outcome(ev.resolver.laid_out, params)
        assert isinstance(want, str) is refused and same(got, want), (params, got, want)
    assert len(ev.resolver._layouts) == 4
    monkey = pytest.MonkeyPatch()
    monkey.setitem(ev.parameters, "m_e", ev.parameters["m_e"].with_values(default=np.full(3, 0.1)))
    try:
        first, second = (
            ev.resolver.laid_out(3, {"k_a": 2000.0}, "rigid"),
            ev.resolver.laid_out(3, {"k_a": 2000.0}, "rigid"),
        )
        assert ev.resolver._layouts.get(("rigid", (("k_a", False),))) is False
        assert same(second, first) and same(first, ev.resolver.resolve_in_full(3, {"k_a": 2000.0}, "rigid"))
    finally:
        monkey.undo()


def test_a_misspelled_leg_value_is_matched_on_its_name(ev):
    """The suggestion compares the name before ``@`` (``dx@12``: did you mean d?)."""
    with pytest.raises(InputError, match=r"^unknown parameter\(s\) 'dx@12' for heli4 \(did you mean d\?\)"):
        ev.inputs(values={"dx@12": 1.0})


def test_a_robot_without_leg_level_parameters_says_so():
    five_bar = eigentwist.load("examples/robots/five_bar.py", backend="numpy", progress=None)
    with pytest.raises(
        InputError,
        match=r"^parameter 'k_a@1': k_a belongs to no leg-level effect, so it has no per-leg value "
        r"\(leg-level parameters: none\)$",
    ):
        five_bar.inputs(values={"k_a@1": 2000.0})


def test_values_given_as_integers_reach_the_kernels_as_floats(ev):
    values = ev.parameter_values(2, "rigid", k_a=np.array([1500, 2500]))
    assert values["k_a"].dtype == np.float64 and values["k_a"].tolist() == [1500.0, 2500.0]
    assert ev.resolver.resolve(1, {"k_a": 2000}, "rigid")["k_a"].dtype == np.float64
