"""A modal-test campaign: a manifest CSV and one UFF file per setting.

Manifest columns (header on line 1, ``#`` and blank lines skipped):

* ``file`` (required): the setting's UFF file, relative to the manifest's folder: dataset
  58 FRFs (identified here) or dataset 55 modes (taken as identified);
* ``k_a`` (required): commanded actuator stiffness, N m/rad;
* ``x``, ``y``, ``z``: end-effector position, m (default: the robot's x_ref);
* ``nodeN_x``, ``nodeN_y``, ``nodeN_z`` (N a UFF node number, e.g. ``node3_x``): node N's
  offset from the end-effector origin, m, platform axes; they override the UFF file's
  own node coordinates (dataset 15 or 2411, read in the same convention);
* ``sensor_x``, ``sensor_y``, ``sensor_z``: the same for the node ``--node`` (default 1),
  kept from the triaxial-sensor format; that node sits at the origin when nothing gives
  its position;
* any model parameter name: passed through to the measurement rows (SI units).

Any layout of responses and references (:mod:`.uff_io`) is identified; the mode shape
(:mod:`.identify`, step 4) is compared with the model only where the layout allows
(:func:`.layout.shape_note`); otherwise the campaign's notes say so once and the
frequencies and damping ratios go on.

:func:`identify_campaign` returns the measurements (the columns of a measurement CSV,
``k_a, mode, freq_hz, sigma_hz, kind, x, y, z, damping_ratio, phi_x, phi_y, phi_z``, then
``sensor_x, sensor_y, sensor_z`` when a shape point is off the origin or the manifest
gives positions, then the parameter columns; ``freq_hz`` is each pole's omega_n / 2 pi,
``kind`` = ``undamped``, ``damping_ratio`` its zeta) and the per-setting results (for plots and
the report). ``phi_x, phi_y, phi_z`` are the shape of a layout that is one node measured
along X, Y and Z (``sensor_*`` its position); other layouts (several nodes, uniaxial
accelerometers, a roving hammer) write it per DOF: ``phi_N_x`` ... (node N along +X) with the
node positions ``nodeN_x, nodeN_y, nodeN_z`` (m), which the diagnosis compares with the
model's ``e . (v + omega x r)`` by the MAC over those DOFs
(:mod:`eigentwist.diagnose.shapes`).
"""

from __future__ import annotations

import csv
import io
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..outputs import write_atomic
from ..diagnose.measurements import MeasurementError, Measurements, parse_csv
from .identify import SIGMA_FLOOR_REL, SettingModes, identify_frfs, modes_from_set
from .layout import note_line, shape_note, triaxial_node
from .uff_io import FrfSet, read_uff

__all__ = [
    "Setting",
    "Campaign",
    "CampaignResult",
    "read_manifest",
    "write_manifest",
    "identify_campaign",
    "identify_setting",
    "node_positions",
    "shape_point",
    "dof_columns",
    "measurement_csv",
    "SENSOR",
    "OUTPUT_COLUMNS",
]

SENSOR = ("sensor_x", "sensor_y", "sensor_z")
NODE_COLUMN = re.compile(r"node(\d+)_([xyz])$")
OUTPUT_COLUMNS = (
    "k_a",
    "mode",
    "freq_hz",
    "sigma_hz",
    "kind",
    "x",
    "y",
    "z",
    "damping_ratio",
    "phi_x",
    "phi_y",
    "phi_z",
)


@dataclass
class Setting:
    """One manifest row: file (resolved path), k_a (N m/rad), pose (3,) m, sensor (3,) m
    (position of the ``--node`` node; None when the manifest has no sensor columns),
    params (name -> SI value), line (manifest line), nodes (node -> (3,) m from the
    ``nodeN_*`` columns)."""

    file: Path
    k_a: float
    pose: np.ndarray
    sensor: np.ndarray | None
    params: dict
    line: int
    nodes: dict = field(default_factory=dict)

    def name(self) -> str:
        return self.file.stem


@dataclass
class Campaign:
    settings: list
    source: str
    has_sensor: bool = False
    param_names: tuple = ()


@dataclass
class CampaignResult:
    campaign: Campaign
    results: list  # SettingModes per setting
    measurements: Measurements
    notes: list = field(default_factory=list)


def _number(text: str, source: str, line: int, column: str, positive: bool = False) -> float:
    try:
        value = float(text)
    except ValueError:
        raise MeasurementError(source, f"value {text!r} is not a number", line, column) from None
    if not np.isfinite(value) or (positive and value <= 0):
        raise MeasurementError(
            source, f"value {text!r}: expected a {'positive ' if positive else ''}finite number", line, column
        )
    return value


def read_manifest(path, ev) -> Campaign:
    """Read and check a campaign manifest (module doc); errors name the file, line and column."""
    path = Path(path)
    source = str(path)
    if not path.is_file():
        raise MeasurementError(source, "no such file (expected a campaign manifest CSV: file, k_a, x, y, z)")
    records = [(n, cells) for n, cells in _rows(path.read_text(encoding="utf-8-sig"))]
    if not records:
        raise MeasurementError(source, "empty manifest: expected a header file, k_a, x, y, z and one row per setting")
    names = [c.strip() for c in records[0][1]]
    allowed = {"file", "k_a", "x", "y", "z", *SENSOR, *ev.parameters}
    for name in names:
        if name not in allowed and not NODE_COLUMN.match(name):
            raise MeasurementError(
                source,
                f"unknown column: not one of file, k_a, x, y, z, {', '.join(SENSOR)}, "
                f"nodeN_x/y/z and not a parameter of {ev.robot.name}",
                records[0][0],
                name,
            )
    node_cols: dict[int, list] = {}
    for name in names:
        if NODE_COLUMN.match(name):
            node_cols.setdefault(int(NODE_COLUMN.match(name).group(1)), []).append(name)
    for n, cols in node_cols.items():
        if len(cols) != 3:
            raise MeasurementError(
                source, f"node {n} needs the three columns node{n}_x, node{n}_y, node{n}_z", records[0][0], cols[0]
            )
    for name in ("file", "k_a"):
        if name not in names:
            raise MeasurementError(source, f"missing required column {name!r}", records[0][0], name)
    if len(records) == 1:
        raise MeasurementError(source, "no settings after the header", records[0][0])
    params = tuple(n for n in names if n in ev.parameters and n != "k_a")
    settings = []
    for line, cells in records[1:]:
        if len(cells) != len(names):
            raise MeasurementError(source, f"{len(cells)} cells where the header has {len(names)} columns", line)
        row = dict(zip(names, (c.strip() for c in cells)))
        file = path.parent / row["file"]
        if not row["file"] or not file.is_file():
            raise MeasurementError(
                source,
                f"{row['file'] or '(empty)'}: no such file (paths are relative to the manifest's folder {path.parent})",
                line,
                "file",
            )
        pose = np.array(
            [_number(row[a], source, line, a) if row.get(a) else ev.robot.x_ref[k] for k, a in enumerate("xyz")],
            dtype=float,
        )
        has_sensor = any(a in names for a in SENSOR)
        sensor = np.array([_number(row[a], source, line, a) if row.get(a) else 0.0 for a in SENSOR])
        nodes = {
            n: np.array([_number(row[f"node{n}_{a}"], source, line, f"node{n}_{a}") for a in "xyz"])
            for n in node_cols
            if all(row[f"node{n}_{a}"] for a in "xyz")
        }
        values = {n: _number(row[n], source, line, n) for n in params if row[n]}
        settings.append(
            Setting(
                file,
                _number(row["k_a"], source, line, "k_a", positive=True),
                pose,
                sensor if has_sensor else None,
                values,
                line,
                nodes,
            )
        )
    return Campaign(settings, source, any(a in names for a in SENSOR) or bool(node_cols), params)


def _rows(text: str):
    reader = csv.reader(io.StringIO(text))
    for cells in reader:
        if not cells or all(not c.strip() for c in cells) or cells[0].lstrip().startswith("#"):
            continue
        yield reader.line_num, cells


def write_manifest(path, rows: list[dict]) -> Path:
    """Write a manifest: ``rows`` of {file, k_a, x, y, z[, sensor_*][, params]} (same keys each)."""
    path = Path(path)
    out = io.StringIO()
    w = csv.DictWriter(out, list(rows[0]), lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: v if isinstance(v, str) else format(float(v), ".10g") for k, v in r.items()})
    write_atomic(path, out.getvalue())
    return path


def node_positions(setting: Setting, frfs: FrfSet, node: int) -> dict:
    """node -> (3,) m: the UFF file's coordinates, overridden by the manifest's node columns and
    ``sensor_*`` (node ``node``, at the origin when nothing gives it)."""
    coords = {**frfs.coords, **setting.nodes}
    if setting.sensor is not None:
        coords[node] = setting.sensor
    coords.setdefault(node, np.zeros(3))
    return coords


def identify_setting(
    setting: Setting, band=None, node: int = 1, sigma_floor_rel: float = SIGMA_FLOOR_REL, max_order: int | None = None
) -> SettingModes:
    """Modes of one setting from its UFF file (FRFs identified, or dataset 55 modes).

    ``coords`` of the result: the node positions (:func:`node_positions`); ``notes``: why the
    layout gives no shape to compare with the model (:func:`.layout.shape_note`), if so.
    """
    data = read_uff(setting.file, node)
    if isinstance(data, FrfSet):
        kwargs = {} if max_order is None else {"max_order": max_order}
        res = identify_frfs(data, band, sigma_floor_rel=sigma_floor_rel, **kwargs)
        res.coords = node_positions(setting, data, node)
        why = shape_note(res.modes[0].dofs, res.coords) if res.modes else None
        if why:
            res.notes.append(why)
        return res
    res = modes_from_set(data, band, sigma_floor_rel)
    res.coords = {node: np.zeros(3) if setting.sensor is None else setting.sensor}
    return res


def identify_campaign(
    manifest, ev, band=None, node: int = 1, sigma_floor_rel: float = SIGMA_FLOOR_REL, progress=None
) -> CampaignResult:
    """Identify every setting of a campaign; the measurements are validated as a CSV would be.

    ``notes``: each distinct setting note once (:func:`.layout.note_line`), naming its file or
    how many settings it applies to.
    """
    camp = read_manifest(manifest, ev)
    items = progress(camp.settings, desc="identifying", leave=False) if progress else camp.settings
    results = [identify_setting(s, band, node, sigma_floor_rel) for s in items]
    text = measurement_csv(camp, results)
    notes: dict[str, list] = {}
    for s, r in zip(camp.settings, results):
        for n in r.notes:
            notes.setdefault(n, []).append(s.file.name)
    lines = [note_line(files[0] if len(files) == 1 else f"{len(files)} settings", n) for n, files in notes.items()]
    return CampaignResult(camp, results, parse_csv(text, f"{camp.source} (identified)", ev), lines)


def shape_point(mode, coords: dict):
    """(phi (3,) unit, position (3,) m) when the mode's DOFs are one node along X, Y, Z, or (None, None)."""
    node = triaxial_node(mode.dofs)
    if node is None or node not in coords or len(mode.dofs) != 3:
        return None, None
    phi = np.array([mode.shape[mode.dofs.index(f"{node}+{a}")] for a in "XYZ"])
    norm = np.linalg.norm(phi)
    return (phi / norm if norm > 0 else None), np.asarray(coords[node], dtype=float)


def dof_columns(mode, coords: dict) -> dict:
    """Per-DOF shape columns ``phi_N_a`` and node positions ``nodeN_a`` of a mode measured at
    DOFs that give a shape, other than one node along X, Y, Z ({} otherwise)."""
    if shape_point(mode, coords)[0] is not None or shape_note(mode.dofs, coords):
        return {}
    out = {f"phi_{d.split('+')[0]}_{d[-1].lower()}": v for d, v in zip(mode.dofs, mode.shape)}
    for n in dict.fromkeys(int(d.split("+")[0]) for d in mode.dofs):
        out.update({f"node{n}_{a}": float(c) for a, c in zip("xyz", coords[n])})
    return out


def measurement_csv(camp: Campaign, results: list) -> str:
    """The identified modes as measurement-CSV text (columns in ``OUTPUT_COLUMNS`` order, then the
    sensor columns, the per-DOF shape and node columns (:func:`dof_columns`), the parameters)."""
    rows = []
    for s, res in zip(camp.settings, results):
        coords = getattr(res, "coords", {}) or {}
        for m in sorted(res.modes, key=lambda m: m.freq_hz):
            phi, r = shape_point(m, coords)
            rows.append((s, m, phi, r, dof_columns(m, coords)))
    has_sensor = camp.has_sensor or any(r is not None and np.any(r != 0) for *_, r, _ in rows)
    extra = list(dict.fromkeys(k for *_, d in rows for k in d if k.startswith("phi_")))
    extra += list(dict.fromkeys(k for *_, d in rows for k in d if k.startswith("node")))
    cols = list(OUTPUT_COLUMNS) + (list(SENSOR) if has_sensor else []) + extra + list(camp.param_names)
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(cols)
    for s, m, phi, r, dofs in rows:
        z = m.damping_ratio if np.isfinite(m.damping_ratio) else None
        row = [s.k_a, m.label, m.freq_hz, m.sigma_hz, "undamped", *s.pose, z, *(phi if phi is not None else [None] * 3)]
        row += (list(r) if r is not None else [None] * 3) if has_sensor else []
        row += [dofs.get(k) for k in extra]
        row += [s.params.get(n) for n in camp.param_names]
        w.writerow([v if isinstance(v, str) else "" if v is None else format(float(v), ".8g") for v in row])
    return out.getvalue()
