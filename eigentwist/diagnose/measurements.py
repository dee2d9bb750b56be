"""Measured natural frequencies: CSV loading and validation, the paper's data set.

CSV format (one measured frequency per row, header on the first line; ``#`` lines and
blank lines are skipped):

* required: ``k_a`` (commanded actuator stiffness, N m/rad), ``mode`` (a rank ``1``,
  ``2``, ... with 1 the lowest mode, or a direction ``x``, ``y``, ``z``, ``rx``, ``ry``,
  ``rz``; see :mod:`eigentwist.diagnose.matching`), ``freq_hz`` (measured frequency, Hz);
* optional: ``x``, ``y``, ``z`` (end-effector position in the base frame, m; default the
  robot's x_ref), ``sigma_hz`` (standard uncertainty, Hz; default 2 % of ``freq_hz``),
  and any column named after a model parameter (SI units; per leg ``NAME@N``), which
  overrides that parameter for its row. A blank optional cell takes the default (or the
  value given for the run, e.g. ``--set``);
* optional ``kind``: ``undamped`` (the default: the value is omega_n / 2 pi, e.g. a curve
  fit's pole) or ``damped`` (a free decay or a step response: the value is the damped
  omega_d / 2 pi = omega_n sqrt(1 - zeta^2) / 2 pi); ``compare`` and ``diagnose`` compare
  each row with the model's frequency of the same kind (they differ where the model has
  a damping effect, :mod:`eigentwist.runtime.damped`);
* optional modal columns (from ``eigentwist identify``, see :mod:`eigentwist.modal`):
  ``damping_ratio`` (-; compared with the model's damping ratio, with the uncertainty
  ``sigma_damping_ratio`` (-), by default the larger of 20 % of the value and 0.005),
  ``phi_x``, ``phi_y``, ``phi_z`` (the measured mode shape: a real unit translation of
  the sensor point, base-frame axes) and ``sensor_x``, ``sensor_y``,
  ``sensor_z`` (the sensor's offset from the end-effector origin, m; default 0). A shape
  measured at other DOFs (uniaxial accelerometers, a roving hammer) is given
  per DOF: ``phi_N_x``, ``phi_N_y``, ``phi_N_z`` (the shape's component at node N along
  +X, +Y, +Z; any subset) with ``nodeN_x``, ``nodeN_y``, ``nodeN_z`` (node N's offset
  from the end-effector origin, m, platform axes; required with them). When shape
  columns are present, ``compare`` reports the MAC per row (over the row's measured
  DOFs) and matches rows to model modes by shape (:mod:`eigentwist.diagnose.shapes`);
* optional measured joint coordinates, e.g. encoder readings at the measured
  pose: ``q<m>@<leg>`` is coordinate m of leg ``leg`` (both 1-based; ``q1@1, q2@1, q3@1,
  q1@2, ...``) in the layout of ``Evaluator.joint_angles`` (rad; m for a prismatic
  joint). Either every coordinate of every leg has a column, or none; no blank cells. The
  model is then evaluated at these joint coordinates instead of the pose's inverse
  kinematics (``Evaluator.modes(..., joints=)``; :func:`joint_columns`).

Files as spreadsheets export them are accepted: the separator is ``,``, ``;`` or a tab
(whichever splits the header into the most columns); with ``;`` or a tab a decimal
comma (``15,5``) is read as a decimal point; a UTF-8 BOM, a UTF-16 BOM and CRLF line
ends are accepted. Two rows with the same pose, ``k_a``, mode and parameter columns
are an error naming both lines (they would count twice in chi2): average them first.
A parameter column whose effect the model lacks is an error where the measurements meet
the model (:func:`check_columns`).

Every error names the file, the line (the header is line 1) and the column.
"""

from __future__ import annotations

import csv
import io
import itertools
import math
import re
from dataclasses import dataclass, field, replace
from importlib import resources
from pathlib import Path

import numpy as np

from ..description.names import did_you_mean
from ..outputs import write_atomic
from ..runtime import InputError, SingularPoseError, UnreachablePoseError
from .evaluators import resolve
from .matching import parse_mode

__all__ = [
    "Measurements",
    "MeasurementError",
    "load_measurements",
    "paper_measurements",
    "paper_csv",
    "REQUIRED",
    "OPTIONAL",
    "MODAL",
    "KINDS",
    "ROTATION_COLUMNS",
    "pose_columns",
    "joint_columns",
    "DEFAULT_SIGMA_REL",
    "check_poses",
    "check_columns",
    "parse_csv",
]

REQUIRED = ("k_a", "mode", "freq_hz")
# measured modal data: NaN where blank; shapes are phi_x..z, sensor_* in m
MODAL = ("damping_ratio", "phi_x", "phi_y", "phi_z", "sensor_x", "sensor_y", "sensor_z", "sigma_damping_ratio")
OPTIONAL = ("x", "y", "z", "sigma_hz", "kind") + MODAL
#: the values of the ``kind`` column: what the measured frequency is
KINDS = ("undamped", "damped")
#: default uncertainty of a measured damping ratio: the larger of 20 % of it and 0.005
DEFAULT_SIGMA_ZETA_REL = 0.2
DEFAULT_SIGMA_ZETA_ABS = 0.005
#: per-DOF shape columns ``phi_N_x`` and the node positions ``nodeN_x`` they need
DOF_COLUMN = re.compile(r"(phi_|node)(\d+)_([xyz])$")
#: the rotation columns of a 6-DoF robot's poses (rotation vector, rad); ``rx, ry, rz`` stay mode labels
ROTATION_COLUMNS = ("rot_x", "rot_y", "rot_z")


def joint_columns(ev) -> tuple:
    """The measured-joint-coordinate columns of ``ev``'s robot: ``q<m>@<leg>``, leg-major
    (``q1@1, q2@1, ..., q1@2, ...``), as many coordinates per leg as ``joint_angles`` gives."""
    nq = len(ev.robot.legs[0].kinematics.coordinates)
    return tuple(f"q{m}@{leg}" for leg in range(1, len(ev.robot.legs) + 1) for m in range(1, nq + 1))


def pose_columns(ev) -> tuple:
    """The CSV pose columns of ``ev``'s robot: ``x, y, z`` (m), a 6-DoF robot adds ``rot_x,
    rot_y, rot_z`` (rad)."""
    return tuple(getattr(ev, "pose_names", ("x", "y", "z")))


SEPARATORS = {",": "','", ";": "';'", "\t": "a tab"}
DEFAULT_SIGMA_REL = 0.02  # default standard uncertainty: 2 % of the measured value


class MeasurementError(InputError):
    """Bad measurement input; the message starts with ``FILE, line L, column 'C':``."""

    def __init__(self, source: str, message: str, line: int | None = None, column: str | None = None):
        self.source, self.line, self.column = source, line, column
        where = source
        if line is not None:
            where += f", line {line}"
        if column is not None:
            where += f", column {column!r}"
        super().__init__(f"{where}: {message}")


@dataclass
class Measurements:
    """N measured frequencies with their conditions.

    k_a : (N,) commanded actuator stiffness, N m/rad.
    mode : N normalised mode labels (``"x"``, ``"2"``, ...).
    freq_hz : (N,) measured natural frequency, Hz.
    sigma_hz : (N,) standard uncertainty, Hz.
    poses : (N, 3) end-effector position, m; (N, 6) for a 6-DoF robot, the rotation
        vector (rad) last (CSV columns ``rot_x, rot_y, rot_z``).
    params : per-row parameter overrides, name -> (N,) array in SI units.
    lines : (N,) source line of each row (header = line 1).
    source : file name used in messages.
    robot : robot the data belong to (``eigentwist.robots.NAMES``).
    modal : optional modal columns (``MODAL``), name -> (N,) array, NaN where blank.
    k_a_unit : the unit of k_a, the robot's (N m/rad for a revolute actuator, N/m for a
        prismatic one); :func:`parse_csv` takes it from the robot's ``k_a`` parameter.
    """

    k_a: np.ndarray
    mode: tuple
    freq_hz: np.ndarray
    sigma_hz: np.ndarray
    poses: np.ndarray
    params: dict = field(default_factory=dict)
    lines: np.ndarray | None = None
    source: str = "<data>"
    robot: str = "heli4"
    modal: dict = field(default_factory=dict)
    k_a_unit: str = "N m/rad"
    #: measured joint coordinates (N, legs, coordinates), columns ``q<m>@<leg>``; None: none
    joints: np.ndarray | None = None
    #: what each value is (:data:`KINDS`): ``"undamped"`` omega_n / 2 pi, ``"damped"`` omega_d / 2 pi
    kind: tuple = ()

    def __post_init__(self):
        n = len(self.freq_hz)
        if self.lines is None:
            self.lines = np.arange(2, n + 2)
        self.mode = tuple(self.mode)
        self.kind = tuple(self.kind) or ("undamped",) * n

    @property
    def damped(self) -> np.ndarray:
        """(N,) bool: rows whose value is a damped frequency (``kind`` = ``damped``)."""
        return np.array([k == "damped" for k in self.kind], dtype=bool)

    @property
    def damping_ratio(self) -> np.ndarray:
        """(N,) measured damping ratio (-), NaN where not measured."""
        return self.modal.get("damping_ratio", np.full(len(self), np.nan))

    @property
    def sigma_damping_ratio(self) -> np.ndarray:
        """(N,) uncertainty of the measured damping ratio: the ``sigma_damping_ratio`` column,
        else the larger of :data:`DEFAULT_SIGMA_ZETA_REL` of it and :data:`DEFAULT_SIGMA_ZETA_ABS`."""
        zeta = self.damping_ratio
        default = np.maximum(DEFAULT_SIGMA_ZETA_REL * np.abs(zeta), DEFAULT_SIGMA_ZETA_ABS)
        given = self.modal.get("sigma_damping_ratio")
        return default if given is None else np.where(np.isnan(given), default, given)

    def __len__(self) -> int:
        return len(self.freq_hz)

    @property
    def relative_sigma(self) -> np.ndarray:
        """sigma_hz / freq_hz, (N,)."""
        return self.sigma_hz / self.freq_hz

    def where(self, i: int) -> str:
        """``"FILE, line L"`` of row ``i``."""
        return f"{self.source}, line {int(self.lines[i])}"

    @property
    def shapes(self):
        """(N, D) measured mode shapes over the :attr:`shape_columns` (NaN where not measured),
        or None without shape columns."""
        cols = self.shape_columns
        if not cols or (not any(c.count("_") == 2 for c in cols) and len(cols) < 3):
            return None
        return np.column_stack([self.modal[c] for c in cols])

    @property
    def shape_columns(self) -> list:
        """Names of the shape columns present (``phi_x, phi_y, phi_z``, ``phi_N_a``), in header order."""
        return [c for c in self.modal if c in ("phi_x", "phi_y", "phi_z") or c.startswith("phi_")]

    @property
    def shape_projection(self) -> np.ndarray:
        """(N, D, 6) rows ``e^T T(r)`` of the :attr:`shapes` columns: the model's shape component
        there is ``P @ t`` for an eigentwist ``t = [omega; v]`` (:mod:`.shapes`)."""
        from .shapes import transport_matrix

        rows = []
        for c in self.shape_columns:
            if c in ("phi_x", "phi_y", "phi_z"):
                rows.append(transport_matrix(self.sensor)[:, "xyz".index(c[-1])])
            else:
                node, axis = c.split("_")[1:]
                r = np.column_stack([self.modal[f"node{node}_{a}"] for a in "xyz"])
                rows.append(transport_matrix(np.nan_to_num(r))[:, "xyz".index(axis)])
        return np.stack(rows, axis=1) if rows else np.zeros((len(self), 0, 6))

    @property
    def sensor(self) -> np.ndarray:
        """(N, 3) sensor offsets from the end-effector origin, m (0 where not given)."""
        return np.column_stack(
            [
                np.nan_to_num(self.modal.get(c, np.zeros(len(self))), nan=0.0)
                for c in ("sensor_x", "sensor_y", "sensor_z")
            ]
        )

    def evaluation_params(self) -> dict:
        """Keyword arguments for the evaluator: ``k_a`` and the per-row overrides."""
        return {"k_a": self.k_a, **self.params}

    def subset(self, rows) -> "Measurements":
        """The rows ``rows`` (index array or boolean mask) as new Measurements."""
        rows = np.arange(len(self))[rows]
        return Measurements(
            self.k_a[rows],
            tuple(self.mode[i] for i in rows),
            self.freq_hz[rows],
            self.sigma_hz[rows],
            self.poses[rows],
            {k: v[rows] for k, v in self.params.items()},
            self.lines[rows],
            self.source,
            self.robot,
            {k: v[rows] for k, v in self.modal.items()},
            self.k_a_unit,
            None if self.joints is None else self.joints[rows],
            tuple(self.kind[i] for i in rows),
        )

    @classmethod
    def from_arrays(
        cls,
        k_a,
        mode,
        freq_hz,
        poses=None,
        sigma_hz=None,
        params=None,
        robot: str = "heli4",
        source: str = "<data>",
        ev=None,
        modal=None,
        kind=None,
    ) -> "Measurements":
        """Build validated measurements from arrays (defaults as in the CSV format);
        ``kind``: ``"undamped"``/``"damped"`` for every row or one per row.

        The arrays go through the same parser as a file, so every check applies; row i
        is reported as line i + 2 of ``source``.
        """
        ev = resolve(ev, robot)
        freq = np.asarray(freq_hz, dtype=float).reshape(-1)
        n = len(freq)
        rows = []
        for i in range(n):
            row = {
                "k_a": np.broadcast_to(k_a, (n,))[i],
                "mode": np.broadcast_to(np.asarray(mode, dtype=object), (n,))[i],
                "freq_hz": freq[i],
            }
            if poses is not None:
                names = pose_columns(ev)
                row.update(zip(names, np.broadcast_to(np.asarray(poses, dtype=float), (n, len(names)))[i]))
            if sigma_hz is not None:
                row["sigma_hz"] = np.broadcast_to(sigma_hz, (n,))[i]
            for name, val in {**(params or {}), **(modal or {})}.items():
                row[name] = np.broadcast_to(val, (n,))[i]
            if kind is not None:
                row["kind"] = str(np.broadcast_to(np.asarray(kind, dtype=object), (n,))[i])
            rows.append(row)
        header = list(rows[0]) if rows else list(REQUIRED)
        text = io.StringIO()
        w = csv.DictWriter(text, header, lineterminator="\n")
        w.writeheader()
        for row in rows:
            w.writerow(
                {k: v if k in ("mode", "kind") else repr(float(v)) if np.isfinite(v) else "" for k, v in row.items()}
            )
        return parse_csv(text.getvalue(), source, ev)

    def to_csv(self, path=None) -> str:
        """CSV text of these measurements (written to ``path`` when given)."""
        names = ("x", "y", "z") + (ROTATION_COLUMNS if self.poses.shape[1] == 6 else ())
        kinds = any(k != "undamped" for k in self.kind)
        cols = ["k_a", "mode", "freq_hz", "sigma_hz", *(("kind",) if kinds else ()), *names, *self.modal, *self.params]
        out = io.StringIO()
        w = csv.writer(out, lineterminator="\n")
        w.writerow(cols)
        for i in range(len(self)):
            vals = [
                self.k_a[i],
                self.mode[i],
                self.freq_hz[i],
                self.sigma_hz[i],
                *((self.kind[i],) if kinds else ()),
                *self.poses[i],
                *(self.modal[k][i] for k in self.modal),
                *(self.params[k][i] for k in self.params),
            ]
            w.writerow([v if isinstance(v, str) else format(float(v), ".10g") if np.isfinite(v) else "" for v in vals])
        text = out.getvalue()
        if path is not None:
            write_atomic(path, text)
        return text


def _number(text: str, source: str, line: int, column: str, positive: bool) -> float:
    try:
        value = float(text)
    except ValueError:
        raise MeasurementError(source, f"value {text!r} is not a number", line, column) from None
    if not math.isfinite(value):
        raise MeasurementError(source, f"value {text!r} is not finite: expected a number", line, column)
    if positive and value < 0:
        raise MeasurementError(source, f"negative value {value:g}: expected a value > 0", line, column)
    if positive and value == 0:
        raise MeasurementError(source, "value 0: expected a value > 0", line, column)
    return value


def _parameter(name: str, ev):
    """The Parameter a column names (``l2``, or per leg ``eta_a@3``), or None."""
    base, at, leg = name.partition("@")
    if base not in ev.parameters or (at and not (leg.isdigit() and int(leg) >= 1)):
        return None
    return ev.parameters[base]


def _header(cells: list[str], source: str, ev) -> list[str]:
    names = [c.strip() for c in cells]
    known = REQUIRED + OPTIONAL + tuple(c for c in pose_columns(ev) if c not in OPTIONAL) + joint_columns(ev)
    for k, name in enumerate(names):
        if not name:
            raise MeasurementError(source, f"column {k + 1} has an empty name", 1)
        if names.index(name) != k:
            raise MeasurementError(
                source, f"column {name!r} appears twice (columns {names.index(name) + 1} and {k + 1})", 1, name
            )
        if name not in known and not ev.accepts(name) and not DOF_COLUMN.match(name):  # eta_a@3: leg 3's own
            hint = did_you_mean(name, list(known) + list(ev.parameters))
            raise MeasurementError(
                source,
                f"unknown column (column {k + 1}){hint}: not one of {', '.join(known)} and not a "
                f"parameter of {ev.robot.name} (NAME or NAME@LEG; parameters: {', '.join(ev.parameters)})",
                1,
                name,
            )
    for name in REQUIRED:
        if name not in names:
            raise MeasurementError(
                source,
                f"missing required column {name!r} (header: {', '.join(names)}); required: {', '.join(REQUIRED)}",
                1,
                name,
            )
    for name in names:
        m = DOF_COLUMN.match(name)
        if m and m.group(1) == "phi_" and not all(f"node{m.group(2)}_{a}" in names for a in "xyz"):
            raise MeasurementError(
                source,
                f"shape column {name} needs node {m.group(2)}'s position: columns "
                f"node{m.group(2)}_x, node{m.group(2)}_y, node{m.group(2)}_z (m)",
                1,
                name,
            )
    joints = joint_columns(ev)
    missing = [c for c in joints if c not in names]
    if len(missing) < len(joints) and missing:
        raise MeasurementError(
            source,
            f"joint-coordinate column {missing[0]!r} is missing: give every coordinate "
            f"of every leg ({', '.join(joints)}) or none",
            1,
            missing[0],
        )
    return names


def _separator(text: str, source: str) -> str:
    """The separator that splits the header line into the most columns (``,`` on a tie)."""
    header = next((ln for ln in text.splitlines() if ln.strip() and not ln.lstrip().startswith("#")), "")
    best = max(SEPARATORS, key=lambda sep: (header.count(sep), sep == ","))
    if header.strip() == "-1":  # the delimiter line of a universal file (UFF/UNV)
        raise MeasurementError(
            source,
            "a UFF file (universal file format), not a measurement CSV: identify its "
            "modes first, `eigentwist identify MANIFEST.csv -o modes.csv` on the campaign's "
            "manifest, and compare modes.csv",
            1,
        )
    if header.count(best) == 0 and header.strip():
        raise MeasurementError(
            source,
            f"header {header.strip()[:60]!r} has a single column: expected the columns "
            f"{', '.join(REQUIRED)}, ... separated by ',', ';' or a tab",
            1,
        )
    return best


def _lines(text: str):
    """The lines of ``text`` with their ends, one at a time (an ``io.StringIO`` would hold a
    copy of up to four bytes per character); a lone carriage return (old Mac line ends)
    is a line end too, through ``io.StringIO``."""
    if text.count("\r") != text.count("\r\n"):
        yield from io.StringIO(text, newline="")
        return
    start, size = 0, len(text)
    while start < size:
        end = text.find("\n", start)
        end = size if end < 0 else end + 1
        yield text[start:end]
        start = end


def _records(text: str, source: str, sep: str = ","):
    """(line number, cells) of the header and data rows, skipping blank and ``#`` lines.

    With ``;`` or tab separators a decimal comma in a data cell becomes a point.
    """
    reader = csv.reader(_lines(text), delimiter=sep)
    first = True
    try:
        for cells in reader:
            head = cells[0].strip() if cells else ""
            if head.startswith("#") or (not head and all(not c.strip() for c in cells)):
                continue
            if sep != "," and not first:
                cells = [c.replace(",", ".") for c in cells]
            first = False
            yield reader.line_num, cells
    except csv.Error as exc:
        raise MeasurementError(
            source, f"not readable as CSV ({exc}): expected text with one row per line", reader.line_num or None
        ) from None


#: rows parsed per block: the strings of one block are held at a time (a large file streams)
BLOCK_ROWS = 65536


def parse_csv(
    text: str, source: str = "<data>", ev=None, robot: str = "heli4", values: dict | None = None, progress=None
) -> Measurements:
    """Parse and validate CSV ``text`` (see the module docstring); ``source`` names it in errors.

    ``values`` (SI) replace the robot's defaults for blank parameter cells and for the
    reachability check of the poses (the values given for the run, e.g. ``--set``).
    Rows are read in blocks of :data:`BLOCK_ROWS`, each column of a block at once
    (:func:`_parse_block`); ``progress`` (a tqdm-like factory, e.g. the command line's) is
    told the rows read.
    """
    ev = resolve(ev, robot)
    values = dict(values or {})
    if "\0" in text:
        raise MeasurementError(source, "contains NUL characters: expected a text file (CSV)")
    if text.startswith("\ufeff"):
        text = text[1:]
    records = _records(text, source, _separator(text, source))
    first = next(records, None)
    if first is None:
        raise MeasurementError(
            source,
            "empty file: expected a header line with the columns "
            f"{', '.join(REQUIRED)} and one row per measured frequency",
        )
    header_line, header_cells = first
    names = _header(header_cells, source, ev)
    x_ref = np.asarray(ev.robot.x_ref, dtype=float)
    blocks, bar = [], None
    if progress is not None:
        bar = progress(
            total=max(text.count("\n") - header_line, 0),
            unit="row",
            unit_scale=True,
            desc=f"reading {Path(source).name}",
            leave=False,
        )
    try:
        while True:
            block = list(itertools.islice(records, BLOCK_ROWS))
            if not block:
                break
            blocks.append(_parse_block(block, names, source, ev, x_ref))
            if bar is not None:
                bar.update(len(block))
    finally:
        if bar is not None:
            bar.close()
    if not blocks:
        raise MeasurementError(
            source, "no data rows after the header: expected one row per measured frequency", header_line
        )
    lines = np.concatenate([b[0] for b in blocks])
    cols = {
        name: (
            np.concatenate([b[1][name] for b in blocks])
            if isinstance(blocks[0][1][name], np.ndarray)
            else [v for b in blocks for v in b[1][name]]
        )
        for name in names
    }
    n = len(lines)
    blank = lambda name: np.isnan(cols[name]) if name in cols else np.ones(n, dtype=bool)  # noqa: E731
    freq = cols["freq_hz"]
    sigma = np.where(blank("sigma_hz"), DEFAULT_SIGMA_REL * freq, cols.get("sigma_hz", freq))
    poses = np.stack([np.where(blank(a), x_ref[k], cols.get(a, 0.0)) for k, a in enumerate(pose_columns(ev))], axis=1)
    params = {}
    for name in names:
        p = _parameter(name, ev) if name not in REQUIRED + OPTIONAL + ROTATION_COLUMNS else None
        if p is not None:
            fill = values.get(name, values.get(p.name, p.default))
            params[name] = np.where(blank(name), fill, cols[name])
    modal = {name: cols[name] for name in names if name in MODAL or DOF_COLUMN.match(name)}
    joints = None
    if joint_columns(ev)[0] in names:
        for name in joint_columns(ev):
            if blank(name).any():
                raise MeasurementError(
                    source,
                    "empty cell: a joint coordinate is required on every row when the "
                    "file has joint-coordinate columns",
                    int(lines[np.argmax(blank(name))]),
                    name,
                )
        nq = len(joint_columns(ev)) // len(ev.robot.legs)
        joints = np.array([cols[c] for c in joint_columns(ev)], dtype=float).T.reshape(n, len(ev.robot.legs), nq)
    kind = tuple(k or "undamped" for k in cols.get("kind", [None] * n))
    meas = Measurements(
        np.asarray(cols["k_a"], dtype=float),
        tuple(cols["mode"]),
        freq,
        sigma,
        poses,
        params,
        lines,
        source,
        ev.spec,
        modal,
        ev.parameter("k_a").unit,
        joints,
        kind,
    )
    _check_duplicates(meas)
    check_poses(meas, ev, values)
    return meas


class _RowByRow(Exception):
    """A block's column holds a cell that the row-by-row reading reports (named there)."""


def _numeric(name: str, ev):
    """How :func:`_cell` reads column ``name``: ``(positive, parameter or None)`` for a
    number, None for text (``mode``, or any column it reads otherwise)."""
    if name == "mode":
        return None
    if (
        name in ("x", "y", "z")
        or name in ROTATION_COLUMNS
        or name in MODAL[1:-1]
        or DOF_COLUMN.match(name)
        or name in joint_columns(ev)
    ):
        return False, None
    if name in ("damping_ratio", "sigma_damping_ratio", "k_a", "freq_hz", "sigma_hz"):
        return True, None
    p = _parameter(name, ev)
    return (p.bounds[0] >= 0, p) if p is not None else None


def _parse_block(block: list, names: list, source: str, ev, x_ref) -> tuple:
    """``(lines, {name: values})`` of a block of records: a number column as one float
    array (NaN where blank), a text column as a list (each distinct cell read once by
    :func:`_cell`). Whatever is wrong in the block is reported as the row-by-row reading
    reports it (:func:`_parse_rows`: the first bad cell, by line then column)."""
    width = len(names)
    if any(len(cells) != width for _, cells in block):
        return _parse_rows(block, names, source, ev, x_ref)
    lines = np.fromiter((line for line, _ in block), dtype=np.int64, count=len(block))
    out = {}
    try:
        for k, name in enumerate(names):
            cells = [cells[k].strip() for _, cells in block]
            kind = _numeric(name, ev)
            if kind is None:
                seen: dict = {}
                column = []
                for cell, line in zip(cells, lines):
                    if cell not in seen:
                        seen[cell] = _cell(name, cell, source, int(line), ev, x_ref)
                    column.append(seen[cell])
                out[name] = column
                continue
            positive, param = kind
            filled = [c for c in cells if c]
            if len(filled) != len(cells) and name in REQUIRED:
                raise _RowByRow(name)
            values = np.full(len(cells), np.nan)
            values[[bool(c) for c in cells]] = np.fromiter((float(c) for c in filled), dtype=float, count=len(filled))
            given = values[~np.isnan(values)]
            if len(given) != len(filled) or not np.all(np.isfinite(given)) or (positive and np.any(given <= 0)):
                raise _RowByRow(name)
            if param is not None:
                param.check(given)
            out[name] = values
    except (_RowByRow, ValueError):  # MeasurementError and InputError are ValueErrors
        return _parse_rows(block, names, source, ev, x_ref)
    return lines, out


def _parse_rows(block: list, names: list, source: str, ev, x_ref) -> tuple:
    """The row-by-row reading of a block (what :func:`_parse_block` falls back to): raises
    :class:`MeasurementError` at the first bad cell (line, then column)."""
    cols: dict[str, list] = {n: [] for n in names}
    lines = []
    for line, cells in block:
        if len(cells) != len(names):
            raise MeasurementError(source, f"{len(cells)} cells where the header has {len(names)} columns", line)
        lines.append(line)
        for name, cell in zip(names, (c.strip() for c in cells)):
            cols[name].append(_cell(name, cell, source, line, ev, x_ref))
    out = {
        name: (
            column
            if _numeric(name, ev) is None
            else np.array([np.nan if v is None else v for v in column], dtype=float)
        )
        for name, column in cols.items()
    }
    return np.array(lines, dtype=np.int64), out


def _check_duplicates(meas: Measurements) -> None:
    """Two rows with the same conditions would count twice in chi2: an error naming both
    lines (the first row, in file order, whose conditions an earlier row has)."""
    n = len(meas)
    if n < 2:
        return
    labels, codes = np.unique(np.asarray(meas.mode, dtype=str), return_inverse=True)
    keys = [*meas.poses.T, meas.k_a, codes.astype(float), *meas.params.values()]
    order = np.lexsort(keys[::-1])  # stable: equal keys keep file order
    same = np.ones(n - 1, dtype=bool)
    for key in keys:  # one column at a time: bounded memory
        column = key[order]
        same &= column[1:] == column[:-1]  # -0.0 == 0.0, as the rows' values compare
    if not same.any():
        return
    group = np.concatenate([[0], np.cumsum(~same)])  # group number of each sorted row
    first = order[np.flatnonzero(np.concatenate([[True], ~same]))]
    later = np.flatnonzero(np.concatenate([[False], same]))  # sorted positions of repeated rows
    i = int(order[later].min())
    j = int(first[group[np.flatnonzero(order == i)[0]]])
    raise MeasurementError(
        meas.source,
        f"duplicate of line {int(meas.lines[j])} (same pose {meas.poses[i].tolist()}, k_a = "
        f"{meas.k_a[i]:g} {meas.k_a_unit}, mode {meas.mode[i]}): give one row per condition (average repeated "
        "measurements and state their sigma_hz)",
        int(meas.lines[i]),
    )


def check_columns(meas: Measurements, effects, ev, what: str = "the model") -> None:
    """Raise :class:`MeasurementError` for a parameter column whose effect is not in ``effects``."""
    for name in meas.params:
        p = _parameter(name, ev)
        if p is not None and p.effect is not None and p.effect not in effects:
            raise MeasurementError(
                meas.source,
                f"parameter column of effect {p.effect}, which {what} ({', '.join(effects) or 'no effect'}) "
                f"does not have: add {p.effect} to the model or drop the column",
                1,
                name,
            )


def _cell(name: str, cell: str, source: str, line: int, ev, x_ref):
    if name == "mode":
        if not cell:
            raise MeasurementError(source, "empty cell: expected a mode label", line, name)
        try:
            return parse_mode(cell)
        except ValueError as exc:
            raise MeasurementError(source, str(exc), line, name) from None
    if name == "kind":
        if cell and cell.lower() not in KINDS:
            raise MeasurementError(
                source, f"kind {cell!r}: expected {' or '.join(KINDS)} (blank: undamped)", line, name
            )
        return cell.lower() or None
    if not cell:
        if name in REQUIRED:
            raise MeasurementError(source, "empty cell: a value is required", line, name)
        return None
    if (
        name in ("x", "y", "z")
        or name in ROTATION_COLUMNS
        or name in MODAL[1:-1]
        or DOF_COLUMN.match(name)
        or name in joint_columns(ev)
    ):
        return _number(cell, source, line, name, positive=False)
    if name in ("damping_ratio", "sigma_damping_ratio"):
        return _number(cell, source, line, name, positive=True)
    if name in ("k_a", "freq_hz", "sigma_hz"):
        return _number(cell, source, line, name, positive=True)
    p = _parameter(name, ev)
    value = _number(cell, source, line, name, positive=p.bounds[0] >= 0)
    try:
        p.check(value)
    except ValueError as exc:
        raise MeasurementError(source, str(exc), line, name) from None
    return value


def check_poses(meas: Measurements, ev, values: dict | None = None) -> None:
    """Raise :class:`MeasurementError` naming the line of the first unreachable or singular pose.

    ``values`` (SI) are the parameter values of the run where no column gives one.
    """
    given = {k: v for k, v in (values or {}).items() if k not in meas.params}
    bad = []
    for start in range(0, len(meas), BLOCK_ROWS):  # bounded memory: one block's Jacobians
        rows = slice(start, start + BLOCK_ROWS)
        try:
            ev.jacobians(meas.poses[rows], **given, **{k: v[rows] for k, v in meas.params.items()})
        except (UnreachablePoseError, SingularPoseError):
            bad = range(start, len(meas))
            break
    for i in bad:
        try:
            ev.jacobians(meas.poses[i], **given, **{k: v[i] for k, v in meas.params.items()})
        except (UnreachablePoseError, SingularPoseError) as exc:
            from ..runtime.reach import reach_hint

            hint = reach_hint(ev, meas.poses[i], "paper", **given, **{k: v[i] for k, v in meas.params.items()})
            raise MeasurementError(
                meas.source, str(exc) + (f"; {hint}" if hint else ""), int(meas.lines[i]), "x, y, z"
            ) from None


def _decode(data: bytes, name: str) -> str:
    """Text of a file: UTF-16 with a BOM, else UTF-8 (a BOM is dropped)."""
    try:
        if data.startswith((b"\xff\xfe", b"\xfe\xff")):
            return data.decode("utf-16")
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise MeasurementError(
            name, f"not a UTF-8 text file ({exc.reason} at byte {exc.start}): save it as UTF-8 CSV"
        ) from None


def load_measurements(path, robot: str = "heli4", ev=None, values: dict | None = None, progress=None) -> Measurements:
    """Read and validate a measurement CSV file (see the module docstring).

    ``values``, ``progress``: see :func:`parse_csv`. Raises :class:`MeasurementError` (an
    ``InputError``/``ValueError``) naming the file, line and column of the first
    problem; ``OSError`` if the file is unreadable.
    """
    path = Path(path)
    return parse_csv(_decode(path.read_bytes(), str(path)), str(path), ev, robot, values, progress)


def paper_csv(robot: str = "heli4") -> str:
    """Text of the shipped measurements of ``robot`` (``eigentwist/data/<robot>_paper.csv``)."""
    ref = resources.files("eigentwist").joinpath("data", f"{robot}_paper.csv")
    if not ref.is_file():
        raise InputError(f"no shipped measurements for robot {robot!r} (expected eigentwist/data/{robot}_paper.csv)")
    return ref.read_text(encoding="utf-8")


def paper_measurements(ev=None, kind: str | None = None) -> Measurements:
    """The paper's measured omega_1 (mode x) and omega_2 (mode y) at x_ref over k_a.

    Hoevenaars, Krut & Herder (2020), Tables E.1/E.2, "Meas." columns; 16 rows, default
    uncertainty (2 %). Counted from step responses with the servos' damping on, the values
    are damped frequencies (``kind`` ``"damped"``, the file's); ``kind="undamped"`` reads
    them as natural frequencies, as the paper did.
    """
    ev = resolve(ev, "heli4")
    meas = parse_csv(paper_csv("heli4"), "heli4_paper.csv", ev)
    if kind is None:
        return meas
    if kind not in KINDS:
        raise MeasurementError("heli4_paper.csv", f"kind {kind!r}: expected one of {', '.join(KINDS)}")
    return replace(meas, kind=(kind,) * len(meas.freq_hz))
