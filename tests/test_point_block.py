"""Which point platforms' rigid models the generated C pass solves itself
(eigentwist.codegen.c_source.point_block, eigen_models)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from eigentwist.codegen.c_source import EIGEN_MODELS, EIGEN_MODELS_6DOF, eigen_dims, eigen_models, point_block
from eigentwist.description.pose import PointPose, TranslationPose


@pytest.mark.parametrize(
    "coordinates, block",
    [
        (("x", "y"), (2, 3)),
        (("y", "z"), (2, 4)),
        (("x", "y", "z"), (3, 3)),
        (("y", "x"), (2, 3)),  # the allowed twists in the twist's order
        (("x", "z"), None),  # not consecutive
        (("x",), None),  # a point on a line: 1 x 1, outside the pass
        (("z",), None),
    ],
)
def test_a_points_block_is_its_consecutive_translations(coordinates, block):
    assert point_block(PointPose(coordinates)) == block


def test_only_a_point_has_a_block():
    assert point_block(TranslationPose()) is None
    assert point_block(None) is None


def robot(space, pose):
    return SimpleNamespace(pose_space=space, pose=pose)


def test_the_pass_solves_a_planar_points_2x2_and_keeps_the_others_models():
    models = eigen_models(robot(PointPose(("x", "y")), ("x", "y")))
    assert models == (EIGEN_MODELS[0], ("rigid", 2, 3, "M", "K_R"))
    assert eigen_dims(robot(PointPose(("x", "y")), ("x", "y"))) == (6, 3, 2)
    assert eigen_models(robot(PointPose(("x", "z")), ("x", "z"))) is EIGEN_MODELS
    assert eigen_models(robot(PointPose(("x", "y", "z")), ("x", "y", "z"))) is EIGEN_MODELS
    assert eigen_models(robot(TranslationPose(), ("x", "y", "z"))) is EIGEN_MODELS
    assert eigen_models(robot(None, ("x", "y", "z", "rot_x", "rot_y", "rot_z"))) is EIGEN_MODELS_6DOF
    assert eigen_dims(robot(TranslationPose(), ("x", "y", "z"))) == (6, 3)


def columns(*cols):
    """A (6, n) basis from its columns."""
    return [[c[i] for c in cols] for i in range(6)]


@pytest.mark.parametrize(
    "basis, block",
    [
        (columns((0, 0, 0, 1, 0, 0), (0, 0, 0, 0, 1, 0)), (2, 3)),
        (columns((1, 0, 0, 0, 0, 0), (0, 1, 0, 0, 0, 0)), (2, 0)),  # unit twists from the first coordinate
        (columns((0, 0, 0, 0.6, 0.8, 0), (0, 0, 0, 0, 0, 1)), None),  # a direction that is no coordinate
        (columns((0, 0, 0, 1, 0, 0), (0, 0, 0, 0, 0.6, 0.8)), None),  # the second one is not
        (columns((0, 0, 0, 2, 0, 0), (0, 0, 0, 0, 1, 0)), None),  # not unit
        (columns((0, 0, 0, 1, 1, 0), (0, 0, 0, 0, 0, 1)), None),  # two coordinates at once
        (columns((0, 0.6, 0.8, 0, 0, 0), (1, 0, 0, 0, 0, 0)), None),  # the first not, the second the first
        (columns((0.6, 0.8, 0, 0, 0, 0), (0, 0, 1, 0, 0, 0)), None),  # the first not, the second the third
    ],
)
def test_only_unit_twists_of_consecutive_coordinates_make_a_block(basis, block):
    assert point_block(SimpleNamespace(point=True, basis=basis)) == block
    assert point_block(SimpleNamespace(point=False, basis=basis)) is None
    assert point_block(SimpleNamespace(basis=basis)) is None  # no point attribute: not a point


def test_a_description_without_a_pose_space_keeps_the_models():
    assert eigen_models(SimpleNamespace(pose=("x", "y", "z"))) is EIGEN_MODELS
