"""The HTML report: every section present, every image decodes; rendered in Chromium."""

from __future__ import annotations

import base64
import contextlib
import io
import re
import shutil
import subprocess
import tempfile
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest

from eigentwist.cli.main import main
from eigentwist.report.build import SECTIONS

from .conftest import skip_tier

# their fixtures are diagnoses of 7-11 s: make test, not make test-fast
pytestmark = pytest.mark.slow


class _Collector(HTMLParser):
    """Ids, images, text (also per section), table rows per section and every tag seen."""

    def __init__(self):
        super().__init__()
        self.ids, self.images, self.text, self.tags = set(), [], [], []
        self.section, self.by_section, self.rows = None, {}, {}
        self._row = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        self.tags.append(tag)
        if "id" in a:
            self.ids.add(a["id"])
        if tag == "section":
            self.section = a.get("id")
        if tag == "img":
            self.images.append(a.get("src", ""))
        if tag == "tr":
            self._row = []
            self.rows.setdefault(self.section, []).append(self._row)
        if tag in ("td", "th") and self._row is not None:
            self._row.append("")

    def handle_endtag(self, tag):
        if tag == "tr":
            self._row = None
        if tag == "section":
            self.section = None

    def handle_data(self, data):
        self.text.append(data)
        self.by_section.setdefault(self.section, []).append(data)
        if self._row:
            self._row[-1] += data

    def section_text(self, name) -> str:
        return " ".join("".join(self.by_section.get(name, [])).split())


def _parse(html: str) -> _Collector:
    c = _Collector()
    c.feed(html)
    return c


@pytest.fixture(scope="module")
def default_report(tmp_path_factory):
    """``eigentwist report -o report.html`` run once: its file, the ReportData it rendered and
    what it printed."""
    import eigentwist.report as report

    built = []

    def recording(*args, **kwargs):
        built.append(original(*args, **kwargs))
        return built[-1]

    original = report.build_report
    path = tmp_path_factory.mktemp("report") / "report.html"
    out = io.StringIO()
    with pytest.MonkeyPatch.context() as mp, contextlib.redirect_stdout(out):
        mp.setattr(report, "build_report", recording)
        assert main(["report", "-o", str(path)]) == 0
    assert len(built) == 1
    return path, built[0], out.getvalue()


@pytest.fixture(scope="module")
def report_path(default_report):
    return default_report[0]


@pytest.fixture(scope="module")
def parsed(report_path):
    return _parse(report_path.read_text(encoding="utf-8"))


def test_every_section_present(parsed):
    assert set(SECTIONS) <= parsed.ids
    text = " ".join(parsed.text)
    for phrase in (
        "Reproduction of the paper",
        "Comparison with the measurements",
        "Diagnosis",
        "Suggested next measurement",
        "10.1016/j.mechmachtheory.2019.103775",
    ):
        assert phrase in text


def test_every_image_is_embedded_and_decodes(parsed):
    import matplotlib.image as mpimg

    assert len(parsed.images) >= 3  # comparison, diagnosis, robot with its mode shapes
    svgs = [src for src in parsed.images if src.startswith("data:image/svg+xml;base64,")]
    assert len(svgs) == 1  # the animated mode shapes
    import xml.etree.ElementTree as ET

    root = ET.fromstring(base64.b64decode(svgs[0].split(",", 1)[1]))
    assert root.tag.endswith("svg") and len([e for e in root.iter() if e.tag.endswith("animate")]) >= 3
    for src in parsed.images:
        if src in svgs:
            continue
        assert src.startswith("data:image/png;base64,"), src[:40]
        img = mpimg.imread(io.BytesIO(base64.b64decode(src.split(",", 1)[1])), format="png")
        assert img.ndim == 3 and img.shape[0] > 100 and img.shape[1] > 100
        assert img.std() > 0.01  # not a blank picture


def test_report_numbers_match_the_paper_comparison(parsed):
    """The paper model errs by 4.2 % RMS and 9.0 % max on the paper's data (facts file)."""
    text = " ".join(parsed.text)
    assert "RMS error 4.17 %" in text and "max 8.96 %" in text


def test_make_run_summary_printed(default_report):
    out = default_report[2]
    assert "report written to" in out and "RMS error" in out


def _chromium():
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    return None


@pytest.mark.browser
def test_report_renders_in_headless_chromium(report_path, tmp_path):
    exe = _chromium()
    if exe is None:
        skip_tier("browser", "Chromium is not installed (CI installs it in .ci/run; apt-get install chromium)")
    png = tmp_path / "report.png"
    with tempfile.TemporaryDirectory() as profile:
        subprocess.run(
            [
                exe,
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--disable-quic",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                f"--user-data-dir={profile}",
                "--window-size=1200,2000",
                f"--screenshot={png}",
                Path(report_path).resolve().as_uri(),
            ],
            check=True,
            capture_output=True,
            timeout=120,
        )
    import matplotlib.image as mpimg

    img = mpimg.imread(str(png))
    assert img.shape[0] >= 1000 and img.shape[1] >= 1000
    # the page has content: many distinct grey levels, not a blank or error page
    grey = (img[..., :3].mean(axis=-1) * 255).astype(int)
    assert len(np.unique(grey)) > 50


# ------------------------------------------------------------ fitted values, units, next measurement, robot picture
def test_final_model_fitted_values_with_errors_and_units(parsed):
    """The final model's fitted values, in a sentence and a table (README: 377 +- 22, (1.70 +- 0.19)e5,
    c_a = 2.41 +- 0.20: the paper's frequencies are damped ones)."""
    import re

    text = parsed.section_text("diagnosis")
    m = re.search(
        r"The final model, actuator_loss \+ ee_compliance \+ servo_damping, fits k_E_rot = (\d+) ± 22 N m/rad, "
        r"k_E_lin = \((1\.\d\d) ± 0\.19\)·10⁵ N/m and c_a = 2\.41 ± 0\.20 N m s/rad",
        text,
    )
    assert m, text
    assert abs(int(m.group(1)) - 377) <= 1 and abs(float(m.group(2)) - 1.70) <= 0.01
    assert "final-model" in parsed.ids
    rows = {r[0]: r for r in parsed.rows["diagnosis"] if r and r[0] in ("k_E_rot", "k_E_lin", "c_a")}
    assert rows["k_E_rot"][1] == f"{m.group(1)} ± 22 N m/rad" and rows["k_E_lin"][1] == f"({m.group(2)} ± 0.19)·10⁵ N/m"
    assert rows["c_a"][1] == "2.41 ± 0.20 N m s/rad"
    summary = parsed.section_text(None)
    assert (
        f"with k_E_rot = {m.group(1)} ± 22 N m/rad, k_E_lin = ({m.group(2)} ± 0.19)·10⁵ N/m and c_a = 2.41 ± 0.20 "
        "N m s/rad"
    ) in summary


def test_ranking_states_units(parsed):
    text = parsed.section_text("diagnosis")
    assert "m_p = 0.231 ± 0.047 kg" in text and "k_t = 5976 ± 800 N m/rad" in text


def test_next_measurement_is_prose_and_a_table_not_a_python_dict(parsed):
    text = parsed.section_text("next-measurement")
    assert "{" not in text and "'" not in text and "predicted_hz" not in text
    assert "These data cannot tell ee_compliance from ee_coupling" in text
    rows = {r[0]: r[1] for r in parsed.rows["next-measurement"]}
    assert rows["pose"].endswith("] m") and rows["mode"] in ("x", "y")  # the directions the paper measured
    assert re.match(r"[\d.]+ σ", rows["separation"])


def test_robot_picture_at_the_measured_pose(parsed):
    text = parsed.section_text("model")
    assert "The robot at the most measured pose, [0, 0, -0.625] m" in text and "three lowest modes" in text


@pytest.fixture(scope="module")
def hidden_payload_report(tmp_path_factory):
    """README walkthrough data: a 0.35 kg payload the paper model lacks; ranked first by far."""
    d = tmp_path_factory.mktemp("hidden")
    assert (
        main(
            [
                "synth",
                "--truth",
                "paper+payload_mass:m_p=0.35",
                "--k-a",
                "250,500,1000,2000,4000",
                "--pose",
                "0",
                "0",
                "-0.625",
                "--pose",
                "0.06",
                "-0.04",
                "-0.6",
                "--modes",
                "x,y,z",
                "--noise",
                "0.5%",
                "--seed",
                "3",
                "-o",
                str(d / "hidden.csv"),
            ]
        )
        == 0
    )
    from eigentwist.report import build_report, render_html

    rep = build_report(d / "hidden.csv", baseline="paper")
    return rep, _parse(render_html(rep))


def test_no_separation_proposed_when_the_data_tell_the_effects_apart(hidden_payload_report):
    rep, parsed = hidden_payload_report
    top = rep.diagnosis["ranking"][0]
    assert top["effect"] == "payload_mass" and not top["indistinguishable_from"]
    text = parsed.section_text("next-measurement")
    assert "The data already tell payload_mass from the runner-up" in text
    assert "no measurement is needed" in text
    assert "cannot tell" not in text and "separates them" not in text
    assert "m_p = 0.3485 ± 0.0029 kg" in parsed.section_text("diagnosis")


def test_next_measurement_text_follows_the_indistinguishable_flag():
    from eigentwist.report.build import next_measurement_text

    nm = {
        "between": ["a", "b"],
        "pose": [0, 0, -0.55],
        "k_a": 4000.0,
        "mode": "z",
        "predicted_hz": {"a": 50.0, "b": 60.0},
        "separation_sigma": 9.0,
        "sigma_hz": 1.0,
    }
    ranking = [
        {"effect": "a", "indistinguishable_from": [], "delta_aicc": 0.0},
        {"effect": "b", "indistinguishable_from": [], "delta_aicc": 143.0},
    ]
    diag = {"ranking": ranking, "final": {"explained": True}}
    assert (
        next_measurement_text({**diag, "next_measurement": {**nm, "indistinguishable": False}})["kind"] == "told_apart"
    )
    assert next_measurement_text({**diag, "next_measurement": {**nm, "indistinguishable": True}})["kind"] == "separate"
    tied = [{**ranking[0], "indistinguishable_from": ["b"]}, ranking[1]]
    assert next_measurement_text({**diag, "ranking": tied, "next_measurement": nm})["kind"] == "separate"
    out = next_measurement_text({**diag, "next_measurement": nm})  # no flag, not tied: told apart
    assert out["kind"] == "told_apart" and out["delta_aicc"] == 143.0


@pytest.fixture(scope="module")
def report_data(default_report):
    return default_report[1]


def test_keys_the_diagnosis_gains_are_rendered_as_text(report_data):
    """steps[k].alternatives, final.alternatives, outliers, uncertainty (select.py's restructuring)."""
    import copy

    from eigentwist.report import render_html

    rep = copy.deepcopy(report_data)
    d = rep.diagnosis
    d["steps"][1]["alternatives"] = ["ee_coupling"]
    d["final"]["alternatives"] = [{"effects": ["actuator_loss", "ee_coupling"], "delta_aicc": 0.0}]
    d["outliers"] = [{"line": 2, "mode": "x", "error_sigma": 4.2}]
    d["uncertainty"] = {"sigma_pct": 2.0, "source": "default"}
    parsed = _parse(render_html(rep))
    text = parsed.section_text("diagnosis")
    assert "equally good alternatives" in text and "ee_coupling" in text
    assert "effects: actuator_loss, ee_coupling; delta_aicc: 0" in text
    assert "line: 2; mode: x; error_sigma: 4.2" in text
    assert "sigma_pct" not in text  # the uncertainty is a sentence, not a key dump
    assert rep.uncertainty_text in text
    assert "{" not in text.partition("How the diagnosis decides")[0]  # the criteria's formulas have braces


# --------------------------------------------------------------- escaping
SCRIPT = "<script>alert(1)</script>"


def _inject(obj, keys: bool = False):
    """Every string value (and, with ``keys``, parameter-name keys) prefixed with a script element."""
    if isinstance(obj, dict):
        return {(SCRIPT + k if keys and isinstance(k, str) else k): _inject(v, keys) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_inject(v, keys) for v in obj]
    if isinstance(obj, tuple):
        return tuple(_inject(v, keys) for v in obj)
    if isinstance(obj, str):
        return SCRIPT + obj
    return obj


def _no_script(html: str) -> _Collector:
    parsed = _parse(html)
    assert "script" not in parsed.tags
    return parsed


def test_user_strings_are_escaped_everywhere(report_data):
    """File names, CSV cells (rows, labels, failing text), parameter names and docs all reach the HTML escaped."""
    import copy

    from eigentwist.report import render_html

    rep = copy.deepcopy(report_data)
    for name in ("title", "source", "data_source", "robot", "command"):
        setattr(rep, name, SCRIPT + getattr(rep, name))
    rep.model = _inject(rep.model)
    rep.baseline = _inject(rep.baseline)
    rep.parameters = _inject(rep.parameters)
    rep.comparison = _inject(rep.comparison)
    rep.reproduction = _inject(rep.reproduction)
    rep.final = _inject(rep.final)
    rep.next_measurement = _inject(rep.next_measurement)
    d = _inject(rep.diagnosis)
    for c in d["ranking"]:  # parameter names as keys
        c["params"], c["param_std"] = _inject(c["params"], True), _inject(c["param_std"], True)
    d["final"]["params"] = _inject(d["final"]["params"], True)
    d["outliers"] = [{"line": SCRIPT, "mode": SCRIPT}]
    d["uncertainty"] = {SCRIPT: SCRIPT}
    d["final"]["alternatives"] = [SCRIPT]
    rep.diagnosis = d
    rep.units = _inject(rep.units, True)
    parsed = _no_script(render_html(rep))
    text = " ".join(parsed.text)
    assert text.count(SCRIPT) > 50  # shown as text, not dropped


def test_script_in_the_file_name_is_escaped(tmp_path):
    """A measurement file whose name holds a script element: the report shows the name as text."""
    from eigentwist.diagnose import paper_csv

    src = tmp_path / f"{SCRIPT.replace('/', '_')}.csv"
    src.write_text(paper_csv("heli4"), encoding="utf-8")
    out = tmp_path / "r.html"
    assert main(["report", str(src), "-o", str(out)]) == 0
    parsed = _no_script(out.read_text(encoding="utf-8"))
    assert "<script>alert(1)<_script>.csv" in " ".join(parsed.text)


def test_delta_report_draws_its_robot(tmp_path):
    """Any robot: the Delta's report has its own picture and the final fitted values with units."""
    csv = tmp_path / "delta.csv"
    assert (
        main(
            [
                "synth",
                "--robot",
                "delta",
                "--truth",
                "paper+payload_mass:m_p=0.2",
                "--k-a",
                "500,1000,2000",
                "--modes",
                "x,y,z",
                "--noise",
                "0.5%",
                "--seed",
                "1",
                "-o",
                str(csv),
            ]
        )
        == 0
    )
    from eigentwist.report import build_report, render_html

    rep = build_report(csv, robot="delta")
    parsed = _no_script(render_html(rep))
    assert len(parsed.images) >= 3
    assert "The robot at the most measured pose, [0, 0, -0.75] m" in parsed.section_text("model")
    assert "fits m_p = 0.2047 ± 0.0032 kg" in parsed.section_text("diagnosis")


# --------------------------------------------------------------- the answer first, shown
def test_the_report_leads_with_the_answer(parsed, report_data):
    """The first section is the diagnosis's answer block, the same sentences as the CLI's."""
    assert "answer" in parsed.ids
    text = parsed.section_text("answer")
    for part in ("verdict", "added", "damping", "next"):
        assert " ".join(report_data.answer[part].split()) in text
    assert text.index("Explained") < text.index("Added: ee_compliance") < text.index("Damping supported")
    assert text.index("Damping supported") < text.index("Next: measure mode")


def test_provenance_criteria_uncertainty_and_implausible_marks(report_path, parsed):
    import hashlib

    from eigentwist import __version__

    text = parsed.section_text("provenance")
    assert __version__ in text and "eigentwist report -o" in text and re.search(r"\d{4}-\d\d-\d\d \d\d:\d\d", text)
    diag = parsed.section_text("diagnosis")
    assert "How the diagnosis decides" in diag and "extra-sum-of-squares F test" in diag
    assert "The stated uncertainty is consistent with the fit (Birge ratio 0.897)." in diag  # damped frequencies
    assert "IMPLAUSIBLE: needs E_rod = 1.15" in diag  # rod_compliance alone (README)
    assert hashlib.sha256(b"x").hexdigest() == sha256_file_of(b"x")


def sha256_file_of(data: bytes) -> str:
    import tempfile as tf

    from eigentwist.report.provenance import sha256_file

    with tf.NamedTemporaryFile(delete=False) as fh:
        fh.write(data)
    return sha256_file(fh.name)


def test_provenance_hashes_every_input_file(hidden_payload_report):
    import hashlib

    rep, _ = hidden_payload_report
    files = rep.provenance["files"]
    assert len(files) == 1 and files[0]["path"].endswith("hidden.csv")
    assert files[0]["sha256"] == hashlib.sha256(Path(files[0]["path"]).read_bytes()).hexdigest()


def test_the_report_needs_no_network(report_path):
    """Every resource is embedded: no http(s) URL in a src, a stylesheet, a script or CSS url()."""
    html = Path(report_path).read_text(encoding="utf-8")
    assert not re.search(
        r"""<(?:img|script|link|iframe|source|video|audio)\b[^>]*\b(?:src|href)\s*=\s*["']?https?:""", html, re.I
    )
    assert not re.search(r"url\(\s*['\"]?https?:", html, re.I) and "@import" not in html
    svg = _svg_of(html)
    assert "http://" not in svg.replace('xmlns="http://www.w3.org/2000/svg"', "") and "https://" not in svg
    assert "<script" not in svg


def _svg_of(html: str) -> str:
    m = re.search(r'src="data:image/svg\+xml;base64,([^"]+)"', html)
    return base64.b64decode(m.group(1)).decode("utf-8")


def test_lowest_frequency_map_matches_the_evaluator(report_data):
    """The map's values are the final model's f1 at those poses (the evaluator, called directly)."""
    import eigentwist
    from eigentwist.report.figures import lowest_frequency_map

    ev = eigentwist.load("heli4", backend="numpy")
    view = report_data.lowest_map
    values = {"k_E_rot": 373.5, "k_E_lin": 1.641e5}
    m = lowest_frequency_map(ev, "actuator_loss,ee_compliance", view["pose"], view["k_a"], values, grid=5)
    f = ev.frequencies(
        [[m["x"][1], m["y"][3], view["pose"][2]]], "actuator_loss,ee_compliance", k_a=view["k_a"], **values
    )[0, 0]
    assert m["f1"][3, 1] == pytest.approx(f, rel=1e-12)
    assert np.all(np.isfinite(m["f1"])) and np.ptp(m["f1"]) > 0


def _shapes_csv(ev, path):
    """Measurements with mode shapes (phi_x..z) of the paper model at two settings: frequencies
    and shapes of its three lowest modes, the shape the translation of the eigentwist."""
    rows = ["k_a,mode,freq_hz,x,y,z,phi_x,phi_y,phi_z"]
    for k_a in (1000.0, 2000.0):
        m = ev.modes([[0, 0, -0.625]], "paper", k_a=k_a)
        for j, label in enumerate(["x", "y", "z"]):
            v = m.eigentwists[0][3:, j]
            v = v / np.linalg.norm(v)
            rows.append(f"{k_a:g},{label},{m.freq_hz[0, j]:.6f},0,0,-0.625,{v[0]:.6f},{v[1]:.6f},{v[2]:.6f}")
    path.write_text("\n".join(rows) + "\n")
    return path


def test_mac_matrix_of_measured_vs_model_shapes(tmp_path):
    import eigentwist
    from eigentwist.diagnose.measurements import load_measurements
    from eigentwist.report.figures import mac_matrix

    ev = eigentwist.load("heli4", backend="numpy")
    meas = load_measurements(_shapes_csv(ev, tmp_path / "s.csv"), "heli4", ev)
    mac = np.array(mac_matrix(meas, ev, "paper", {})["mac"])
    # the same model: each measured shape is its own mode (MAC 1) and, for orthogonal translations,
    # nothing else; independently: |a.b|^2 of unit vectors
    assert mac.shape[0] == 3 and np.allclose(np.diag(mac[:, :3]), 1.0, atol=1e-9)
    m = ev.modes([[0, 0, -0.625]], "paper", k_a=1000.0)
    a = m.eigentwists[0][3:, 0] / np.linalg.norm(m.eigentwists[0][3:, 0])
    b = m.eigentwists[0][3:, 1]
    assert mac[0, 1] == pytest.approx(float(a @ b) ** 2 / float(b @ b), abs=1e-9)


def _chrome(exe, url, png, profile, size="1200,900", budget=None):
    args = [
        exe,
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--proxy-server=127.0.0.1:9",
        "--proxy-bypass-list=<-loopback>",  # any network request fails
        f"--user-data-dir={profile}",
        f"--window-size={size}",
        f"--screenshot={png}",
    ]
    if budget is not None:
        args.append(f"--virtual-time-budget={budget}")
    subprocess.run(args + [url], check=True, capture_output=True, timeout=120)
    import matplotlib.image as mpimg

    return mpimg.imread(str(png))


def _only(html: str, element_id: str) -> str:
    """The report with everything but one element hidden (a screenshot of that element)."""
    style = (
        f"<style>body * {{ visibility: hidden; }} #{element_id}, #{element_id} * {{ visibility: visible; }}"
        f" #{element_id} {{ position: absolute; left: 0; top: 0; }}</style>"
    )
    return html.replace("</head>", style + "</head>", 1)


@pytest.mark.browser
def test_the_animation_runs_offline_in_chromium(report_path, tmp_path):
    exe = _chromium()
    if exe is None:
        skip_tier("browser", "Chromium is not installed (CI installs it in .ci/run; apt-get install chromium)")
    page = tmp_path / "modes.html"
    page.write_text(_only(Path(report_path).read_text(encoding="utf-8"), "modes-animation"), encoding="utf-8")
    frames = []
    with tempfile.TemporaryDirectory() as profile:
        # the SVG is an <img>: its SMIL clock is not the page's virtual one, so each screenshot
        # catches the 1.6 s cycle at a phase of its own (two caught alike now and then: 77 and
        # 151 moved pixels seen, 336 to 5934 more often): four frames, the most different pair
        for k, budget in enumerate((300, 700, 1100, 1500)):
            frames.append(
                _chrome(exe, page.resolve().as_uri(), tmp_path / f"f{k}.png", profile, "1000,420", budget)[..., :3]
            )
    assert frames[0].std() > 0.02  # something is drawn
    changed = max(int((np.abs(a - b).sum(axis=-1) > 0.1).sum()) for k, a in enumerate(frames) for b in frames[k + 1 :])
    # the platforms moved between two frames (a still page changes no pixel; the lines of a
    # small-amplitude mode move a few hundred to a few thousand)
    assert changed > 100, changed


@pytest.mark.browser
def test_screenshots_of_the_answer_and_the_mac_matrix(report_path, report_data, tmp_path):
    exe = _chromium()
    if exe is None:
        skip_tier("browser", "Chromium is not installed (CI installs it in .ci/run; apt-get install chromium)")
    import copy

    import eigentwist
    from eigentwist.diagnose.measurements import load_measurements
    from eigentwist.report import render_html
    from eigentwist.report.figures import mac_matrix

    ev = eigentwist.load("heli4", backend="numpy")
    rep = copy.copy(report_data)
    rep.mac = mac_matrix(load_measurements(_shapes_csv(ev, tmp_path / "s.csv"), "heli4", ev), ev, "paper", {})
    html = render_html(rep)
    shots = {}
    with tempfile.TemporaryDirectory() as profile:
        for element in ("answer", "mac-table"):
            page = tmp_path / f"{element}.html"
            page.write_text(_only(html, element), encoding="utf-8")
            shots[element] = _chrome(exe, page.resolve().as_uri(), tmp_path / f"{element}.png", profile, "1100,500")
    for element, img in shots.items():
        grey = img[..., :3].mean(axis=-1)
        assert (grey < 0.6).sum() > 2000, element  # text (the answer) or dark cells (the MAC) drawn
    # the MAC's diagonal cells are dark blue: count strongly blue pixels
    img = shots["mac-table"][..., :3]
    blue = img[..., 2] - img[..., 0] > 0.3
    assert blue.sum() > 1000
