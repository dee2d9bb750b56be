"""Pinocchio as an independent engine: each leg a kinematic tree, the platform
its own free body, the tree's mass matrix (``crba``) and the actuated/elastic joints'
rows reduced through the loop-closure velocity map to the platform's freedoms
(``tests/pinocchio_model.py``); frequencies, M and K equal eigentwist's at 20 random
reachable poses to 1e-8 relative."""

from __future__ import annotations

import numpy as np
import pytest

pin = pytest.importorskip("pinocchio")

import eigentwist  # noqa: E402
from eigentwist.description.effects import resolve_model  # noqa: E402

from .conftest import random_poses  # noqa: E402
from .pinocchio_model import PinFrame, PinocchioRobot, eigen_frequencies, from_description, rotation_vector_matrix  # noqa: E402

RTOL = 1e-8
N_POSES = 20
TRANSLATION = np.vstack([np.zeros((3, 3)), np.eye(3)])  # the 3-DoF robots' freedoms: [0; v]


def _rel(a, b) -> float:
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@pytest.fixture(scope="module")
def evaluators():
    return {}


def _ev(evaluators, name):
    if name not in evaluators:
        evaluators[name] = eigentwist.load(name, backend="numpy")
    return evaluators[name]


def _rod_law(params):
    """The rod pair's compliance at frame L2 (App. C, Eq. C.10; the material law is an
    input here, the frames and the joint-space mapping are Pinocchio's)."""
    from eigentwist.symbolic.stiffness import rod_pair_compliance

    def law(i, state):
        r2 = state["frames"]["L2"].rotation[:, 0]
        s = state["frames"]["E1"].rotation[:, 1]  # the bars' direction s_i (elbow link)
        d_pi = params["w_pi"] * np.linalg.norm(np.cross(r2, s))
        C = rod_pair_compliance(params["l2"], params["r_i"], params["r_o"], params["E_rod"], params["G_rod"], d_pi)
        return np.array(C, dtype=float)

    return law


def _tube_inertia(p) -> np.ndarray:
    """One parallelogram rod: a tube of length l2 (kg, kg m^2 at its centre, x along it)."""
    m = p["l2"] * p["rho"] * np.pi * (p["r_o"] ** 2 - p["r_i"] ** 2)
    ix = m / 2 * (p["r_i"] ** 2 + p["r_o"] ** 2)
    iyz = m / 12 * (3 * (p["r_i"] ** 2 + p["r_o"] ** 2) + p["l2"] ** 2)
    return np.diag([ix, iyz, iyz, m, m, m])


def build(ev, model: str):
    """(PinocchioRobot, freedoms E, matrices keyword arguments) for eigentwist's ``model``."""
    robot, p = ev.robot, dict(ev.defaults)
    x_ref = np.asarray(robot.x_ref, float)
    q_ref = ev.joint_angles(x_ref[None])[0]
    rrpirr = any(j.kind == "Pi" for j in robot.legs[0].joints)
    # L2 (rod tips at a_i, x along the rods) swings with the rods; E1 (axes r1, s, n1:
    # the bars' direction s is its y axis) rides on the elbow link
    frames = (("L2", 2, "pE"), ("E1", 1, None)) if rrpirr else ()
    spec = from_description(robot, p, q_ref, x_ref, frames=frames)
    effects = resolve_model(model, robot)
    if "swinging_rods" in effects:
        # the rods as bodies on the swinging joint: each a tube of length l2 at its own
        # centre, x along the rod (Eqs. 27-29 for one rod); the fictitious rod goes
        rod = _tube_inertia(p)
        for leg in spec.legs:
            for b in leg.bodies:
                if b.riding:
                    b.inertia = np.zeros((6, 6))
                elif b.pivot is not None:
                    b.inertia = rod
    eta = p["eta_a"] if "actuator_loss" in effects else 1.0
    kw = {"c_act": 1 / (eta * p["k_a"])}
    structural = any(robot.effect(e).structural for e in effects)
    if not structural:
        kw["stiffness"] = "actuated"
    else:
        kw["c_virtual"] = p["c_rigid"]
        laws = {}
        if "rod_compliance" in effects:
            laws["L2"] = _rod_law(p)
        if "ee_compliance" in effects:
            split = robot.ee_compliance
            origin = x_ref[:3] + np.array(
                [
                    float(c.subs({s: p[s.name] for s in c.free_symbols})) if hasattr(c, "free_symbols") else float(c)
                    for c in split.origin
                ]
            )
            for leg in spec.legs:
                leg.frames.append(PinFrame("ee", -1, np.eye(3), origin))
            subs = {s: p[s.name] for s in set().union(*[m.free_symbols for m in split.per_leg.values()])}
            per_leg = {i: np.array(m.xreplace(subs), dtype=float) for i, m in split.per_leg.items()}
            laws["ee"] = lambda i, st: per_leg.get(i)
        kw["compliances"] = laws
    freedoms = np.eye(6) if (structural or len(x_ref) == 6) else TRANSLATION
    return PinocchioRobot(spec), freedoms, kw


CASES = [
    ("hexapod", "none"),
    ("hexapod", "rigid"),
    ("heli4", "none"),
    ("heli4", "paper"),
    ("heli4", "swinging_rods"),
    ("heli4", "paper,swinging_rods"),
    ("delta", "none"),
    ("delta", "paper"),
    ("delta", "swinging_rods"),
    ("delta", "paper,swinging_rods"),
]


@pytest.mark.parametrize("name,model", CASES)
def test_pinocchio_equals_eigentwist(evaluators, name, model):
    ev = _ev(evaluators, name)
    pr, E, kw = build(ev, model)
    poses = random_poses(ev.robot, N_POSES, seed=21)
    M_et, K_et = ev.stiffness(poses, model)
    f_et = ev.frequencies(poses, model)
    worst = {"M": 0.0, "K": 0.0, "f": 0.0}
    for pose, Me, Ke, fe in zip(poses, M_et, K_et, f_et):
        R = rotation_vector_matrix(pose[3:6]) if len(pose) == 6 else None
        out = pr.matrices(pose[:3], R, **kw)
        M, K = E.T @ out["M"] @ E, E.T @ out["K"] @ E
        f = eigen_frequencies(M, K)
        worst["M"] = max(worst["M"], _rel(M, Me))
        worst["K"] = max(worst["K"], _rel(K, Ke))
        worst["f"] = max(worst["f"], float(np.max(np.abs(f - fe) / fe)))
    assert max(worst.values()) < RTOL, f"{name} {model}: relative deviations {worst}"
