"""The robot at a pose, drawn from its own description, and its lowest mode shapes.

Nothing here knows a particular robot. The joint angles come from the generated
evaluator's closed-form inverse kinematics (:meth:`Evaluator.joint_angles`); the points
come from the description's legs: the actuated joint centre B_i (``Leg.base``), the lower
link along ``r_i1 = cos q_i1 u_i - sin q_i1 e_z`` with length ``l1`` to the elbow, and the
parallelogram to the attachment ``P + a_i`` (``Leg.attachment``), as in the derivation
(:mod:`eigentwist.symbolic.leg`). A mode shape is the eigentwist ``[omega; v]`` at the EE
origin moving the platform: each attachment point moves by ``v + omega x a_i`` (Eqs. 57, 65).
"""

from __future__ import annotations

import textwrap
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..outputs import atomic_path
from ..matplotlib_agg import pyplot

__all__ = [
    "RobotGeometry",
    "robot_geometry",
    "mode_displacements",
    "plot_modes",
    "platform_outline",
    "AXIS_WORDS",
    "stiffness_argument",
    "stiffness_text",
    "damped_text",
]

AXIS_WORDS = {
    "rx": "rotation about X",
    "ry": "rotation about Y",
    "rz": "rotation about Z",
    "x": "translation along X",
    "y": "translation along Y",
    "z": "translation along Z",
}
COLORS = ("tab:blue", "tab:orange", "tab:green", "tab:red", "tab:purple", "tab:brown")


@dataclass
class RobotGeometry:
    """Points of the robot at one pose, base frame, m.

    pose : (3,) end-effector origin P.
    base, elbow, attachment : (legs, 3) actuated joint centres B_i, elbows, and the
        leg attachments P + a_i on the platform.
    legs : the legs' names.
    l1, l2 : lower link and parallelogram lengths.
    """

    pose: np.ndarray
    base: np.ndarray
    elbow: np.ndarray
    attachment: np.ndarray
    legs: tuple
    l1: float
    l2: float
    #: the pose as the evaluator takes it ((3,) position; (6,) with the rotation vector, rad)
    coordinates: np.ndarray | None = None

    @property
    def offsets(self) -> np.ndarray:
        """(legs, 3) attachments relative to the EE origin, a_i."""
        return self.attachment - self.pose


def _numeric(exprs, values: dict) -> np.ndarray:
    """Evaluate a tuple of SymPy expressions in the parameter symbols at ``values``."""
    m = sp.Matrix(exprs)
    return np.array(m.subs({s: values[s.name] for s in m.free_symbols}).evalf(), dtype=float).ravel()


def robot_geometry(ev, pose, **params) -> RobotGeometry:
    """The robot of evaluator ``ev`` at end-effector position ``pose`` (m).

    ``params`` override the description's defaults (SI units), as in
    :meth:`Evaluator.joint_angles`; an unreachable pose raises its usual error.
    """
    if not hasattr(ev.robot, "l1"):
        return _chain_geometry(ev, pose, **params)
    pose = np.asarray(pose, dtype=float).reshape(3)
    values = {**ev.defaults, **params}
    q = ev.joint_angles(pose[None, :], **params)[0]
    l1, l2 = (float(_numeric((e,), values)[0]) for e in (ev.robot.l1, ev.robot.l2))
    base, elbow, attach = [], [], []
    for leg, (q1, _q2, _q3) in zip(ev.robot.legs, q):
        B, u, a = (_numeric(getattr(leg, k), values) for k in ("base", "radial", "attachment"))
        r1 = np.cos(q1) * u - np.sin(q1) * np.array([0.0, 0.0, 1.0])
        base.append(B)
        elbow.append(B + l1 * r1)
        attach.append(pose + a)
    return RobotGeometry(
        pose, np.array(base), np.array(elbow), np.array(attach), tuple(leg.name for leg in ev.robot.legs), l1, l2, pose
    )


def _chain_geometry(ev, pose, **params) -> RobotGeometry:
    """A joint-list robot (the hexapod, a planar, point or lower-mobility platform): each leg
    drawn as a straight strut from its first joint's location (base) to its last joint's
    (platform; a leg in URDF form: its first joint's origin to its attachment), at ``pose``
    (the robot's coordinates, m and rad) completed to the six of a
    rigid platform (followers solved, :func:`eigentwist.runtime.platform.full_poses`)."""
    from ..runtime.platform import full_poses
    from ..runtime.poses import rotation_matrix

    given = np.asarray(pose, dtype=float).reshape(len(ev.pose_names))
    ev.joint_angles(given[None, :], **params)  # an unreachable pose raises its usual error
    if len(ev.space.inputs) > 3:
        full = full_poses(ev.space, given[None, :], getattr(ev.module, "followers", None), ev.inputs("rigid", params))[
            0
        ]
    else:
        full = np.concatenate([given, np.zeros(3)])
    values = {**ev.defaults, **params}
    p = {q.name: sp.Float(values[q.name]) for q in ev.robot.parameters}
    position = sp.Matrix(full[:3])
    rotation = sp.Matrix(rotation_matrix(full[3:6]))
    base, attach = [], []
    subs = {q.symbol: values[q.name] for q in ev.robot.parameters}
    for leg in ev.robot.legs:
        serial = getattr(getattr(leg, "numeric", None), "leg", None)
        if serial is not None:  # a leg in URDF form: from its first joint to its attachment
            base.append(np.array(sp.Matrix(serial.joints[0].origin).subs(subs).evalf(), dtype=float).ravel())
            end = position + rotation * sp.Matrix(serial.attachment).subs(subs)
            attach.append(np.array(end.evalf(), dtype=float).ravel())
            continue
        g = leg.geometry(position, rotation, p)
        located = [j.location for j in leg.joints if j.location is not None]  # a prismatic joint has none

        def point(loc):
            return np.array(sp.Matrix(g[loc] if isinstance(loc, str) else loc).evalf(), dtype=float).ravel()

        real = [j.location for j in leg.joints if j.location is not None and not j.virtual]
        base.append(point(located[0]))
        attach.append(point(real[-1] if len(real) > 1 else located[-1]))  # a U-P leg: its virtual joints' point
    base, attach = np.array(base), np.array(attach)
    length = float(np.mean(np.linalg.norm(attach - base, axis=1)))
    return RobotGeometry(
        full[:3],
        base,
        0.5 * (base + attach),
        attach,
        tuple(leg.name for leg in ev.robot.legs),
        0.5 * length,
        0.5 * length,
        given,
    )


def stiffness_argument(ev, k_a) -> dict:
    """``{"k_a": k_a}`` for a robot whose actuators share the parameter ``k_a``, else ``{}``
    (legs that differ name their own stiffnesses, given with the other parameters)."""
    return {"k_a": k_a} if k_a is not None and "k_a" in ev.defaults else {}


def stiffness_text(ev, k_a) -> str:
    """``"k_a = 2000 N m/rad, "`` for the titles, "" for a robot without ``k_a``."""
    return f"k_a = {k_a:g} {ev.parameter('k_a').unit}, " if stiffness_argument(ev, k_a) else ""


def mode_displacements(geometry: RobotGeometry, twist, axes) -> np.ndarray:
    """(legs, 3) displacement of each attachment for the eigentwist ``twist``.

    ``axes`` names its coordinates (``Modes.axes``): ``("rx", ..., "z")`` for a
    flexible model (``[omega; v]``), ``("x", "y", "z")`` for the rigid one.
    """
    full = dict.fromkeys(("rx", "ry", "rz", "x", "y", "z"), 0.0)
    full.update(zip(axes, np.asarray(twist, dtype=float)))
    omega = np.array([full["rx"], full["ry"], full["rz"]])
    v = np.array([full["x"], full["y"], full["z"]])
    return v + np.cross(omega, geometry.offsets)


def platform_outline(points: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Closed polygon through ``points`` (k, 3), m, ordered by angle about ``centre`` in the XY plane."""
    d = points - centre
    order = np.argsort(np.arctan2(d[:, 1], d[:, 0]))
    return np.vstack([points[order], points[order[:1]]])


_outline = platform_outline


def _draw_robot(ax, g: RobotGeometry, color="0.45"):
    for k, name in enumerate(g.legs):
        pts = np.vstack([g.base[k], g.elbow[k], g.attachment[k]])
        ax.plot(*pts.T, "-", color=color, lw=2.2, marker="o", ms=3, gid=f"leg {name}")
    ax.plot(*g.base.T, "s", color="k", ms=5, gid="base")
    ax.plot(*_outline(g.attachment, g.pose).T, "-", color=color, lw=1.5, gid="platform")
    ax.plot(*g.pose, "+", color="k", ms=8, gid="ee origin")


def _limits(ax, pts: np.ndarray):
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    span = max(float(np.max(hi - lo)), 1e-3) * 0.55
    mid = (lo + hi) / 2
    ax.set_xlim(mid[0] - span, mid[0] + span)
    ax.set_ylim(mid[1] - span, mid[1] + span)
    ax.set_zlim(mid[2] - span, mid[2] + span)
    ax.set_box_aspect((1, 1, 1))


def _zoom(ax, g: RobotGeometry, d: np.ndarray, color: str, k: int):
    """The platform seen in the plane of its largest motion, rest (grey) and displaced (colour)."""
    size = max(float(np.max(np.linalg.norm(g.offsets - g.offsets.mean(axis=0), axis=1))), 1e-3)
    i, j = sorted(np.argsort(np.abs(d).sum(axis=0))[-2:])
    scale = 0.6 * size / max(float(np.max(np.linalg.norm(d, axis=1))), 1e-12)
    moved = g.attachment + scale * d
    centre = g.attachment.mean(axis=0)
    for m, name in enumerate(g.legs):
        pts = np.vstack([g.elbow[m], g.attachment[m]])
        ax.plot(pts[:, i], pts[:, j], "-", color="0.6", lw=1.5)
    for pts, col, style in ((g.attachment, "0.45", "-"), (moved, color, "-")):
        out = _outline(pts, centre)
        ax.plot(out[:, i], out[:, j], style, color=col, lw=2.2, marker="o", ms=4)
    for a, b in zip(g.attachment, moved):
        ax.annotate("", xy=(b[i], b[j]), xytext=(a[i], a[j]), arrowprops=dict(arrowstyle="->", color=color, lw=1.2))
    ax.plot(g.pose[i], g.pose[j], "+", color="k", ms=9)
    span = 1.9 * size
    mid = (centre + g.pose) / 2
    ax.set_xlim(mid[i] - span, mid[i] + span)
    ax.set_ylim(mid[j] - span, mid[j] + span)
    ax.set_aspect("equal")
    names = "XYZ"
    ax.set_xlabel(f"{names[i]} [m]", fontsize=8)
    ax.set_ylabel(f"{names[j]} [m]", fontsize=8)
    ax.tick_params(labelsize=7)
    ax.grid(alpha=0.3)
    ax.set_title(f"mode {k + 1}, platform in the {names[i]}{names[j]} plane (+: EE origin)", fontsize=9)


def damped_text(modes, k: int) -> str:
    """``", zeta 0.43, damped 5.28 Hz"`` for a model with damping (:attr:`Modes.damping`), else ""."""
    if modes.damping is None:
        return ""
    return f", zeta {modes.damping_ratio[0, k]:.2g}, damped {modes.damped_hz[0, k]:.4g} Hz"


def plot_modes(
    ev,
    pose,
    path=None,
    model="paper",
    k_a: float = 2000.0,
    n_modes: int = 3,
    amplitude=0.2,
    title: str | None = None,
    **params,
):
    """Draw the robot at ``pose`` with its ``n_modes`` lowest mode shapes, one 3D panel each.

    Top row: the whole robot in 3D; the grey robot is at rest, the coloured platform is
    displaced along the mode's eigentwist, scaled so that the largest attachment
    displacement is ``amplitude`` times the parallelogram length l2 (a mode shape has no
    absolute size); arrows show each attachment's displacement. A model with a damping
    effect titles each mode with its damping ratio zeta and damped frequency too. Bottom row: the platform
    close up, in the plane of its largest motion. Saved as PNG to ``path`` (a file name or a binary
    file object) when given. Returns the Matplotlib figure.
    """
    plt = pyplot()
    g = robot_geometry(ev, pose, **params)
    modes = ev.modes(g.coordinates[None, :], model, **stiffness_argument(ev, k_a), **params)
    n = min(n_modes, modes.freq_hz.shape[1])
    fig = plt.figure(figsize=(4.2 * n, 8.4))
    for k in range(n):
        d = mode_displacements(g, modes.eigentwists[0][:, k], modes.axes)
        color = COLORS[k % len(COLORS)]
        axis = ("rx", "ry", "rz", "x", "y", "z")[int(modes.direction[0, k])]
        ax = fig.add_subplot(2, n, k + 1, projection="3d")
        _draw_robot(ax, g)
        scale = amplitude * g.l2 / max(float(np.max(np.linalg.norm(d, axis=1))), 1e-12)
        moved = g.attachment + scale * d
        ax.plot(*_outline(moved, g.pose + scale * d.mean(axis=0)).T, "-", color=color, lw=2.5, gid=f"mode {k + 1}")
        ax.quiver(*g.attachment.T, *(scale * d).T, color=color, arrow_length_ratio=0.25, lw=1.2)
        ax.set_title(
            f"mode {k + 1}: {modes.freq_hz[0, k]:.4g} Hz{damped_text(modes, k)}\nmostly {axis} ({AXIS_WORDS[axis]})",
            fontsize=10,
        )
        _limits(ax, np.vstack([g.base, g.elbow, g.attachment, moved]))
        ax.view_init(elev=18, azim=-60)
        for name, setter in zip("XYZ", (ax.set_xlabel, ax.set_ylabel, ax.set_zlabel)):
            setter(f"{name} [m]", fontsize=8)
        ax.tick_params(labelsize=7)
        _zoom(fig.add_subplot(2, n, n + k + 1), g, d, color, k)
    model_name = (
        model
        if isinstance(model, str) and "," not in model
        else " + ".join(model.split(",") if isinstance(model, str) else model)
    )
    where = ", ".join(f"{v:g}" for v in np.round(g.coordinates, 4))
    unit = "m, rad" if any(c.startswith("rot") for c in ev.pose_names) else "m"
    text = title or (
        f"{ev.robot.title} at [{where}] {unit}, {stiffness_text(ev, k_a)}model {model_name}: "
        "grey at rest, colour the mode shape"
    )
    fig.suptitle(textwrap.fill(text, 30 * n), fontsize=10)
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    if path is not None:
        with atomic_path(path) as tmp:
            fig.savefig(tmp, format="png", dpi=110)
        plt.close(fig)
    return fig
