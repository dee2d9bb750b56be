"""Measurement files as people export them and their faults:
separators, decimal commas, encodings, duplicated rows, columns the model cannot use,
and a property test that malformed text is always one error line, never a traceback."""

from __future__ import annotations

import subprocess
import sys
import warnings

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from eigentwist.cli.main import main
from eigentwist.diagnose import MeasurementError, compare, diagnose, load_measurements

PLAIN = "k_a,mode,freq_hz\n1000,x,15.5\n2000,y,20.25\n"


def write(tmp_path, data, name="d.csv"):
    path = tmp_path / name
    (path.write_bytes if isinstance(data, bytes) else path.write_text)(data)
    return path


@pytest.mark.parametrize(
    "text",
    [
        "k_a;mode;freq_hz\n1000;x;15,5\n2000;y;20,25\n",  # European Excel
        "k_a;mode;freq_hz\r\n1000;x;15.5\r\n2000;y;20.25\r\n",  # CRLF, decimal point
        "\ufeffk_a;mode;freq_hz\n1000;x;15,5\n2000;y;20,25\n",  # BOM
        "k_a\tmode\tfreq_hz\n1000\tx\t15,5\n2000\ty\t20.25\n",  # tab
        "\ufeffk_a,mode,freq_hz\r\n1000,x,15.5\r\n2000,y,20.25\r\n",  # BOM + CRLF, commas
    ],
)
def test_exported_separators_and_decimal_commas(tmp_path, ev, text):
    m = load_measurements(write(tmp_path, text.encode("utf-8")), ev=ev)
    assert m.freq_hz.tolist() == [15.5, 20.25] and m.mode == ("x", "y")


def test_utf16_with_bom(tmp_path, ev):
    m = load_measurements(write(tmp_path, "k_a\tmode\tfreq_hz\r\n1000\tx\t15,5\r\n".encode("utf-16")), ev=ev)
    assert m.freq_hz.tolist() == [15.5]


def test_unknown_separator_says_what_was_found(tmp_path, ev):
    with pytest.raises(MeasurementError, match=r"header 'k_a\|mode\|freq_hz' has a single column.*';' or a tab"):
        load_measurements(write(tmp_path, "k_a|mode|freq_hz\n1000|x|15\n"), ev=ev)


def test_duplicated_rows_are_an_error_naming_both_lines(tmp_path, ev):
    text = "k_a,mode,freq_hz,z\n1000,x,15.5,-0.625\n2000,x,20,\n1000,X,15.9,\n"
    with pytest.raises(MeasurementError, match=r"line 4: duplicate of line 2 .*k_a = 1000 N m/rad, mode x"):
        load_measurements(write(tmp_path, text), ev=ev)
    # other conditions (a parameter column) make it another measurement
    load_measurements(write(tmp_path, "k_a,mode,freq_hz,m_e\n1000,x,15.5,0.6\n1000,x,15.9,0.7\n"), ev=ev)


def test_parameter_column_of_an_effect_the_model_lacks(tmp_path, ev):
    meas = load_measurements(write(tmp_path, "k_a,mode,freq_hz,m_p\n1000,x,15.5,0.3\n2000,x,20,0.3\n"), ev=ev)
    with pytest.raises(
        MeasurementError, match=r"column 'm_p': parameter column of effect payload_mass, which the model"
    ):
        compare(meas, "rigid", ev)
    assert compare(meas, "rigid,payload_mass", ev).predicted.shape == (2,)
    with pytest.raises(MeasurementError, match="payload_mass"):
        diagnose(meas, "rigid", ev=ev)
    assert diagnose(meas, "rigid", ev=ev, add=["payload_mass"]).final.effects[-1] == "payload_mass"


def test_unknown_column_is_named_and_documented_columns_pass(tmp_path, ev):
    with pytest.raises(MeasurementError, match=r"column 'temperature': unknown column"):
        load_measurements(write(tmp_path, "k_a,mode,freq_hz,temperature\n1000,x,15,20\n"), ev=ev)
    with pytest.raises(MeasurementError, match=r"did you mean sigma_hz\?"):
        load_measurements(write(tmp_path, "k_a,mode,freq_hz,sigma_Hz\n1000,x,15,0.2\n"), ev=ev)
    text = "k_a,mode,freq_hz,damping_ratio,phi_x,phi_y,phi_z\n1000,x,15,0.02,1,0,0\n"
    assert load_measurements(write(tmp_path, text), ev=ev).params == {}
    # a per-leg column passes the header; whether the evaluator knows per-leg values is its call
    try:
        m = load_measurements(write(tmp_path, "k_a,mode,freq_hz,eta_a@3\n1000,x,15,0.8\n"), ev=ev)
    except ValueError as exc:
        assert "eta_a@3" in str(exc) and "unknown column" not in str(exc)
    else:
        assert list(m.params) == ["eta_a@3"]
    with pytest.raises(MeasurementError, match=r"column 'eta_a@0': unknown column"):
        load_measurements(write(tmp_path, "k_a,mode,freq_hz,eta_a@0\n1000,x,15,0.8\n"), ev=ev)


def test_unreachable_row_names_the_reachable_heights(tmp_path, ev):
    with pytest.raises(MeasurementError, match=r"line 2, column 'x, y, z': .*unreachable.*heights are z in \["):
        load_measurements(write(tmp_path, "k_a,mode,freq_hz,z\n1000,x,15,-2\n"), ev=ev)


# --------------------------------------------------------------- property test
CELLS = st.one_of(
    st.sampled_from(
        [
            "",
            " ",
            "nan",
            "NaN",
            "inf",
            "-inf",
            "1e400",
            "-1",
            "0",
            "1e308",
            "x",
            "y",
            "rz",
            "7",
            "abc",
            "1,5",
            "0x10",
            "\"",
            "\"\"",
            "#",
            "1e-320",
            "99999999999999999999",
            "-0.625",
            "0.1",
        ]
    ),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.text(max_size=6),
)
HEADERS = st.one_of(
    st.lists(
        st.sampled_from(
            [
                "k_a",
                "mode",
                "freq_hz",
                "x",
                "y",
                "z",
                "sigma_hz",
                "m_e",
                "l2",
                "m_p",
                "eta_a@2",
                "damping_ratio",
                "bogus",
                "",
            ]
        ),
        min_size=1,
        max_size=6,
    ),
    st.just(["k_a", "mode", "freq_hz", "z", "sigma_hz", "m_e", "l2"]),  # well-formed header, wild values
)


@st.composite
def csv_texts(draw):
    header = draw(HEADERS)
    sep = draw(st.sampled_from([",", ";", "\t"]))
    width = st.integers(len(header) - 1, len(header) + 1) if len(header) > 1 else st.just(1)
    rows = draw(st.lists(width.flatmap(lambda n: st.lists(CELLS, min_size=n, max_size=n)), max_size=4))
    end = draw(st.sampled_from(["\n", "\r\n"]))
    return end.join(sep.join(r) for r in [header, *rows]) + end


ENCODINGS = st.sampled_from(["utf-8", "utf-8-sig", "utf-16", "latin-1", "cp1252", "utf-32"])


def _bytes(text, encoding) -> bytes:
    return text.encode(encoding, errors="replace")


NUMBERS = st.one_of(
    st.sampled_from(["1e308", "1e-320", "1e300", "5e-324", "1e-300", "1000", "15", "-0.625", "0", "nan", "inf"]),
    st.floats(min_value=1e-300, max_value=1e300).map(repr),
)
WELL_FORMED = st.builds(
    lambda k, m, f, z, l2: f"k_a,mode,freq_hz,z,l2\n{k},{m},{f},{z},{l2}\n".encode(),
    NUMBERS,
    st.sampled_from(["x", "y", "z", "rz", "1", "6", "40"]),
    NUMBERS,
    st.sampled_from(["", "-0.6", "-0.7", "-2", "1e300"]),
    st.sampled_from(["", "0.5", "1e300", "1e-300"]),
)


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.one_of(st.binary(max_size=200), st.builds(_bytes, csv_texts(), ENCODINGS), WELL_FORMED))
def test_malformed_csv_is_one_error_line(tmp_path, capsys, data):
    path = tmp_path / "fuzz.csv"
    path.write_bytes(data)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)  # a warning would be a second stderr line
        code = main(["compare", str(path), "--model", "rigid"])
    captured = capsys.readouterr()
    if code == 0:  # some random text is a valid file
        return
    err = captured.err.strip()
    assert code == 2, err
    assert "Traceback" not in err and len(err.splitlines()) == 1, err
    assert err.startswith("eigentwist compare: error: "), err


def test_malformed_csv_in_a_subprocess(tmp_path):
    path = write(tmp_path, b"k_a;mode;freq_hz\n1000;x;\x00\xff15\n")
    r = subprocess.run([sys.executable, "-m", "eigentwist", "diagnose", str(path)], capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr and len(r.stderr.strip().splitlines()) == 1, r.stderr
