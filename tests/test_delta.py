"""The Delta robot from a description alone (issue 6): symmetry and full rank."""
from __future__ import annotations

import numpy as np
import pytest

import eigentwist

from .conftest import random_poses, workspace_grid


@pytest.fixture(scope="module")
def delta():
    return eigentwist.load("delta", backend="numpy")


@pytest.mark.parametrize("z", [-0.65, -0.75, -0.9])
def test_horizontal_frequencies_equal_on_the_central_axis(delta, z):
    for model in ("rigid", "paper"):
        f = delta.frequencies([0.0, 0.0, z], model)[0]
        assert f[1] == pytest.approx(f[0], rel=1e-9)


def test_rotation_by_120_degrees_leaves_frequencies_unchanged(delta):
    phi = 2 * np.pi / 3
    Rz = np.array([[np.cos(phi), -np.sin(phi), 0], [np.sin(phi), np.cos(phi), 0], [0, 0, 1]])
    poses = random_poses(delta.robot, 8, seed=12)
    for model in ("rigid", "paper"):
        f = delta.frequencies(poses, model)
        np.testing.assert_allclose(delta.frequencies(poses @ Rz.T, model), f, rtol=1e-9)
        np.testing.assert_allclose(delta.frequencies(poses @ Rz, model), f, rtol=1e-9)


def test_flexible_model_full_rank_and_translations_lowest(delta):
    grid = workspace_grid(delta.robot, 3)
    K = delta.matrices(grid, "paper")["K_F"]
    assert np.linalg.eigvalsh(K).min() > 0
    modes = delta.modes(grid, "paper")
    # the three lowest modes are translations: largest eigentwist component in x, y or z
    assert (modes.direction[:, :3] >= 3).all()
    assert (modes.direction[:, 3:] < 3).all()
    assert (modes.freq_hz[:, 2] * 3 < modes.freq_hz[:, 3]).all()


def test_delta_has_no_ee_compliance_effect(delta):
    assert "ee_compliance" not in delta.effects
    with pytest.raises(ValueError, match="ee_compliance"):
        delta.frequencies(delta.robot.x_ref, "rigid,ee_compliance")
