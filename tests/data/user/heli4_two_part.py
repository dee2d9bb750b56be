"""The Heli4 with a cable chain written as two effects: its mass on the tool, its spring to ground along y."""

from dataclasses import replace

import sympy as sp

from eigentwist.description import Effect, Parameter
from eigentwist.robots import heli4

MASS = Effect(
    "chain_mass",
    "cable chain mass carried by the tool (a point mass at the EE origin)",
    params=(Parameter("m_chain", 0.2, "kg", "chain mass", effect="chain_mass", plausible=(0.0, 5.0)),),
    fit=("m_chain",),
    primitive="added_inertia",
    body="platform",
    build=lambda ctx: sp.diag(0, 0, 0, *[ctx.p["m_chain"]] * 3),
)
SPRING = Effect(
    "chain_spring",
    "cable chain stiffness: a spring to ground along y at the EE origin",
    params=(
        Parameter("k_chain", 1000.0, "N/m", "chain stiffness along y", effect="chain_spring", plausible=(10.0, 1e5)),
    ),
    fit=("k_chain",),
    primitive="ground_spring",
    build=lambda ctx: (sp.diag(0, 0, 0, 0, ctx.p["k_chain"], 0), sp.eye(3), (0, 0, 0)),
)


def describe():
    return replace(heli4.describe(), name="heli4_two_part", effects=heli4.EFFECTS + (MASS, SPRING))
