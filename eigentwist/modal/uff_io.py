"""Universal File Format (UFF) in and out, through ``pyuff`` (no parser of our own).

* Dataset 58 (function at nodal DOF), function type 4 (FRF): any layout. Every FRF is
  one (response DOF, reference DOF) pair, a DOF being a node and a translation axis of
  the base frame (``"3+X"``): uniaxial or triaxial accelerometers at any nodes, a roving
  hammer, a shaker; a pair need not be measured for every combination. A ``-X``
  response or reference is read as ``+X`` with the FRF's sign flipped. Rotational DOFs
  (directions 4-6) are skipped. The form comes from each dataset's ordinate specific
  data type: 8 displacement -> receptance, 11 velocity -> mobility, 12 acceleration ->
  accelerance (denominator 13, excitation force, or 0); a file mixing forms is brought
  to the highest one present (receptance x i w = mobility, x (i w)^2 = accelerance, a
  product, so the 0 Hz line stays finite). The abscissa must be frequency in Hz
  (abscissa specific data type 18, or 0 unknown) and shared by every FRF of the file.
* Dataset 15 or 2411 (nodes): node coordinates, read as the node's offset from the
  end-effector origin in platform axes, m (a campaign manifest's node columns override
  them; see :mod:`.campaign`).
* Dataset 55 (data at nodes), normal modes (analysis type 2) or complex modes (3, 7):
  already identified modes; the shape is the translation (r1, r2, r3) at the node.

Every error is one line ``FILE, dataset K (type T): what is wrong`` (K counts from 1).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..outputs import atomic_path
from ..runtime import InputError

__all__ = [
    "FrfSet",
    "ModeSet",
    "UffError",
    "read_uff",
    "write_frf_uff",
    "write_modes_uff",
    "dof_label",
    "node_coordinates",
    "parse_dof",
    "FORM_OF_ORDINATE",
    "ORDINATE_OF_FORM",
]

FORM_OF_ORDINATE = {8: "receptance", 11: "mobility", 12: "accelerance"}
ORDINATE_OF_FORM = {v: k for k, v in FORM_OF_ORDINATE.items()}
AXIS = {1: "X", 2: "Y", 3: "Z"}
FORM_RANK = {"receptance": 0, "mobility": 1, "accelerance": 2}  # powers of i w


def dof_label(node: int, axis: int) -> str:
    """``"NODE+AXIS"`` of a translation DOF (``axis`` 1, 2, 3 for X, Y, Z), e.g. ``"3+Y"``."""
    return f"{int(node)}+{AXIS[abs(int(axis))]}"


def parse_dof(label: str) -> tuple[int, int]:
    """(node, axis 1..3) of a DOF label ``"NODE+AXIS"``."""
    node, _, axis = label.partition("+")
    return int(node), "XYZ".index(axis) + 1


class UffError(InputError):
    """Bad UFF input; the message names the file and, where it applies, the dataset."""

    def __init__(self, source, message: str, dataset: int | None = None, kind: int | None = None):
        where = str(source)
        if dataset is not None:
            where += f", dataset {dataset + 1}" + (f" (type {kind})" if kind is not None else "")
        super().__init__(f"{where}: {message}")


@dataclass
class FrfSet:
    """FRFs of one setting, any layout.

    freq_hz : (F,) frequency axis, Hz.
    H : (F, P) complex, one column per measured pair ``pairs[p] = (o, r)``: response
        ``responses[o]`` over reference ``references[r]``.
    responses, references : DOF labels ``"NODE+AXIS"`` (e.g. ``"1+X"``).
    form : ``"accelerance"``, ``"mobility"`` or ``"receptance"`` (every column).
    coords : node -> (3,) position from the file's dataset 15/2411, m (may be empty).
    node : the node a dataset 55 file or ``sensor_*`` columns refer to; source : file name.
    """

    freq_hz: np.ndarray
    H: np.ndarray
    responses: list
    references: list
    pairs: list
    form: str
    coords: dict = field(default_factory=dict)
    node: int = 1
    source: str = "<uff>"

    @classmethod
    def from_grid(cls, freq_hz, H, responses, references, form, **kw) -> "FrfSet":
        """From a full grid ``H`` (F, O, R) (every response over every reference)."""
        H = np.asarray(H, dtype=complex)
        pairs = [(o, r) for o in range(H.shape[1]) for r in range(H.shape[2])]
        return cls(
            np.asarray(freq_hz, dtype=float),
            np.stack([H[:, o, r] for o, r in pairs], axis=1),
            list(responses),
            list(references),
            pairs,
            form,
            **kw,
        )

    def pair_label(self, p: int) -> str:
        o, r = self.pairs[p]
        return f"{self.responses[o]} / {self.references[r]}"


@dataclass
class ModeSet:
    """Identified modes of one setting (dataset 55).

    freq_hz : (n,) Hz; damping_ratio : (n,) (NaN where the file gives none);
    shapes : (n, 3) translation along +X, +Y, +Z at the node (complex for complex modes).
    """

    freq_hz: np.ndarray
    damping_ratio: np.ndarray
    shapes: np.ndarray
    node: int = 1
    source: str = "<uff>"


def _sets(path: Path) -> list[dict]:
    import pyuff

    if not path.is_file():
        raise UffError(path, "no such file (expected a UFF file with dataset 58 FRFs or dataset 55 modes)")
    try:
        uff = pyuff.UFF(str(path))
        n = uff.get_n_sets()
        sets = uff.read_sets() if n else []
    except Exception as exc:  # pyuff raises bare Exception on malformed files
        raise UffError(path, f"not a readable UFF file ({exc})") from None
    sets = [sets] if isinstance(sets, dict) else list(sets)
    _check_complete(path, sets)
    return sets


def _delimiters(path: Path) -> list[tuple[int, str]]:
    """(line number, the next line's first field) of each ``-1`` delimiter line of the file."""
    out = []
    with open(path, "rb") as f:
        lines = f.read().split(b"\n")
    for i, line in enumerate(lines):
        if line.strip() == b"-1":
            following = lines[i + 1].split() if i + 1 < len(lines) else []
            out.append((i + 1, following[0].decode("ascii", "replace") if following else ""))
    return out


def _check_complete(path: Path, sets: list[dict]) -> None:
    """A UFF file's datasets each open and close with a ``-1`` line; pyuff drops a dataset
    whose closing line is missing (a file cut short) without a word, and reads the points
    present of a dataset cut inside. Raise :class:`UffError` naming the dataset instead."""
    marks = _delimiters(path)
    if len(marks) % 2:
        line, kind = marks[-1]
        number = len(marks) // 2
        raise UffError(
            path,
            f"truncated: the dataset opened on line {line} has no closing -1 line (the file ends "
            f"after {number} complete dataset{'s' if number != 1 else ''}); write the file again",
            number,
            int(kind) if kind.isdigit() else None,
        )
    if len(sets) != len(marks) // 2:
        raise UffError(
            path, f"{len(marks) // 2} datasets delimited by -1 lines, but {len(sets)} read: the file is damaged"
        )
    for k, s in enumerate(sets):
        if s.get("type") == 58 and s.get("num_pts") is not None and "data" in s:
            n, got = int(s["num_pts"]), len(s["data"])
            if got != n:
                raise UffError(
                    path,
                    f"{got} data points where its header says {n}: the dataset is truncated or inconsistent",
                    k,
                    58,
                )


def read_uff(path, node: int = 1):
    """Read the FRFs (dataset 58) or modes (dataset 55 at ``node``) of one setting's file.

    Returns :class:`FrfSet` when the file holds dataset 58 FRFs, else :class:`ModeSet`.
    """
    path = Path(path)
    sets = _sets(path)
    types = [s.get("type") for s in sets]
    if 58 in types:
        return _frfs(path, sets, node)
    if 55 in types:
        return _modes(path, sets, node)
    found = ", ".join(str(t) for t in dict.fromkeys(types)) or "none"
    raise UffError(path, f"no dataset 58 (FRF) or 55 (modes) in the file (datasets found: {found})")


def _form(path, k: int, s: dict) -> str:
    ordinate = int(s.get("ordinate_spec_data_type", 0) or 0)
    denom = int(s.get("orddenom_spec_data_type", 0) or 0)
    if ordinate not in FORM_OF_ORDINATE:
        raise UffError(
            path,
            f"ordinate specific data type {ordinate} is not displacement (8), velocity (11) or "
            "acceleration (12): cannot tell receptance, mobility or accelerance",
            k,
            58,
        )
    if denom not in (0, 13):
        raise UffError(path, f"ordinate denominator type {denom}: expected excitation force (13)", k, 58)
    abscissa = int(s.get("abscissa_spec_data_type", 0) or 0)
    if abscissa not in (0, 18):
        raise UffError(path, f"abscissa specific data type {abscissa}: expected frequency in Hz (18)", k, 58)
    return FORM_OF_ORDINATE[ordinate]


def node_coordinates(sets: list[dict]) -> dict:
    """node -> (3,) coordinates from datasets 15 and 2411 (later datasets win)."""
    coords = {}
    for s in sets:
        if s.get("type") in (15, 2411):
            for n, x, y, z in zip(s["node_nums"], s["x"], s["y"], s["z"]):
                coords[int(n)] = np.array([x, y, z], dtype=float)
    return coords


def _frfs(path: Path, sets: list[dict], node: int) -> FrfSet:
    columns: dict[tuple, tuple] = {}  # (response, reference) -> (form, data, dataset)
    axis = None
    for k, s in enumerate(sets):
        if s.get("type") != 58 or int(s.get("func_type", 0)) != 4:
            continue
        rdir, fdir = int(s["rsp_dir"]), int(s["ref_dir"])
        if abs(rdir) not in AXIS or abs(fdir) not in AXIS:
            continue
        form = _form(path, k, s)
        x = np.asarray(s["x"], dtype=float)
        if axis is None:
            axis = (x, k)
        elif x.shape != axis[0].shape or not np.allclose(x, axis[0], rtol=1e-9, atol=1e-9):
            raise UffError(
                path,
                f"inconsistent frequency axes: {len(x)} points {x[0]:g}..{x[-1]:g} Hz where "
                f"dataset {axis[1] + 1} has {len(axis[0])} points {axis[0][0]:g}..{axis[0][-1]:g} Hz",
                k,
                58,
            )
        pair = (dof_label(s["rsp_node"], rdir), dof_label(s["ref_node"], fdir))
        if pair in columns:
            raise UffError(
                path, f"FRF {pair[0]} / {pair[1]} given twice (first in dataset {columns[pair][2] + 1})", k, 58
            )
        data = np.sign(rdir) * np.sign(fdir) * np.asarray(s["data"], dtype=complex)
        if not np.all(np.isfinite(data[1:])):
            raise UffError(path, f"FRF {pair[0]} / {pair[1]} has non-finite values above 0 Hz", k, 58)
        columns[pair] = (form, data, k)
    if not columns:
        raise UffError(
            path,
            "no FRF (dataset 58, function type 4) with a translational response and reference (directions X, Y, Z)",
        )
    freq = axis[0]
    target = max((c[0] for c in columns.values()), key=FORM_RANK.get)
    iw = 2j * np.pi * freq
    responses = list(dict.fromkeys(p[0] for p in columns))
    references = list(dict.fromkeys(p[1] for p in columns))
    pairs, H = [], []
    for (o, r), (form, data, _) in columns.items():
        pairs.append((responses.index(o), references.index(r)))
        H.append(np.nan_to_num(data * iw ** (FORM_RANK[target] - FORM_RANK[form])))
    return FrfSet(
        freq, np.stack(H, axis=1), responses, references, pairs, target, node_coordinates(sets), node, str(path)
    )


def _modes(path: Path, sets: list[dict], node: int) -> ModeSet:
    freq, zeta, shapes = [], [], []
    for k, s in enumerate(sets):
        if s.get("type") != 55:
            continue
        kind = int(s.get("analysis_type", 0))
        nodes = list(np.asarray(s.get("node_nums", []), dtype=int))
        if node not in nodes:
            raise UffError(path, f"no shape at node {node} (nodes: {', '.join(map(str, nodes[:10]))})", k, 55)
        j = nodes.index(node)
        if kind == 2:
            f, z = float(s["freq"]), float(s.get("modal_damp_vis", np.nan))
        elif kind in (3, 7):
            lam = complex(s["eig"])
            f, z = abs(lam) / (2 * np.pi), -lam.real / abs(lam)
        else:
            raise UffError(path, f"analysis type {kind}: expected normal modes (2) or complex modes (3, 7)", k, 55)
        if not f > 0:
            raise UffError(path, f"mode frequency {f:g} Hz: expected a value > 0", k, 55)
        freq.append(f)
        zeta.append(z if z > 0 else np.nan)
        shapes.append([complex(s[c][j]) for c in ("r1", "r2", "r3")])
    return ModeSet(np.array(freq), np.array(zeta), np.array(shapes), node, str(path))


def write_frf_uff(path, frfs: FrfSet) -> Path:
    """Write an :class:`FrfSet` as dataset 58 (ASCII, double precision), one per measured pair,
    after a dataset 15 with its node coordinates (when it has any).

    The abscissa is stored with 6 significant digits (E13.5, the format's own): use a
    frequency step that it holds exactly.
    """
    import pyuff

    path = Path(path)
    sets = []
    if frfs.coords:
        nodes = sorted(frfs.coords)
        xyz = np.array([frfs.coords[n] for n in nodes], dtype=float).reshape(-1, 3)
        sets.append(
            pyuff.prepare_15(
                node_nums=nodes,
                def_cs=[0] * len(nodes),
                disp_cs=[0] * len(nodes),
                color=[1] * len(nodes),
                x=xyz[:, 0],
                y=xyz[:, 1],
                z=xyz[:, 2],
            )
        )
    for p, (o, r) in enumerate(frfs.pairs):
        (rsp_node, rsp_dir), (ref_node, ref_dir) = parse_dof(frfs.responses[o]), parse_dof(frfs.references[r])
        sets.append(
            pyuff.prepare_58(
                binary=0,
                id1="eigentwist synthetic FRF",
                id2=frfs.pair_label(p),
                id3="NONE",
                id4="NONE",
                id5="NONE",
                func_type=4,
                ver_num=0,
                load_case_id=0,
                rsp_ent_name="EE",
                rsp_node=rsp_node,
                rsp_dir=rsp_dir,
                ref_ent_name="EE",
                ref_node=ref_node,
                ref_dir=ref_dir,
                abscissa_spacing=1,
                abscissa_spec_data_type=18,
                ordinate_spec_data_type=ORDINATE_OF_FORM[frfs.form],
                orddenom_spec_data_type=13,
                data=np.asarray(frfs.H[:, p], dtype=complex).copy(),
                x=np.asarray(frfs.freq_hz, dtype=float).copy(),
            )
        )
    if path.exists():
        path.unlink()
    with atomic_path(path) as tmp:
        pyuff.UFF(str(tmp)).write_sets(sets, mode="overwrite")
    return path


def write_modes_uff(path, freq_hz, damping_ratio, shapes, node: int = 1) -> Path:
    """Write real modes as dataset 55 (normal modes, 3 translations at ``node``)."""
    import pyuff

    path = Path(path)
    sets = []
    for k, (f, z, phi) in enumerate(zip(freq_hz, damping_ratio, np.asarray(shapes, dtype=float))):
        sets.append(
            pyuff.prepare_55(
                id1="eigentwist synthetic modes",
                id2="NONE",
                id3="NONE",
                id4="NONE",
                id5="NONE",
                model_type=1,
                analysis_type=2,
                data_ch=2,
                spec_data_type=8,
                data_type=2,
                n_data_per_node=3,
                r1=np.array([phi[0]]),
                r2=np.array([phi[1]]),
                r3=np.array([phi[2]]),
                node_nums=np.array([node]),
                load_case=1,
                mode_n=k + 1,
                modal_m=0.0,
                freq=float(f),
                modal_damp_vis=float(z),
                modal_damp_his=0.0,
            )
        )
    if path.exists():
        path.unlink()
    with atomic_path(path) as tmp:
        pyuff.UFF(str(tmp)).write_sets(sets, mode="overwrite")
    return path
