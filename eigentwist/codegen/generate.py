"""Regenerate the evaluators in ``eigentwist/generated/`` (render, write, check).

``render_all`` returns ``{relative path: text}`` without touching the disk;
``write`` writes; ``stale`` compares with what is checked in. The command line
``eigentwist generate [--check]`` wraps these.
"""

from __future__ import annotations

import hashlib
import time
from pathlib import Path

from ..generated import FILES
from ..outputs import write_atomic
from ..robots import NAMES, get
from ..symbolic import POSE, derive
from ..symbolic.model import EffectSymbols
from .c_source import render_c
from .c_library import render_c_header
from .kernel import Kernel, Output, build_kernel, source_hash, sub_kernel
from .numpy_backend import render_numpy
from .render import TEMPLATES

__all__ = [
    "GENERATED",
    "joints_per_leg",
    "kernels_for",
    "fused_kernels_for",
    "cse_kernels",
    "matrices_kernels",
    "render_robot",
    "render_all",
    "write",
    "stale",
    "TARGETS",
    "PROGRESS_STEPS",
]

GENERATED = Path(__file__).resolve().parent.parent / "generated"

KERNEL_DOCS = {
    "inverse_kinematics": "Joint angles of every leg for end-effector positions (facts file IK).",
    "matrices": (
        "Cartesian inertia M (Eq. 12), rigid-body stiffness K_R (Eq. 14) and flexible-body stiffness K_F (Eq. 13, "
        "tau_e = 0) at the EE origin."
    ),
    "jacobians": (
        "Inverse-Jacobian rows of joints 1, 2, 3 and the virtual joint of every leg (Huang's method), and the "
        "actuation levers (m)."
    ),
    "matrices_lever": (
        "The matrices kernel with each leg's actuation lever (m) as a further output: the fused C pass checks "
        "singularity without the jacobians kernel."
    ),
    "followers": (
        "Each leg's closure equations (m, zero where the platform can be) and their rates along the platform's six "
        "unit twists, for the followers of a lower-mobility pose space."
    ),
    "followers_legs": (
        "Loop-closure residual of every leg (orientation error, rad, then position, m), its exact Jacobian with "
        "respect to the leg's coordinates and its rates along the platform's six unit twists, for the followers of "
        "a lower-mobility pose space solved with the legs' coordinates."
    ),
    "lever": (
        "Each leg's actuation lever (m) alone, the jacobians kernel's output: the sign the damped Newton inverse "
        "kinematics checks against the assembly branch recorded at x_ref."
    ),
    "loop_closure": (
        "Loop-closure residual of every leg at its joint coordinates and the pose (orientation error, rad, then "
        "position, m) and its exact Jacobian with respect to the leg's coordinates, for the damped Newton inverse "
        "kinematics."
    ),
    "legs": (
        "Each leg's elastic-joint rows Je, their compliance Cq without the rigid-constraint penalty (rigid "
        "directions exact zeros), the springs K_ground in parallel with the legs, and each coupling's twists G_c and "
        "stiffnesses K_c: the exact condensation of rigid constraints."
    ),
    "gravity": (
        "Matrices G multiplying the elastic joint torques in the first term of Eq. 13, each leg's elastic joint "
        "stiffness Kqe (Eq. 40), each leg's series actuator stiffness k_act and the static preload wrench W on the "
        "platform."
    ),
}
SYMMETRIC = {"M", "K_R", "K_F", "Kqe"}


def pose_split(model) -> tuple[list, list[str]]:
    """(position symbols x, y, z, the other pose inputs' names): the backends take the
    position as the inverse kinematics' arguments and any further pose input (a 6-DoF
    robot's rotation matrix entries R_ij) through the parameter dict."""
    pose = list(getattr(model, "pose_inputs", POSE))
    return pose[:3], [s.name for s in pose[3:]]


def joints_per_leg(model) -> int:
    """Joint coordinates per leg in the IK output ``q`` (3 for the Heli4/Delta, 1 for the hexapod)."""
    return int(model.ik_outputs["q"][0][-1])


def kernels_for(model, progress=None) -> list[Kernel]:
    """CSE'd kernels of a derived model, in a fixed order.

    The kernels after the inverse kinematics take the joint coordinates ``q`` and the
    parameters; a model whose program also reads the pose (a 6-DoF robot) takes it
    through the parameter dict (names from ``model.pose_inputs``).
    """
    return cse_kernels(model, progress)[0]


def fused_kernels_for(model) -> list[Kernel]:
    """Kernels only the C backend's fused pass uses: ``matrices_lever`` (M, K_R, K_F and
    the jacobians kernel's ``lever``, CSE'd together: the levers are intermediates of K_R,
    so the singularity check costs nothing). Empty when the model has no levers."""
    return matrices_kernels(model)[1]


def _program_inputs(model) -> tuple[list[str], int]:
    """The parameter inputs of the kernels after the inverse kinematics (the parameters, and a
    6-DoF robot's pose through them) and the joint coordinates per leg."""
    position, rotation = pose_split(model)
    return list(model.inputs) + [s.name for s in position] + rotation, joints_per_leg(model)


def matrices_kernels(model) -> tuple[Kernel, list[Kernel]]:
    """``(matrices, fused)``: the matrices kernel (M, K_R, K_F) and :func:`fused_kernels_for`'s
    kernels, from one CSE. Where the model has levers, the matrices and the levers are CSE'd
    together as ``matrices_lever`` and the matrices kernel is its part without the levers
    (:func:`~.kernel.sub_kernel`; for the shipped robots and the gallery the same text as a
    CSE of the matrices alone, for half the CSE time: ``benchmarks/render.py --cse``)."""
    params, nq = _program_inputs(model)
    outs = [Output(k, sh, ex, symmetric=k in SYMMETRIC) for k, (sh, ex) in model.outputs["matrices"].items()]
    if "lever" not in model.outputs["jacobians"]:
        return build_kernel("matrices", KERNEL_DOCS["matrices"], model.program, outs, [], model.joints, params, nq), []
    names = [out.name for out in outs]
    outs.append(Output("lever", *model.outputs["jacobians"]["lever"]))
    doc = KERNEL_DOCS["matrices_lever"]
    both = build_kernel("matrices_lever", doc, model.program, outs, [], model.joints, params, nq)
    return sub_kernel(both, "matrices", KERNEL_DOCS["matrices"], names), [both]


def cse_kernels(model, progress=None) -> tuple[list[Kernel], list[Kernel]]:
    """``(kernels_for(model), fused_kernels_for(model))`` from one CSE of each group (the
    matrices and the levers once: :func:`matrices_kernels`)."""
    position, rotation = pose_split(model)
    params = list(model.inputs)
    program_params, nq = _program_inputs(model)
    kernels = []
    ik_outs = [Output(k, sh, ex) for k, (sh, ex) in model.ik_outputs.items()]
    kernels.append(
        build_kernel(
            "inverse_kinematics",
            KERNEL_DOCS["inverse_kinematics"],
            model.ik,
            ik_outs,
            position,
            [],
            params + rotation + list(model.ik_joint_inputs),
        )
    )
    if model.closure is not None:
        outs = [Output(k, sh, ex) for k, (sh, ex) in model.closure_outputs.items()]
        kernels.append(
            build_kernel(
                "loop_closure", KERNEL_DOCS["loop_closure"], model.closure, outs, [], model.joints, program_params, nq
            )
        )
    for group in ("matrices", "jacobians", "gravity", "legs"):
        if progress:
            progress(f"CSE {group}")
        if group == "matrices":
            matrices, fused = matrices_kernels(model)
            kernels.append(matrices)
            continue
        outs = [Output(k, sh, ex, symmetric=k in SYMMETRIC) for k, (sh, ex) in model.outputs[group].items()]
        kernels.append(
            build_kernel(group, KERNEL_DOCS[group], model.program, outs, [], model.joints, program_params, nq)
        )
    if model.closure is not None and "lever" in model.outputs["jacobians"]:
        # the branch check of every Newton solution reads the levers only: CSE'd alone they
        # take ~40 % of the jacobians kernel's statements (6-RUS: 518; its part of the
        # jacobians kernel, CSE'd with the other rows, 704)
        outs = [Output("lever", *model.outputs["jacobians"]["lever"])]
        kernels.append(
            build_kernel("lever", KERNEL_DOCS["lever"], model.program, outs, [], model.joints, program_params, nq)
        )
    if getattr(model, "followers", None) is not None:  # the runtime's Newton steps
        prog, closure = model.followers
        outs = [Output(k, sh, ex) for k, (sh, ex) in closure.items()]
        if model.closure is not None:  # legs solved numerically: their loop closures, read at (q, p)
            kernels.append(
                build_kernel(
                    "followers", KERNEL_DOCS["followers_legs"], prog, outs, [], model.joints, program_params, nq
                )
            )
        else:
            kernels.append(
                build_kernel("followers", KERNEL_DOCS["followers"], prog, outs, position, [], params + rotation)
            )
    return kernels, fused


def _compiled(kernel: Kernel) -> bool:
    """Whether the C backend compiles ``kernel``: all but the followers kernel of legs
    solved numerically (its Newton steps, on every leg's coordinates at once, run in NumPy);
    the followers kernel of closed-form legs is iterated by the C driver
    (:mod:`eigentwist.runtime.c_levenberg_marquardt`)."""
    return kernel.name != "followers" or not any(names for group, names in kernel.inputs if group == "q")


def _template_text(backend: str) -> str:
    return "".join(p.read_text() for p in sorted((TEMPLATES / backend).glob("*.jinja")))


def _render_numpy(robot, kernels, digest):
    return render_numpy(robot, kernels, digest, EffectSymbols(robot).switches())


#: the files rendered per robot (target -> file name, renderer); the C header shares the C
#: source's templates and hash (one library, two files). The runtime's backends that run
#: them are :data:`eigentwist.runtime.loader.BACKENDS`.
TARGETS = {
    "numpy": (FILES["numpy"], _render_numpy),
    "c": (FILES["c"], render_c),
    "c_header": (FILES["c_header"], render_c_header),
}
TEMPLATE_DIR = {"c_header": "c"}
# progress messages of render_robot per robot (every backend): derive, CSE of the matrices
# (with the levers: the fused pass's matrices_lever), jacobians, gravity and legs kernels, one
# per file emitted
PROGRESS_STEPS = 5 + len(TARGETS)


def render_robot(
    robot, progress=None, timings: dict | None = None, backends=None, stages: dict | None = None
) -> dict[str, str]:
    """Derive, CSE and render every backend (or those in ``backends``): ``{filename: text}``
    (nothing written).

    ``robot`` is a robot name or a :class:`~eigentwist.description.RobotDescription`
    (e.g. a modified copy of a shipped one, for design studies in memory). ``stages``: a
    dict owned by the caller that keeps the derived model and its CSE'd kernels between
    calls on the same description, so a backend rendered later derives nothing again.
    """
    description = get(robot) if isinstance(robot, str) else robot
    name = description.name
    timings = {} if timings is None else timings
    stages = {} if stages is None else stages
    say = (lambda m: progress(f"{name}: {m}")) if progress else None
    t0 = time.perf_counter()
    if "model" not in stages:
        if say:
            say("derive")
        stages["model"] = derive(description)
    model = stages["model"]
    t1 = time.perf_counter()
    if "kernels" not in stages:
        stages["kernels"], stages["fused"] = cse_kernels(model, progress=say)
    kernels = stages["kernels"]
    t2 = time.perf_counter()
    files = {}
    for backend, (pattern, render) in TARGETS.items():
        if backends is not None and backend not in backends:
            continue
        ks = [k for k in kernels if _compiled(k)] + stages["fused"] if backend in ("c", "c_header") else kernels
        if say:
            say(f"emit {pattern.format(robot=name)}")
        digest = source_hash(ks, _template_text(TEMPLATE_DIR.get(backend, backend)))
        files[pattern.format(robot=name)] = render(model.robot, ks, digest)
    t3 = time.perf_counter()
    timings[name] = {"derive_s": t1 - t0, "cse_s": t2 - t1, "emit_s": t3 - t2}
    return files


def digests_text(files: dict[str, str]) -> str:
    """``<robot>.sha256``: the SHA-256 of each rendered file's UTF-8 bytes, one line
    ``HEX  NAME`` per file in name order (``sha256sum -c`` reads it; the runtime checks a
    generated file against it before importing or compiling it:
    :func:`eigentwist.runtime.ccompile.read_shipped`)."""
    return "".join(
        f"{hashlib.sha256(text.encode('utf-8')).hexdigest()}  {name}\n" for name, text in sorted(files.items())
    )


def render_all(robots=NAMES, progress=None, timings=None) -> dict[str, str]:
    """Render the generated files of every robot, and each robot's ``<robot>.sha256``
    (:func:`digests_text`); nothing is written."""
    files = {}
    for name in robots:
        rendered = render_robot(name, progress=progress, timings=timings)
        files.update(rendered)
        files[f"{name}.sha256"] = digests_text(rendered)
    return files


def write(files: dict[str, str], directory: Path = GENERATED) -> list[Path]:
    """Write rendered files into ``directory``; return the paths written."""
    directory.mkdir(parents=True, exist_ok=True)
    written = []
    for rel, text in files.items():
        path = directory / rel
        write_atomic(path, text.encode("utf-8"))
        written.append(path)
    return written


def stale(files: dict[str, str], directory: Path = GENERATED) -> list[str]:
    """Names of files whose checked-in bytes differ from the rendered text."""
    out = []
    for rel, text in files.items():
        path = directory / rel
        if not path.exists() or path.read_bytes() != text.encode("utf-8"):
            out.append(rel)
    return out
