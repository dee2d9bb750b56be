# ---
# jupyter:
#   jupytext:
#     formats: ipynb,py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#       format_version: '1.3'
#       jupytext_version: 1.19.6
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # 04 · The design space: lowest natural frequency over the workspace and the design
#
# The lowest natural frequency $\omega_1$ limits how fast a parallel manipulator can move and be controlled
# (Hoevenaars, Krut & Herder 2020, DOI 10.1016/j.mechmachtheory.2019.103775). Because eigentwist's
# evaluators are generated closed forms with every design quantity as an input, mapping $\omega_1$ over
# the workspace and over design parameters is a matter of large batched calls — here about 0.7 million
# pose-and-design rows in total, on the C backend where a compiler exists (NumPy otherwise: `backend="auto"`).
#
# Model: the Heli4 with the **coupled** end-effector model (preset `coupled`: actuator loss, rod compliance
# and the traveling plates joined to the tool by compliant couplings), because it holds at every
# pose; the paper's split of the end-effector compliance (Eqs. 45–49) is derived for $x_\mathrm{ref}$ only
# (notebook 02 compares the two: their $\omega_1$ differ by at most 0.1 Hz at $k_a$ = 2000 N m/rad).
# Frequencies in Hz, lengths in m, actuator stiffness $k_a$ in N m/rad.

# %%
import time

import numpy as np
import matplotlib.pyplot as plt

import eigentwist

t_start = time.perf_counter()
MODEL = "coupled"
ev = eigentwist.load("heli4")                   # C where a compiler exists, NumPy otherwise
box = np.array(ev.robot.workspace)                      # (3, 2): [lo, hi] per axis, m
x_ref = np.array(ev.robot.x_ref)
print("workspace box [m]:", box.tolist(), "  reference pose [m]:", x_ref.tolist())


def grid(box, n):
    """A regular grid over a box: (n_x * n_y * n_z, 3) poses, x slowest."""
    n = np.broadcast_to(n, (3,))
    axes = [np.linspace(lo, hi, k) for (lo, hi), k in zip(box, n)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3), axes


def timed(label, fn, rows):
    t0 = time.perf_counter()
    out = fn()
    dt = time.perf_counter() - t0
    print(f"{label}: {rows:,} rows in {dt:.2f} s ({rows / dt:,.0f} rows/s)")
    return out


# %% [markdown]
# ## 1 · ω1 over the workspace
#
# Top row: three horizontal slices of the workspace box (bottom, reference height, top), 121 × 121 poses
# each, $k_a$ = 2000 N m/rad, each with its own colour scale. Bottom row: two vertical slices through
# $x_\mathrm{ref}$ and, for comparison, the second frequency $\omega_2$ at the reference height.

# %%
n = 121
zs = (box[2, 0], x_ref[2], box[2, 1])
xy, (gx, gy, _) = grid([box[0], box[1], (0, 0)], (n, n, 1))
xz, (hx, _, hz) = grid([box[0], (0, 0), box[2]], (n, 1, n))
yz, (_, vy, vz) = grid([(0, 0), box[1], box[2]], (1, n, n))
poses = np.concatenate([xy + [0, 0, z] for z in zs] + [xz, yz])
modes = timed("slices", lambda: ev.modes(poses, MODEL), len(poses))
f_slices = modes.freq_hz[:, :2].reshape(5, n, n, 2)
along_x = np.mean(modes.direction[:, 0] == 3)
print(f"the lowest mode moves mainly along X at {100 * along_x:.1f} % of these poses (largest share of its energy)")


def panel(ax, X, Y, Z, title, xlabel, ylabel):
    im = ax.pcolormesh(X, Y, Z, cmap="viridis", shading="auto")
    cs = ax.contour(X, Y, Z, levels=8, colors="white", linewidths=0.6)
    ax.clabel(cs, fontsize=7, fmt="%.1f")
    ax.set_title(title, fontsize=10)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_aspect("equal")
    fig.colorbar(im, ax=ax, shrink=0.8)


fig, axes = plt.subplots(2, 3, figsize=(15, 9))
GX, GY = np.meshgrid(gx, gy, indexing="ij")
for c, z in enumerate(zs):
    panel(axes[0, c], GX, GY, f_slices[c, ..., 0], f"ω1 [Hz], horizontal slice z = {z:.3f} m", "x [m]", "y [m]")
axes[0, 1].plot(*x_ref[:2], "r+", ms=12)
HX, HZ = np.meshgrid(hx, hz, indexing="ij")
panel(axes[1, 0], HX, HZ, f_slices[3, ..., 0], "ω1 [Hz], vertical slice y = 0", "x [m]", "z [m]")
VY, VZ = np.meshgrid(vy, vz, indexing="ij")
panel(axes[1, 1], VY, VZ, f_slices[4, ..., 0], "ω1 [Hz], vertical slice x = 0", "y [m]", "z [m]")
panel(axes[1, 2], GX, GY, f_slices[1, ..., 1], f"ω2 [Hz], horizontal slice z = {zs[1]:.3f} m", "x [m]", "y [m]")
plt.tight_layout()
plt.show()

# %% [markdown]
# ## 2 · The worst case over the box
#
# A designer cares about the lowest $\omega_1$ anywhere in the workspace. Over a 41 × 41 × 41 grid of the box:

# %%
P, axes3 = grid(box, 41)
f = timed("box", lambda: ev.frequencies(P, MODEL), len(P))
w1_box = f[:, 0].reshape(41, 41, 41)
worst = np.argmin(f[:, 0])
print(f"omega_1 over the box: {f[:, 0].min():.2f} ... {f[:, 0].max():.2f} Hz; "
      f"at x_ref {ev.frequencies(x_ref, MODEL)[0, 0]:.2f} Hz")
print(f"worst case {f[worst, 0]:.2f} Hz at {np.round(P[worst], 3).tolist()} m")

fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
axes[0].hist(f[:, 0], bins=60, color="tab:blue")
axes[0].set_xlabel("ω1 [Hz]")
axes[0].set_ylabel("poses")
axes[0].set_title("ω1 over the box (41³ poses)")
axes[1].plot(axes3[2], w1_box.min(axis=(0, 1)), label="lowest over x, y")
axes[1].plot(axes3[2], w1_box.max(axis=(0, 1)), label="highest over x, y")
axes[1].plot(axes3[2], w1_box[20, 20], "--", label="x = y = 0")
axes[1].set_xlabel("z [m]")
axes[1].set_ylabel("ω1 [Hz]")
axes[1].set_title("ω1 against height")
axes[1].legend(fontsize=8)
axes[1].grid(alpha=0.3)
plt.tight_layout()
plt.show()

# %% [markdown]
# $\omega_1$ is lowest at the bottom of the workspace and highest at the top; across a horizontal slice it
# varies by less than 0.5 Hz.
#
# ## 3 · ω1 against the design
#
# Each design below is judged by its **worst-case** $\omega_1$ over a 7 × 7 × 7 grid of the box (343 poses,
# corners and faces included; on the Heli4 design it finds the same minimum as the 41³ grid above). Every
# row of a batch is one (design, pose) pair, so a 25 × 25 design map is one call of 214,375 rows. The
# parallelogram length $l_2$ is varied over the range where the whole box stays reachable
# (0.47–0.60 m).

# %%
coarse, _ = grid(box, 7)
check = ev.frequencies(coarse, MODEL)[:, 0].min()
print(f"worst case on the 7^3 grid: {check:.2f} Hz (41^3 grid: {f[:, 0].min():.2f} Hz)")


def worst_case(ev, poses, model, **design):
    """Lowest omega_1 over ``poses`` for every design: ``design`` maps names to equal-shape arrays."""
    shape = np.shape(next(iter(design.values())))
    n_d, n_p = int(np.prod(shape)), len(poses)
    rows = {k: np.repeat(np.ravel(v), n_p) for k, v in design.items()}
    f = timed(f"{' x '.join(design)} map", lambda: ev.frequencies(np.tile(poses, (n_d, 1)), model, **rows), n_d * n_p)
    return f[:, 0].reshape(n_d, n_p).min(axis=1).reshape(shape)


l2 = np.linspace(0.47, 0.60, 25)
k_a = np.linspace(500.0, 4000.0, 25)
r_o = np.linspace(0.0038, 0.0070, 25)
L2a, KA = np.meshgrid(l2, k_a, indexing="ij")
L2b, RO = np.meshgrid(l2, r_o, indexing="ij")
map_ka = worst_case(ev, coarse, MODEL, l2=L2a, k_a=KA)
map_ro = worst_case(ev, coarse, MODEL, l2=L2b, r_o=RO)

# %%
d = ev.defaults
fig, axes = plt.subplots(1, 2, figsize=(13, 5))
for ax, X, Y, Z, ylabel, y0 in ((axes[0], L2a, KA, map_ka, "k_a [N m/rad]", d["k_a"]),
                                (axes[1], L2b, RO * 1e3, map_ro, "rod outer radius r_o [mm]", d["r_o"] * 1e3)):
    cf = ax.contourf(X, Y, Z, levels=20, cmap="viridis")
    cs = ax.contour(X, Y, Z, levels=10, colors="white", linewidths=0.6)
    ax.clabel(cs, fontsize=7, fmt="%.1f")
    ax.plot(d["l2"], y0, "r*", ms=14, label="Heli4")
    ax.set_xlabel("parallelogram length l2 [m]")
    ax.set_ylabel(ylabel)
    ax.legend(loc="upper left")
    fig.colorbar(cf, ax=ax, label="worst-case ω1 over the box [Hz]")
axes[0].set_title("worst-case ω1: l2 × k_a (r_o = 5 mm)")
axes[1].set_title("worst-case ω1: l2 × r_o (k_a = 2000 N m/rad)")
plt.tight_layout()
plt.show()
i, j = np.unravel_index(np.argmax(map_ro), map_ro.shape)
print(f"Heli4 design: worst-case omega_1 {check:.2f} Hz")
print(f"best on the l2 x r_o map: {map_ro[i, j]:.2f} Hz at l2 = {l2[i]:.3f} m, r_o = {r_o[j] * 1e3:.2f} mm")

# %% [markdown]
# Within this range $k_a$ is the strongest lever (the frequency grows like $\sqrt{k_a}$ until the
# end-effector assembly's compliance takes over, notebook 02); thinner rods help because their mass counts
# more than their compliance (notebook 01); $l_2$ matters little near the Heli4's design and more at high
# $k_a$, where shorter parallelograms are better. The same maps can be computed for the rigid-body
# model (`"rigid"`) or with any effect switched on, at no extra generation cost.
#
# ## 4 · The same for a Delta robot
#
# The Delta robot shipped with eigentwist (three RR(Π)RR legs at 120°, `eigentwist.robots.get("delta")`,
# model `paper` = actuator loss + rod compliance) is evaluated by the same runtime: its $\omega_1$ at the
# reference height and its worst case over its box against $l_2$ and $k_a$.

# %%
delta = eigentwist.load("delta")
dbox = np.array(delta.robot.workspace)
dxy, (dgx, dgy, _) = grid([dbox[0], dbox[1], (0, 0)], (101, 101, 1))
dposes = dxy + [0, 0, delta.robot.x_ref[2]]
dw1 = timed("delta slice", lambda: delta.frequencies(dposes, "paper"), len(dposes))[:, 0].reshape(101, 101)
dcoarse, _ = grid(dbox, 7)
dl2 = np.linspace(0.76, 0.90, 21)
dka = np.linspace(500.0, 4000.0, 21)
DL2, DKA = np.meshgrid(dl2, dka, indexing="ij")
dmap = worst_case(delta, dcoarse, "paper", l2=DL2, k_a=DKA)

fig, axes = plt.subplots(1, 2, figsize=(13, 5))
im = axes[0].imshow(dw1.T, origin="lower", extent=[*dbox[0], *dbox[1]], cmap="viridis")
cs = axes[0].contour(dgx, dgy, dw1.T, levels=8, colors="white", linewidths=0.6)
axes[0].clabel(cs, fontsize=7, fmt="%.1f")
axes[0].set_title(f"Delta: ω1 [Hz] at z = {delta.robot.x_ref[2]:.2f} m")
axes[0].set_xlabel("x [m]")
axes[0].set_ylabel("y [m]")
fig.colorbar(im, ax=axes[0])
cf = axes[1].contourf(DL2, DKA, dmap, levels=20, cmap="viridis")
cs = axes[1].contour(DL2, DKA, dmap, levels=10, colors="white", linewidths=0.6)
axes[1].clabel(cs, fontsize=7, fmt="%.1f")
axes[1].plot(delta.defaults["l2"], delta.defaults["k_a"], "r*", ms=14, label="shipped design")
axes[1].set_xlabel("forearm length l2 [m]")
axes[1].set_ylabel("k_a [N m/rad]")
axes[1].set_title("Delta: worst-case ω1 over its box [Hz]")
axes[1].legend(loc="upper left")
fig.colorbar(cf, ax=axes[1])
plt.tight_layout()
plt.show()

# %%
print(f"notebook ran in {time.perf_counter() - t_start:.1f} s")
