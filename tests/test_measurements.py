"""Measurement CSV files: defaults, per-row parameters, and errors naming file, line and column."""

from __future__ import annotations

import numpy as np
import pytest

from eigentwist.diagnose import MeasurementError, load_measurements, paper_measurements
from eigentwist.diagnose.measurements import DEFAULT_SIGMA_REL, paper_csv
from eigentwist.paper import MEASURED, TABLE_KA


def write(tmp_path, text, name="data.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


def test_paper_data_is_tables_e1_e2(ev):
    m = paper_measurements(ev)
    assert len(m) == 16 and set(m.mode) == {"x", "y"}
    for label in ("x", "y"):
        rows = np.asarray(m.mode) == label
        assert m.k_a[rows].tolist() == list(TABLE_KA)
        assert m.freq_hz[rows].tolist() == list(MEASURED[label])
    assert np.allclose(m.poses, [0.0, 0.0, -0.625])
    assert paper_csv().splitlines()[0] == "k_a,mode,freq_hz,x,y,z,kind"
    assert set(m.kind) == {"damped"}  # counted from step responses (Sec. 4)


def test_defaults_pose_sigma_and_parameter_columns(tmp_path, ev):
    path = write(tmp_path, "# comment\nk_a,mode,freq_hz,z,sigma_hz,m_e\n\n1000,X,15.5,,0.3,\n2000,2,20.0,-0.6,,0.7\n")
    m = load_measurements(path, ev=ev)
    assert m.mode == ("x", "2")
    assert m.lines.tolist() == [4, 5]
    assert np.allclose(m.poses, [[0.0, 0.0, -0.625], [0.0, 0.0, -0.6]])  # x, y and blank z -> x_ref
    assert np.allclose(m.sigma_hz, [0.3, DEFAULT_SIGMA_REL * 20.0])
    assert np.allclose(m.params["m_e"], [ev.parameters["m_e"].default, 0.7])  # blank -> default


def test_parameter_column_overrides_the_row(tmp_path, ev):
    path = write(tmp_path, "k_a,mode,freq_hz,m_e\n2000,x,20,0.592\n2000,x,20,2.0\n")
    from eigentwist.diagnose import compare

    pred = compare(load_measurements(path, ev=ev), "rigid", ev).predicted
    direct = [ev.frequencies(ev.robot.x_ref, "rigid", k_a=2000.0, m_e=m)[0, 0] for m in (0.592, 2.0)]
    assert np.allclose(pred, direct) and pred[1] < pred[0]


@pytest.mark.parametrize(
    "text, line, column, words",
    [
        ("k_a,freq_hz\n1000,15\n", 1, "mode", "missing required column"),
        ("k_a,mode,freq_hz\n1000,x,fast\n", 2, "freq_hz", "not a number"),
        ("k_a,mode,freq_hz\n1000,x,15\n-5,y,12\n", 3, "k_a", "negative"),
        ("k_a,mode,freq_hz,sigma_hz\n1000,x,15,-0.1\n", 2, "sigma_hz", "negative"),
        ("k_a,mode,freq_hz\n1000,x,0\n", 2, "freq_hz", "> 0"),
        ("k_a,mode,freq_hz\n1000,x,nan\n", 2, "freq_hz", "not finite"),
        ("k_a,mode,freq_hz\n1000,x,15\n1000,sideways,15\n", 3, "mode", "unknown mode label"),
        ("k_a,mode,freq_hz\n1000,0,15\n", 2, "mode", "unknown mode label"),
        ("k_a,mode,freq_hz,flux\n1000,x,15,1\n", 1, "flux", "unknown column"),
        ("k_a,mode,freq_hz,E_rod\n1000,x,15,-1e9\n", 2, "E_rod", "negative"),
        ("k_a,mode,freq_hz,eta_a\n1000,x,15,7\n", 2, "eta_a", "eta_a"),
        ("k_a,mode,freq_hz,z\n1000,x,15,-0.625\n1000,x,15,-3\n", 3, "x, y, z", "unreachable"),
        ("k_a,mode,freq_hz\n1000,x\n", 2, None, "2 cells where the header has 3"),
        ("k_a,mode,freq_hz,k_a\n1000,x,15,3\n", 1, "k_a", "appears twice"),
        ("k_a,mode,freq_hz\n,x,15\n", 2, "k_a", "empty cell"),
    ],
)
def test_errors_name_file_line_and_column(tmp_path, ev, text, line, column, words):
    path = write(tmp_path, text, "bench.csv")
    with pytest.raises(MeasurementError) as info:
        load_measurements(path, ev=ev)
    msg = str(info.value)
    assert "bench.csv" in msg and f"line {line}" in msg and words in msg
    if column is not None:
        assert f"column {column!r}" in msg
    assert info.value.line == line


@pytest.mark.parametrize(
    "text, words", [("", "empty file"), ("# only a comment\n\n", "empty file"), ("k_a,mode,freq_hz\n", "no data rows")]
)
def test_empty_files(tmp_path, ev, text, words):
    with pytest.raises(MeasurementError, match=words) as info:
        load_measurements(write(tmp_path, text, "empty.csv"), ev=ev)
    assert "empty.csv" in str(info.value)


def test_singular_pose_is_named(tmp_path, ev):
    l1, l2, R, r, d = (ev.defaults[k] for k in ("l1", "l2", "R", "r", "d"))
    z = float(-np.sqrt((l1 + l2) ** 2 - (R - r) ** 2) - d + 1e-9)
    path = write(tmp_path, f"k_a,mode,freq_hz,z\n1000,x,15,-0.6\n1000,x,15,{z!r}\n")
    with pytest.raises(MeasurementError, match=r"line 3, column 'x, y, z'.*(singular|unreachable)"):
        load_measurements(path, ev=ev)


def test_measurement_errors_are_value_errors(tmp_path, ev):
    # the CLI turns ValueError into one line without a traceback
    with pytest.raises(ValueError):
        load_measurements(write(tmp_path, "k_a,mode\n"), ev=ev)


def test_round_trip_through_csv(tmp_path, ev):
    m = paper_measurements(ev)
    m2 = load_measurements(write(tmp_path, m.to_csv()), ev=ev)
    assert np.allclose(m2.freq_hz, m.freq_hz) and np.allclose(m2.sigma_hz, m.sigma_hz) and m2.mode == m.mode
