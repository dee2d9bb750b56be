"""The lowest mode shapes as animations: an SVG for the HTML report, a GIF for slides.

The robot is drawn as in :func:`~.robot.plot_modes` (from its description's legs and the
generated inverse kinematics, :func:`~.robot.robot_geometry`); the platform and the links
to it move along each mode's eigentwist, ``a_i + s sin(2 pi t / T) (v + omega x a_i)``
(Eqs. 57, 65), scaled so that the largest attachment displacement is ``amplitude`` times
the link length l2 (a mode shape has no absolute size).

:func:`modes_svg` is self-contained SVG animated by SMIL ``<animate>`` elements: no script,
no network, it runs where the report is opened (also inside an ``<img>``).
:func:`modes_gif` writes the same motion as an animated GIF (Matplotlib, Pillow writer).
"""

from __future__ import annotations

import html

import numpy as np

from ..outputs import atomic_path
from .robot import AXIS_WORDS, damped_text, mode_displacements, robot_geometry, stiffness_argument
from .robot import platform_outline as _outline

__all__ = ["mode_frames", "modes_svg", "modes_gif", "PERIOD_S"]

PERIOD_S = 1.6  # one oscillation of the animation, s
COLORS = ("#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b")
PHASES = (0.0, 1.0, 0.0, -1.0, 0.0)  # sin at quarter periods: one cycle of SMIL key values


def mode_frames(ev, pose, model="paper", k_a: float = 2000.0, n_modes: int = 3, amplitude: float = 0.2, **params):
    """The robot at ``pose`` (m, or m and rad) and its ``n_modes`` lowest modes.

    Returns ``(geometry, modes)``: the :class:`~.robot.RobotGeometry` at rest and, per mode,
    a dict ``freq_hz``, ``axis`` (the direction it mostly moves along), ``displacement``
    (legs, 3) of the attachments, m, already scaled for display, and ``damped`` (a damped
    model's ``", zeta 0.43, damped 5.28 Hz"``, else "").
    """
    g = robot_geometry(ev, pose, **params)
    modes = ev.modes(g.coordinates[None, :], model, **stiffness_argument(ev, k_a), **params)
    out = []
    for k in range(min(n_modes, modes.freq_hz.shape[1])):
        d = mode_displacements(g, modes.eigentwists[0][:, k], modes.axes)
        scale = amplitude * g.l2 / max(float(np.max(np.linalg.norm(d, axis=1))), 1e-12)
        out.append(
            {
                "freq_hz": float(modes.freq_hz[0, k]),
                "axis": ("rx", "ry", "rz", "x", "y", "z")[int(modes.direction[0, k])],
                "displacement": scale * d,
                "damped": damped_text(modes, k),
            }
        )
    return g, out


def _anchor(ev, g) -> np.ndarray:
    """Where the moving link of each leg starts: the elbow of a leg with a lower link (the
    Heli4, the Delta), the base joint of a strut (a joint-list robot: the hexapod)."""
    return g.elbow if hasattr(ev.robot, "l1") else g.base


def _view(points, azim_deg: float = -60.0, elev_deg: float = 18.0) -> np.ndarray:
    """(N, 2) screen coordinates (right, up) of base-frame points seen from azimuth/elevation
    (Matplotlib's convention)."""
    a, e = np.radians(azim_deg), np.radians(elev_deg)
    p = np.asarray(points, float)
    right = -p[:, 0] * np.sin(a) + p[:, 1] * np.cos(a)
    depth = p[:, 0] * np.cos(a) + p[:, 1] * np.sin(a)
    up = p[:, 2] * np.cos(e) - depth * np.sin(e)
    return np.column_stack([right, up])


def _pts(xy) -> str:
    return " ".join(f"{x:.1f},{y:.1f}" for x, y in xy)


def modes_svg(
    ev,
    pose,
    model="paper",
    k_a: float = 2000.0,
    n_modes: int = 3,
    amplitude: float = 0.2,
    title: str | None = None,
    panel_px: int = 300,
    **params,
) -> str:
    """An animated SVG (a string): one panel per mode, the grey robot at rest, the coloured
    platform and links oscillating along the mode shape (period :data:`PERIOD_S`)."""
    g, modes = mode_frames(ev, pose, model, k_a, n_modes, amplitude, **params)
    anchor = _anchor(ev, g)
    rest = np.vstack([g.base, g.elbow, g.attachment])
    moving = [np.vstack([g.attachment + s * m["displacement"] for s in (-1.0, 1.0)]) for m in modes]
    allxy = _view(np.vstack([rest] + moving))
    lo, hi = allxy.min(axis=0), allxy.max(axis=0)
    span = max(float(np.max(hi - lo)), 1e-6) * 1.1
    mid = (lo + hi) / 2
    top = 46

    def screen(points, k):
        xy = _view(points)
        x = (xy[:, 0] - mid[0]) / span * panel_px + panel_px / 2 + k * panel_px
        y = top + panel_px / 2 - (xy[:, 1] - mid[1]) / span * panel_px
        return np.column_stack([x, y])

    width, height = panel_px * max(len(modes), 1), panel_px + top + 8
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
        f'viewBox="0 0 {width} {height}" font-family="sans-serif" font-size="12">',
        f'<rect width="{width}" height="{height}" fill="white"/>',
    ]
    if title:
        out.append(f'<text x="6" y="14" fill="#333">{html.escape(title)}</text>')
    for k, m in enumerate(modes):
        color = COLORS[k % len(COLORS)]
        out.append(f'<g id="mode-{k + 1}">')
        out.append(
            f'<text x="{k * panel_px + 8}" y="32" fill="{color}" font-weight="bold">mode {k + 1}: '
            f'{m["freq_hz"]:.4g} Hz{m["damped"]}, mostly {m["axis"]} ({AXIS_WORDS[m["axis"]]})</text>'
        )
        for i in range(len(g.legs)):  # the robot at rest, grey
            out.append(
                f'<polyline points="{_pts(screen(np.vstack([g.base[i], g.elbow[i], g.attachment[i]]), k))}" '
                'fill="none" stroke="#bbb" stroke-width="2"/>'
            )
        out.append(
            f'<polyline points="{_pts(screen(_outline(g.attachment, g.pose), k))}" fill="none" '
            'stroke="#bbb" stroke-width="1.5"/>'
        )
        for b in screen(g.base, k):
            out.append(f'<rect x="{b[0] - 3:.1f}" y="{b[1] - 3:.1f}" width="6" height="6" fill="#333"/>')
        frames = [g.attachment + s * m["displacement"] for s in PHASES]
        keys = ";".join(_pts(screen(_outline(f, g.pose), k)) for f in frames)
        anim = (
            f'dur="{PERIOD_S:g}s" repeatCount="indefinite" calcMode="spline" '
            'keySplines="0.4 0 0.6 1;0.4 0 0.6 1;0.4 0 0.6 1;0.4 0 0.6 1"'
        )
        out.append(
            f'<polyline class="moving" points="{_pts(screen(_outline(frames[0], g.pose), k))}" '
            f'fill="{color}" fill-opacity="0.25" stroke="{color}" stroke-width="2.5">'
            f'<animate attributeName="points" values="{keys}" {anim}/></polyline>'
        )
        for i in range(len(g.legs)):  # the links to the platform follow it
            keys = ";".join(_pts(screen(np.vstack([anchor[i], f[i]]), k)) for f in frames)
            out.append(
                f'<polyline points="{_pts(screen(np.vstack([anchor[i], frames[0][i]]), k))}" fill="none" '
                f'stroke="{color}" stroke-width="1.5"><animate attributeName="points" values="{keys}" '
                f'{anim}/></polyline>'
            )
        out.append("</g>")
    out.append("</svg>")
    return "\n".join(out)


def modes_gif(
    ev,
    pose,
    path,
    model="paper",
    k_a: float = 2000.0,
    n_modes: int = 3,
    amplitude: float = 0.2,
    frames: int = 24,
    fps: int = 15,
    title: str | None = None,
    **params,
) -> None:
    """Write the lowest mode shapes as an animated GIF to ``path`` (Matplotlib's
    ``FuncAnimation`` with the Pillow writer): one 3D panel per mode, ``frames`` per period."""
    from matplotlib.animation import FuncAnimation, PillowWriter

    from ..matplotlib_agg import pyplot

    plt = pyplot()
    g, modes = mode_frames(ev, pose, model, k_a, n_modes, amplitude, **params)
    anchor = _anchor(ev, g)
    n = len(modes)
    fig = plt.figure(figsize=(3.6 * n, 3.8))
    pts = np.vstack(
        [g.base, g.elbow, g.attachment] + [g.attachment + s * m["displacement"] for m in modes for s in (-1, 1)]
    )
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    span, mid = max(float(np.max(hi - lo)), 1e-3) * 0.55, (lo + hi) / 2
    artists = []
    for k, m in enumerate(modes):
        ax = fig.add_subplot(1, n, k + 1, projection="3d")
        for i in range(len(g.legs)):
            ax.plot(*np.vstack([g.base[i], g.elbow[i], g.attachment[i]]).T, "-", color="0.75", lw=2)
        ax.plot(*_outline(g.attachment, g.pose).T, "-", color="0.75", lw=1.5)
        color = COLORS[k % len(COLORS)]
        (plat,) = ax.plot(*_outline(g.attachment, g.pose).T, "-", color=color, lw=2.5)
        links = [
            ax.plot(*np.vstack([anchor[i], g.attachment[i]]).T, "-", color=color, lw=1.5)[0] for i in range(len(g.legs))
        ]
        artists.append((plat, links, m["displacement"]))
        for setter, c in zip((ax.set_xlim, ax.set_ylim, ax.set_zlim), range(3)):
            setter(mid[c] - span, mid[c] + span)
        ax.set_box_aspect((1, 1, 1))
        ax.view_init(elev=18, azim=-60)
        ax.set_axis_off()
        ax.set_title(f"mode {k + 1}: {m['freq_hz']:.4g} Hz{m['damped']}\nmostly {m['axis']}", fontsize=10, color=color)
    if title:
        fig.suptitle(title, fontsize=9)

    def update(t):
        s = np.sin(2 * np.pi * t / frames)
        changed = []
        for plat, links, d in artists:
            moved = g.attachment + s * d
            out = _outline(moved, g.pose)
            plat.set_data_3d(out[:, 0], out[:, 1], out[:, 2])
            for i, line in enumerate(links):
                seg = np.vstack([anchor[i], moved[i]])
                line.set_data_3d(seg[:, 0], seg[:, 1], seg[:, 2])
            changed += [plat, *links]
        return changed

    anim = FuncAnimation(fig, update, frames=frames, interval=1000 / fps, blit=False)
    with atomic_path(path) as tmp:
        anim.save(str(tmp), writer=PillowWriter(fps=fps), dpi=80)
    plt.close(fig)
