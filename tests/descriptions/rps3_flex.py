"""The 3-RPS of ``rps3.py`` with a structural compliance: a flexible model on a
lower-mobility platform (the followers x, y, rot_z move with the geometry's parameters).

``strut_bending``: each leg's compliance at the platform origin, c_b (m/N) along the three
translations and 5 c_b (rad/(N m)) about the three axes; with it the model uses K_F and
has six modes.
"""

import dataclasses
import importlib.util
from pathlib import Path

import sympy as sp

from eigentwist.description import Parameter
from eigentwist.description.effects import Effect

BENDING = Effect(
    "strut_bending",
    "each leg's compliance at the platform origin",
    params=(Parameter("c_b", 2e-7, "m/N", "leg compliance", effect="strut_bending", plausible=(1e-9, 1e-5)),),
    fit=("c_b",),
    structural=True,
    primitive="body_compliance",
    body="platform",
    build=lambda ctx: sp.diag(*[5 * ctx.p["c_b"]] * 3, *[ctx.p["c_b"]] * 3),
)


def describe():
    spec = importlib.util.spec_from_file_location("rps3", Path(__file__).with_name("rps3.py"))
    rps3 = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(rps3)
    return dataclasses.replace(rps3.describe(), name="rps3_flex", effects=(BENDING,))
