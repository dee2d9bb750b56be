"""Direction labels from energy shares; degenerate pairs matched as one eigenspace."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import eigentwist
from eigentwist.diagnose import diagnose, paper_measurements, synth
from eigentwist.diagnose.matching import ModeMatchError, match_frequencies, match_modes
from eigentwist.diagnose.measurements import Measurements
from eigentwist.runtime import Modes
from eigentwist.runtime.labels import DEGENERATE_REL, degenerate_groups, directions, energy_shares, group_shares

from .conftest import random_poses

XY_TURNS = [0.0, 30.0, 45.0, 90.0, 135.0]


@pytest.fixture(scope="module")
def heli4():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eigentwist.load("heli4", backend="auto")


@pytest.fixture(scope="module")
def delta():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return eigentwist.load("delta", backend="auto")


def _kinetic_shares(M, V):
    """s_ik = t_ik (M t_k)_i / t_k^T M t_k written out with the inertia matrix."""
    MV = M @ V
    return V * MV / np.einsum("rik,rik->rk", V, MV)[:, None, :]


def test_energy_shares_are_the_kinetic_energy_shares(heli4):
    poses = random_poses(heli4.robot, 20, seed=3)
    for model in ("rigid", "paper"):
        M, _ = heli4.stiffness(poses, model, k_a=1500.0)
        m = heli4.modes(poses, model, k_a=1500.0)
        s = energy_shares(m.eigentwists)
        assert s == pytest.approx(_kinetic_shares(M, m.eigentwists), abs=1e-9)
        assert s.sum(axis=1) == pytest.approx(np.ones(s.shape[::2]), abs=1e-9)  # per mode
        assert s.sum(axis=2) == pytest.approx(np.ones(s.shape[:2]), abs=1e-9)  # per coordinate


def test_shares_kept_with_the_modes_are_the_shares_of_their_eigentwists(heli4, delta):
    """Where the evaluator keeps the shares (a flexible model: from M), they are the
    eigentwists' shares from V and V^-1, to round-off, and name the same axes."""
    for ev in (heli4, delta):
        poses = random_poses(ev.robot, 200, seed=8)
        m = ev.modes(poses, "paper", k_a=1500.0)
        if m.shares is None:
            assert ev.backend == "numpy"  # make test-fast: computed on demand
            continue
        assert m.shares == pytest.approx(energy_shares(m.eigentwists), abs=1e-12)
        np.testing.assert_array_equal(directions(m.eigentwists, shares=m.shares), directions(m.eigentwists))


def test_energy_shares_do_not_depend_on_units_or_eigentwist_scale(heli4):
    m = heli4.modes(random_poses(heli4.robot, 10, seed=4), "paper", k_a=800.0)
    rng = np.random.default_rng(1)
    scale = rng.uniform(-5, 5, (10, 1, 6))  # any scale per eigentwist, signs too
    units = np.diag([180 / np.pi] * 3 + [1000.0] * 3)  # deg and mm instead of rad and m
    s = energy_shares(m.eigentwists)
    assert energy_shares(m.eigentwists * scale) == pytest.approx(s, abs=1e-9)
    assert energy_shares(units @ m.eigentwists) == pytest.approx(s, abs=1e-9)
    assert np.array_equal(directions(units @ m.eigentwists), directions(m.eigentwists))
    nan = m.eigentwists.copy()
    nan[0] = np.nan
    assert np.isnan(energy_shares(nan)[0]).all() and np.isfinite(energy_shares(nan)[1:]).all()
    # the finite rows' shares are those of the definition, t_ik (M t_k)_i / (t_k^T M t_k)
    M = heli4.matrices(random_poses(heli4.robot, 10, seed=4), "paper", k_a=800.0)["M"]
    assert energy_shares(nan)[1:] == pytest.approx(_kinetic_shares(M, m.eigentwists)[1:], abs=1e-9)


def test_heli4_labels_unchanged_where_modes_are_well_separated(heli4):
    meas = paper_measurements(ev=heli4)
    for model in ("rigid", "paper"):
        m = heli4.modes(meas.poses, model, **meas.evaluation_params())
        f = m.freq_hz
        assert np.all(np.diff(f[:, :3], axis=1) > DEGENERATE_REL * f[:, 1:3])  # no near-equal pair
        largest_entry = np.argmax(np.abs(m.eigentwists), axis=-2) + (3 if model == "rigid" else 0)
        assert np.array_equal(m.direction[:, :2], largest_entry[:, :2])  # the paper's x and y modes
        idx = match_modes(m, meas.mode)
        assert np.array_equal(idx, np.where(np.array(meas.mode) == "x", 0, 1))


def test_degenerate_groups_chain_near_equal_modes():
    f = np.array([[10.0, 10.05, 10.1, 20.0], [10.0, 11.0, 11.05, 30.0], [5.0, 6.0, 7.0, 8.0]])
    assert degenerate_groups(f).tolist() == [[0, 0, 0, 1], [0, 1, 1, 2], [0, 1, 2, 3]]
    shares = np.tile(np.eye(4), (3, 1, 1))
    assert group_shares(shares, degenerate_groups(f))[0, 1].tolist() == [1, 1, 1, 0]


def _random_modes(n: int, seed: int, apart: bool = True) -> Modes:
    """Six modes of n rows with random eigentwists; ``apart``: no two within DEGENERATE_REL."""
    rng = np.random.default_rng(seed)
    freq = np.cumsum(rng.uniform(1.05, 3.0, (n, 6)), axis=1) * 10.0 if apart else np.full((n, 6), 10.0)
    return Modes(freq, rng.normal(size=(n, 6, 6)) + 3 * np.eye(6), ("rx", "ry", "rz", "x", "y", "z"), "flexible")


def test_modes_all_apart_match_as_groups_of_one_mode():
    """Rows whose modes are all apart (each its own group) give, bit for bit, what the group
    rule gives with singleton groups (an axis no mode points along: the order rule; a row
    whose eigentwists are not finite: shares 0); a batch with a degenerate row matches the
    other rows the same (row by row, whichever rule the batch takes)."""
    from eigentwist.diagnose import matching

    m = _random_modes(60, seed=5)
    m.eigentwists[7] = np.nan
    labels = [("x", "y", "z", "rx", "ry", "rz")[i % 6] for i in range(60)]
    with np.errstate(all="ignore"):
        freq, idx = match_frequencies(m, labels, strict=False)
        shares = energy_shares(m.eigentwists)
        axis = np.array([m.axes.index(label) for label in labels])
        singles = np.tile(np.arange(6), (60, 1))
        want_idx, want = matching._match_axes(m, shares, singles, axis, np.arange(60), labels, False, None)
    assert np.array_equal(idx, want_idx) and freq.tobytes() == want.tobytes()
    assert np.allclose(freq, m.freq_hz[np.arange(60), idx], rtol=1e-15)  # each row's one mode
    with pytest.raises(matching.ModeMatchError, match="no mode of the flexible model points along"):
        match_frequencies(m, labels, strict=True)
    pair = _random_modes(1, seed=6)
    pair.freq_hz[0, 1] = pair.freq_hz[0, 0] * (1 + DEGENERATE_REL / 2)  # one degenerate pair
    both = Modes(np.vstack([m.freq_hz, pair.freq_hz]), np.vstack([m.eigentwists, pair.eigentwists]), m.axes, "flexible")
    with np.errstate(all="ignore"):
        f2, i2 = match_frequencies(both, labels + ["x"], strict=False)
    assert f2[:60].tobytes() == freq.tobytes() and np.array_equal(i2[:60], idx)


def test_label_codes_follow_the_model_they_are_matched_on():
    """A label sequence met before is not parsed again, yet each model gets its own codes and
    a label the model lacks is refused every time."""
    flexible = _random_modes(3, seed=1)
    rigid = Modes(flexible.freq_hz[:, :3], flexible.eigentwists[:, :3, :3], ("x", "y", "z"), "rigid")
    labels = ["z", "2", "x"]
    for m in (flexible, rigid, flexible):
        idx = match_modes(m, labels)
        assert idx[1] == 1 and idx[0] == idx[0]  # rank 2: the second mode, whatever the model
    assert match_frequencies(rigid, ["3", "1", "2"])[1].tolist() == [2, 0, 1]
    for _ in range(2):
        with pytest.raises(ModeMatchError, match="rank 4 does not exist"):
            match_modes(rigid, ["4", "1", "2"])
        with pytest.raises(ModeMatchError, match="has no mode along rz"):
            match_modes(rigid, ["rz", "x", "y"])


def _rotated_pair(m: Modes, turn_deg: float) -> Modes:
    """The same eigenspaces with the basis of modes 0 and 1 turned by ``turn_deg``."""
    c, s = np.cos(np.radians(turn_deg)), np.sin(np.radians(turn_deg))
    v = m.eigentwists.copy()
    v[:, :, 0], v[:, :, 1] = (
        c * m.eigentwists[:, :, 0] + s * m.eigentwists[:, :, 1],
        -s * m.eigentwists[:, :, 0] + c * m.eigentwists[:, :, 1],
    )
    return Modes(m.freq_hz, v, m.axes, m.stiffness_model)


@pytest.mark.parametrize("model", ["rigid", "paper"])
def test_delta_on_axis_pair_is_matched_as_one_eigenspace(delta, model):
    x_ref = np.array(delta.robot.x_ref)
    m = delta.modes(np.array([x_ref] * 3), model, k_a=1000.0)  # one row per label
    assert m.freq_hz[0, 1] / m.freq_hz[0, 0] - 1 < 1e-9  # degenerate: any basis is right
    for turn in XY_TURNS:
        turned = _rotated_pair(m, turn)
        f, idx = match_frequencies(turned, ["x", "y", "z"])
        assert f == pytest.approx([m.freq_hz[0, 0], m.freq_hz[0, 0], m.freq_hz[0, 2]], rel=1e-9)
        assert sorted(idx[:2]) in ([0, 0], [0, 1], [1, 1]) and idx[2] == 2


@pytest.mark.parametrize("angle", [0.0, 37.0, 45.0, 90.0, 200.0])
def test_delta_poses_1mm_apart_give_the_same_labels(delta, angle):
    x_ref = np.array(delta.robot.x_ref)
    off = x_ref + 0.001 * np.array([np.cos(np.radians(angle)), np.sin(np.radians(angle)), 0.0])
    for model in ("rigid", "paper"):
        labels = ["x", "y", "z"]
        a = delta.modes(np.array([x_ref] * 3), model, k_a=1000.0)
        b = delta.modes(np.array([off] * 3), model, k_a=1000.0)
        fa, ia = match_frequencies(a, labels)
        fb, ib = match_frequencies(b, labels)
        groups_a, groups_b = degenerate_groups(a.freq_hz), degenerate_groups(b.freq_hz)
        assert np.array_equal(groups_a[np.arange(3), ia], groups_b[np.arange(3), ib])  # same eigenspaces
        assert fb == pytest.approx(fa, rel=1e-3)  # the pair splits by 6e-4 per mm


def test_a_pair_that_splits_beyond_the_tolerance_is_matched_mode_by_mode(delta):
    off = np.array(delta.robot.x_ref) + [0.05, 0.0, 0.0]  # 50 mm along x: split 3 %
    m = delta.modes(np.array([off] * 2), "rigid", k_a=1000.0)
    assert m.freq_hz[0, 1] / m.freq_hz[0, 0] - 1 > 2 * DEGENERATE_REL
    f, idx = match_frequencies(m, ["x", "y"])
    assert idx.tolist() == [1, 0] and f == pytest.approx([m.freq_hz[0, 1], m.freq_hz[0, 0]], rel=1e-12)


@pytest.mark.slow  # > ~8 s: make test, not make test-fast
def test_delta_diagnosis_is_the_same_1mm_off_axis(delta):
    x_ref = np.array(delta.robot.x_ref)
    meas = synth(
        "paper+payload_mass:m_p=0.25",
        k_a=[250, 1000, 4000],
        poses=[x_ref],
        modes=("x", "y", "z"),
        noise="0.5%",
        seed=2,
        robot="delta",
        ev=delta,
    )
    selections = []
    for shift in ([0.0, 0.0, 0.0], [0.001, 0.0, 0.0], [0.0, 0.001, 0.0], [0.0007, 0.0007, 0.0]):
        moved = Measurements(
            meas.k_a, meas.mode, meas.freq_hz, meas.sigma_hz, meas.poses + shift, robot="delta", source="moved"
        )
        d = diagnose(moved, baseline="paper", ev=delta)
        selections.append((d.selected, d.ranking[0].effect, d.explained))
    assert all(s == selections[0] for s in selections), selections
    assert "payload_mass" in selections[0][0]


def test_the_old_names_of_the_stiffness_model_still_answer_with_a_warning():
    ev = eigentwist.load("heli4", backend="numpy")
    m = ev.modes(np.array([0.0, 0.0, -0.625]), "paper")
    assert ev.stiffness_model("paper") == m.stiffness_model == "flexible" and ev.stiffness_model("rigid") == "rigid"
    with pytest.warns(DeprecationWarning, match="stiffness_model"):
        assert ev.kind("rigid") == "rigid"
    with pytest.warns(DeprecationWarning, match="stiffness_model"):
        assert m.kind == "flexible"


def test_label_codes_beyond_the_memo_bound_stay_right():
    """More label sequences than the memo keeps (``_CODES_SIZE``): each still gets its codes."""
    from eigentwist.diagnose import matching

    m = _random_modes(2, seed=2)
    size = matching._CODES_SIZE
    pairs = [(a, b) for a in ("1", "2", "3", "4", "5", "6", "x", "y", "z", "rx", "ry", "rz") for b in "123456"]
    assert len(pairs) > size + 1
    for first, second in pairs:  # inside, at and beyond the bound
        idx = match_frequencies(m, [first, second], strict=False)[1]
        assert idx[1] == int(second) - 1 and (not first.isdigit() or idx[0] == int(first) - 1)
        assert len(matching._CODES) <= size
    again = match_frequencies(m, ["x", "y"], strict=False)[1]
    assert np.array_equal(again, match_frequencies(m, np.array(["x", "y"]), strict=False)[1])  # not memoised


def test_the_shares_come_from_the_inertia_when_first_read_and_go_with_it():
    """A pass that has M at hand leaves it in ``Modes.inertia``: the shares are computed from
    it on first reading (t_ik (M t_k)_i / t_k^T M t_k), then kept and M dropped; shares set
    (None where the eigentwists change) drop the inertia, and no eigentwists give no shares."""
    from eigentwist.runtime.modes import AXES, Modes

    rng = np.random.default_rng(5)
    v, L = rng.normal(size=(3, 6, 6)), rng.normal(size=(3, 6, 6))
    M = L @ np.swapaxes(L, 1, 2) + 6 * np.eye(6)
    m = Modes(np.ones((3, 6)), v, AXES, "flexible", inertia=M)
    assert m.inertia is M
    s = m.shares
    assert s == pytest.approx(_kinetic_shares(M, v), rel=1e-12)
    assert m.inertia is None and m.shares is s
    changed = Modes(np.ones((3, 6)), v, AXES, "flexible", inertia=M)
    changed.shares = None
    assert changed.inertia is None and changed.shares is None
    assert Modes(np.ones((3, 6)), None, AXES, "flexible", inertia=M).shares is None
