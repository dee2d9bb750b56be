"""Mode shapes as evidence: MAC identities, transport to a sensor, matching by shape."""

from __future__ import annotations

import numpy as np
import pytest

from eigentwist.diagnose import compare
from eigentwist.diagnose.measurements import Measurements, parse_csv
from eigentwist.diagnose.shapes import mac, sensor_shapes, shape_residuals, transport_matrix


def test_mac_of_a_mode_with_itself_is_one_and_of_orthogonal_modes_zero():
    rng = np.random.default_rng(4)
    a = rng.standard_normal(3) + 1j * rng.standard_normal(3)
    assert mac(a, a) == pytest.approx(1.0, abs=1e-14)
    assert mac(a, -2.5j * a) == pytest.approx(1.0, abs=1e-14)  # any scale and phase
    q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    for i in range(3):
        for j in range(3):
            assert mac(q[:, i], q[:, j]) == pytest.approx(float(i == j), abs=1e-14)


def test_transport_is_v_plus_omega_cross_r():
    rng = np.random.default_rng(5)
    twist, r = rng.standard_normal(6), rng.standard_normal(3)
    assert np.allclose(transport_matrix(r) @ twist, twist[3:] + np.cross(twist[:3], r), rtol=1e-14)
    V = rng.standard_normal((2, 6, 6))
    assert np.allclose(sensor_shapes(V, r)[1][:, 4], V[1, 3:, 4] + np.cross(V[1, :3, 4], r))
    assert np.array_equal(sensor_shapes(V[:, 3:, 3:]), V[:, 3:, 3:])  # rigid: translations already


def _measured(ev, labels, shapes, sensor=None):
    """Rows of the truth model at one setting with the given labels and shapes."""
    pose = np.array([0.06, -0.04, -0.6])
    m = ev.modes(pose, "paper", k_a=1000.0)
    freq = m.freq_hz[0, :3]
    modal = {c: shapes[:, k] for k, c in enumerate(("phi_x", "phi_y", "phi_z"))}
    if sensor is not None:
        modal.update({c: sensor[k] for k, c in enumerate(("sensor_x", "sensor_y", "sensor_z"))})
    return Measurements.from_arrays(1000.0, labels, freq, pose, None, ev=ev, modal=modal), m


def test_matching_follows_the_shape_not_the_label(ev):
    """Rows labelled by rank in the wrong order (as when two modes cross between model and
    test) are matched by their shapes; without shapes the labels would be taken as is."""
    sensor = np.array([0.05, 0.02, -0.03])
    pose = np.array([[0.06, -0.04, -0.6]])
    m = ev.modes(pose, "paper", k_a=1000.0)
    U = sensor_shapes(m.eigentwists, sensor)[0][:, :3].T  # modes 1, 2, 3 at the sensor
    U = U / np.linalg.norm(U, axis=1)[:, None]
    meas, _ = _measured(ev, ["2", "1", "3"], U[[0, 1, 2]], sensor)  # labels 1 <-> 2 swapped
    cmp = compare(meas, "paper", ev)
    assert list(cmp.mode_index) == [0, 1, 2]
    assert np.allclose(cmp.mac, 1.0, atol=1e-9)
    assert np.allclose(cmp.predicted, meas.freq_hz, rtol=1e-9)
    rows = ev.modes(meas.poses, "paper", k_a=meas.k_a)
    assert np.allclose(shape_residuals(meas.shapes, rows, cmp.mode_index, meas.sensor), 0.0, atol=1e-3)
    plain = compare(Measurements(meas.k_a, meas.mode, meas.freq_hz, meas.sigma_hz, meas.poses), "paper", ev)
    assert list(plain.mode_index) == [1, 0, 2] and plain.mac is None


def test_shape_columns_round_trip_through_csv(ev):
    text = (
        "k_a,mode,freq_hz,damping_ratio,phi_x,phi_y,phi_z,sensor_x\n"
        "1000,x,15.5,0.015,1,0.01,-0.02,0.05\n1000,z,30.6,,,,,\n"
    )
    meas = parse_csv(text, "shapes.csv", ev)
    assert np.isnan(meas.shapes[1]).all() and meas.shapes[0, 0] == 1.0
    assert np.allclose(meas.sensor, [[0.05, 0, 0], [0, 0, 0]])
    again = parse_csv(meas.to_csv(), "again.csv", ev)
    assert np.array_equal(again.shapes, meas.shapes, equal_nan=True)
    assert np.isnan(compare(meas, "paper", ev).mac[1])


def test_settings_are_rows_with_equal_keys_whatever_a_shared_column_holds():
    from eigentwist.diagnose.shapes import setting_rows as _groups

    rng = np.random.default_rng(8)
    keys = np.array([[0.0, 1.0, 5.0], [0.0, 2.0, 5.0], [-0.0, 1.0, 5.0], [0.0, 2.0 + 1e-14, 5.0]])
    expected = [[0, 2], [1, 3]]  # -0.0 is 0.0; keys equal to 12 decimals share a setting
    for shared in (5.0, rng.standard_normal()):  # a column every row shares, at any value
        keys[:, 2] = shared
        assert [list(g) for g in _groups(keys)] == expected
    keys[3, 1] = 2.0 + 1e-9  # beyond 12 decimals: a setting of its own
    assert [list(g) for g in _groups(keys)] == [[0, 2], [1], [3]]
    keys[1, 2] = 6.0  # the column now tells rows apart
    assert sorted(list(g) for g in _groups(keys)) == [[0, 2], [1], [3]]
    # settings in the order of their keys, first column first; every key alike: one setting
    keys = np.array([[2.0, 0.0], [1.0, 9.0], [2.0, 0.0], [1.0, 3.0], [np.nan, 0.0], [np.nan, 0.0]])
    assert [list(g) for g in _groups(keys)] == [[3], [1], [0, 2], [4], [5]]  # NaN: never equal
    assert [list(g) for g in _groups(np.ones((3, 2)))] == [[0, 1, 2]] and _groups(np.ones((0, 2))) == ()


def _hungarian_total(S):
    from scipy.optimize import linear_sum_assignment

    r, c = linear_sum_assignment(-S)
    return S[r, c].sum()


def test_enumerated_assignment_is_the_best_total_and_ties_go_to_the_hungarian_method():
    from eigentwist.diagnose.shapes import ENUMERATED, TIE, _best_assignments

    rng = np.random.default_rng(11)
    for k, n in [(1, 6), (2, 3), (3, 6), (3, 3)]:
        S = rng.random((40, k, n))
        cols, unique = _best_assignments(S)
        assert unique.all()
        for s, c in zip(S, cols):
            assert len(set(c)) == k  # injective
            assert s[np.arange(k), c].sum() == pytest.approx(_hungarian_total(s), abs=1e-14)
    # two assignments apart by just over the tie margin: decided; just under: left to the Hungarian method
    base = np.array([[[0.9, 0.5, 0.0], [0.5, 0.9, 0.0]]])  # diagonal 1.8 against swapped 1.0
    for gap, decided in [(3 * TIE, True), (TIE / 3, False)]:
        S = base.copy()
        S[0, 0, 1] = S[0, 1, 0] = 0.9 + gap / 2  # swapped total 1.8 + gap
        cols, unique = _best_assignments(S)
        assert unique[0] == decided
        if decided:
            assert list(cols[0]) == [1, 0]
    # more rows than modes, or too many assignments to enumerate: the Hungarian method
    assert not _best_assignments(rng.random((2, 4, 3)))[1].any()
    k, n = 5, 8  # 6720 assignments
    assert np.prod(np.arange(n - k + 1, n + 1)) > ENUMERATED
    assert not _best_assignments(rng.random((2, k, n)))[1].any()
    assert not _best_assignments(np.full((1, 2, 3), np.nan))[1].any()


def test_equal_parameter_sets_are_matched_alike(ev):
    """Two parameter sets with the same values in one batched prediction are two settings:
    each set's rows take their own modes (merged, the second set's rows would be pushed onto
    modes the first set's rows had taken)."""
    from eigentwist.diagnose.predict import Predictor

    sensor = np.array([0.05, 0.02, -0.03])
    pose = np.array([[0.06, -0.04, -0.6]])
    m = ev.modes(pose, "paper", k_a=1000.0)
    U = sensor_shapes(m.eigentwists, sensor)[0][:, :3].T
    meas, _ = _measured(ev, ["x", "y", "z"], U / np.linalg.norm(U, axis=1)[:, None], sensor)
    pred = Predictor(meas, ("paper", "payload_mass"), ev)
    table = np.array([[0.2], [0.2], [0.3]])
    freq = pred.predict_sets(["m_p"], table)
    assert np.array_equal(freq[0], freq[1])
    for row, value in zip(freq, table[:, 0]):
        one, _ = pred.predict({"m_p": value})
        assert np.allclose(row, one, rtol=1e-13)
    assert np.all(np.diff(freq[0]) > 0)  # three distinct modes, in ascending order


def test_settings_of_different_sizes_are_each_matched_by_shape():
    """Rows of a two-row and of a three-row setting in one call each take the mode their
    measured shape names (unit translations x, y, z as modes 3, 4, 5), given the settings as a
    tuple or stacked (SettingGroups); a row without a shape keeps its label's mode."""
    from types import SimpleNamespace

    from eigentwist.diagnose.shapes import SettingGroups, match_by_shape

    n = 6
    modes = SimpleNamespace(eigentwists=np.broadcast_to(np.eye(n), (6, n, n)), direction=np.tile(np.arange(n), (6, 1)))
    e = np.eye(3)
    shapes = np.array([e[1], e[0], e[2], e[0], e[1], [np.nan] * 3])
    fallback = np.zeros(6, dtype=int)
    groups = (np.array([0, 1]), np.array([2, 3, 4]))
    for given in (groups, SettingGroups(groups)):
        idx = match_by_shape(modes, shapes, given, fallback)
        assert idx.tolist() == [4, 3, 5, 3, 4, 0]
    stacked = SettingGroups(groups)
    assert [m.shape for m in stacked.by_size] == [(1, 2), (1, 3)]


def test_real_mac_equals_the_complex_formula_bit_for_bit():
    """Real shapes take MAC's real path (products instead of conjugates and moduli): the same
    bits as the complex formula on the same values, with a measured norm given or not."""
    rng = np.random.default_rng(11)
    a, b = rng.standard_normal((40, 6, 3)), rng.standard_normal((40, 1, 3))
    b[3] = 0.0  # a zero shape: MAC 0, not NaN
    a[5, 2] = 0.0
    with np.errstate(invalid="ignore"):  # 0 / 0 where a shape is zero
        complex_formula = np.abs(np.sum(np.conj(a + 0j) * b, axis=-1)) ** 2 / (
            np.sum(np.abs(a + 0j) ** 2, axis=-1) * np.sum(np.abs(b + 0j) ** 2, axis=-1)
        )
    expected = np.where(np.isfinite(complex_formula), complex_formula, 0.0)
    assert np.array_equal(mac(a, b), expected)
    assert np.array_equal(mac(a, b, np.sum(b * b, axis=-1)), expected)
    assert mac(a[0, 0], b[0, 0]) == pytest.approx(float(expected[0, 0]), abs=0.0)
    assert mac(a + 0j, b) == pytest.approx(mac(a, b), abs=1e-15)  # complex input: the complex path


def test_prepared_measured_shapes_match_as_the_raw_array():
    """:class:`MeasuredShapes` (prepared once per fit) gives match_by_shape the same modes as the
    raw array, and its ``has`` is :func:`has_shape`'s (two finite components)."""
    from types import SimpleNamespace

    from eigentwist.diagnose.shapes import MeasuredShapes, has_shape, match_by_shape

    rng = np.random.default_rng(12)
    n = 6
    V = rng.standard_normal((8, n, n))
    modes = SimpleNamespace(eigentwists=V, direction=np.tile(np.arange(n), (8, 1)))
    shapes = rng.standard_normal((8, 3))
    shapes[1, 0] = np.nan  # two DOFs measured: a shape
    shapes[2, :2] = np.nan  # one: none
    shapes[5] = np.nan
    groups = (np.array([0, 1]), np.array([3, 4]), np.array([6, 7]))  # the rows with a shape
    prepared = MeasuredShapes(shapes)
    assert np.array_equal(has_shape(prepared), has_shape(shapes))
    assert has_shape(shapes).tolist() == [True, True, False, True, True, False, True, True]
    fallback = np.arange(8) % n
    sensor = rng.standard_normal((8, 3)) * 0.1
    raw = match_by_shape(modes, shapes, groups, fallback, sensor)
    assert np.array_equal(match_by_shape(modes, prepared, groups, fallback, sensor), raw)
    assert raw[5] == fallback[5] and raw[2] == fallback[2]  # no shape: the label's mode
