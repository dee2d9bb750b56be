"""Large measurement files: read a block of rows at a time, a column at once, evaluated a block
at a time, listed by their failing rows; the same numbers and the same errors as row by row
(the figures at 10^6 rows: benchmarks/large_inputs.py, benchmarks/README.md)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import eigentwist.diagnose.measurements as measurements
import eigentwist.diagnose.predict as predict
from eigentwist.diagnose import MeasurementError, load_measurements, paper_measurements
from eigentwist.diagnose.compare import compare
from eigentwist.diagnose.verdict import comparison_table

ROWS = """k_a,mode,freq_hz,x,y,z,sigma_hz,m_e,eta_a@2
1000,X,15.5,,0.001,-0.625,0.3,,
# a comment between rows
2000,2,20.0,0.01,,-0.6,,0.7,0.5

1000,y,16.0,0.0,0.0,-0.61,0.25,0.6,
4000,3,40.0,-0.01,0.01,-0.62,,,0.7
"""


def _fields(m):
    return {f.name: getattr(m, f.name) for f in dataclasses.fields(m)}


def _same(a, b):
    fa, fb = _fields(a), _fields(b)
    assert fa.keys() == fb.keys()
    for key in fa:
        x, y = fa[key], fb[key]
        if isinstance(x, dict):
            assert x.keys() == y.keys(), key
            for k in x:
                np.testing.assert_array_equal(x[k], y[k], err_msg=f"{key}[{k}]")
        elif isinstance(x, np.ndarray) or isinstance(y, np.ndarray):
            np.testing.assert_array_equal(x, y, err_msg=key)
        else:
            assert x == y, key


@pytest.mark.parametrize("block", [1, 2, 1000])
def test_blocks_and_columns_read_as_rows_do(tmp_path, ev, monkeypatch, block):
    """Every block size (a block of one row, blocks split by comments and blank lines, one
    block) gives the row-by-row reading's measurements, field by field."""
    path = tmp_path / "data.csv"
    path.write_text(ROWS)
    monkeypatch.setattr(measurements, "_parse_block", measurements._parse_rows)
    rows = load_measurements(path, ev=ev)
    monkeypatch.undo()
    monkeypatch.setattr(measurements, "BLOCK_ROWS", block)
    _same(load_measurements(path, ev=ev), rows)
    assert rows.mode == ("x", "2", "y", "3") and rows.lines.tolist() == [2, 4, 6, 7]
    assert np.allclose(
        rows.params["eta_a@2"], [ev.parameters["eta_a"].default, 0.5, ev.parameters["eta_a"].default, 0.7]
    )


def test_a_clean_block_is_read_a_column_at_once(tmp_path, ev, monkeypatch):
    """Clean rows never go through the row-by-row reader (the fallback is for bad cells):
    number columns come back as float arrays, NaN where blank."""
    path = tmp_path / "data.csv"
    path.write_text(ROWS)
    lines = [line.split(",") for line in ROWS.splitlines() if line and not line.startswith("#")]
    block = [(k + 2, cells) for k, cells in enumerate(lines[1:])]
    got_lines, cols = measurements._parse_block(block, lines[0], "data.csv", ev, np.zeros(3))
    monkeypatch.setattr(measurements, "_parse_rows", lambda *a: pytest.fail("read row by row"))
    load_measurements(path, ev=ev)
    assert got_lines.tolist() == [2, 3, 4, 5] and cols["mode"] == ["x", "2", "y", "3"]
    for name in lines[0]:
        if name != "mode":
            assert isinstance(cols[name], np.ndarray) and cols[name].dtype == float, name
    np.testing.assert_array_equal(cols["x"], [np.nan, 0.01, 0.0, -0.01])
    np.testing.assert_array_equal(cols["sigma_hz"], [0.3, np.nan, 0.25, np.nan])


@pytest.mark.parametrize("end", ["\n", "\r\n", "\r"])
def test_line_ends(tmp_path, ev, end):
    path = tmp_path / "data.csv"
    path.write_bytes(ROWS.replace("\n", end).encode())
    m = load_measurements(path, ev=ev)
    assert m.mode == ("x", "2", "y", "3") and m.lines.tolist() == [2, 4, 6, 7]
    path.write_bytes((end + ROWS.replace("\n", end)).encode())  # a blank first line
    assert load_measurements(path, ev=ev).lines.tolist() == [3, 5, 7, 8]


@pytest.mark.parametrize(
    "bad, message",
    [
        # the first bad cell by line, then column, whatever column is read first
        ({(3, 6): "-0.2", (2, 2): "abc"}, r"line 3, column 'freq_hz': value 'abc' is not a number"),
        ({(2, 7): "nan", (2, 1): "q"}, r"line 3, column 'mode': unknown mode label 'q'"),
        ({(3, 0): "", (2, 7): "-1"}, r"line 3, column 'm_e': negative value -1"),
        ({(4, 8): "5"}, r"line 5, column 'eta_a@2': parameter 'eta_a' = 5.0"),
        ({(4, 3): "0.0, 1"}, r"line 5: 10 cells where the header has 9 columns"),
        ({(1, 0): "0"}, r"line 2, column 'k_a': value 0: expected a value > 0"),
        ({(3, 2): "inf"}, r"line 4, column 'freq_hz': value 'inf' is not finite"),
        ({(2, 6): "-0.1"}, r"line 3, column 'sigma_hz': negative value -0.1"),
    ],
)
def test_errors_name_the_first_bad_cell(tmp_path, ev, monkeypatch, bad, message):
    lines = [line for line in ROWS.splitlines() if line and not line.startswith("#")]  # line k + 1: lines[k]
    cells = [line.split(",") for line in lines]
    for (row, col), value in bad.items():
        cells[row][col] = value
    path = tmp_path / "bad.csv"
    path.write_text("\n".join(",".join(c) for c in cells) + "\n")
    monkeypatch.setattr(measurements, "BLOCK_ROWS", 1000)
    with pytest.raises(MeasurementError, match=message):
        load_measurements(path, ev=ev)


def test_duplicates_name_the_first_repeated_row_and_its_first_line(tmp_path, ev):
    text = (
        "k_a,mode,freq_hz,x,y,z\n1000,1,15,0,0,-0.6\n2000,1,20,0,0,-0.6\n2000,2,21,0,0,-0.6\n"
        "2000,1,20.5,0,0,-0.6\n1000,1,15.2,-0.0,0,-0.6\n1000,1,15.1,0,0,-0.6\n"
    )
    path = tmp_path / "dup.csv"
    path.write_text(text)
    with pytest.raises(MeasurementError, match=r"line 5: duplicate of line 3 "):
        load_measurements(path, ev=ev)
    path.write_text(text.replace("2000,1,20.5", "2000,1,20.5").replace("2000,1,20,", "3000,1,20,"))
    with pytest.raises(MeasurementError, match=r"line 6: duplicate of line 2 "):  # -0.0 is 0.0
        load_measurements(path, ev=ev)


def test_two_rows_can_be_duplicates(tmp_path, ev):
    path = tmp_path / "two.csv"
    path.write_text("k_a,mode,freq_hz\n1000,1,15\n1000,1,15.2\n")
    with pytest.raises(MeasurementError, match=r"line 3: duplicate of line 2 "):
        load_measurements(path, ev=ev)
    path.write_text("k_a,mode,freq_hz\n1000,1,15\n")
    assert len(load_measurements(path, ev=ev)) == 1


def test_progress_is_told_every_row(tmp_path, ev, monkeypatch):
    calls = []

    class Bar:
        def __init__(self, **kw):
            calls.append(("total", kw["total"]))

        def update(self, n):
            calls.append(("rows", n))

        def close(self):
            calls.append(("closed",))

    path = tmp_path / "data.csv"
    path.write_text(ROWS)
    monkeypatch.setattr(measurements, "BLOCK_ROWS", 3)
    load_measurements(path, ev=ev, progress=Bar)
    assert calls[0][0] == "total" and calls[0][1] >= 4
    assert [c[1] for c in calls if c[0] == "rows"] == [3, 1] and calls[-1] == ("closed",)


def test_blocks_of_evaluation_give_the_same_numbers(ev, monkeypatch):
    meas = paper_measurements(ev)
    whole = compare(meas, "paper", ev)
    monkeypatch.setattr(predict, "EVAL_BLOCK", 5)  # 16 rows: blocks of 5, 5, 5, 1
    blocks = compare(meas, "paper", ev)
    np.testing.assert_array_equal(blocks.predicted, whole.predicted)
    np.testing.assert_array_equal(blocks.mode_index, whole.mode_index)


def _listed(table: str) -> list[int]:
    """The source lines of the rows a table lists (its first column)."""
    return [
        int(w[0])
        for w in (line.split() for line in table.splitlines())
        if len(w) > 8 and w[0].isdigit() and w[1] != "rows,"
    ]


def test_table_lists_every_row_up_to_its_limit_then_the_failing_ones(ev):
    cmp = compare(paper_measurements(ev), "rigid", ev)
    n, failing = len(cmp.meas), cmp.meas.lines[cmp.failing].tolist()
    assert 1 < len(failing) < n
    full = comparison_table(cmp, limit=n)  # just inside: every row
    assert "more than" not in full and _listed(full) == cmp.meas.lines.tolist()
    short = comparison_table(cmp, limit=n - 1)  # just outside: the failing rows
    assert short.splitlines()[0] == (
        f"{n} rows, more than {n - 1}: listed are the {len(failing)} failing rows (--json prints every row)"
    )
    assert _listed(short) == failing
    first = comparison_table(cmp, limit=len(failing) - 1)  # more failing rows than the limit
    assert f"the first {len(failing) - 1} of the {len(failing)} failing rows" in first
    assert _listed(first) == failing[:-1]


def test_modal_columns_are_read_as_numbers_a_column_at_once(tmp_path, ev, monkeypatch):
    path = tmp_path / "modal.csv"
    path.write_text(
        "k_a,mode,freq_hz,damping_ratio,phi_x,phi_y,phi_z,sensor_x\n1000,x,15.5,0.01,1,0,-0.1,0.01\n2000,y,20,,0,1,0,\n"
    )
    monkeypatch.setattr(measurements, "_parse_rows", lambda *a: pytest.fail("read row by row"))
    m = load_measurements(path, ev=ev)
    np.testing.assert_array_equal(m.modal["damping_ratio"], [0.01, np.nan])
    np.testing.assert_array_equal(m.modal["phi_z"], [-0.1, 0.0])
    np.testing.assert_array_equal(m.modal["sensor_x"], [0.01, np.nan])
    monkeypatch.undo()
    path.write_text(path.read_text().replace("1000,x,15.5,0.01", "1000,x,15.5,-0.01"))
    with pytest.raises(MeasurementError, match=r"line 2, column 'damping_ratio': negative value"):
        load_measurements(path, ev=ev)
