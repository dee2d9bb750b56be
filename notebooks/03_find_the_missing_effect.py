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
# # 03 — Find the missing effect
#
# The users' workflow: an engineer has measured natural frequencies, and the model does not
# match. eigentwist compares the model with the measurements, shows **where** it fails, ranks
# **which physical effect** of its catalogue is most likely missing, adds it and shows the
# **error fall**.
#
# We first prove the workflow on data with a *hidden* effect (we know the truth), then run it
# on the paper's real measurements (Hoevenaars, Krut & Herder 2020,
# DOI 10.1016/j.mechmachtheory.2019.103775, Tables E.1/E.2).

# %%
import io
import json

import matplotlib
matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from IPython.display import Image, Markdown, display

import eigentwist
from eigentwist.diagnose import compare, diagnose, paper_measurements, synth
from eigentwist.plots import plot_comparison, plot_diagnosis

ev = eigentwist.load("heli4")                 # backend="auto": C where a compiler exists, else NumPy


def show(plot, *args):
    buf = io.BytesIO()
    plot(args[0], buf, *args[1:])
    display(Image(buf.getvalue()))


# %% [markdown]
# ## 1. Measurements from a truth with a hidden effect
#
# The truth is the paper's model **plus a payload of 0.35 kg** on the end-effector, which
# the engineer's model (`paper`) does not know about. We "measure" the x, y and z modes at
# six actuator stiffnesses k_a (N m/rad) and two poses (m), with 0.5 % noise.

# %%
poses = np.array([[0.0, 0.0, -0.625], [0.06, -0.04, -0.60]])
k_a = [250, 500, 1000, 2000, 3000, 4000]
meas = synth("paper+payload_mass:m_p=0.35", k_a=k_a, poses=poses, modes=("x", "y", "z"),
             noise="0.5%", seed=3, ev=ev)
print(len(meas), "measured frequencies; first rows:")
print(meas.to_csv().splitlines()[:6])

# %% [markdown]
# ## 2. Compare: where does the model fail?
#
# Each measured frequency against the `paper` model: the error in % and in standard
# uncertainties σ. The shaded bands mark where |error| > 2σ.

# %%
cmp = compare(meas, "paper", ev)
print(f"RMS error {cmp.rms_pct:.2f} %, max {cmp.max_pct:.2f} %")
for item in cmp.where_it_fails():
    print(item)
show(plot_comparison, cmp, ev)

# %% [markdown]
# ## 3. Diagnose: which effect is missing?
#
# For every catalogue effect that the baseline lacks, eigentwist fits the effect's
# parameters (bounded, weighted least squares on the frequencies, reusing the generated
# evaluator) and ranks the effects by an information criterion (AICc) with the significance
# of the improvement. It then adds the best significant effect and repeats.

# %%
d = diagnose(meas, baseline="paper", ev=ev)
out = d.to_json()
rows = ["| rank | effect | fitted parameters | RMS % | max % | p-value | indistinguishable from |", "|---|---|---|---|---|---|---|"]
for k, c in enumerate(out["ranking"][:6], start=1):
    pars = "; ".join(f"{n} = {v:.4g} ± {(c['param_std'][n] or float('nan')):.2g}" for n, v in c["params"].items())
    rows.append(f"| {k} | `{c['effect']}` | {pars} | {c['rms_pct']:.2f} | {c['max_pct']:.2f} | {c['p_value']:.2g} | {', '.join(c['indistinguishable_from'])} |")
display(Markdown("\n".join(rows)))
print("selected:", out["selected"])
print("the truth was m_p = 0.35 kg")

# %% [markdown]
# ## 4. Add it and watch the error fall
#
# The steps of the forward selection, and the final verdict: does the model now explain the
# data within the measurement uncertainty?

# %%
for s in out["steps"]:
    print(f"{' + '.join(s['effects']):60s} RMS {s['rms_pct']:6.2f} %   max {s['max_pct']:6.2f} %")
print(out["final"]["message"])
show(plot_diagnosis, d, ev)

# %% [markdown]
# The engineer can also add an effect by hand and see the new comparison
# (`eigentwist diagnose DATA.csv --add payload_mass` on the command line):

# %%
manual = diagnose(meas, baseline="paper", add=["payload_mass"], ev=ev).to_json()
print(manual["final"]["effects"], f"RMS {manual['final']['rms_pct']:.2f} %", manual["final"]["params"])

# %% [markdown]
# ## 5. The same on the paper's real measurements
#
# Starting from the `rigid` model (actuator stiffness only, Eq. 14), which errs by 13.6 % RMS
# and 32.9 % at most on these data. The paper's Appendix E concludes that the end-effector
# assembly compliance is significant and the rod compliance is not.

# %%
real = paper_measurements(ev)
d = diagnose(real, baseline="rigid", ev=ev)
out = d.to_json()
print(f"rigid: RMS {out['baseline']['rms_pct']:.1f} %, max {out['baseline']['max_pct']:.1f} %")
for c in out["ranking"]:
    print(f"{c['effect']:25s} RMS {c['rms_pct']:5.2f} %  p = {c['p_value']:.2g}  params {json.dumps({k: round(v, 4) for k, v in c['params'].items()})}"
          + (f"  indistinguishable from {c['indistinguishable_from']}" if c['indistinguishable_from'] else ""))
print("selected:", out["selected"])
for s in out["steps"]:
    print(f"{' + '.join(s['effects']):55s} RMS {s['rms_pct']:6.2f} %   max {s['max_pct']:6.2f} %")
print("paper's static test (App. D): k_E_rot = 500 N m/rad, k_E_lin = 1.3e5 N/m")
print("next measurement:", out["next_measurement"])
show(plot_diagnosis, d, ev)

# %% [markdown]
# `ee_compliance` (the paper's split of the end-effector compliance) and `ee_coupling`
# (the plates coupled to the tool, valid at every pose) cannot be told apart with modes x
# and y only: they differ in the vertical mode. The diagnosis proposes the measurement that
# separates them best.
