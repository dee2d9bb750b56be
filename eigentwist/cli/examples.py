"""Examples in ``--help`` for the robot the user named (``--robot hexapod --help``).

The subcommands' epilogs show Heli4 examples; with ``--robot R`` for another shipped
robot, their ``examples:`` block is replaced by the same kinds of call written in R's
terms: its reference pose (m, and rad for a 6-DoF robot), its k_a (N m/rad or N/m), one
of its geometry parameters and one of its leg-level effects.
"""

from __future__ import annotations

import re

__all__ = ["robot_examples", "adapt_epilog", "requested_robot"]


def _fmt(values) -> str:
    return " ".join(f"{v:g}" for v in values)


def robot_examples(command: str, robot: str) -> list[str] | None:
    """Example lines of ``command`` for the shipped ``robot`` (None: keep the epilog's)."""
    from ..robots import get

    d = get(robot)
    pose = list(d.x_ref)
    pose2 = [pose[0] + 0.05] + pose[1:]
    params = {p.name: p for p in d.parameters}
    ka = params["k_a"]
    geo = next(p for p in d.parameters if p.unit == "m" and p.effect is None and p.default > 0)
    leg = next((e for e in d.effects if d.effect(e).leg_level), None)
    payload = "payload_mass" if "payload_mass" in d.effects else None
    r = f"--robot {robot}"
    ka_text = f"{ka.default:g} {ka.unit}"
    grid = " ".join(["5"] * len(pose))
    lo, hi = 0.9 * geo.default, 1.1 * geo.default
    truth = "paper+payload_mass:m_p=0.5" if payload else "paper"
    table = {
        "matrices": [
            f"eigentwist matrices {r}           # at x_ref = [{', '.join(f'{v:g}' for v in pose)}], k_a = {ka_text}",
            f"eigentwist matrices {r} --pose {_fmt(pose2)} --k-a {0.5 * ka.default:g} --json",
            f"eigentwist matrices {r} --model rigid{',payload_mass --set m_p=0.5' if payload else ''}",
        ],
        "compare": [
            f"eigentwist compare data.csv {r} --model rigid",
            f"eigentwist compare data.csv {r} --model paper --set {geo.name}={1.05 * geo.default:g}",
        ],
        "diagnose": [f"eigentwist diagnose data.csv {r} --baseline paper --json"]
        + ([f"eigentwist diagnose data.csv {r} --add {leg}@2"] if leg else []),
        "synth": [
            f"eigentwist synth {r} --truth {truth} --k-a {0.5 * ka.default:g},{ka.default:g} \\",
            f"    --pose {_fmt(pose)} --pose {_fmt(pose2)} --noise 0.5% --seed 1 -o data.csv",
        ],
        "sweep": [f"eigentwist sweep {r} --grid {grid} --k-a {0.5 * ka.default:g}:{2 * ka.default:g}:4 -o sweep"],
        "sensitivity": [
            f"eigentwist sensitivity {r} --pose {_fmt(pose2)}",
            f"eigentwist sensitivity {r} --wrt {geo.name},k_a",
        ],
        "optimize": [f"eigentwist optimize {r} --vary {geo.name}={lo:g}:{hi:g} --pose {_fmt(pose)}"],
        "report": [f"eigentwist report data.csv {r} -o report.html"],
        "identify": [f"eigentwist identify campaign/manifest.csv {r} -o identified.csv"],
    }
    return table.get(command)


def adapt_epilog(epilog: str | None, command: str, robot: str) -> str | None:
    """``epilog`` with its ``examples:`` block (up to the next blank line) in ``robot``'s terms."""
    lines = robot_examples(command, robot) if epilog else None
    if not lines or "examples:" not in epilog:
        return epilog
    head, _, rest = epilog.partition("examples:")
    block_end = re.search(r"\n\s*\n", rest)
    tail = rest[block_end.start() :] if block_end else "\n"
    return head + f"examples ({robot}):\n" + "\n".join(f"  {ln}" for ln in lines) + tail


def requested_robot(argv: list[str]) -> str | None:
    """The shipped robot named by ``--robot R`` on a ``--help`` command line, else None."""
    from ..robots import NAMES

    if not any(a in ("-h", "--help") for a in argv):
        return None
    for k, a in enumerate(argv):
        value = (
            a.partition("=")[2]
            if a.startswith("--robot=")
            else argv[k + 1]
            if a == "--robot" and k + 1 < len(argv)
            else None
        )
        if value in NAMES and value != "heli4":
            return value
    return None
