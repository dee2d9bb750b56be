"""Universal File Format (UFF) in and out, through ``pyuff`` (no parser of our own).

* Dataset 58 (function at nodal DOF), function type 4 (FRF): responses at one node
  along +X, +Y, +Z of the base frame (a -X response is read with its sign flipped);
  references (hammer or shaker) at any node along X, Y, Z. The FRF form comes from the
  ordinate's specific data type: 8 displacement -> receptance, 11 velocity -> mobility,
  12 acceleration -> accelerance (denominator 13, excitation force, or 0). Rotational
  responses and references (directions 4-6) are skipped. Every FRF of a file must
  share one frequency axis.
* Dataset 55 (data at nodes), normal modes (analysis type 2) or complex modes (3, 7):
  already identified modes; the shape is the translation (r1, r2, r3) at the node.

Every error is one line ``FILE, dataset K (type T): what is wrong`` (K counts from 1).
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..runtime import InputError

__all__ = ["FrfSet", "ModeSet", "UffError", "read_uff", "write_frf_uff", "write_modes_uff",
           "FORM_OF_ORDINATE", "ORDINATE_OF_FORM"]

FORM_OF_ORDINATE = {8: "receptance", 11: "mobility", 12: "accelerance"}
ORDINATE_OF_FORM = {v: k for k, v in FORM_OF_ORDINATE.items()}
AXIS = {1: "X", 2: "Y", 3: "Z"}


class UffError(InputError):
    """Bad UFF input; the message names the file and, where it applies, the dataset."""

    def __init__(self, source, message: str, dataset: int | None = None, kind: int | None = None):
        where = str(source)
        if dataset is not None:
            where += f", dataset {dataset + 1}" + (f" (type {kind})" if kind is not None else "")
        super().__init__(f"{where}: {message}")


@dataclass
class FrfSet:
    """FRFs of one setting.

    freq_hz : (F,) frequency axis, Hz.
    H : (F, 3, R) complex: responses +X, +Y, +Z at ``node``, one column per reference.
    references : R names, ``"NODE+AXIS"`` (e.g. ``"1+X"``).
    form : ``"accelerance"``, ``"mobility"`` or ``"receptance"``.
    node : the response node; source : file name for messages.
    """

    freq_hz: np.ndarray
    H: np.ndarray
    references: list
    form: str
    node: int = 1
    source: str = "<uff>"


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
    except Exception as exc:          # pyuff raises bare Exception on malformed files
        raise UffError(path, f"not a readable UFF file ({exc})") from None
    return [sets] if isinstance(sets, dict) else list(sets)


def read_uff(path, node: int = 1):
    """Read the FRFs (dataset 58) or modes (dataset 55) at ``node`` of one setting's file.

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
        raise UffError(path, f"ordinate specific data type {ordinate} is not displacement (8), velocity (11) or "
                       "acceleration (12): cannot tell receptance, mobility or accelerance", k, 58)
    if denom not in (0, 13):
        raise UffError(path, f"ordinate denominator type {denom}: expected excitation force (13)", k, 58)
    return FORM_OF_ORDINATE[ordinate]


def _frfs(path: Path, sets: list[dict], node: int) -> FrfSet:
    cols: dict[str, dict[int, np.ndarray]] = {}
    form = axis = None
    for k, s in enumerate(sets):
        if s.get("type") != 58 or int(s.get("func_type", 0)) != 4:
            continue
        rdir, fdir = int(s["rsp_dir"]), int(s["ref_dir"])
        if int(s["rsp_node"]) != node or abs(rdir) not in AXIS or abs(fdir) not in AXIS:
            continue
        this_form = _form(path, k, s)
        if form is not None and this_form != form[0]:
            raise UffError(path, f"FRF form {this_form} differs from {form[0]} of dataset {form[1] + 1}", k, 58)
        form = form or (this_form, k)
        x = np.asarray(s["x"], dtype=float)
        if axis is None:
            axis = (x, k)
        elif x.shape != axis[0].shape or not np.allclose(x, axis[0], rtol=1e-9, atol=1e-9):
            raise UffError(path, f"inconsistent frequency axes: {len(x)} points {x[0]:g}..{x[-1]:g} Hz where "
                           f"dataset {axis[1] + 1} has {len(axis[0])} points {axis[0][0]:g}..{axis[0][-1]:g} Hz",
                           k, 58)
        ref = f"{int(s['ref_node'])}+{AXIS[abs(fdir)]}"
        sign = np.sign(rdir) * np.sign(fdir)
        cols.setdefault(ref, {})[abs(rdir)] = sign * np.asarray(s["data"], dtype=complex)
    if not cols:
        raise UffError(path, f"no FRF (dataset 58, function type 4) with a translational response at node {node} "
                       f"(--node selects another)")
    for ref, by_dir in cols.items():
        for d, name in AXIS.items():
            if d not in by_dir:
                raise UffError(path, f"no response at node {node} along +{name} for reference {ref} "
                               "(dataset 58 FRFs need responses along X, Y and Z)")
    refs = list(cols)
    H = np.stack([np.stack([cols[r][d] for d in AXIS], axis=1) for r in refs], axis=2)
    return FrfSet(axis[0], H, refs, form[0], node, str(path))


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


def write_frf_uff(path, freq_hz, H, node: int = 1, form: str = "accelerance", references=None) -> Path:
    """Write (F, 3, R) FRFs as dataset 58 (ASCII, double precision), one per (response, reference).

    ``references`` are R ``(node, direction)`` pairs (default: forces at ``node`` along
    +X, +Y, +Z). The abscissa is stored with 6 significant digits (E13.5, the format's
    own): use a frequency step that it holds exactly.
    """
    import pyuff

    path = Path(path)
    H = np.asarray(H, dtype=complex)
    refs = references or [(node, d) for d in (1, 2, 3)][:H.shape[2]]
    sets = []
    for r, (ref_node, ref_dir) in enumerate(refs):
        for i in range(3):
            sets.append(pyuff.prepare_58(
                binary=0, id1="eigentwist synthetic FRF", id2=f"response {node}+{AXIS[i + 1]}",
                id3="NONE", id4="NONE", id5="NONE", func_type=4, ver_num=0, load_case_id=0,
                rsp_ent_name="EE", rsp_node=node, rsp_dir=i + 1, ref_ent_name="EE", ref_node=ref_node,
                ref_dir=ref_dir, abscissa_spacing=1, abscissa_spec_data_type=18,
                ordinate_spec_data_type=ORDINATE_OF_FORM[form], orddenom_spec_data_type=13,
                data=H[:, i, r].copy(), x=np.asarray(freq_hz, dtype=float).copy()))
    if path.exists():
        path.unlink()
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")
    return path


def write_modes_uff(path, freq_hz, damping_ratio, shapes, node: int = 1) -> Path:
    """Write real modes as dataset 55 (normal modes, 3 translations at ``node``)."""
    import pyuff

    path = Path(path)
    sets = []
    for k, (f, z, phi) in enumerate(zip(freq_hz, damping_ratio, np.asarray(shapes, dtype=float))):
        sets.append(pyuff.prepare_55(
            id1="eigentwist synthetic modes", id2="NONE", id3="NONE", id4="NONE", id5="NONE",
            model_type=1, analysis_type=2, data_ch=2, spec_data_type=8, data_type=2, n_data_per_node=3,
            r1=np.array([phi[0]]), r2=np.array([phi[1]]), r3=np.array([phi[2]]), node_nums=np.array([node]),
            load_case=1, mode_n=k + 1, modal_m=0.0, freq=float(f), modal_damp_vis=float(z), modal_damp_his=0.0))
    if path.exists():
        path.unlink()
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")
    return path
