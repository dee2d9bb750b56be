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
# # 01 · The closed-form model, opened up
#
# eigentwist derives the natural-frequency model of a parallel manipulator symbolically, with every
# design quantity kept as a symbol, following Hoevenaars, Krut & Herder (2020), *Jacobian-based natural
# frequency analysis of parallel manipulators*, DOI 10.1016/j.mechmachtheory.2019.103775. This notebook
# opens the Heli4 model and shows what is inside:
#
# 1. one leg's unit twists and reciprocal wrenches (Appendix A) and a row of its inverse Jacobian;
# 2. entries of the inertia matrix **M** (Eq. 12), the rigid-body stiffness **K_R** (Eq. 14) and the
#    flexible-body stiffness **K_F** (Eq. 13) as formulas;
# 3. which design parameters each entry depends on;
# 4. how large the expressions are before and after common-subexpression elimination (CSE);
# 5. a design change: first a parameter *value* (no regeneration), then a *structural* change that is
#    derived, generated and loaded in memory in a few seconds.
#
# Conventions (all in SI units): twists are $[\omega;\,v]$, wrenches $[m;\,f]$, everything is expressed at the
# end-effector (EE) origin with base-frame axes; coordinates are ordered $(R_x, R_y, R_z, X, Y, Z)$.
# The reference pose is $x_\mathrm{ref} = [0, 0, -0.625]$ m.

# %%
import re
import time
import dataclasses

import numpy as np
import sympy as sp
import matplotlib.pyplot as plt
from IPython.display import HTML, Math, display

import eigentwist
import eigentwist.robots
from eigentwist.symbolic import derive
from eigentwist.codegen import kernels_for
from eigentwist.runtime import evaluator_from_description

t_start = time.perf_counter()
heli4 = eigentwist.robots.get("heli4")
ev = eigentwist.load("heli4", backend="numpy")          # the generated (checked-in) evaluator
x_ref = np.array([heli4.x_ref])                          # m, shape (1, 3)

t0 = time.perf_counter()
model = derive(heli4)                                    # SymPy derivation, nothing generated
prog = model.program
print(f"derived in {time.perf_counter() - t0:.1f} s: {len(prog.assignments)} named intermediates, "
      f"{len(model.joints)} joint angles, {len(heli4.parameters)} design parameters")

# %% [markdown]
# The derivation is a *straight-line program*: named intermediates (joint axes, unit twists, reciprocal
# wrenches, inverse-Jacobian rows, ...) assigned one after the other. `prog.expand(expr)` substitutes all of
# them and returns the closed form in the joint angles $q_{ij}$ (leg $i$, joint $j$) and the design
# parameters. A small helper renders symbols the way the paper writes them.

# %%
VECTORS = {"r1": r"\hat r_{%s1}", "r2": r"\hat r_{%s2}", "sp": r"\hat s_{%s3}", "s4": r"\hat s_{%s4}",
           "f2": r"f_{%s2}", "f5": r"f_{%s5}", "ch": r"\hat c_{%s1}", "pE": r"p_{E%s}", "pB": r"p_{B%s}"}
PARAMS = {"l1": "l_1", "l2": "l_2", "k_a": "k_a", "eta_a": r"\eta_a", "E_rod": "E", "G_rod": "G",
          "k_E_rot": r"k_{E,\mathrm{rot}}", "k_E_lin": r"k_{E,\mathrm{lin}}", "I1_yy": r"I_{1,yy}",
          "I_rotor": r"I_\mathrm{rotor}", "m_e": "m_e", "rho": r"\rho", "w_pi": r"w_\Pi",
          "I_e_xx": r"I_{e,xx}", "I_e_yy": r"I_{e,yy}", "I_e_zz": r"I_{e,zz}", "k_act": r"k_\mathrm{act}",
          "k_t": "k_t"}
AXES = ("R_x", "R_y", "R_z", "X", "Y", "Z")


def tex_name(s):
    n = s.name
    if m := re.fullmatch(r"q(\d)_(\d)", n):
        return f"q_{{{m[2]}{m[1]}}}"
    if m := re.fullmatch(r"j(\d)_(\d)_0_(\d)", n):       # entry of an inverse-Jacobian row
        return f"j_{{{m[2]}{m[1]}}}^{{{AXES[int(m[3])]}}}"
    if m := re.fullmatch(r"(\w+?)_(\d)_(\d)", n):
        if m[1] in VECTORS:
            return VECTORS[m[1]] % m[2] + "^{" + "xyz"[int(m[3])] + "}"
    if m := re.fullmatch(r"c3_(\d)", n):
        return rf"\cos q_{{{m[1]}3}}"
    if m := re.fullmatch(r"s3_(\d)", n):
        return rf"\sin q_{{{m[1]}3}}"
    if n.startswith("on_"):
        return r"\mathrm{on}_\mathrm{" + n[3:].replace("_", r"\_") + "}"
    return PARAMS.get(n, sp.latex(s))


def tex(expr, **kw):
    expr = sp.sympify(expr)
    return sp.latex(expr, symbol_names={s: tex_name(s) for s in expr.free_symbols}, **kw)


def show(lhs, expr, **kw):
    display(Math(lhs + " = " + tex(expr, **kw)))


# %% [markdown]
# ## 1 · One leg: unit twists, reciprocal wrenches, an inverse-Jacobian row
#
# Leg 1 of the Heli4 is an RR(Π)RR chain: the actuated joint ($q_{11}$), the elbow ($q_{12}$), the
# parallelogram Π (a curvilinear translation; its tilt is $q_{13}$), the twist of the rods about each other
# and the joint at the platform. Its five unit twists of permission $\hat t_{a1}\ldots\hat t_{a5}$
# (Appendix A, with the corrections of the facts file), in closed form — $d$, $r$ locate the attachment
# $a_1 = [r, 0, d]$ on the lower traveling plate:

# %%
leg = model.screws[0]                                    # leg 1
T = sp.Matrix.hstack(*[leg.twists[k] for k in (1, 2, 3, 4, 5)])
show(r"\left[\hat t_{a1}\;\hat t_{a2}\;\hat t_{a3}\;\hat t_{a4}\;\hat t_{a5}\right]", prog.expand(T))
show(r"\hat s_{14}", prog.expand(model.screws[0].vectors["s4"]))
c_hat = leg.twists["c"][:3, :]
show(r"\hat t_{c}", sp.Matrix.vstack(c_hat, leg.vectors["a"].cross(c_hat)))

# %% [markdown]
# The twist of restriction $\hat t_c$ is a rotation about $\hat c_{11}$ through $a_1$. The reciprocal
# wrenches $\hat w_{a1}\ldots\hat w_{a5}$ and the wrench of constraint $\hat w_c$ (Appendix A) are not
# written by hand: each is the generalised cross product of the other five unit twists, from their 5x5
# minors (named intermediates `mn_...`; Huang's method for any joint list), so the leg's named vectors
# ($\hat r_{12}$: parallelogram centre line, $\hat s_{14}$, ...) enter through the twists only:

# %%
W = sp.Matrix.hstack(*[leg.wrenches[k] for k in (1, 2, 3, 4, 5, "c")])
show(r"\left[\hat w_{a1}\;\hat w_{a2}\;\hat w_{a3}\;\hat w_{a4}\;\hat w_{a5}\;\hat w_{c}\right]", W)
show(r"\hat r_{12}", prog.expand(leg.vectors["r2"]))


# %% [markdown]
# Each wrench is reciprocal to every twist of the leg except its own (Huang's method): the matrix of
# reciprocal products $\hat w_j \cdot \hat t_k$ is diagonal, at $x_\mathrm{ref}$ and at any other pose.
# `prog.evaluate` evaluates the program exactly (SymPy arithmetic, 30 digits), independently of the
# generated code:

# %%
def symbol_values(poses, **params):
    """Joint angles (from the generated IK), parameter defaults and all switches on, by symbol name."""
    q = ev.joint_angles(poses, **params)[0].reshape(-1)
    values = {**ev.defaults, **params, **{s.name: v for s, v in zip(model.joints, q)}}
    values |= {copy: values[name] for copy, name in model.leg_copies.items() if name in values}  # each leg's copy
    return {**values, **{sw: 1.0 for sw in model.switches}}


T6 = sp.Matrix.hstack(T, leg.twists["c"])
for pose in ([0.0, 0.0, -0.625], [0.06, -0.04, -0.58]):
    recip = np.array(prog.evaluate(symbol_values(np.array([pose])), W.T * T6, precision=30).tolist(), dtype=float)
    off = np.abs(recip - np.diag(np.diag(recip))).max()
    print(f"pose {pose} m: diagonal w.t = {np.round(np.diag(recip), 4)}, largest off-diagonal {off:.1e}")

# %% [markdown]
# So the rows of the leg's inverse Jacobian $J_1^{-1}$ (the missing Eq. 15) are $\hat w_j^T / (\hat w_j
# \cdot \hat t_j)$. The actuated row $j_{11}$, which maps an EE twist to the actuated joint rate, simplifies
# to a compact closed form (the expanded row's fractions cancelled, its trigonometry simplified and
# its common factors pulled out: `cancel`, `trigsimp`, `factor_terms`, the same forms as a full
# `sympy.simplify` here in a third of the time):

# %%
row = prog.expand(leg.rows[1])
def compact(expr):
    """A closed form of ``expr``: fractions cancelled, trigonometry simplified, common factors out."""
    return sp.factor_terms(sp.trigsimp(sp.cancel(expr)))


row_simple = row.applyfunc(compact)
show(r"j_{11} = \frac{\hat w_{a1}^T}{\hat w_{a1}\cdot\hat t_{a1}}", row_simple)

# check against the generated evaluator (rows of joints 1, 2, 3 and the constraint, per leg)
q = ev.joint_angles(x_ref)[0]
subs = {s: v for s, v in zip(model.joints, q.reshape(-1))} | {p.symbol: p.default for p in heli4.parameters}
print("closed form at x_ref :", np.array(row_simple.xreplace(subs).evalf(), dtype=float).round(5))
print("generated evaluator  :", ev.jacobians(x_ref)["J_rows"][0, 0, 0].round(5))

# %% [markdown]
# At $x_\mathrm{ref}$ the parallelogram does not tilt ($q_{13} = 0$), so the row has no $R_x$, $R_z$ or $Y$
# component: actuator 1 sees only $X$, $Z$ and rotations about $Y$.
#
# ## 2 · Entries of M, K_R and K_F as formulas
#
# **K_R (Eq. 14)** is $\sum_i k_\mathrm{act}\, j_{i1}^T j_{i1}$: each leg contributes the outer product of its
# actuated row, weighted by the delivered actuator stiffness. In the program it is literally that sum; with
# each leg's row simplified as above, the translational diagonal reads:

# %%
K_R = sp.Matrix(6, 6, model.outputs["matrices"]["K_R"][1])
show(r"K_R(Z,Z)", K_R[5, 5])                            # as the program holds it

simple = {}
for i, ls in enumerate(model.screws):
    r = prog.expand(ls.rows[1])
    for k in (3, 4, 5):                                  # X, Y, Z entries of each actuated row
        simple[ls.rows[1][k]] = compact(r[k])
k_act = sp.Symbol("k_act", real=True)
same = {sp.Symbol(f"k_act_{i + 1}", real=True): k_act for i in range(len(model.screws))}  # legs alike here
shared = {sp.Symbol(c, real=True): sp.Symbol(n, real=True) for c, n in model.leg_copies.items()}
for k, axis in zip((3, 4, 5), "XYZ"):
    show(rf"K_R({axis},{axis})", sp.factor_terms(K_R[k, k].xreplace(simple).xreplace(same)))
show(r"k_\mathrm{act}", prog.expand(sp.Symbol("k_act_1", real=True)).xreplace(shared))

# %% [markdown]
# $k_\mathrm{act}$ carries the effect switches ($\mathrm{on}_\bullet \in \{0, 1\}$): one generated evaluator
# serves every combination of effects. Each leg has its own switches and values of its leg-level effects
# (`actuator_loss@3`, `eta_a@3`); the legs are alike here, so they are shown once. With the paper's model it is $\eta_a k_a$ (Eq. 34, $\eta_a = 0.82$).
#
# **M (Eq. 12)** is a sum over the bodies of every leg of $J_i^{-T} J_{ij}^T M_{ij} J_{ij} J_i^{-1}$ plus the EE
# inertia. Its closed form is large in general, but at a fixed pose it is *linear* in the inertial
# parameters. Substituting the joint angles and the geometry at $x_\mathrm{ref}$ and keeping the inertias
# symbolic (kg, kg m², kg/m³) shows where the moving mass comes from:

# %%
S = lambda name: sp.Symbol(name, real=True)  # noqa: E731
paper_switches = {S(sw): (1 if sw in ("on_actuator_loss", "on_rod_compliance", "on_ee_compliance") else 0)
                  for sw in {model.leg_copies.get(sw, sw) for sw in model.switches}}
q_ref = {s: sp.Float(v) for s, v in zip(model.joints, ev.joint_angles(x_ref)[0].reshape(-1))}


_env_at_x_ref = {}


def at_x_ref(expr, keep):
    """``expr`` (in the program's symbols) at x_ref with every parameter except ``keep`` at its
    default (paper model): the numbers go into the program statement by statement, so only the
    ``keep`` symbols are left and nothing else is expanded."""
    if keep not in _env_at_x_ref:
        env = {**q_ref, **paper_switches, **{S(n): sp.Float(v) for n, v in ev.defaults.items() if n not in keep},
               S("c_rigid"): sp.Integer(0)}   # the paper model has no rigid direction: exact, no penalty (README)
        env |= {copy: env.get(name, name) for copy, name in shared.items()}     # each leg's copy
        for sym, rhs in prog.assignments:
            env[sym] = rhs.xreplace(env)
        _env_at_x_ref[keep] = env
    return sp.sympify(expr).xreplace(_env_at_x_ref[keep])


M = sp.Matrix(6, 6, model.outputs["matrices"]["M"][1])
inertial = ("m_e", "I_e_xx", "I_e_yy", "I_e_zz", "I1_yy", "I_rotor", "rho")
for k, axis in enumerate(("R_x", "R_y", "R_z", "X", "Y", "Z")):
    show(rf"M({axis},{axis})\big|_{{x_\mathrm{{ref}}}}", sp.expand(at_x_ref(M[k, k], inertial)).n(4))

# %% [markdown]
# The translational inertia is the EE mass $m_e$ plus the actuator-side rotary inertia $I_{1,yy} +
# I_\mathrm{rotor}$ reflected through the legs (78.6 m⁻² along $Z$: about 0.67 kg of the 1.56 kg) plus the
# parallelogram rods (through $\rho$). The lower link's mass and centre of gravity do not appear: body 1
# only rotates about its own axis, so only its inertia about that axis counts (facts file).
#
# **K_F (Eq. 13)** adds the structural compliances of the legs in series with the actuators (Eqs. 37–50):
# rods (App. C), end-effector assembly (App. D, Eqs. 45–49). At $x_\mathrm{ref}$ the $X$ stiffness,
# written as a compliance in the three stiffnesses that matter, is exactly three springs in series
# (m/N, with $k_a$ in N m/rad, $k_{E,\mathrm{rot}}$ in N m/rad, $E$ in Pa):

# %%
K_F = sp.Matrix(6, 6, model.outputs["matrices"]["K_F"][1])
keep = ("k_a", "k_E_rot", "E_rod")
kf_xx = at_x_ref(K_F[3, 3], keep)
# springs in series: 1/K_F(X,X) is a/k_a + b/k_E,rot + c/E, so the coefficient of 1/k is -k^2 d(1/K)/dk
# (floating-point coefficients keep SymPy's cancel from finding that form by itself)
d = ev.defaults
at_defaults = {S(n): d[n] for n in keep}
coefficient = {n: float((-S(n) ** 2 * sp.diff(1 / kf_xx, S(n))).xreplace(at_defaults)) for n in keep}
compliance = sum(sp.Float(c) / S(n) for n, c in coefficient.items())
elsewhere = {S(n): 3.7 * d[n] for n in keep}             # the same three terms at other stiffnesses
assert abs(float(compliance.xreplace(elsewhere) * kf_xx.xreplace(elsewhere)) - 1) < 1e-9
show(r"\frac{1}{K_F(X,X)}\Big|_{x_\mathrm{ref}}", compliance.n(4))

terms = {n: c / d[n] for n, c in coefficient.items()}
for name, c in terms.items():
    print(f"  {name:8s} {c:.3e} m/N  ({100 * c / sum(terms.values()):.1f} % of the X compliance)")
kf_generated = ev.matrices(x_ref, "paper")["K_F"][0, 3, 3]
print(f"K_F(X,X) = {1 / sum(terms.values()):.2f} N/m; generated evaluator: {kf_generated:.2f} N/m "
      "(paper, Eq. 58: 16170)")
assert abs(1 / sum(terms.values()) / kf_generated - 1) < 1e-9     # the closed form is the evaluator's


# %% [markdown]
# The actuators and the EE assembly dominate; the rods add about 0.1 % — which is what Appendix E concludes
# from its ablation (notebook 02).
#
# ## 3 · Which design parameters each entry depends on
#
# The matrices are written in joint angles and design parameters; the joint angles come from the
# closed-form inverse kinematics, which brings in the geometry ($R$, $l_1$, $l_2$, $r$, $d$, $h$). The map
# below marks, for each upper-triangle entry of **M**, **K_R** and **K_F**, the parameters that appear in its
# closed form (dark) and those that act only through the joint angles (light). Collecting the free
# symbols walks the program once (no expansion needed).

# %%
def input_dependencies(program):
    """For every intermediate of ``program``: the set of input symbols its closed form contains."""
    deps = {}
    for s, rhs in program.assignments:
        deps[s] = frozenset().union(*[deps.get(f, {f}) for f in rhs.free_symbols])
    return deps


deps, ik_deps = input_dependencies(prog), input_dependencies(model.ik)
q_deps = {q: frozenset().union(*[ik_deps.get(f, {f}) for f in sp.sympify(e).free_symbols])
          for q, e in zip(model.joints, model.ik_outputs["q"][1])}
names = [p.name for p in heli4.parameters] + sorted({model.leg_copies.get(sw, sw) for sw in model.switches})
index = {n: k for k, n in enumerate(names)}
index |= {copy: index[name] for copy, name in model.leg_copies.items()}    # each leg's copy counts as the input
columns, dep = [], []
for mat in ("M", "K_R", "K_F"):
    flat = model.outputs["matrices"][mat][1]
    for i in range(6):
        for j in range(i, 6):
            direct = frozenset().union(*[deps.get(f, {f}) for f in sp.sympify(flat[6 * i + j]).free_symbols])
            via_q = frozenset().union(*[q_deps[s] for s in direct if s in q_deps])
            col = np.zeros(len(names))
            col[[index[s.name] for s in via_q if s.name in index]] = 1
            col[[index[s.name] for s in direct if s.name in index]] = 2
            columns.append(f"{mat}({i + 1},{j + 1})")
            dep.append(col)
dep = np.array(dep).T

fig, ax = plt.subplots(figsize=(13, 9))
ax.imshow(dep, cmap=plt.matplotlib.colors.ListedColormap(["white", "#9ecae1", "#08519c"]), aspect="auto",
          interpolation="nearest")
ax.set_yticks(range(len(names)), names, fontsize=7)
ax.set_xticks(range(len(columns)), columns, rotation=90, fontsize=6)
for x in (20.5, 41.5):
    ax.axvline(x, color="k", lw=1)
ax.set_title("dark: in the closed form of the entry   light: only through the joint angles (IK)")
plt.tight_layout()
plt.show()
unused = [n for n in names if not dep[index[n]].any()]
print("parameters and switches that no entry of M, K_R, K_F depends on:", ", ".join(unused))

# %% [markdown]
# A symbol can appear in a closed form and still have no influence. The elasticities
# $\partial \ln \omega_k / \partial \ln p$ of the six natural frequencies at $x_\mathrm{ref}$ (paper model,
# central differences of ±1 % on the generated evaluator, one batch of two rows per parameter) tell the designer what
# actually moves the frequencies — e.g. the shear modulus $G$ of the rods appears in $K_F$ but a leg
# loads only the axial and in-plane bending compliance of the rods, so its elasticity is zero:

# %%
varied = [p for p in heli4.parameters if p.default != 0 and p.effect in (None, "actuator_loss", "rod_compliance",
                                                                        "ee_compliance")]
rows = {p.name: np.full(2 * len(varied), p.default) for p in varied}
for k, p in enumerate(varied):
    rows[p.name][2 * k] *= 1.01
    rows[p.name][2 * k + 1] *= 0.99
f = ev.frequencies(np.repeat(x_ref, 2 * len(varied), axis=0), "paper", **rows)
elasticity = (np.log(f[0::2]) - np.log(f[1::2])) / (np.log(1.01) - np.log(0.99))

fig, ax = plt.subplots(figsize=(9, 8))
im = ax.imshow(elasticity, cmap="RdBu_r", vmin=-1, vmax=1, aspect="auto")
ax.set_yticks(range(len(varied)), [f"{p.name} [{p.unit}]" for p in varied], fontsize=8)
ax.set_xticks(range(6), [f"ω{k + 1}" for k in range(6)])
for (i, j), e in np.ndenumerate(elasticity):
    if abs(e) >= 0.005:
        ax.text(j, i, f"{e:.2f}", ha="center", va="center", fontsize=6)
fig.colorbar(im, label="∂ ln ω / ∂ ln p")
ax.set_title("elasticity of the natural frequencies at x_ref, k_a = 2000 N m/rad (paper model)")
plt.tight_layout()
plt.show()


# %% [markdown]
# $\omega_1$–$\omega_3$ grow with the actuator stiffness ($k_a$, $\eta_a$: elasticity about 0.4, below the
# 0.5 of a single spring because the EE assembly compliance is in series) and fall with the moving
# inertia ($m_e$, and the rods through $r_o$ and $\rho$); the constrained-direction modes
# $\omega_4$–$\omega_6$ are set by the rods ($r_o$, $r_i$, $w_\Pi$, $E$) and the EE rotational inertias.
#
# ## 4 · Expression sizes: closed form, program, CSE'd kernel
#
# Fully expanded, the closed forms are enormous — the same subexpressions (trigonometric functions of
# the joint angles, the legs' rows, the compliance matrices) occur again and again. The derivation keeps
# them named; `kernels_for` then runs SymPy's CSE over what each generated function needs. Operation
# counts are those of `sympy.count_ops`; for the expanded closed forms they are computed on the shared
# expression graph (`count_ops` itself would walk tens of millions of nodes), checked against
# `count_ops` on K_R below.

# %%
def tree_ops(expr, memo):
    """Operation count of the expanded tree, computed once per distinct subexpression."""
    if expr.is_Atom:
        return 0
    if expr in memo:
        return memo[expr]
    args = expr.args
    total = 0
    for a in args:
        if isinstance(expr, sp.Mul) and a.is_Pow and a.exp == -1:
            total += tree_ops(a.base, memo)               # x / y: one division, counted by the Mul
        elif isinstance(expr, sp.Add) and a.is_Mul and a.args[0] == -1:
            total += tree_ops(sp.Mul(*a.args[1:]), memo)  # a - b: one subtraction, counted by the Add
        else:
            total += tree_ops(a, memo)
    memo[expr] = total + (len(args) - 1 if isinstance(expr, (sp.Add, sp.Mul)) else 1)
    return memo[expr]


t0 = time.perf_counter()
closed = {}
for mat in ("M", "K_R", "K_F"):
    memo = {}
    closed[mat] = sum(tree_ops(e, memo) for e in prog.expand(sp.Matrix(model.outputs["matrices"][mat][1])))
kr = prog.expand(sp.Matrix(model.outputs["matrices"]["K_R"][1]))
print(f"check on K_R: count_ops {sum(sp.count_ops(e) for e in kr)}, graph count {closed['K_R']}")

kernels = {k.name: k for k in kernels_for(model)}               # CSE, as `eigentwist generate` does
kern = kernels["matrices"]
lets = [b for b in kern.body if b[0] == "let"]
outs = [b for b in kern.body if b[0] == "out"]
cse_ops = sum(sp.count_ops(b[2]) for b in lets) + sum(sp.count_ops(b[3]) for b in outs)
used, stack = set(), [s for mat in ("M", "K_R", "K_F") for e in model.outputs["matrices"][mat][1]
                      for s in sp.sympify(e).free_symbols]
defs = prog.definitions()
while stack:
    s = stack.pop()
    if s in defs and s not in used:
        used.add(s)
        stack.extend(defs[s].free_symbols)
prog_ops = sum(sp.count_ops(defs[s]) for s in used) + sum(
    sp.count_ops(e) for mat in ("M", "K_R", "K_F") for e in model.outputs["matrices"][mat][1])
print(f"sizes in {time.perf_counter() - t0:.1f} s")

table = [("closed form, fully expanded (M + K_R + K_F)", "—", sum(closed.values())),
         ("&nbsp;&nbsp;of which M", "—", closed["M"]), ("&nbsp;&nbsp;of which K_R", "—", closed["K_R"]),
         ("&nbsp;&nbsp;of which K_F", "—", closed["K_F"]),
         ("derivation program (named intermediates)", len(used) + 108, prog_ops),
         ("CSE'd kernel <code>matrices</code> (generated code)", len(lets) + len(outs), cse_ops)]
html = "<table><tr><th>form</th><th>statements</th><th>operations</th></tr>" + "".join(
    f"<tr><td>{a}</td><td style='text-align:right'>{b}</td><td style='text-align:right'>{c:,}</td></tr>"
    for a, b, c in table) + "</table>"
display(HTML(html))
print(f"CSE'd kernel vs expanded closed form: {sum(closed.values()) / cse_ops:,.0f}x fewer operations")

# %%
fig, ax = plt.subplots(figsize=(7, 3))
labels = ["expanded M", "expanded K_R", "expanded K_F", "program", "CSE'd kernel"]
values = [closed["M"], closed["K_R"], closed["K_F"], prog_ops, cse_ops]
ax.barh(labels, values, color=["#bbb", "#bbb", "#bbb", "#6baed6", "#08519c"])
ax.set_xscale("log")
ax.set_xlabel("operations (log scale)")
for y, v in enumerate(values):
    ax.text(v, y, f" {v:,}", va="center", fontsize=8)
ax.set_xlim(1e3, 1e9)
ax.invert_yaxis()
plt.tight_layout()
plt.show()
for name, k in kernels.items():
    n_let = sum(1 for b in k.body if b[0] == "let")
    print(f"kernel {name:18s} {n_let:5d} temporaries, {sum(1 for b in k.body if b[0] == 'out'):4d} outputs")

# %% [markdown]
# ## 5 · A design change
#
# ### 5a · A parameter value: no regeneration
#
# Every design quantity is a symbol in the generated code, so changing a value is a keyword argument — a
# scalar or one value per pose. Below, the lowest three natural frequencies at $x_\mathrm{ref}$ (paper
# model, $k_a$ = 2000 N m/rad) as the parallelogram length $l_2$ and the rods' outer radius $r_o$ vary
# (one batched call each):

# %%
l2 = np.linspace(0.48, 0.62, 57)
r_o = np.linspace(0.0037, 0.008, 87)
f_l2 = ev.frequencies(np.repeat(x_ref, len(l2), axis=0), "paper", l2=l2)
f_ro = ev.frequencies(np.repeat(x_ref, len(r_o), axis=0), "paper", r_o=r_o)

fig, axes = plt.subplots(1, 2, figsize=(11, 3.8), sharey=True)
for ax, x, f, name, unit, default in ((axes[0], l2, f_l2, "l2", "m", ev.defaults["l2"]),
                                      (axes[1], r_o * 1e3, f_ro, "r_o", "mm", ev.defaults["r_o"] * 1e3)):
    for k in range(3):
        ax.plot(x, f[:, k], label=f"ω{k + 1}")
    ax.axvline(default, color="grey", ls=":", label="Heli4")
    ax.set_xlabel(f"{name} [{unit}]")
    ax.grid(alpha=0.3)
axes[0].set_ylabel("natural frequency at x_ref [Hz]")
axes[0].legend()
plt.tight_layout()
plt.show()
print(f"r_o = {r_o[0] * 1e3:.1f} mm: omega_1..4 = {np.round(f_ro[0, :4], 1)} Hz; r_o = 5 mm: "
      f"{np.round(ev.frequencies(x_ref)[0, :4], 1)} Hz; r_o = {r_o[-1] * 1e3:.0f} mm: {np.round(f_ro[-1, :4], 1)} Hz")

# %% [markdown]
# Over this range the lowest three frequencies fall as the rods get thicker: the rods' mass (through
# $\rho\,(r_o^2 - r_i^2)$, Eqs. 27–29) counts for more than their stiffness, which contributes 0.1 % of the
# compliance (section 2). The modes in the constrained directions ($\omega_4$–$\omega_6$) go the other way
# and collapse as the wall thins toward $r_i$ = 3.5 mm. $l_2$ changes little at $x_\mathrm{ref}$.
#
# ### 5b · A structural change: derive, generate and load in memory
#
# A change the existing symbols cannot express needs a new description. Here the actuated joints of legs 3
# and 4 (the legs on the upper traveling plate B) get their own base radius $R_B$, a new design parameter.
# `dataclasses.replace` builds the modified description from the shipped one;
# `evaluator_from_description` derives, CSEs, renders and loads it without writing anything to
# `eigentwist/generated`. After that one regeneration, $R_B$ is a keyword like any other.

# %%
R = heli4.parameter("R")
R_B = dataclasses.replace(R, name="R_B", doc="radius of the actuated joints of legs 3 and 4 (plate B)")
legs = tuple(dataclasses.replace(leg, base=tuple(R_B.symbol * c for c in leg.radial))
             if leg.platform_body == "plate_B" else leg for leg in heli4.legs)
variant = dataclasses.replace(heli4, name="heli4_rb", parameters=heli4.parameters + (R_B,), legs=legs)

t0 = time.perf_counter()
ev_rb = evaluator_from_description(variant)
print(f"derived, generated and loaded in {time.perf_counter() - t0:.1f} s")
same = np.abs(ev_rb.frequencies(x_ref) - ev.frequencies(x_ref)).max()
print(f"with R_B = R the variant reproduces the shipped model: largest difference {same:.1e} Hz")

R_values = np.linspace(0.10, 0.20, 41)
f_rb = ev_rb.frequencies(np.repeat(x_ref, len(R_values), axis=0), "paper", R_B=R_values)
fig, ax = plt.subplots(figsize=(6, 3.8))
for k in range(3):
    ax.plot(R_values * 1e3, f_rb[:, k], label=f"ω{k + 1}")
ax.axvline(R.default * 1e3, color="grey", ls=":", label="R_B = R (Heli4)")
ax.set_xlabel("R_B: base radius of legs 3 and 4 [mm]")
ax.set_ylabel("natural frequency at x_ref [Hz]")
ax.legend()
ax.grid(alpha=0.3)
plt.tight_layout()
plt.show()

# %% [markdown]
# Moving the actuators of legs 3 and 4 outwards stiffens the $Y$ mode ($\omega_2$, driven by legs 3 and 4)
# and leaves the $X$ mode ($\omega_1$, legs 1 and 2) untouched, while $\omega_3$ ($Z$) drops slightly.

# %%
print(f"notebook ran in {time.perf_counter() - t_start:.1f} s")
