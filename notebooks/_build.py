"""Write notebooks 01, 02 and 04 from the cell sources below, outputs stripped.

    python notebooks/_build.py            # rewrite the three notebooks
    python notebooks/_build.py --check    # exit 1 if a checked-in notebook differs

The notebooks are the deliverable; this script is only a convenient way to keep their
sources reviewable as plain Python. Editing a notebook by hand is fine too: then edit
the matching cells here (or delete the notebook's entry below) before rebuilding.
``tests/test_notebooks.py`` executes every ``notebooks/*.ipynb`` and checks that the
checked-in files carry no outputs.
"""
from __future__ import annotations

import sys
from pathlib import Path

import nbformat
from nbformat.v4 import new_code_cell, new_markdown_cell, new_notebook

HERE = Path(__file__).resolve().parent
KERNELSPEC = {"name": "python3", "display_name": "Python 3", "language": "python"}


def build(cells) -> nbformat.NotebookNode:
    """A notebook with no outputs and no execution counts, kernel ``python3``."""
    nb = new_notebook(metadata={"kernelspec": KERNELSPEC, "language_info": {"name": "python"}})
    for k, (kind, source) in enumerate(cells):
        source = source.strip("\n")
        cell = new_markdown_cell(source) if kind == "md" else new_code_cell(source)
        cell["id"] = f"cell-{k:02d}"          # stable ids: rebuilding is byte-identical
        nb.cells.append(cell)
    return nb


def render(cells) -> str:
    return nbformat.writes(build(cells)) + "\n"


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    check = "--check" in argv
    differ = []
    for name, cells in NOTEBOOKS.items():
        path = HERE / name
        text = render(cells)
        if check:
            if not path.exists() or path.read_text(encoding="utf-8") != text:
                differ.append(name)
        else:
            path.write_text(text, encoding="utf-8")
            print(f"wrote notebooks/{name}")
    if differ:
        print("out of date: " + ", ".join(differ) + " (run: python notebooks/_build.py)")
        return 1
    return 0


# ----------------------------------------------------------------------------- 01
NB01 = [
("md", r'''
# 01 · The closed-form model, opened up

eigentwist derives the natural-frequency model of a parallel manipulator symbolically, with every
design quantity kept as a symbol, following Hoevenaars, Krut & Herder (2020), *Jacobian-based natural
frequency analysis of parallel manipulators*, DOI 10.1016/j.mechmachtheory.2019.103775. This notebook
opens the Heli4 model and shows what is inside:

1. one leg's unit twists and reciprocal wrenches (Appendix A) and a row of its inverse Jacobian;
2. entries of the inertia matrix **M** (Eq. 12), the rigid-body stiffness **K_R** (Eq. 14) and the
   flexible-body stiffness **K_F** (Eq. 13) as formulas;
3. which design parameters each entry depends on;
4. how large the expressions are before and after common-subexpression elimination (CSE);
5. a design change: first a parameter *value* (no regeneration), then a *structural* change that is
   derived, generated and loaded in memory in a few seconds.

Conventions (all in SI units): twists are $[\omega;\,v]$, wrenches $[m;\,f]$, everything is expressed at the
end-effector (EE) origin with base-frame axes; coordinates are ordered $(R_x, R_y, R_z, X, Y, Z)$.
The reference pose is $x_\mathrm{ref} = [0, 0, -0.625]$ m.
'''),
("code", r'''
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
from eigentwist.codegen.generate import kernels_for
from eigentwist.runtime.loader import evaluator_from_description

t_start = time.perf_counter()
heli4 = eigentwist.robots.get("heli4")
ev = eigentwist.load("heli4", backend="numpy")          # the generated (checked-in) evaluator
x_ref = np.array([heli4.x_ref])                          # m, shape (1, 3)

t0 = time.perf_counter()
model = derive(heli4)                                    # SymPy derivation, nothing generated
prog = model.program
print(f"derived in {time.perf_counter() - t0:.1f} s: {len(prog.assignments)} named intermediates, "
      f"{len(model.joints)} joint angles, {len(heli4.parameters)} design parameters")
'''),
("md", r'''
The derivation is a *straight-line program*: named intermediates (joint axes, unit twists, reciprocal
wrenches, inverse-Jacobian rows, ...) assigned one after the other. `prog.expand(expr)` substitutes all of
them and returns the closed form in the joint angles $q_{ij}$ (leg $i$, joint $j$) and the design
parameters. A small helper renders symbols the way the paper writes them.
'''),
("code", r'''
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
'''),
("md", r'''
## 1 · One leg: unit twists, reciprocal wrenches, an inverse-Jacobian row

Leg 1 of the Heli4 is an RR(Π)RR chain: the actuated joint ($q_{11}$), the elbow ($q_{12}$), the
parallelogram Π (a curvilinear translation; its tilt is $q_{13}$), the twist of the rods about each other
and the joint at the platform. Its five unit twists of permission $\hat t_{a1}\ldots\hat t_{a5}$
(Appendix A, with the corrections of the facts file), in closed form — $d$, $r$ locate the attachment
$a_1 = [r, 0, d]$ on the lower traveling plate:
'''),
("code", r'''
leg = model.screws[0]                                    # leg 1
T = sp.Matrix.hstack(*[leg.twists[k] for k in (1, 2, 3, 4, 5)])
show(r"\left[\hat t_{a1}\;\hat t_{a2}\;\hat t_{a3}\;\hat t_{a4}\;\hat t_{a5}\right]", prog.expand(T))
show(r"\hat s_{14}", prog.expand(model.screws[0].vectors["s4"]))
c_hat = leg.twists["c"][:3, :]
show(r"\hat t_{c}", sp.Matrix.vstack(c_hat, leg.vectors["a"].cross(c_hat)))
'''),
("md", r'''
The twist of restriction $\hat t_c$ is a rotation about $\hat c_{11}$ through $a_1$. The reciprocal
wrenches $\hat w_{a1}\ldots\hat w_{a5}$ and the wrench of constraint $\hat w_c$ (Appendix A), written with
the leg's named vectors ($\hat r_{12}$: parallelogram centre line, $\hat s_{14}$, $f_{12}$, $f_{15}$):
'''),
("code", r'''
W = sp.Matrix.hstack(*[leg.wrenches[k] for k in (1, 2, 3, 4, 5, "c")])
show(r"\left[\hat w_{a1}\;\hat w_{a2}\;\hat w_{a3}\;\hat w_{a4}\;\hat w_{a5}\;\hat w_{c}\right]", W)
show(r"\hat r_{12}", prog.expand(leg.vectors["r2"]))
'''),
("md", r'''
Each wrench is reciprocal to every twist of the leg except its own (Huang's method): the matrix of
reciprocal products $\hat w_j \cdot \hat t_k$ is diagonal, at $x_\mathrm{ref}$ and at any other pose.
`prog.evaluate` evaluates the program exactly (SymPy arithmetic, 30 digits), independently of the
generated code:
'''),
("code", r'''
def symbol_values(poses, **params):
    """Joint angles (from the generated IK), parameter defaults and all switches on, by symbol name."""
    q = ev.joint_angles(poses, **params)[0].reshape(-1)
    values = {**ev.defaults, **params, **{s.name: v for s, v in zip(model.joints, q)}}
    return {**values, **{sw: 1.0 for sw in model.switches}}


T6 = sp.Matrix.hstack(T, leg.twists["c"])
for pose in ([0.0, 0.0, -0.625], [0.06, -0.04, -0.58]):
    recip = np.array(prog.evaluate(symbol_values(np.array([pose])), W.T * T6, precision=30).tolist(), dtype=float)
    off = np.abs(recip - np.diag(np.diag(recip))).max()
    print(f"pose {pose} m: diagonal w.t = {np.round(np.diag(recip), 4)}, largest off-diagonal {off:.1e}")
'''),
("md", r'''
So the rows of the leg's inverse Jacobian $J_1^{-1}$ (the missing Eq. 15) are $\hat w_j^T / (\hat w_j
\cdot \hat t_j)$. The actuated row $j_{11}$, which maps an EE twist to the actuated joint rate, simplifies
to a compact closed form (a `sympy.simplify` of the expanded row):
'''),
("code", r'''
row = prog.expand(leg.rows[1])
row_simple = row.applyfunc(sp.simplify)
show(r"j_{11} = \frac{\hat w_{a1}^T}{\hat w_{a1}\cdot\hat t_{a1}}", row_simple)

# check against the generated evaluator (rows of joints 1, 2, 3 and the constraint, per leg)
q = ev.joint_angles(x_ref)[0]
subs = {s: v for s, v in zip(model.joints, q.reshape(-1))} | {p.symbol: p.default for p in heli4.parameters}
print("closed form at x_ref :", np.array(row_simple.xreplace(subs).evalf(), dtype=float).round(5))
print("generated evaluator  :", ev.jacobians(x_ref)["J_rows"][0, 0, 0].round(5))
'''),
("md", r'''
At $x_\mathrm{ref}$ the parallelogram does not tilt ($q_{13} = 0$), so the row has no $R_x$, $R_z$ or $Y$
component: actuator 1 sees only $X$, $Z$ and rotations about $Y$.

## 2 · Entries of M, K_R and K_F as formulas

**K_R (Eq. 14)** is $\sum_i k_\mathrm{act}\, j_{i1}^T j_{i1}$: each leg contributes the outer product of its
actuated row, weighted by the delivered actuator stiffness. In the program it is literally that sum; with
each leg's row simplified as above, the translational diagonal reads:
'''),
("code", r'''
K_R = sp.Matrix(6, 6, model.outputs["matrices"]["K_R"][1])
show(r"K_R(Z,Z)", K_R[5, 5])                            # as the program holds it

simple = {}
for i, ls in enumerate(model.screws):
    r = prog.expand(ls.rows[1])
    for k in (3, 4, 5):                                  # X, Y, Z entries of each actuated row
        simple[ls.rows[1][k]] = sp.simplify(r[k])
k_act = sp.Symbol("k_act", real=True)
for k, axis in zip((3, 4, 5), "XYZ"):
    show(rf"K_R({axis},{axis})", sp.factor_terms(K_R[k, k].xreplace(simple)))
show(r"k_\mathrm{act}", prog.expand(k_act))
'''),
("md", r'''
$k_\mathrm{act}$ carries the effect switches ($\mathrm{on}_\bullet \in \{0, 1\}$): one generated evaluator
serves every combination of effects. With the paper's model it is $\eta_a k_a$ (Eq. 34, $\eta_a = 0.82$).

**M (Eq. 12)** is a sum over the bodies of every leg of $J_i^{-T} J_{ij}^T M_{ij} J_{ij} J_i^{-1}$ plus the EE
inertia. Its closed form is large in general, but at a fixed pose it is *linear* in the inertial
parameters. Substituting the joint angles and the geometry at $x_\mathrm{ref}$ and keeping the inertias
symbolic (kg, kg m², kg/m³) shows where the moving mass comes from:
'''),
("code", r'''
S = lambda name: sp.Symbol(name, real=True)  # noqa: E731
paper_switches = {S(sw): (1 if sw in ("on_actuator_loss", "on_rod_compliance", "on_ee_compliance") else 0)
                  for sw in model.switches}
q_ref = {s: sp.Float(v) for s, v in zip(model.joints, ev.joint_angles(x_ref)[0].reshape(-1))}


def at_x_ref(expr, keep):
    """``expr`` at x_ref with every parameter except ``keep`` at its default (paper model)."""
    values = {S(n): sp.Float(v) for n, v in ev.defaults.items() if n not in keep}
    return expr.xreplace({**q_ref, **paper_switches, **values})


M = sp.Matrix(6, 6, model.outputs["matrices"]["M"][1])
inertial = ("m_e", "I_e_xx", "I_e_yy", "I_e_zz", "I1_yy", "I_rotor", "rho")
M_diag = prog.expand(sp.Matrix([M[k, k] for k in range(6)]))
for k, axis in enumerate(("R_x", "R_y", "R_z", "X", "Y", "Z")):
    show(rf"M({axis},{axis})\big|_{{x_\mathrm{{ref}}}}", sp.expand(at_x_ref(M_diag[k], inertial)).n(4))
'''),
("md", r'''
The translational inertia is the EE mass $m_e$ plus the actuator-side rotary inertia $I_{1,yy} +
I_\mathrm{rotor}$ reflected through the legs (78.6 m⁻² along $Z$: about 0.67 kg of the 1.56 kg) plus the
parallelogram rods (through $\rho$). The lower link's mass and centre of gravity do not appear: body 1
only rotates about its own axis, so only its inertia about that axis counts (facts file).

**K_F (Eq. 13)** adds the structural compliances of the legs in series with the actuators (Eqs. 37–50):
rods (App. C), end-effector assembly (App. D, Eqs. 45–49). At $x_\mathrm{ref}$ the $X$ stiffness,
written as a compliance in the three stiffnesses that matter, is exactly three springs in series
(m/N, with $k_a$ in N m/rad, $k_{E,\mathrm{rot}}$ in N m/rad, $E$ in Pa):
'''),
("code", r'''
K_F = sp.Matrix(6, 6, model.outputs["matrices"]["K_F"][1])
keep = ("k_a", "k_E_rot", "E_rod")
kf_xx = sp.cancel(sp.together(at_x_ref(prog.expand(K_F[3, 3]), keep)))
compliance = sp.expand(1 / kf_xx)
show(r"\frac{1}{K_F(X,X)}\Big|_{x_\mathrm{ref}}", compliance.n(4))

d = ev.defaults
terms = {str(t.free_symbols.pop()): float(t.xreplace({S(n): d[n] for n in keep})) for t in compliance.args}
for name, c in terms.items():
    print(f"  {name:8s} {c:.3e} m/N  ({100 * c / sum(terms.values()):.1f} % of the X compliance)")
print(f"K_F(X,X) = {1 / sum(terms.values()):.2f} N/m; generated evaluator: "
      f"{ev.matrices(x_ref, 'paper')['K_F'][0, 3, 3]:.2f} N/m (paper, Eq. 58: 16170)")
'''),
("md", r'''
The actuators and the EE assembly dominate; the rods add about 0.1 % — which is what Appendix E concludes
from its ablation (notebook 02).

## 3 · Which design parameters each entry depends on

The matrices are written in joint angles and design parameters; the joint angles come from the
closed-form inverse kinematics, which brings in the geometry ($R$, $l_1$, $l_2$, $r$, $d$, $h$). The map
below marks, for each upper-triangle entry of **M**, **K_R** and **K_F**, the parameters that appear in its
closed form (dark) and those that act only through the joint angles (light). Collecting the free
symbols walks the program once (no expansion needed).
'''),
("code", r'''
def input_dependencies(program):
    """For every intermediate of ``program``: the set of input symbols its closed form contains."""
    deps = {}
    for s, rhs in program.assignments:
        deps[s] = frozenset().union(*[deps.get(f, {f}) for f in rhs.free_symbols])
    return deps


deps, ik_deps = input_dependencies(prog), input_dependencies(model.ik)
q_deps = {q: frozenset().union(*[ik_deps.get(f, {f}) for f in sp.sympify(e).free_symbols])
          for q, e in zip(model.joints, model.ik_outputs["q"][1])}
names = [p.name for p in heli4.parameters] + list(model.switches)
index = {n: k for k, n in enumerate(names)}
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
'''),
("md", r'''
A symbol can appear in a closed form and still have no influence. The elasticities
$\partial \ln \omega_k / \partial \ln p$ of the six natural frequencies at $x_\mathrm{ref}$ (paper model,
central differences of ±1 % on the generated evaluator, one batch of two rows per parameter) tell the designer what
actually moves the frequencies — e.g. the shear modulus $G$ of the rods appears in $K_F$ but a leg
loads only the axial and in-plane bending compliance of the rods, so its elasticity is zero:
'''),
("code", r'''
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
'''),
("md", r'''
$\omega_1$–$\omega_3$ grow with the actuator stiffness ($k_a$, $\eta_a$: elasticity about 0.4, below the
0.5 of a single spring because the EE assembly compliance is in series) and fall with the moving
inertia ($m_e$, and the rods through $r_o$ and $\rho$); the constrained-direction modes
$\omega_4$–$\omega_6$ are set by the rods ($r_o$, $r_i$, $w_\Pi$, $E$) and the EE rotational inertias.

## 4 · Expression sizes: closed form, program, CSE'd kernel

Fully expanded, the closed forms are enormous — the same subexpressions (trigonometric functions of
the joint angles, the legs' rows, the compliance matrices) occur again and again. The derivation keeps
them named; `kernels_for` then runs SymPy's CSE over what each generated function needs. Operation
counts are those of `sympy.count_ops`; for the expanded closed forms they are computed on the shared
expression graph (`count_ops` itself would walk tens of millions of nodes), checked against
`count_ops` on K_R below.
'''),
("code", r'''
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
'''),
("code", r'''
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
'''),
("md", r'''
## 5 · A design change

### 5a · A parameter value: no regeneration

Every design quantity is a symbol in the generated code, so changing a value is a keyword argument — a
scalar or one value per pose. Below, the lowest three natural frequencies at $x_\mathrm{ref}$ (paper
model, $k_a$ = 2000 N m/rad) as the parallelogram length $l_2$ and the rods' outer radius $r_o$ vary
(one batched call each):
'''),
("code", r'''
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
'''),
("md", r'''
Over this range the lowest three frequencies fall as the rods get thicker: the rods' mass (through
$\rho\,(r_o^2 - r_i^2)$, Eqs. 27–29) counts for more than their stiffness, which contributes 0.1 % of the
compliance (section 2). The modes in the constrained directions ($\omega_4$–$\omega_6$) go the other way
and collapse as the wall thins toward $r_i$ = 3.5 mm. $l_2$ changes little at $x_\mathrm{ref}$.

### 5b · A structural change: derive, generate and load in memory

A change the existing symbols cannot express needs a new description. Here the actuated joints of legs 3
and 4 (the legs on the upper traveling plate B) get their own base radius $R_B$, a new design parameter.
`dataclasses.replace` builds the modified description from the shipped one;
`evaluator_from_description` derives, CSEs, renders and loads it without writing anything to
`eigentwist/generated`. After that one regeneration, $R_B$ is a keyword like any other.
'''),
("code", r'''
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
'''),
("md", r'''
Moving the actuators of legs 3 and 4 outwards stiffens the $Y$ mode ($\omega_2$, driven by legs 3 and 4)
and leaves the $X$ mode ($\omega_1$, legs 1 and 2) untouched, while $\omega_3$ ($Z$) drops slightly.
'''),
("code", r'''
print(f"notebook ran in {time.perf_counter() - t_start:.1f} s")
'''),
]

# ----------------------------------------------------------------------------- 02
NB02 = [
("md", r'''
# 02 · Reproducing the paper, and the coupled end-effector model

Hoevenaars, Krut & Herder (2020), *Jacobian-based natural frequency analysis of parallel manipulators*,
DOI 10.1016/j.mechmachtheory.2019.103775, analyse the Heli4 at the reference pose
$x_\mathrm{ref} = [0, 0, -0.625]$ m with actuator stiffness $k_a$ = 2000 N m/rad (Eqs. 52–65), compare
predictions with measured natural frequencies over $k_a$ (Fig. 6, Tables E.1/E.2) and ablate the two
structural compliances (Appendix E). This notebook puts eigentwist's generated model beside every number
they print, redraws Fig. 6 and the ablation, and then shows what the **coupled end-effector model**
(issue 7) predicts that the paper's split of the end-effector compliance (Eqs. 45–49) does not.

Units: frequencies in Hz, stiffness in N/m, N and N m/rad, inertia in kg, kg m and kg m²; coordinates
ordered $(R_x, R_y, R_z, X, Y, Z)$. Facts the paper does not print (base geometry, $E$ = 170 GPa for the
rods, misprints) are documented in the project's facts file and in `eigentwist.paper`.
'''),
("code", r'''
import time

import numpy as np
import matplotlib.pyplot as plt
from IPython.display import HTML, display

import eigentwist
from eigentwist import paper

t_start = time.perf_counter()
ev = eigentwist.load("heli4", backend="numpy")
x_ref = np.array([paper.X_REF])
summary = paper.reproduce(ev)
values = summary["values"]
print(f"{summary['within_rounding']} of {summary['printed']} printed model numbers are within print rounding "
      f"(half a unit of the last printed digit); {summary['required_ok']} of {summary['required']} required "
      f"numbers are within rounding or an accepted tolerance")
'''),
("md", r'''
## 1 · Eqs. 52–65 side by side

Each cell shows the **printed** value and eigentwist's value below it. Green: within print rounding;
yellow: outside rounding but within a tolerance the facts file explains (hover for the reason);
grey: not required (depends on the end-effector inertias that Eq. 31 prints to one significant digit);
red: a miss.
'''),
("code", r'''
COLOURS = {"round": "#d9f0d3", "tol": "#fee8a0", "free": "#e8e8e8", "miss": "#f4a6a6"}


def status(v):
    if v.within_rounding:
        return "round"
    if not v.required:
        return "free"
    return "tol" if v.ok else "miss"


def digits(printed):
    return len(printed.split(".")[1]) + 1 if "." in printed else 1


def matrix_html(source, title):
    vals = [v for v in values if v.source == source]
    n = int(round(len(vals) ** 0.5))
    cells = ""
    for i in range(n):
        cells += "<tr>" + "".join(
            f"<td title='{v.note}' style='background:{COLOURS[status(v)]};text-align:right;padding:2px 6px'>"
            f"<b>{v.printed}</b><br><span style='font-size:85%'>{v.model:.{digits(v.printed)}f}</span></td>"
            for v in vals[i * n:(i + 1) * n]) + "</tr>"
    return f"<div style='display:inline-block;margin:0 18px 12px 0;vertical-align:top'><b>{title}</b>" \
           f"<table style='border-collapse:collapse;font-size:80%'>{cells}</table></div>"


def list_html(sources, title):
    vals = [v for v in values if v.source in sources]
    rows = "".join(
        f"<tr style='background:{COLOURS[status(v)]}'><td>{v.source}</td><td>{v.label}</td>"
        f"<td style='text-align:right'><b>{v.printed}</b></td><td style='text-align:right'>{v.model:.3f}</td>"
        f"<td style='font-size:85%'>{v.note}</td></tr>" for v in vals)
    return f"<div style='display:inline-block;margin:0 18px 12px 0;vertical-align:top'><b>{title}</b>" \
           f"<table style='font-size:85%'><tr><th>eq.</th><th>quantity</th><th>paper</th><th>eigentwist</th>" \
           f"<th>note</th></tr>{rows}</table></div>"


display(HTML(matrix_html("Eq. 52 M", "Eq. 52: M at x_ref") + matrix_html("Eq. 53 K_R", "Eq. 53: K_R")
             + matrix_html("Eq. 58 K_F", "Eq. 58: K_F")))
display(HTML(list_html({f"Eq. {k}" for k in range(54, 57)} | {f"Eq. {k}" for k in range(59, 65)},
                       "Eqs. 54–56 (rigid) and 59–64 (flexible): natural frequencies, Hz")
             + matrix_html("Eq. 57 S_v rigid", "Eq. 57: eigentwists, rigid (X, Y, Z)")
             + matrix_html("Eq. 65 S_v flexible", "Eq. 65: eigentwists, flexible")))
misses = [v for v in values if v.required and not v.ok]
print("required numbers outside rounding and tolerance:", ", ".join(f"{v.source} {v.label}" for v in misses) or "none")
'''),
("md", r'''
The remaining differences are explained in the facts file: $M(3,3)$ and $\omega_4$–$\omega_6$ depend on the
end-effector rotational inertias, which Eq. 31 prints to one significant digit, and the printed
$K_F(2,4) = -74$ is likely a misprint ($K_F(2,4)/K_F(4,4)$ equals the purely geometric
$K_R(2,4)/K_R(4,4)$ in this model structure, which gives −74.72).

## 2 · Fig. 6 redrawn

The two lowest natural frequencies at $x_\mathrm{ref}$ over the commanded actuator stiffness $k_a$
from 0 to 4000 N m/rad: the rigid-body stiffness model (K_R, Eq. 14, on the 3 × 3 translational
subsets) and the flexible-body model (K_F, Eq. 13), both with the same rigid-body inertia model M
(Eq. 12), beside the measurements of Tables E.1/E.2 (step responses in $X$ excite $\omega_1$, in $Y$
$\omega_2$). One batched call per model.
'''),
("code", r'''
k_a = np.linspace(0.0, 4000.0, 161)[1:]                 # N m/rad (k_a = 0 gives 0 Hz, left out)
poses = np.repeat(x_ref, len(k_a), axis=0)
rigid = ev.modes(poses, "rigid", k_a=k_a)
flex = ev.modes(poses, "paper", k_a=k_a)
# omega_1 is the X mode and omega_2 the Y mode at every k_a (largest share of the energy)
assert (rigid.direction[:, :2] == [3, 4]).all() and (flex.direction[:, :2] == [3, 4]).all()

ka_meas = np.array(paper.TABLE_KA, dtype=float)
meas = {1: np.array(paper.MEASURED["x"]), 2: np.array(paper.MEASURED["y"])}
fig, ax = plt.subplots(figsize=(8, 5))
for k, colour in ((1, "tab:blue"), (2, "tab:orange")):
    ax.plot(np.r_[0, k_a], np.r_[0, rigid.freq_hz[:, k - 1]], "--", color=colour, label=f"ω{k} rigid-body model")
    ax.plot(np.r_[0, k_a], np.r_[0, flex.freq_hz[:, k - 1]], "-", color=colour, label=f"ω{k} flexible-body model")
    ax.plot(ka_meas, meas[k], "o", color=colour, mfc="white", label=f"ω{k} measured ({'XY'[k - 1]} step)")
ax.set_xlabel("actuator stiffness k_a [N m/rad]")
ax.set_ylabel("natural frequency [Hz]")
ax.set_xlim(0, 4000)
ax.set_ylim(0, 40)
ax.grid(alpha=0.3)
ax.legend(ncol=2, fontsize=9)
ax.set_title("Fig. 6 redrawn: Heli4 at x_ref")
plt.tight_layout()
plt.show()
'''),
("code", r'''
pred = {name: ev.frequencies(np.repeat(x_ref, 8, axis=0), model, k_a=ka_meas)[:, :2]
        for name, model in (("rigid", "rigid"), ("flexible", "paper"))}
measured = np.stack([meas[1], meas[2]], axis=1)
rows = ""
for name, f in pred.items():
    err = 100 * (f - measured) / measured
    rows += (f"<tr><td>{name}</td><td>{np.sqrt(np.mean(err ** 2)):.1f} %</td><td>{np.abs(err).max():.1f} %</td>"
             f"<td>{err[-1, 0]:+.1f} %</td><td>{err[-1, 1]:+.1f} %</td></tr>")
display(HTML("<table><tr><th>stiffness model</th><th>RMS error</th><th>largest |error|</th>"
             "<th>ω1 at 4000 N m/rad</th><th>ω2 at 4000 N m/rad</th></tr>" + rows + "</table>"))
'''),
("md", r'''
As the paper reports (Sec. 5): up to about 1000 N m/rad both models agree with the measurements; above
it only the flexible-body model does. At $k_a$ = 4000 N m/rad the error on $\omega_1$ falls from 33 % to 6 %
and on $\omega_2$ from 17 % to 2 %.

## 3 · Appendix E: which structural compliance matters

The benchmark model (BM) includes both structural compliances. Appendix E removes one at a time by
dividing it by 1000: **BM − K_E⁻¹** multiplies the end-effector assembly stiffnesses $k_{E,\mathrm{rot}}$
and $k_{E,\mathrm{lin}}$ by 1000, **BM − K_Π⁻¹** multiplies the rods' Young's modulus $E$ by 1000 (the
shear modulus has no influence, notebook 01). Paper (bold) and eigentwist side by side:
'''),
("code", r'''
d = ev.defaults
SCENARIOS = {"BM": {}, "BM-KE": {"k_E_rot": 1000 * d["k_E_rot"], "k_E_lin": 1000 * d["k_E_lin"]},
             "BM-KPi": {"E_rod": 1000 * d["E_rod"]}}
LABELS = {"BM": "BM", "BM-KE": "BM − K_E⁻¹", "BM-KPi": "BM − K_Π⁻¹"}
ablation = {s: ev.frequencies(np.repeat(x_ref, 8, axis=0), "paper", k_a=ka_meas, **over)[:, :2]
            for s, over in SCENARIOS.items()}


def table_html(table, printed, mode):
    head = "<tr><th>k_a [N m/rad]</th><th>Meas.</th>" + "".join(
        f"<th colspan=2>{LABELS[s]}<br><span style='font-weight:normal'>paper | eigentwist</span></th>"
        for s in SCENARIOS) + "</tr>"
    body = ""
    for k, ka in enumerate(paper.TABLE_KA):
        body += f"<tr><td>{ka}</td><td>{meas[mode][k]:.1f}</td>"
        for s in SCENARIOS:
            p = printed[s].split()[k]
            ok = abs(ablation[s][k, mode - 1] - float(p)) <= 0.05 + 1e-9
            body += (f"<td style='text-align:right'><b>{p}</b></td><td style='text-align:right;"
                     f"background:{COLOURS['round' if ok else 'miss']}'>{ablation[s][k, mode - 1]:.2f}</td>")
        body += "</tr>"
    return f"<div style='display:inline-block;margin-right:24px'><b>{table}: ω{mode}, Hz</b>" \
           f"<table style='font-size:85%'>{head}{body}</table></div>"


display(HTML(table_html("Table E.1", paper.TABLE_E1, 1) + table_html("Table E.2", paper.TABLE_E2, 2)))
'''),
("code", r'''
curves = {s: ev.frequencies(poses, "paper", k_a=k_a, **over)[:, :2] for s, over in SCENARIOS.items()}
fig, axes = plt.subplots(1, 3, figsize=(14, 4.2), gridspec_kw={"width_ratios": [1, 1, 0.8]})
styles = {"BM": "-", "BM-KE": "--", "BM-KPi": ":"}
for mode, ax in ((1, axes[0]), (2, axes[1])):
    for s in SCENARIOS:
        ax.plot(k_a, curves[s][:, mode - 1], styles[s], label=LABELS[s], lw=2 if s == "BM-KPi" else 1.5)
    ax.plot(ka_meas, meas[mode], "ko", mfc="white", label="measured")
    ax.set_xlabel("k_a [N m/rad]")
    ax.set_ylabel(f"ω{mode} [Hz]")
    ax.set_title(f"{'Table E.1' if mode == 1 else 'Table E.2'}: ω{mode} ({'XY'[mode - 1]} mode)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
errors = {s: (100 * np.abs(ablation[s] - measured) / measured).ravel() for s in SCENARIOS}
axes[2].boxplot(list(errors.values()), tick_labels=[LABELS[s] for s in SCENARIOS])
axes[2].set_ylabel("|ω_meas − ω_pred| / ω_meas [%]")
axes[2].set_title("Fig. E.1 redrawn: errors, ω1 and ω2 pooled")
axes[2].grid(alpha=0.3)
plt.tight_layout()
plt.show()
for s in SCENARIOS:
    print(f"{LABELS[s]:12s} mean error {errors[s].mean():5.2f} %, largest {errors[s].max():5.2f} %")
'''),
("md", r'''
Removing the end-effector assembly compliance changes the predictions a lot (and makes them worse);
removing the rod compliance changes nothing visible — the paper's conclusion that the end-effector
assembly is the dominant structural compliance.

## 4 · Coupled end-effector model (issue 7)

The paper's Sec. 6 leaves open how to include end-effector compliance at *any* pose. Eqs. 45–49 split
the two measured compliances of Appendix D over the legs — $2/k_{E,\mathrm{rot}}$ about $Y$ to each of legs
1 and 2, $2/k_{E,\mathrm{lin}}$ along $Y$ to each of legs 3 and 4 — which was derived for $x_\mathrm{ref}$,
where the legs are aligned with the axes. eigentwist's **coupled** model (preset `coupled` =
`actuator_loss` + `rod_compliance` + `ee_coupling`) instead treats the traveling assembly as three rigid
bodies: the tool T, plate A (legs 1, 2) joined to T by a rotation about $Y$ through the lower plate centre
($k_{E,\mathrm{rot}}$), and plate B (legs 3, 4) joined to T by a translation along $Y$ ($k_{E,\mathrm{lin}}$). A
group of legs with Cartesian stiffness $K_p$ reaching the tool through a coupling with unit twists $G$ and
stiffness $K_c$ contributes $K_p - K_p G (G^T K_p G + K_c)^{-1} G^T K_p$ (the coupling coordinates condensed
in closed form), and K_F is the sum over the plates. Nothing in it depends on the pose being special.

### 4a · At x_ref: one entry differs
'''),
("code", r'''
split = ev.matrices(x_ref, "paper")["K_F"][0]
coupled = ev.matrices(x_ref, "coupled")["K_F"][0]
diff = coupled - split
AX = ("Rx", "Ry", "Rz", "X", "Y", "Z")
big = np.argwhere(np.abs(diff) > 1e-6 * np.abs(split).max())
for i, j in big:
    print(f"K_F({i + 1},{j + 1}) [{AX[i]},{AX[j]}]: split (paper, Eq. 58) {split[i, j]:,.1f}, coupled "
          f"{coupled[i, j]:,.1f} N/m ({100 * diff[i, j] / split[i, j]:+.1f} %)")
rest = np.abs(np.where(np.abs(diff) > 1e-6 * np.abs(split).max(), 0, diff)).max()
print(f"every other entry: largest difference {rest:.1e}")
print(f"rigid-body K_R(6,6) for comparison: {ev.matrices(x_ref, 'paper')['K_R'][0, 5, 5]:,.1f} N/m")

f_split, f_coupled = ev.frequencies(x_ref, "paper")[0], ev.frequencies(x_ref, "coupled")[0]
rows = "".join(f"<tr><td>ω{k + 1}</td><td style='text-align:right'>{paper.FLEX_HZ[k]}</td>"
               f"<td style='text-align:right'>{f_split[k]:.3f}</td><td style='text-align:right'>{f_coupled[k]:.3f}</td>"
               f"<td style='text-align:right'>{f_coupled[k] - f_split[k]:+.3f}</td></tr>" for k in range(6))
display(HTML("<table><tr><th>mode</th><th>paper (Eqs. 59–64)</th><th>split (<code>paper</code>)</th>"
             "<th>coupled</th><th>coupled − split</th></tr>" + rows + "</table>"))
'''),
("md", r'''
At $x_\mathrm{ref}$ the two models agree on every entry of K_F except $K_F(6,6)$, the vertical ($Z$)
stiffness, and so on $\omega_1$, $\omega_2$ and $\omega_4$–$\omega_6$; only $\omega_3$ (the $Z$ mode) differs.
**Why:** under a purely vertical load the legs' lateral loads cancel in pairs. Legs 3 and 4, mirror
images in the $Y$–$Z$ plane, push on plate B with equal and opposite $Y$-forces; legs 1 and 2 load plate A
with equal and opposite moments about its $Y$ rotation axis. The split gives every leg its own share of
the coupling compliance in series ($2/k_{E,\mathrm{lin}}$ along $Y$ for legs 3 and 4, $2/k_{E,\mathrm{rot}}$
about $Y$ for legs 1 and 2), so each leg's own lateral load deflects its share and the tool sinks: $Z$
softens. In the coupled model each plate is one rigid body and its coupling feels only the *net* load,
which is zero, so a $Y$-slide between plate B and the tool (or a $Y$-rotation of plate A) does not soften
$Z$: $K_F(6,6)$ stays at the legs' own stiffness (the rigid-body $K_R(6,6)$ less the rods). The loads
each leg exerts on the end-effector for a 1 mm vertical displacement of the tool, with the actuators as
springs (from the generated inverse-Jacobian rows; the moment is taken about plate A's rotation axis
through $[0, 0, d]$ from the EE origin):
'''),
("code", r'''
jac = ev.jacobians(x_ref)["J_rows"][0]                  # (legs, 4, 6): rows of joints 1, 2, 3, constraint
k_act = d["eta_a"] * d["k_a"]                            # N m/rad, delivered actuator stiffness (Eq. 34)
delta = np.array([0, 0, 0, 0, 0, 1e-3])                  # 1 mm along Z
axis_A = np.array([0, 0, d["d"]])                        # a point on plate A's rotation axis (m)
rows = ""
for i in range(4):
    wrench = -jac[i, 0] * k_act * (jac[i, 0] @ delta)    # the leg's wrench on the EE, [moment; force]
    moment_A = wrench[:3] - np.cross(axis_A, wrench[3:])
    rows += (f"<tr><td>leg {i + 1} (plate {'AABB'[i]})</td>"
             + "".join(f"<td style='text-align:right'>{w:+.2f}</td>" for w in (*wrench[3:], moment_A[1]))
             + "</tr>")
display(HTML("<table><tr><th></th><th>F_x [N]</th><th>F_y [N]</th><th>F_z [N]</th>"
             "<th>M_y about plate A's axis [N m]</th></tr>" + rows + "</table>"))
'''),
("md", r'''
The same statement as sweeps at $x_\mathrm{ref}$: the vertical stiffness depends on the coupling
stiffnesses only in the split, while the lateral stiffnesses the couplings are meant to soften ($Y$ for
$k_{E,\mathrm{lin}}$; $X$ for $k_{E,\mathrm{rot}}$, through the tilt about $Y$) are the same in both models.
'''),
("code", r'''
sweep = np.logspace(-1, 4, 81)                           # multiple of the Heli4's value
P = np.repeat(x_ref, len(sweep), axis=0)
fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharex=True)
for c, name in enumerate(("k_E_lin", "k_E_rot")):
    K = {m: ev.matrices(P, m, **{name: sweep * d[name]})["K_F"] for m in ("paper", "coupled")}
    for r, idx in enumerate((5, 4 if name == "k_E_lin" else 3)):
        ax = axes[r, c]
        ax.semilogx(sweep, K["paper"][:, idx, idx], "--", label="split (Eqs. 45–49)")
        ax.semilogx(sweep, K["coupled"][:, idx, idx], "-", label="coupled (issue 7)")
        ax.axvline(1, color="grey", ls=":", label="Heli4 (App. D)")
        ax.set_ylabel(f"K_F({AX[idx]},{AX[idx]}) [N/m]")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    axes[1, c].set_xlabel(f"{name} / its Heli4 value ({d[name]:.4g} {ev.parameters[name].unit})")
plt.tight_layout()
plt.show()
stiff = lambda *names: {n: 1e6 * d[n] for n in names}  # noqa: E731
kzz = lambda model, **o: ev.matrices(x_ref, model, **o)["K_F"][0, 5, 5]  # noqa: E731
print(f"K_F(Z,Z) at x_ref, N/m: coupled {kzz('coupled'):,.0f}; split {kzz('paper'):,.0f}; split with only "
      f"the Y-slide of plate B {kzz('paper', **stiff('k_E_rot')):,.0f}; split with only the Y-rotation of "
      f"plate A {kzz('paper', **stiff('k_E_lin')):,.0f}")
'''),
("md", r'''
### 4b · Away from x_ref

Away from $x_\mathrm{ref}$ the legs are no longer aligned with the axes: the split was not derived there
(eigentwist still evaluates it, with the same per-leg compliances), while the coupled model holds at
every pose. The lowest three frequencies along four lines through the workspace box (through
$x_\mathrm{ref}$ along $X$, $Y$, $Z$, and along the diagonal to the corner $[0.1, 0.1, -0.55]$ m),
$k_a$ = 2000 N m/rad:
'''),
("code", r'''
lo = np.array([a for a, _ in ev.robot.workspace])
hi = np.array([b for _, b in ev.robot.workspace])
s = np.linspace(-1, 1, 121)
lines = {
    "along X (y = 0, z = −0.625 m)": (x_ref + np.outer(s, [0.1, 0, 0]), 0.1 * s, "x [m]"),
    "along Y (x = 0, z = −0.625 m)": (x_ref + np.outer(s, [0, 0.1, 0]), 0.1 * s, "y [m]"),
    "along Z (x = y = 0)": (np.outer(np.ones_like(s), [0, 0, -0.625]) + np.outer(s, [0, 0, 0.075]),
                            -0.625 + 0.075 * s, "z [m]"),
    "diagonal to [0.1, 0.1, −0.55] m": (x_ref + np.outer((s + 1) / 2, [0.1, 0.1, 0.075]), (s + 1) / 2,
                                       "fraction of the way to the corner"),
}
fig, axes = plt.subplots(2, 4, figsize=(16, 6.5), sharex="col", gridspec_kw={"height_ratios": [2, 1]})
for c, (title, (P, t, xlabel)) in enumerate(lines.items()):
    fs, fc = ev.frequencies(P, "paper")[:, :3], ev.frequencies(P, "coupled")[:, :3]
    for k, colour in enumerate(("tab:blue", "tab:orange", "tab:green")):
        axes[0, c].plot(t, fs[:, k], "--", color=colour)
        axes[0, c].plot(t, fc[:, k], "-", color=colour, label=f"ω{k + 1}")
        axes[1, c].plot(t, fc[:, k] - fs[:, k], color=colour)
    axes[0, c].set_title(title, fontsize=10)
    axes[1, c].set_xlabel(xlabel)
    axes[0, c].grid(alpha=0.3)
    axes[1, c].grid(alpha=0.3)
axes[0, 0].set_ylabel("frequency [Hz]\n(solid: coupled, dashed: split)")
axes[1, 0].set_ylabel("coupled − split [Hz]")
axes[0, 0].legend()
plt.tight_layout()
plt.show()
'''),
("md", r'''
Over a 21 × 21 × 21 grid of the whole workspace box ($x, y \in [-0.1, 0.1]$ m, $z \in [-0.70, -0.55]$ m),
for all six modes, and the $Z$ mode's difference on three horizontal slices:
'''),
("code", r'''
axes_ = [np.linspace(a, b, 21) for a, b in ev.robot.workspace]
grid = np.stack(np.meshgrid(*axes_, indexing="ij"), axis=-1).reshape(-1, 3)
fs, fc = ev.frequencies(grid, "paper"), ev.frequencies(grid, "coupled")
dabs, drel = fc - fs, 100 * (fc - fs) / fs
rows = "".join(
    f"<tr><td>ω{k + 1}</td><td>{fs[:, k].min():.2f} – {fs[:, k].max():.2f}</td>"
    f"<td>{fc[:, k].min():.2f} – {fc[:, k].max():.2f}</td><td>{dabs[:, k].min():+.3f} … {dabs[:, k].max():+.3f}</td>"
    f"<td>{drel[:, k].min():+.2f} … {drel[:, k].max():+.2f}</td>"
    f"<td>{np.round(grid[np.argmax(np.abs(dabs[:, k]))], 3).tolist()}</td></tr>" for k in range(6))
display(HTML("<table><tr><th>mode</th><th>split [Hz]</th><th>coupled [Hz]</th><th>coupled − split [Hz]</th>"
             "<th>[%]</th><th>largest difference at [m]</th></tr>" + rows + "</table>"))

shape = tuple(len(a) for a in axes_)
D3 = drel[:, 2].reshape(shape)
fig, axes = plt.subplots(1, 3, figsize=(14, 4), sharey=True)
for ax, iz in zip(axes, (0, 10, 20)):
    im = ax.imshow(D3[:, :, iz].T, origin="lower", extent=[lo[0], hi[0], lo[1], hi[1]], vmin=D3.min(),
                   vmax=D3.max(), cmap="viridis")
    ax.set_title(f"ω3: coupled − split [%], z = {axes_[2][iz]:.3f} m", fontsize=10)
    ax.set_xlabel("x [m]")
axes[0].set_ylabel("y [m]")
fig.colorbar(im, ax=axes, shrink=0.9)
plt.show()
'''),
("md", r'''
Where could a measurement tell the two models apart with the modes the paper measured ($\omega_1$ and
$\omega_2$)? The largest difference over the grid, as a function of $k_a$ (8 × 9261 poses per model):
'''),
("code", r'''
n = len(grid)
ka_rows = np.repeat(ka_meas, n)
P = np.tile(grid, (len(ka_meas), 1))
gap = (ev.frequencies(P, "coupled", k_a=ka_rows)[:, :2] - ev.frequencies(P, "paper", k_a=ka_rows)[:, :2])
gap = gap.reshape(len(ka_meas), n, 2)
fig, ax = plt.subplots(figsize=(7, 3.8))
for k in range(2):
    ax.plot(ka_meas, np.abs(gap[:, :, k]).max(axis=1), "o-",
            label=f"ω{k + 1} ({'XY'[k]} mode): largest |coupled − split|")
ax.set_xlabel("k_a [N m/rad]")
ax.set_ylabel("Hz")
ax.grid(alpha=0.3)
ax.legend(fontsize=9)
plt.tight_layout()
plt.show()
kk, ii = np.unravel_index(np.argmax(np.abs(gap[:, :, 1])), gap.shape[:2])
print(f"largest omega_2 difference: {gap[kk, ii, 1]:+.2f} Hz at k_a = {ka_meas[kk]:.0f} N m/rad, "
      f"pose {np.round(grid[ii], 3).tolist()} m")

# both models become the rigid-platform model when the couplings are made rigid
stiff = {"k_E_rot": 1e6 * d["k_E_rot"], "k_E_lin": 1e6 * d["k_E_lin"]}
gap_rigid = np.abs(ev.frequencies(grid, "coupled", **stiff) - ev.frequencies(grid, "paper", **stiff)).max()
print(f"with k_E_rot, k_E_lin x 1e6 the two models agree within {gap_rigid:.1e} Hz over the grid")
'''),
("md", r'''
**What the coupled model predicts that the split does not**

* At $x_\mathrm{ref}$ the split and the coupled model give the same K_F except the vertical stiffness
  $K_F(6,6)$, which the split lowers by about a fifth; $\omega_1$, $\omega_2$ and $\omega_4$–$\omega_6$ are
  identical, $\omega_3$ ($Z$ mode) is higher in the coupled model (figures above).
* Away from $x_\mathrm{ref}$ the coupled model needs no per-leg division and holds at every pose. There the
  two models also differ slightly in $\omega_1$ and $\omega_2$ (at most a few tenths of a hertz, largest at
  the top corners and edges of the box), and $\omega_3$ is 10–15 % higher in the coupled model everywhere.
* On the paper's measurements (modes $X$ and $Y$ at $x_\mathrm{ref}$ only) the two are indistinguishable; a
  measurement of the $Z$ mode at any pose, or of $\omega_2$ near the top of the workspace, would separate them.
'''),
("code", r'''
print(f"notebook ran in {time.perf_counter() - t_start:.1f} s")
'''),
]


# ----------------------------------------------------------------------------- 04
NB04 = [
("md", r'''
# 04 · The design space: lowest natural frequency over the workspace and the design

The lowest natural frequency $\omega_1$ limits how fast a parallel manipulator can move and be controlled
(Hoevenaars, Krut & Herder 2020, DOI 10.1016/j.mechmachtheory.2019.103775). Because eigentwist's
evaluators are generated closed forms with every design quantity as an input, mapping $\omega_1$ over
the workspace and over design parameters is a matter of large batched calls — here about 0.7 million
pose-and-design rows in total, on the NumPy backend (`backend="c"` is faster where a C compiler exists).

Model: the Heli4 with the **coupled** end-effector model (preset `coupled`: actuator loss, rod compliance
and the traveling plates joined to the tool by compliant couplings, issue 7), because it holds at every
pose; the paper's split of the end-effector compliance (Eqs. 45–49) is derived for $x_\mathrm{ref}$ only
(notebook 02 compares the two: their $\omega_1$ differ by at most 0.1 Hz at $k_a$ = 2000 N m/rad).
Frequencies in Hz, lengths in m, actuator stiffness $k_a$ in N m/rad.
'''),
("code", r'''
import time

import numpy as np
import matplotlib.pyplot as plt

import eigentwist

t_start = time.perf_counter()
MODEL = "coupled"
ev = eigentwist.load("heli4", backend="numpy")
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
'''),
("md", r'''
## 1 · ω1 over the workspace

Top row: three horizontal slices of the workspace box (bottom, reference height, top), 121 × 121 poses
each, $k_a$ = 2000 N m/rad, each with its own colour scale. Bottom row: two vertical slices through
$x_\mathrm{ref}$ and, for comparison, the second frequency $\omega_2$ at the reference height.
'''),
("code", r'''
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
'''),
("md", r'''
## 2 · The worst case over the box

A designer cares about the lowest $\omega_1$ anywhere in the workspace. Over a 41 × 41 × 41 grid of the box:
'''),
("code", r'''
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
'''),
("md", r'''
$\omega_1$ is lowest at the bottom of the workspace and highest at the top; across a horizontal slice it
varies by less than 0.5 Hz.

## 3 · ω1 against the design

Each design below is judged by its **worst-case** $\omega_1$ over a 7 × 7 × 7 grid of the box (343 poses,
corners and faces included; on the Heli4 design it finds the same minimum as the 41³ grid above). Every
row of a batch is one (design, pose) pair, so a 25 × 25 design map is one call of 214,375 rows. The
parallelogram length $l_2$ is varied over the range where the whole box stays reachable
(0.47–0.60 m).
'''),
("code", r'''
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
'''),
("code", r'''
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
'''),
("md", r'''
Within this range $k_a$ is the strongest lever (the frequency grows like $\sqrt{k_a}$ until the
end-effector assembly's compliance takes over, notebook 02); thinner rods help because their mass counts
more than their compliance (notebook 01); $l_2$ matters little near the Heli4's design and more at high
$k_a$, where shorter parallelograms are better. The same maps can be computed for the rigid-body
model (`"rigid"`) or with any effect switched on, at no extra generation cost.

## 4 · The same for a Delta robot

The Delta robot shipped with eigentwist (three RR(Π)RR legs at 120°, `eigentwist.robots.get("delta")`,
model `paper` = actuator loss + rod compliance) is evaluated by the same runtime: its $\omega_1$ at the
reference height and its worst case over its box against $l_2$ and $k_a$.
'''),
("code", r'''
delta = eigentwist.load("delta", backend="numpy")
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
'''),
("code", r'''
print(f"notebook ran in {time.perf_counter() - t_start:.1f} s")
'''),
]


NOTEBOOKS = {
    "01_closed_form.ipynb": NB01,
    "02_reproduce_paper.ipynb": NB02,
    "04_design_space.ipynb": NB04,
}


if __name__ == "__main__":
    sys.exit(main())
