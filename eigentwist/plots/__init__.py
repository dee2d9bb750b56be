"""Figures (Matplotlib, Agg backend; ``pip install 'eigentwist[plot]'``).

* :func:`plot_comparison`: the paper's Fig. 6 style, a model against measurements;
* :func:`plot_diagnosis`: the baseline and final model of a diagnosis, the error step by step;
* :func:`plot_modes`: the robot at a pose with its lowest mode shapes, drawn from the
  description's legs and the generated inverse kinematics (:func:`robot_geometry`).

Each takes a ``path`` (file name or binary file object) to write a PNG.
"""

from ..diagnose.plots import model_curves, plot_comparison, plot_diagnosis
from .robot import AXIS_WORDS, RobotGeometry, mode_displacements, plot_modes, robot_geometry

__all__ = [
    "plot_comparison",
    "plot_diagnosis",
    "model_curves",
    "plot_modes",
    "robot_geometry",
    "RobotGeometry",
    "mode_displacements",
    "AXIS_WORDS",
]
