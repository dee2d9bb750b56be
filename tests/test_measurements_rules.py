"""The measurements' own rules (``eigentwist/diagnose/measurements.py``) on the Heli4's
evaluator (the suite's) and a few rows written here: measurements built from arrays (the CSV format's
defaults), subsets, the CSV written back, the text decoding, parameter columns per leg and per
effect, the shipped paper data. No model is evaluated beyond the poses' reachability.
"""

from __future__ import annotations

import numpy as np
import pytest

import eigentwist

from eigentwist.diagnose.measurements import (
    DEFAULT_SIGMA_REL,
    MeasurementError,
    Measurements,
    _decode,
    _parameter,
    check_columns,
    load_measurements,
    paper_csv,
    paper_measurements,
    parse_csv,
)
from eigentwist.runtime.errors import InputError

X_REF = [0.0, 0.0, -0.625]


def test_from_arrays_applies_the_csv_formats_defaults(ev):
    m = Measurements.from_arrays(1000.0, ["X", "2"], [15.0, 20.0], source="lab", ev=ev)
    assert m.k_a.tolist() == [1000.0, 1000.0] and m.mode == ("x", "2") and m.freq_hz.tolist() == [15.0, 20.0]
    assert np.allclose(m.sigma_hz, [DEFAULT_SIGMA_REL * 15.0, DEFAULT_SIGMA_REL * 20.0])  # 2 %
    assert np.array_equal(m.poses, [X_REF, X_REF]) and m.params == {} and m.modal == {}
    assert m.lines.tolist() == [2, 3] and m.source == "lab" and m.robot == "heli4"  # row i: line i + 2
    assert m.kind == ("undamped", "undamped") and m.k_a_unit == "N m/rad" and m.joints is None
    assert m.where(1) == "lab, line 3"


def test_from_arrays_per_row_values(ev):
    poses = [[0.01, 0.0, -0.6], [0.0, -0.02, -0.62], X_REF]
    m = Measurements.from_arrays(
        [500.0, 1000.0, 2000.0],
        "y",
        [10.0, 12.0, 14.0],
        poses=poses,
        sigma_hz=[0.1, 0.2, 0.3],
        params={"m_e": [0.5, 0.6, 0.7]},
        modal={"damping_ratio": [0.02, np.nan, 0.04]},
        kind=["damped", "undamped", "damped"],
        ev=ev,
    )
    assert m.k_a.tolist() == [500.0, 1000.0, 2000.0] and m.mode == ("y",) * 3
    assert np.array_equal(m.poses, poses) and m.sigma_hz.tolist() == [0.1, 0.2, 0.3]
    assert m.params["m_e"].tolist() == [0.5, 0.6, 0.7]
    assert m.modal["damping_ratio"][0] == 0.02 and np.isnan(m.modal["damping_ratio"][1])  # NaN: a blank cell
    assert m.kind == ("damped", "undamped", "damped") and m.damped.tolist() == [True, False, True]
    one = Measurements.from_arrays(1000.0, ["x", "y"], [15.0, 16.0], poses=[0.0, 0.0, -0.6], kind="damped", ev=ev)
    assert np.array_equal(one.poses, [[0.0, 0.0, -0.6]] * 2) and one.kind == ("damped", "damped")
    with pytest.raises(MeasurementError) as err:  # the file's checks apply: line 3 is row 1
        Measurements.from_arrays(1000.0, "x", [15.0, -1.0], source="arrays", ev=ev)
    assert str(err.value).startswith("arrays, line 3, column 'freq_hz': negative value -1")


def test_subset_keeps_every_column(ev):
    m = Measurements.from_arrays(
        [500.0, 1000.0, 2000.0],
        ["x", "y", "x"],
        [10.0, 12.0, 14.0],
        sigma_hz=[0.1, 0.2, 0.3],
        params={"m_e": [0.5, 0.6, 0.7]},
        modal={"damping_ratio": [0.02, 0.03, 0.04]},
        kind=["damped", "undamped", "damped"],
        source="lab",
        ev=ev,
    )
    s = m.subset([2, 0])
    assert s.k_a.tolist() == [2000.0, 500.0] and s.mode == ("x", "x") and s.freq_hz.tolist() == [14.0, 10.0]
    assert s.sigma_hz.tolist() == [0.3, 0.1] and s.lines.tolist() == [4, 2] and s.params["m_e"].tolist() == [0.7, 0.5]
    assert s.modal["damping_ratio"].tolist() == [0.04, 0.02] and s.kind == ("damped", "damped")
    assert (s.source, s.robot, s.k_a_unit, s.joints) == ("lab", "heli4", "N m/rad", None)
    assert np.array_equal(s.poses, m.poses[[2, 0]])
    t = m.subset(np.array([False, True, True]))  # a mask
    assert t.freq_hz.tolist() == [12.0, 14.0] and t.kind == ("undamped", "damped") and t.mode == ("y", "x")
    joints = Measurements(m.k_a, m.mode, m.freq_hz, m.sigma_hz, m.poses, joints=np.arange(12.0).reshape(3, 4, 1))
    assert joints.subset([1]).joints.tolist() == [[[4.0], [5.0], [6.0], [7.0]]]


def test_to_csv_columns_and_numbers(ev, tmp_path):
    m = Measurements.from_arrays(
        1000.0,
        ["x", "y"],
        [15.123456789012, 20.0],
        poses=[[0.01, 0.0, -0.6], X_REF],
        params={"m_e": [0.5, 0.6]},
        modal={"damping_ratio": [0.02, np.nan]},
        ev=ev,
    )
    text = m.to_csv()
    lines = text.splitlines()
    assert lines[0] == "k_a,mode,freq_hz,sigma_hz,x,y,z,damping_ratio,m_e"  # no kind column: all undamped
    assert lines[1] == "1000,x,15.12345679,0.3024691358,0.01,0,-0.6,0.02,0.5"  # 10 significant digits
    assert lines[2] == "1000,y,20,0.4,0,0,-0.625,,0.6" and len(lines) == 3 and text.endswith("\n")
    assert "\r" not in text
    tiny = Measurements.from_arrays(1000.0, "x", [15.0], params={"m_e": 2.5e-12}, ev=ev)
    assert tiny.to_csv().splitlines()[1].endswith(",2.5e-12")
    damped = Measurements.from_arrays(1000.0, "x", [15.0], kind="damped", ev=ev)
    assert damped.to_csv().splitlines() == ["k_a,mode,freq_hz,sigma_hz,kind,x,y,z", "1000,x,15,0.3,damped,0,0,-0.625"]
    path = tmp_path / "out.csv"
    assert m.to_csv(path) == text and path.read_text() == text
    six = Measurements(np.ones(1), ("x",), np.ones(1), np.ones(1), np.array([[0.0, 0.0, -0.6, 0.1, 0.0, 0.0]]))
    assert six.to_csv().splitlines()[0] == "k_a,mode,freq_hz,sigma_hz,x,y,z,rot_x,rot_y,rot_z"


@pytest.mark.parametrize(
    "data, text",
    [
        ("k_a,mode\n".encode("utf-16"), "k_a,mode\n"),  # a BOM and the machine's order
        ("k_a,µ\n".encode("utf-16-be").join([b"\xfe\xff", b""]), "k_a,µ\n"),
        ("k_a,µ\n".encode("utf-16-le").join([b"\xff\xfe", b""]), "k_a,µ\n"),
        (b"\xef\xbb\xbfk_a,mode\n", "k_a,mode\n"),  # UTF-8's BOM dropped
        ("k_a,µ\n".encode("utf-8"), "k_a,µ\n"),
    ],
)
def test_decode(data, text):
    assert _decode(data, "f.csv") == text


def test_decode_refuses_what_is_not_utf8(tmp_path):
    with pytest.raises(MeasurementError) as err:
        _decode(b"k_a,mode\n\xe9t\xe9\n", "f.csv")
    assert str(err.value) == "f.csv: not a UTF-8 text file (invalid continuation byte at byte 9): save it as UTF-8 CSV"
    path = tmp_path / "latin.csv"
    path.write_bytes(b"k_a,mode,freq_hz\n1000,x,1\xe9\n")
    with pytest.raises(MeasurementError) as err:
        load_measurements(path)
    assert str(err.value).startswith(f"{path}: not a UTF-8 text file")


def test_load_measurements_reads_the_file(ev, tmp_path):
    path = tmp_path / "lab.csv"
    path.write_bytes("\ufeffk_a,mode,freq_hz,m_e\n1000,x,15,\n".encode("utf-16"))
    m = load_measurements(path, ev=ev, values={"m_e": 0.9})
    assert m.source == str(path) and m.freq_hz.tolist() == [15.0] and m.params["m_e"].tolist() == [0.9]
    seen = []

    class Bar:
        def __init__(self, **kw):
            seen.append(kw)

        def update(self, n):
            seen.append(n)

        def close(self):
            seen.append("closed")

    load_measurements(str(path), robot="heli4", progress=Bar)
    assert seen[1:] == [1, "closed"] and seen[0]["desc"] == "reading lab.csv" and seen[0]["total"] == 1


def test_parameter_columns_by_name_and_leg(ev):
    assert _parameter("m_e", ev) is ev.parameters["m_e"]
    assert _parameter("eta_a@3", ev) is ev.parameters["eta_a"] and _parameter("eta_a@1", ev) is ev.parameters["eta_a"]
    for name in ("eta_a@0", "eta_a@x", "eta_a@", "eta_a@-1", "nothing", "nothing@2"):
        assert _parameter(name, ev) is None, name


def test_check_columns_names_the_effect_a_column_needs(ev):
    m = parse_csv("k_a,mode,freq_hz,c_a,m_e\n1000,x,15,2,0.5\n", "lab.csv", ev)
    check_columns(m, ("servo_damping",), ev)  # the column's effect is on; m_e belongs to none
    with pytest.raises(MeasurementError) as err:
        check_columns(m, ("rod_compliance", "ee_compliance"), ev, what="the model 'flex'")
    assert str(err.value) == (
        "lab.csv, line 1, column 'c_a': parameter column of effect servo_damping, which the model 'flex' "
        "(rod_compliance, ee_compliance) does not have: add servo_damping to the model or drop the column"
    )
    with pytest.raises(MeasurementError) as err:
        check_columns(m, (), ev)
    assert "which the model (no effect) does not have" in str(err.value)
    legs = parse_csv("k_a,mode,freq_hz,eta_a@2\n1000,x,15,0.8\n", "lab.csv", ev)
    check_columns(legs, ("actuator_loss",), ev)
    with pytest.raises(MeasurementError) as err:
        check_columns(legs, (), ev)
    assert err.value.column == "eta_a@2" and err.value.line == 1


def test_shipped_paper_data():
    with pytest.raises(InputError) as err:
        paper_csv("nobody")
    assert str(err.value) == "no shipped measurements for robot 'nobody' (expected eigentwist/data/nobody_paper.csv)"
    assert paper_csv() == paper_csv("heli4") and paper_csv().startswith("k_a,mode,freq_hz")


def test_paper_measurements_read_as_damped_or_undamped(ev):
    m = paper_measurements(ev)
    assert m.kind == ("damped",) * 16 and m.source == "heli4_paper.csv" and len(m) == 16
    u = paper_measurements(ev, kind="undamped")
    assert u.kind == ("undamped",) * 16 and np.array_equal(u.freq_hz, m.freq_hz) and u.source == m.source
    assert paper_measurements(kind="damped").kind == ("damped",) * 16
    with pytest.raises(MeasurementError) as err:
        paper_measurements(ev, kind="natural")
    assert str(err.value) == "heli4_paper.csv: kind 'natural': expected one of undamped, damped"


def deepest_reported(message):
    """The lowest height of the reachable spans the message's hint gives (m)."""
    return float(message.split("heights are z in [")[1].split(",")[0])


def test_poses_are_checked_with_the_runs_values(ev):
    """A rod of 0.3 m (``values``, as ``--set`` gives it) cannot reach x_ref (0.625 m below the
    base): the line is named and the hint's heights are those of the short rod (x_ref outside
    them); a column of the rod's length wins over the run's value."""
    with pytest.raises(MeasurementError) as err:
        parse_csv("k_a,mode,freq_hz\n1000,x,15\n", "lab.csv", ev, values={"l2": 0.3})
    assert str(err.value).startswith("lab.csv, line 2, column 'x, y, z': pose [0.0, 0.0, -0.625] m is unreachable")
    assert -0.625 < deepest_reported(str(err.value)) < -0.5  # the 0.2 + 0.3 m links reach below -0.5 m
    m = parse_csv("k_a,mode,freq_hz,l2\n1000,x,15,0.53\n", "lab.csv", ev, values={"l2": 0.3})
    assert m.params["l2"].tolist() == [0.53]


@pytest.mark.parametrize("bad", [0, 3])
def test_poses_are_checked_block_by_block(ev, monkeypatch, bad):
    """Blocks of two rows: the first unreachable row is named, its rod length from its own cell."""
    from eigentwist.diagnose import measurements

    monkeypatch.setattr(measurements, "BLOCK_ROWS", 2)
    rows = [f"1000,{mode},15,{0.3 if k == bad else ''}" for k, mode in enumerate("xyz12")]
    with pytest.raises(MeasurementError) as err:
        parse_csv("k_a,mode,freq_hz,l2\n" + "\n".join(rows) + "\n", "lab.csv", ev)
    assert str(err.value).startswith(
        f"lab.csv, line {bad + 2}, column 'x, y, z': pose [0.0, 0.0, -0.625] m is unreachable"
    )
    assert -0.625 < deepest_reported(str(err.value)) < -0.5


@pytest.mark.parametrize(
    "header, cell, column, message",
    [
        ("mode", "", "mode", "empty cell: expected a mode label"),
        ("kind", "natural", "kind", "kind 'natural': expected undamped or damped (blank: undamped)"),
        ("freq_hz", "", "freq_hz", "empty cell: a value is required"),
        ("k_a", "-5", "k_a", "negative value -5: expected a value > 0"),
        ("phi_x", "abc", "phi_x", "value 'abc' is not a number"),
        ("damping_ratio", "-0.1", "damping_ratio", "negative value -0.1: expected a value > 0"),
        ("sigma_damping_ratio", "0", "sigma_damping_ratio", "value 0: expected a value > 0"),
        ("sigma_damping_ratio", "-0.01", "sigma_damping_ratio", "negative value -0.01: expected a value > 0"),
        ("m_e", "-1", "m_e", "negative value -1: expected a value > 0"),
        ("q1@2", "inf", "q1@2", "value 'inf' is not finite: expected a number"),
    ],
)
def test_a_bad_cell_is_named(ev, header, cell, column, message):
    """The second row's cell in the named column is bad; the first row is good."""
    good = {"k_a": "1000", "mode": "y", "freq_hz": "15", "kind": "damped", "phi_x": "0.5", "damping_ratio": "0.02"}
    good.update({"sigma_damping_ratio": "0.01", "m_e": "0.5", "q1@2": "0.1"})
    names = ["k_a", "mode", "freq_hz"] + ([header] if header not in ("k_a", "mode", "freq_hz") else [])
    if header == "phi_x":
        names += ["sensor_x"]
    if header.startswith("q"):
        names = names[:3] + [f"q{m}@{leg}" for leg in range(1, 5) for m in (1, 2, 3)]
    first = ",".join(good.get(n, "0.1") for n in names)
    second = ",".join(cell if n == header else {"mode": "x"}.get(n, good.get(n, "0.1")) for n in names)
    with pytest.raises(MeasurementError) as err:
        parse_csv(",".join(names) + "\n" + first + "\n" + second + "\n", "lab.csv", ev)
    assert str(err.value) == f"lab.csv, line 3, column {column!r}: {message}"


def test_cells_signed_where_their_quantity_is(ev):
    """Sensor offsets, shape entries, joint coordinates and a parameter whose range is signed take
    negative values; a kind is read in any case."""
    text = "k_a,mode,freq_hz,kind,sensor_x,phi_x,phi_y,phi_z,p_x\n1000,x,15,DAMPED,-0.1,-0.5,0.2,0.1,-0.5\n"
    m = parse_csv(text, "lab.csv", ev)
    assert m.kind == ("damped",) and m.modal["sensor_x"].tolist() == [-0.1] and m.modal["phi_x"].tolist() == [-0.5]
    assert m.params["p_x"].tolist() == [-0.5]
    with pytest.raises(MeasurementError) as err:
        parse_csv("k_a,mode,freq_hz,eta_a\n1000,x,15,0.5\n1000,y,15,1.5\n", "lab.csv", ev)
    assert str(err.value).startswith("lab.csv, line 3, column 'eta_a': ") and "1.5" in str(err.value)


def test_a_duplicate_row_names_both_lines(ev):
    with pytest.raises(MeasurementError) as err:
        parse_csv("k_a,mode,freq_hz\n1000,x,15\n2000,x,16\n1000,x,15.5\n", "lab.csv", ev)
    assert str(err.value) == (
        "lab.csv, line 4: duplicate of line 2 (same pose [0.0, 0.0, -0.625], k_a = 1000 N m/rad, mode x): give one "
        "row per condition (average repeated measurements and state their sigma_hz)"
    )


def test_measurements_built_directly_number_their_lines_from_two():
    m = Measurements(np.ones(3), ("x", "y", "z"), np.ones(3), np.ones(3), np.zeros((3, 3)))
    assert m.lines.tolist() == [2, 3, 4] and m.kind == ("undamped",) * 3 and len(m) == 3
    assert np.array_equal(m.relative_sigma, np.ones(3)) and m.where(2) == "<data>, line 4"


JOINTS = ", ".join(f"q{m}@{leg}" for leg in range(1, 5) for m in (1, 2, 3))  # the Heli4: 4 legs of 3 coordinates


def refusal(ev, text, source="lab.csv", **kw):
    with pytest.raises(MeasurementError) as err:
        parse_csv(text, source, ev, **kw)
    return str(err.value)


def test_header_refusals(ev):
    assert refusal(ev, "k_a,,freq_hz\n1,x,2\n") == "lab.csv, line 1: column 2 has an empty name"
    assert refusal(ev, "k_a,mode,freq_hz,k_a\n1,x,2,1\n") == (
        "lab.csv, line 1, column 'k_a': column 'k_a' appears twice (columns 1 and 4)"
    )
    unknown = refusal(ev, "k_a,mode,freq_hz,m_ee\n1000,x,15\n")
    assert unknown.startswith(
        "lab.csv, line 1, column 'm_ee': unknown column (column 4) (did you mean m_e?): not one of "
    )
    assert (
        "not one of k_a, mode, freq_hz, x, y, z, sigma_hz, kind, damping_ratio, phi_x, phi_y, phi_z, sensor_x, "
        f"sensor_y, sensor_z, sigma_damping_ratio, {JOINTS} and not a parameter of heli4 (NAME or NAME@LEG; "
        "parameters: R, l1, l2, r, d, h," in unknown
    )
    assert unknown.endswith(", c_a, t_d, eta_s)")
    assert refusal(ev, "k_a,mode,sigma_hz\n1000,x,1\n") == (
        "lab.csv, line 1, column 'freq_hz': missing required column 'freq_hz' (header: k_a, mode, sigma_hz); "
        "required: k_a, mode, freq_hz"
    )
    assert refusal(ev, "k_a,mode,freq_hz,phi_2_x,node2_x,node2_y\n1000,x,15,1,0,0\n") == (
        "lab.csv, line 1, column 'phi_2_x': shape column phi_2_x needs node 2's position: columns node2_x, node2_y, "
        "node2_z (m)"
    )
    m = parse_csv("k_a,mode,freq_hz,phi_2_x,node2_x,node2_y,node2_z\n1000,x,15,1,0.1,0,0\n", "lab.csv", ev)
    assert m.modal["phi_2_x"].tolist() == [1.0] and m.modal["node2_x"].tolist() == [0.1]
    assert refusal(ev, "k_a,mode,freq_hz,q1@1,q2@1\n1000,x,15,0.1,0.2\n") == (
        "lab.csv, line 1, column 'q3@1': joint-coordinate column 'q3@1' is missing: give every coordinate of every "
        f"leg ({JOINTS}) or none"
    )


def test_joint_coordinates_on_every_row(ev):
    cols = JOINTS.split(", ")
    header = "k_a,mode,freq_hz," + ",".join(cols)
    values = ",".join(str(0.01 * k) for k in range(12))
    m = parse_csv(f"{header}\n1000,x,15,{values}\n", "lab.csv", ev)
    assert m.joints.shape == (1, 4, 3) and m.joints[0, 1].tolist() == [0.03, 0.04, 0.05]  # leg 2's q1..q3
    blank = ",".join("" if c == "q2@3" else "0.1" for c in cols)
    assert refusal(ev, f"{header}\n1000,x,15,{values}\n1000,y,15,{blank}\n") == (
        "lab.csv, line 3, column 'q2@3': empty cell: a joint coordinate is required on every row when the file has "
        "joint-coordinate columns"
    )


def test_pose_columns_of_a_six_dof_robot():
    from types import SimpleNamespace as NS

    from eigentwist.diagnose.measurements import _header, pose_columns

    six = ("x", "y", "z", "rot_x", "rot_y", "rot_z")
    assert pose_columns(NS()) == ("x", "y", "z") and pose_columns(NS(pose_names=list(six))) == six
    ev = NS(
        pose_names=six,
        accepts=lambda name: False,
        parameters={},
        robot=NS(name="hexa", legs=[NS(kinematics=NS(coordinates=("q",)))]),
    )
    assert _header(["k_a", "mode", "freq_hz", "rot_x", " q1@1 "], "lab.csv", ev) == [
        "k_a",
        "mode",
        "freq_hz",
        "rot_x",
        "q1@1",
    ]


def test_separator_and_what_is_not_a_measurement_csv(ev):
    from eigentwist.diagnose.measurements import _separator

    assert _separator("k_a;mode,freq_hz\n", "s") == ","  # a tie: the comma
    assert _separator("k_a\tmode\tfreq_hz;x\n", "s") == "\t"
    assert _separator("  # a;b;c;d\nk_a,mode,freq_hz\n", "s") == ","  # an indented comment is skipped
    assert refusal(ev, "    -1\n   151\n") == (
        "lab.csv, line 1: a UFF file (universal file format), not a measurement CSV: identify its modes first, "
        "`eigentwist identify MANIFEST.csv -o modes.csv` on the campaign's manifest, and compare modes.csv"
    )
    long = "k_a mode freq_hz " * 5
    assert refusal(ev, long + "\n1 x 2\n") == (
        f"lab.csv, line 1: header {long.strip()[:60]!r} has a single column: expected the columns k_a, mode, "
        "freq_hz, ... separated by ',', ';' or a tab"
    )


def test_records_decimal_commas_blank_rows_and_unreadable_csv(ev):
    m = parse_csv("k_a;mode;freq_hz\n\n;;\n1000;x;15,5\n", "lab.csv", ev)
    assert m.freq_hz.tolist() == [15.5] and m.lines.tolist() == [4]  # blank rows skipped, a decimal comma read
    m = parse_csv("k_a\tmode\tfreq_hz\n1000\tx\t15,25\n", "lab.csv", ev)
    assert m.freq_hz.tolist() == [15.25]
    assert refusal(ev, "k_a;mode;freq_hz;m,e\n1000;x;15;1\n").startswith(
        "lab.csv, line 1, column 'm,e': unknown column"
    )
    assert refusal(ev, "k_a,mode,freq_hz\n1000,x," + "1" * 140000 + "\n") == (
        "lab.csv, line 2: not readable as CSV (field larger than field limit (131072)): expected text with one row "
        "per line"
    )


def test_parse_csv_whole_file_rules(ev):
    assert refusal(ev, "k_a,mode,freq_hz\n1000,x,-15\n", source="<data>").startswith("<data>, line 2")
    with pytest.raises(MeasurementError) as err:
        parse_csv("k_a,mode,freq_hz\n1000,x,-15\n", ev=ev)  # the default name
    assert str(err.value).startswith("<data>, line 2, column 'freq_hz'")
    assert parse_csv("k_a,mode,freq_hz\n1000,x,15\n").robot == "heli4"  # the default robot
    assert (
        refusal(ev, "k_a,mode,freq_hz\n1000,x\x00,15\n")
        == "lab.csv: contains NUL characters: expected a text file (CSV)"
    )
    assert parse_csv("\ufeffk_a,mode,freq_hz\n1000,x,15\n", "lab.csv", ev).freq_hz.tolist() == [15.0]  # a BOM dropped
    last = parse_csv("k_a,mode,freq_hz\n1000,x,15\n2000,x,16", "lab.csv", ev)  # no line end after the last row
    assert last.freq_hz.tolist() == [15.0, 16.0] and last.lines.tolist() == [2, 3]
    assert refusal(ev, "\n# only a comment\n") == (
        "lab.csv: empty file: expected a header line with the columns k_a, mode, freq_hz and one row per measured "
        "frequency"
    )
    assert refusal(ev, "# c\nk_a,mode,freq_hz\n\n") == (
        "lab.csv, line 2: no data rows after the header: expected one row per measured frequency"
    )
    seen = []

    class Bar:
        def __init__(self, **kw):
            seen.append(kw)

        def update(self, n):
            seen.append(n)

        def close(self):
            seen.append("closed")

    parse_csv("# c\nk_a,mode,freq_hz\n1000,x,15\n2000,x,15\n", "dir/lab.csv", ev, progress=Bar)
    assert seen == [dict(total=2, unit="row", unit_scale=True, desc="reading lab.csv", leave=False), 2, "closed"]


def test_blank_parameter_cells_take_the_runs_values(ev):
    text = "k_a,mode,freq_hz,eta_a@2,m_e\n1000,x,15,,\n1000,y,15,0.5,0.4\n"
    m = parse_csv(text, "lab.csv", ev, values={"eta_a": 0.7, "m_e": 0.9})
    assert m.params["eta_a@2"].tolist() == [0.7, 0.5] and m.params["m_e"].tolist() == [0.9, 0.4]
    m = parse_csv(text, "lab.csv", ev, values={"eta_a@2": 0.6, "eta_a": 0.7})  # the leg's own value first
    assert m.params["eta_a@2"].tolist() == [0.6, 0.5] and m.params["m_e"][0] == ev.parameters["m_e"].default


def test_a_six_dof_robots_measurements(tmp_path):
    """The hexapod's poses have six columns (the rotation vector last): from arrays, from a file
    (blank rotation cells: x_ref's) and back to CSV, each read with the evaluator given."""
    hexapod = eigentwist.load("hexapod", backend="numpy")
    x_ref = np.asarray(hexapod.robot.x_ref, dtype=float)
    pose = x_ref + [0.0, 0.0, 0.01, 0.02, 0.0, 0.0]
    m = Measurements.from_arrays(1000.0, ["x", "y"], [15.0, 16.0], poses=pose, ev=hexapod)  # the robot: ev's
    assert m.poses.shape == (2, 6) and np.allclose(m.poses[1], pose) and m.robot == "hexapod"
    assert m.k_a_unit == hexapod.parameter("k_a").unit
    text = m.to_csv()
    assert text.splitlines()[0] == "k_a,mode,freq_hz,sigma_hz,x,y,z,rot_x,rot_y,rot_z"
    path = tmp_path / "hexapod.csv"
    path.write_text("k_a,mode,freq_hz,z,rot_x\n1000,x,15,,0.02\n")
    read = load_measurements(path, ev=hexapod)
    assert np.allclose(read.poses, [[*x_ref[:3], 0.02, *x_ref[4:]]]) and read.robot == "hexapod"
    assert np.allclose(parse_csv(text, "back.csv", hexapod).poses, m.poses)


def test_defaults_of_the_readers(ev, tmp_path):
    """Without a robot: the Heli4's; without a name: ``<data>``; no rows: the file's error."""
    m = Measurements.from_arrays(1000.0, "x", [15.0], ev=ev)
    assert m.source == "<data>" and m.lines.tolist() == [2]
    assert Measurements.from_arrays(1000.0, "x", [15.0]).robot == "heli4"
    path = tmp_path / "lab.csv"
    path.write_text("k_a,mode,freq_hz\n1000,x,15\n")
    assert load_measurements(path).robot == "heli4"
    with pytest.raises(MeasurementError) as err:
        Measurements.from_arrays(1000.0, "x", [], ev=ev)
    assert str(err.value) == "<data>, line 1: no data rows after the header: expected one row per measured frequency"


def test_modal_columns_are_arrays_whichever_reader(ev):
    """A block read at once and a block read row by row (a short row follows) give the same
    columns: signed sensor offsets and a signed parameter accepted, each modal column an array."""
    header = "k_a,mode,freq_hz,sensor_z,sigma_damping_ratio,damping_ratio,p_x\n"
    good = "1000,x,15,-0.1,0.01,0.02,-0.5\n"
    m = parse_csv(header + good, "lab.csv", ev)
    for name in ("sensor_z", "sigma_damping_ratio", "damping_ratio"):
        assert isinstance(m.modal[name], np.ndarray) and m.modal[name].dtype == float, name
    assert m.modal["sensor_z"].tolist() == [-0.1] and m.params["p_x"].tolist() == [-0.5]
    with pytest.raises(MeasurementError) as err:  # row by row: the first row's cells read, then the short row
        parse_csv(header + good + "1000,y,15\n", "lab.csv", ev)
    assert str(err.value) == "lab.csv, line 3: 3 cells where the header has 7 columns"


def test_a_quoted_decimal_comma_in_a_comma_separated_file_is_refused(ev):
    with pytest.raises(MeasurementError) as err:
        parse_csv('k_a,mode,freq_hz\n1000,x,"15,5"\n', "lab.csv", ev)
    assert str(err.value) == "lab.csv, line 2, column 'freq_hz': value '15,5' is not a number"


def test_an_unreachable_pose_without_a_hint(ev, monkeypatch):
    from eigentwist.runtime import reach

    monkeypatch.setattr(reach, "reach_hint", lambda *a, **k: "")
    message = refusal(ev, "k_a,mode,freq_hz\n1000,x,15\n", values={"l2": 0.3})
    assert "; " not in message and message.endswith("expected within [-1, 1])")  # the pose's own reason alone
