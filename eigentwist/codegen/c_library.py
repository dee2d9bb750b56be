"""The generated C as a library: a header ``<robot>_c.h`` and the entry points behind it.

Render only (strings come back). ``eigentwist generate`` writes, beside
``<robot>_c.c``, a header declaring (inside ``extern "C"`` guards, so that C++ callers
link against the C object):

* the model's inputs: their count ``ET_<ROBOT>_N_INPUTS``, one index macro
  ``ET_<ROBOT>_IN_<name>`` each, and a table of names, units and default values in the
  header's comments and as ``et_<robot>_input_names`` / ``et_<robot>_input_units``;
* ``et_<robot>_defaults(double *inputs)``: fills the robot's default model as
  ``Evaluator.frequencies`` solves it (the ``paper`` preset, every parameter at its
  default, each leg's copy at the shared value, and the rigid directions' stand-in
  compliance ``c_rigid`` at 0: the default model's legs have no rigid direction, so K_F is
  exact there, as the evaluator's route takes it, :data:`EXACT_DEFAULTS`);
* ``et_<robot>_frequencies(n, poses, inputs, hz, status)``: poses (n x pose width, the
  robot's pose coordinates, m and rad) to natural frequencies (Hz, n x ET_<ROBOT>_MODES,
  ascending) and per-pose status codes, the runtime's (:data:`STATUS`) and with the
  runtime's options (:data:`LEVER_TOL` relative to ``l1``, :data:`ROUNDOFF_EPS`);
* the lower-level functions of the source (kernels, fused pass, eigen-solver).

The input vector is the fused pass's inputs without the pose: parameters (SI units),
effect switches ``on_<effect>`` / ``on_<effect>__N`` (0 or 1) and each leg's copy
``P__N`` of a leg-level effect's parameter, in the generated code's order.
"""

from __future__ import annotations

import re

from ..errors import DescriptionError
from ..description.effects import leg_input_name, leg_switch_name, resolve_model, switch_name
from ..description.serial import padded_references

__all__ = [
    "LEVER_TOL",
    "LEVER_SCALE",
    "ROUNDOFF_EPS",
    "MAX_MODES",
    "DEFAULT_MODEL",
    "EXACT_DEFAULTS",
    "fused_input_names",
    "library_context",
    "render_c_header",
]

# The runtime's options of the fused pass (eigentwist.runtime.validity / .eigen hold the
# same values; tests/test_c_library.py checks they agree): the C library must give the
# frequencies and status codes that Evaluator.frequencies gives.
LEVER_TOL = 1e-3  # |w_a1 . t_a1| / l1 at or below this: singular pose
LEVER_SCALE = "l1"  # the lever is divided by this input (a robot without it: by 1)
ROUNDOFF_EPS = 1e-10  # eigenvalue below -eps * max|lambda| of the pose: unstable mode
MAX_MODES = 6  # columns of hz per pose
DEFAULT_MODEL = "paper"  # what et_<robot>_defaults switches on (Evaluator's default model)
#: inputs whose value in et_<robot>_defaults is not the description's default: the penalty
#: compliance of rigid directions is 0, K_F exact, as Evaluator.frequencies solves a model whose
#: legs have no rigid direction (every shipped robot's default model; tests/test_c_library.py)
EXACT_DEFAULTS = {"c_rigid": 0.0}
POSITION = ("x", "y", "z")
ROTATION = {f"R_{i}{j}": (i, j) for i in range(3) for j in range(3)}


def fused_input_names(kernels) -> list[str]:
    """The fused pass's inputs in order (as ``c_backend`` wires them): every input of the
    inverse kinematics, matrices (``matrices_lever`` where rendered) and jacobians kernels
    but the joint coordinates, each once, in order of first use."""
    by_name = {k.name: k for k in kernels}
    out: list[str] = []
    for kern in (
        by_name["inverse_kinematics"],
        by_name.get("matrices_lever", by_name["matrices"]),
        by_name["jacobians"],
    ):
        for name in kern.input_names:
            group = next(g for g, ns in kern.inputs if name in ns)
            if group != "q" and name not in out:
                out.append(name)
    return out


def _first_sentence(text: str, width: int = 110) -> str:
    """``text`` on one line, cut at a word boundary to at most ``width`` characters."""
    text = " ".join(str(text or "").split())
    if len(text) <= width:
        return text
    return text[:width].rsplit(" ", 1)[0] + " ..."


def _model_inputs(robot) -> dict:
    """name -> (unit, default, doc) of every parameter, leg copy and switch of ``robot``."""
    on = set(resolve_model(DEFAULT_MODEL, robot))
    params = {p.name: p for p in robot.parameters}
    out = {p.name: (p.unit, float(p.default), _first_sentence(p.doc)) for p in robot.parameters}
    for name in robot.effects:
        effect = robot.effect(name)
        flag = 1.0 if name in on else 0.0
        if not effect.leg_level:
            out[switch_name(name)] = ("-", flag, f"switch of effect {name} (0 or 1)")
            continue
        for k in range(1, len(robot.legs) + 1):
            for q in effect.params:
                p = params[q.name]
                out[leg_input_name(q.name, k)] = (p.unit, float(p.default), f"leg {k}'s own {q.name} ({name})")
            out[leg_switch_name(name, k)] = ("-", flag, f"switch of effect {name} on leg {k} (0 or 1)")
    for name, value in EXACT_DEFAULTS.items():
        if name in out:
            unit, _, doc = out[name]
            out[name] = (unit, value, f"{doc}; 0 in the defaults: the default model is exact")
    numeric = [getattr(getattr(leg, "kinematics", None), "reference", None) is not None for leg in robot.legs]
    if any(numeric):
        # legs in URDF form (numeric IK): the kernels read the joint coordinates solved by
        # Newton's method in the runtime; a C caller passes them (default: the reference;
        # legs that differ: padded to the largest leg's count, a padded one held at 0; a
        # closed-form leg among them computes its own)
        for k, (leg, row, own) in enumerate(zip(robot.legs, padded_references(robot.legs), numeric), start=1):
            for m, value in enumerate(row, start=1):
                real = m <= len(leg.kinematics.coordinates)
                if real and not own:
                    continue
                out[f"q{m}_{k}"] = (
                    "rad or m",
                    float(value),
                    f"leg {k}'s joint coordinate {m} (numeric IK: the caller solves it; default: the "
                    "reference configuration)"
                    if real
                    else f"leg {k}'s padded coordinate {m} (legs that differ: 0, no joint)",
                )
    return out


def _c_literal(value: float) -> str:
    text = repr(float(value))
    if text in ("inf", "-inf", "nan"):
        raise DescriptionError(f"default value {text} cannot be written as a C literal")
    return text


def _c_text(text: str) -> str:
    return text.replace("\\", "\\\\").replace('"', '\\"').replace("*/", "* /")


def library_context(robot, kernels, prefix: str) -> dict:
    """Everything the header and the library part of the C source need (pure)."""
    names = fused_input_names(kernels)
    table = _model_inputs(robot)
    pose = tuple(getattr(robot, "pose", POSITION))
    model_names = [n for n in names if n not in POSITION and n not in ROTATION]
    unknown = [n for n in model_names if n not in table]
    if unknown:
        raise DescriptionError(f"generated inputs {unknown} of {robot.name} are neither parameters nor effect inputs")
    index = {n: k for k, n in enumerate(model_names)}
    inputs = []
    for k, n in enumerate(model_names):
        unit, default, doc = table[n]
        inputs.append(
            dict(
                index=k,
                name=n,
                macro=re.sub(r"\W", "_", n),
                unit=_c_text(unit),
                default=_c_literal(default),
                doc=_c_text(doc),
            )
        )
    sources = []
    for n in names:
        if n in POSITION:
            sources.append((f"et_poses + {POSITION.index(n)}", "ET_POSE_WIDTH"))
        elif n in ROTATION:  # computed by the pass from the rotation vector (below): not read
            sources.append(("0", "0"))
        else:
            sources.append((f"et_inputs + {index[n]}", "0"))
    rotation = any(n in ROTATION for n in names)
    if rotation:  # the fused pass's inputs after its named ones: the rotation vector
        sources += [(f"et_poses + {3 + k}", "ET_POSE_WIDTH") for k in range(3)]
    effects = [robot.effect(e) for e in robot.effects]

    def switches(pick) -> list[int]:
        out = []
        for e in effects:
            if not pick(e):
                continue
            keys = (
                [leg_switch_name(e.name, k) for k in range(1, len(robot.legs) + 1)]
                if e.leg_level
                else [switch_name(e.name)]
            )
            out += [index[s] for s in keys if s in index]
        return out

    rigid_dim = 3 if len(pose) == 3 else 6
    upper = "ET_" + prefix[3:].upper()
    return dict(
        prefix=prefix,
        upper=upper,
        robot=robot,
        pose=pose,
        pose_width=len(pose),
        pose_units=", ".join(f"{p} ({'m' if p in POSITION else 'rad'})" for p in pose),
        rotation=rotation,
        inputs=inputs,
        n_inputs=len(inputs),
        sources=sources,
        n_fused=len(sources),
        structural=switches(lambda e: e.structural),
        preload=switches(lambda e: e.primitive == "preload"),
        rigid_dim=rigid_dim,
        modes=MAX_MODES,
        scale=names.index(LEVER_SCALE) if LEVER_SCALE in names else -1,
        lever_tol=repr(LEVER_TOL),
        roundoff=repr(ROUNDOFF_EPS),
        default_model=DEFAULT_MODEL,
        default_on=", ".join(resolve_model(DEFAULT_MODEL, robot)) or "none",
    )


def render_c_header(robot, kernels, digest: str) -> str:
    """Render ``<robot>_c.h`` (pure: returns a string); ``digest`` is the C source's hash."""
    from .render import environment, header

    prefix = "et_" + re.sub(r"\W", "_", robot.name)
    lib = library_context(robot, kernels, prefix)
    return (
        environment()
        .get_template("c/library.h.jinja")
        .render(header=header(robot.name, digest, comment="//"), lib=lib, robot=robot)
    )
