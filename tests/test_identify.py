"""Identification of modal-test campaigns: accuracy, labels, close modes, the diagnosis on top.

The synthetic campaign: 2 poses x 4 k_a, 3x3 accelerance FRFs, modal
damping 1.5 %, 1 % complex noise, from a truth with a hidden 0.35 kg payload.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from eigentwist.cli.main import main
from eigentwist.diagnose import compare, diagnose
from eigentwist.diagnose.matching import match_modes
from eigentwist.modal import FrfSet, identify_campaign, identify_frfs, synth_campaign
from eigentwist.modal.frf import frf_from_modes
from eigentwist.modal.synth import add_noise
from eigentwist.runtime import InputError

TRUTH = "paper+payload_mass:m_p=0.35"
DATA = Path(__file__).resolve().parent.parent / "eigentwist" / "data"
K_A = [250.0, 500.0, 1000.0, 4000.0]
POSES = [[0.0, 0.0, -0.625], [0.06, -0.04, -0.6]]


@pytest.fixture(scope="module", params=[58, 55])
def campaign(request, tmp_path_factory, ev):
    out = tmp_path_factory.mktemp(f"campaign{request.param}")
    noise = "1%" if request.param == 58 else "0.1%"  # 55: noise on the frequencies themselves
    manifest = synth_campaign(TRUTH, K_A, POSES, out, ev, damping="1.5%", noise=noise, seed=1, dataset=request.param)
    return request.param, identify_campaign(manifest, ev)


def test_every_mode_within_half_a_percent_and_labelled_right(campaign, ev):
    dataset, res = campaign
    poses = np.repeat(np.repeat(POSES, 4, axis=0), 3, axis=0)  # settings pose-major, 3 rows each
    truth = ev.modes(poses, "paper,payload_mass", k_a=np.repeat(np.tile(K_A, 2), 3), m_p=0.35)
    f_truth = truth.freq_hz[np.arange(24), match_modes(truth, ["x", "y", "z"] * 8)].reshape(8, 3)
    for s, (setting, r) in enumerate(zip(res.campaign.settings, res.results)):
        found = {m.label: m for m in r.modes}
        assert sorted(found) == ["x", "y", "z"], setting.file
        for label, f_true in zip("xyz", f_truth[s]):
            assert abs(found[label].freq_hz / f_true - 1) < 0.005, (setting.file, label)
            assert abs(found[label].damping_ratio - 0.015) < 0.0015
            assert found[label].sigma_hz >= 0.001 * found[label].freq_hz


def test_diagnose_on_the_identified_csv_finds_the_payload(campaign, ev):
    _, res = campaign
    # the frequencies and shapes only: the campaign's damping ratios are the synthesis' uniform
    # 1.5 %, which the damping effects would be fitted to (README; seconds of damped fits)
    import dataclasses

    meas = dataclasses.replace(
        res.measurements, modal={k: v for k, v in res.measurements.modal.items() if k != "damping_ratio"}
    )
    d = diagnose(meas, baseline="paper", ev=ev)
    assert d.selected[0] == "payload_mass"
    m_p, std = d.final.values["m_p"], d.final.std["m_p"]
    assert abs(m_p - 0.35) < 3 * std, (m_p, std)
    shapes = d.to_json()["shapes"]  # the final model's shape term
    assert shapes["n"] == 24 and shapes["mac_min"] > 0.99


def test_two_modes_three_percent_apart_at_three_percent_noise_are_resolved():
    f_k = np.array([20.0, 20.6, 33.0])  # modes 1 and 2 are 3 % apart
    q = np.linalg.qr(np.random.default_rng(2).standard_normal((3, 3)))[0]
    freq = np.round(np.arange(int(45 / 0.02) + 1) * 0.02, 10)
    H = frf_from_modes(freq, 2 * np.pi * f_k, q, 0.015, "accelerance")
    H = add_noise(H, 0.03, np.random.default_rng(3))
    res = identify_frfs(
        FrfSet.from_grid(freq, H, ["1+X", "1+Y", "1+Z"], ["1+X", "1+Y", "1+Z"], "accelerance", source="close.uff")
    )
    found = np.array(sorted(m.freq_hz for m in res.modes))
    assert len(found) == 3
    assert np.all(np.abs(found / f_k - 1) < 0.005)
    shapes = {round(m.freq_hz): m.shape for m in res.modes}
    for k, f in enumerate(f_k):
        cos = abs(shapes[round(f)] @ q[:, k]) / np.linalg.norm(q[:, k])
        assert cos > 0.99


def test_a_band_with_no_modes_and_a_missing_file_are_one_line_each(tmp_path, ev, capsys):
    manifest = synth_campaign(TRUTH, [1000.0], None, tmp_path, ev, noise="1%")
    with pytest.raises(InputError, match=r"setting_01.uff, dataset 58: no stable mode in the band 32..34 Hz"):
        identify_campaign(manifest, ev, band=(32.0, 34.0))
    manifest.write_text(manifest.read_text() + "setting_09.uff,500,0,0,-0.625\n")
    assert main(["identify", str(manifest)]) == 2
    err = capsys.readouterr().err.strip()
    assert "manifest.csv, line 3, column 'file': setting_09.uff: no such file" in err and "\n" not in err


def test_cli_synth_identify_compare(tmp_path, capsys):
    out = tmp_path / "c"
    assert (
        main(
            [
                "synth",
                "--truth",
                TRUTH,
                "--k-a",
                "500,2000",
                "--pose",
                "0.06",
                "-0.04",
                "-0.6",
                "--uff",
                str(out),
                "--noise",
                "1%",
                "--sensor",
                "0.05",
                "0.02",
                "-0.03",
                "--seed",
                "4",
            ]
        )
        == 0
    )
    assert main(["identify", str(out / "manifest.csv"), "-o", str(tmp_path / "id.csv"), "--band", "5:45"]) == 0
    header = (tmp_path / "id.csv").read_text().splitlines()[0]
    assert header == ("k_a,mode,freq_hz,sigma_hz,kind,x,y,z,damping_ratio,phi_x,phi_y,phi_z,sensor_x,sensor_y,sensor_z")
    capsys.readouterr()
    assert main(["compare", str(tmp_path / "id.csv"), "--model", "paper"]) == 0
    text = capsys.readouterr().out
    assert "MAC" in text and "1.0000" in text


def _inside(fig) -> None:
    """Every title, tick label and axis label of ``fig`` within the figure (1 px)."""
    renderer = fig.canvas.get_renderer()
    for artist in [*fig.axes, *fig.texts]:
        b = artist.get_tightbbox(renderer)
        assert b.x0 >= -1 and b.y0 >= -1 and b.x1 <= fig.bbox.x1 + 1 and b.y1 <= fig.bbox.y1 + 1, artist


def test_plots_and_report_section(campaign, tmp_path, monkeypatch):
    from eigentwist.matplotlib_agg import pyplot
    from eigentwist.modal.plots import plot_frfs, plot_stabilisation
    from eigentwist.modal.report import is_manifest, render_section

    dataset, res = campaign
    assert is_manifest(res.campaign.source) and not is_manifest(DATA / "heli4_paper.csv")
    html = render_section(res, figures=False)
    assert html.startswith('<section id="campaign">') and "setting_08.uff" in html and html.count("<tr>") == 1 + 24
    if dataset == 58:
        plt = pyplot("modal")
        drawn = []
        monkeypatch.setattr(plt, "close", drawn.append)  # keep the figures to look inside
        plot_stabilisation(res.results[0], tmp_path / "stab.png")
        plot_frfs(res.results[0], tmp_path / "frf.png")
        assert (tmp_path / "stab.png").read_bytes()[:4] == b"\x89PNG" and (tmp_path / "frf.png").stat().st_size > 0
        monkeypatch.undo()
        for fig in drawn:
            _inside(fig)  # fixed margins, sized for these labels
            plt.close(fig)


def test_fixed_margins_in_inches_and_no_room_refused():
    from eigentwist.matplotlib_agg import margins, pyplot

    plt = pyplot("modal")
    fig, axes = plt.subplots(2, 3, figsize=(9.0, 5.0))
    margins(fig, left=0.5, right=0.25, bottom=0.4, top=0.6, wspace=0.3, hspace=0.5)
    box = [[ax.get_position().bounds for ax in row] for row in axes]  # figure fractions
    panel_w, panel_h = (9.0 - 0.75 - 2 * 0.3) / 3, (5.0 - 1.0 - 0.5) / 2
    x0, y0, w, h = box[1][0]  # lower left panel
    assert np.allclose([x0 * 9, y0 * 5, w * 9, h * 5], [0.5, 0.4, panel_w, panel_h])
    x2, y2, _, _ = box[0][2]  # upper right panel
    assert np.isclose(x2 * 9, 0.5 + 2 * (panel_w + 0.3)) and np.isclose(y2 * 5, 0.4 + panel_h + 0.5)
    assert np.isclose((x2 + w) * 9, 9.0 - 0.25) and np.isclose((y2 + h) * 5, 5.0 - 0.6)
    with pytest.raises(InputError, match="leave no room"):
        margins(fig, left=4.5, right=4.5, bottom=0.4, top=0.6)
    margins(fig, left=0.1, right=0.1, bottom=0.1, top=0.1)  # just fits
    plt.close(fig)


# ---------------------------------------------------------------------------------------------
# Any sensor layout

BEAM = Path(__file__).resolve().parent / "data" / "measured_beam" / "beam_accelerance.uff"
#: free-free Euler-Bernoulli beam: roots of cos(bL) cosh(bL) = 1 (f_n proportional to (b_n L)^2)
BETA_L = np.array([4.730041, 7.853205, 10.995608, 14.137165, 17.278760, 20.420352])


def test_public_measured_beam():
    """Public measured FRFs (pyuff's data/meas_point_1..3.txt, MIT licence, ladisk/pyuff; see
    tests/data/measured_beam/README.md): one accelerometer 1+X, hammer at nodes 1, 2, 3 along +X,
    accelerance 0..1000 Hz at 1 Hz. Expected: the six bending modes of a free-free beam in the band,
    frequency ratios (b_n L / b_1 L)^2 (Euler-Bernoulli, independent of the code), nothing else."""
    from eigentwist.modal import read_uff
    from eigentwist.modal.layout import shape_note

    frfs = read_uff(BEAM)
    assert frfs.responses == ["1+X"] and frfs.references == ["1+X", "2+X", "3+X"]
    res = identify_frfs(frfs)
    f = np.array(sorted(m.freq_hz for m in res.modes))
    assert len(f) == 6, f  # every mode, nothing spurious
    ratio = (f / f[0]) / (BETA_L / BETA_L[0]) ** 2
    assert np.all(np.abs(ratio - 1) < 0.01), ratio
    assert all(0 < m.damping_ratio < 0.01 and m.dofs == ("1+X", "2+X", "3+X") for m in res.modes)
    assert [m.label for m in sorted(res.modes, key=lambda m: m.freq_hz)] == ["1", "2", "3", "4", "5", "6"]
    assert shape_note(res.modes[0].dofs, frfs.coords) == "no position of nodes 1, 2, 3"


def test_public_measured_beam_cli(capsys):
    assert main(["identify", str(BEAM)]) == 0
    out, err = capsys.readouterr()
    assert "shape over 1+X, 2+X, 3+X" in out and "6 modes in 1..990 Hz" in out
    assert err.strip() == (
        "note: beam_accelerance.uff: no shape (no position of nodes 1, 2, 3); frequencies and damping go on"
    )
    assert max(len(line) for line in (out + err).splitlines()) <= 100


LAYOUT_POSES = [[0.06, -0.04, -0.6], [-0.05, 0.05, -0.62]]


@pytest.fixture(scope="module", params=["uniaxial", "roving-hammer", "shaker"])
def layout_campaign(request, tmp_path_factory, ev):
    out = tmp_path_factory.mktemp(request.param)
    manifest = synth_campaign(
        TRUTH,
        [500.0, 2000.0],
        LAYOUT_POSES,
        out,
        ev,
        damping="1.5%",
        noise="1%",
        seed=3,
        sensor=[0.03, 0.02, -0.02],
        layout=request.param,
    )
    return request.param, identify_campaign(manifest, ev)


def test_uniaxial_roving_hammer_and_shaker_campaigns(layout_campaign, ev):
    """Frequencies within 0.1 % of the truth's eigenvalues and MAC >= 0.99 against the truth's eigentwists
    transported to each node and projected on each measured direction (a few lines of NumPy here)."""
    from eigentwist.modal.synth import LAYOUTS, NODE_OFFSETS

    layout, res = layout_campaign
    assert res.notes == []
    responses, references = LAYOUTS[layout]
    dofs = responses if len(responses) >= len(references) else references
    r1 = np.array([0.03, 0.02, -0.02])
    t = {k: v for k, v in zip(["m_p"], [0.35])}
    for s, r in zip(res.campaign.settings, res.results):
        M, K = ev.stiffness(s.pose[None], "paper,payload_mass", k_a=np.array([s.k_a]), **t)
        lam, V = np.linalg.eig(np.linalg.solve(M[0], K[0]))
        order = np.argsort(lam.real)
        f_true, V = np.sqrt(lam.real[order]) / (2 * np.pi), V.real[:, order]
        assert len(r.modes) == 3, (layout, s.file)
        for m in r.modes:
            assert m.dofs == dofs
            k = int(np.argmin(np.abs(f_true - m.freq_hz)))
            assert k < 3 and abs(m.freq_hz / f_true[k] - 1) < 0.001, (layout, s.file, m.freq_hz, f_true[k])
            u = []
            for d in dofs:  # e . (v + omega x r), twist [omega; v]
                node, axis = int(d[0]), "XYZ".index(d[-1])
                pos = r1 + (np.array(NODE_OFFSETS[node]) if node > 1 else 0.0)
                u.append((V[3:, k] + np.cross(V[:3, k], pos))[axis])
            u = np.array(u)
            mac = (u @ m.shape) ** 2 / ((u @ u) * (m.shape @ m.shape))
            assert mac >= 0.99, (layout, s.file, m.label, mac)
    labels = sorted(m.label for m in res.results[0].modes)
    assert labels == ["1", "2", "3"]  # no triaxial node: modes by rank
    meas = res.measurements  # per-DOF shape columns phi_N_a + node positions
    names = [f"phi_{d[0]}_{d[-1].lower()}" for d in dofs]
    assert all(n in meas.modal for n in names) and np.allclose(meas.modal["node2_x"], r1[0] + 0.08)
    cmp = compare(meas, "paper,payload_mass", ev=ev, values={"m_p": 0.35})  # the diagnosis side: MAC per row
    assert np.all(cmp.mac >= 0.99), cmp.mac


def test_a_layout_without_a_shape_says_so_once(tmp_path, ev):
    """One accelerometer and one hammer DOF: one note for the whole campaign, frequencies still there."""
    from eigentwist.modal import synth as synth_module

    layouts = dict(synth_module.LAYOUTS, single=(("1+X",), ("2+X",)))
    import unittest.mock as mock

    with mock.patch.object(synth_module, "LAYOUTS", layouts):
        manifest = synth_campaign(
            TRUTH, [500.0, 2000.0], [LAYOUT_POSES[0]], tmp_path, ev, noise="0.5%", seed=5, layout="single"
        )
    res = identify_campaign(manifest, ev)
    assert res.notes == ["2 settings: no shape (one DOF, 1+X); frequencies and damping go on"]
    assert all(len(r.modes) >= 1 for r in res.results) and len(res.measurements) >= 2


def test_manifest_node_columns_override_uff_coordinates(tmp_path, ev):
    manifest = synth_campaign(TRUTH, [1000.0], [LAYOUT_POSES[0]], tmp_path, ev, noise="0.5%", seed=6, layout="uniaxial")
    text = manifest.read_text().splitlines()
    manifest.write_text(f"{text[0]},node3_x,node3_y,node3_z\n{text[1]},0.01,0.02,0.03\n")
    res = identify_campaign(manifest, ev)
    coords = res.results[0].coords
    assert np.allclose(coords[3], [0.01, 0.02, 0.03]) and np.allclose(coords[2], [0.08, 0.0, 0.0])
    manifest.write_text(f"{text[0]},node3_x,node3_y\n{text[1]},0.01,0.02\n")
    with pytest.raises(InputError, match="node 3 needs the three columns node3_x, node3_y, node3_z"):
        identify_campaign(manifest, ev)


def test_one_hertz_lines_three_percent_damping_and_impulsive_noise():
    """Measured-like FRFs: 1 Hz resolution, 3 % damping, heavy-tailed noise (Student t, 2 degrees of
    freedom, plus 1 % of lines hit by spikes 20x larger): the three modes within 0.5 %, nothing else."""
    f_k = np.array([52.0, 143.0, 281.0])
    rng = np.random.default_rng(7)
    shapes = np.array([[1.0, 0.8, 0.6], [0.7, -0.5, 0.9], [0.3, 1.0, -0.6], [-0.8, 0.4, 0.7]])  # 4 DOFs x 3 modes
    freq = np.arange(0.0, 400.0)
    H = frf_from_modes(freq, 2 * np.pi * f_k, shapes, 0.03, "accelerance", shapes[:1])[:, :, 0]
    rms = np.sqrt(np.mean(np.abs(H) ** 2, axis=0))
    noise = (rng.standard_t(2, H.shape) + 1j * rng.standard_t(2, H.shape)) * 0.01 * rms
    noise += (rng.random(H.shape) < 0.01) * 0.2 * rms * np.exp(2j * np.pi * rng.random(H.shape))
    frfs = FrfSet.from_grid(freq, (H + noise)[:, :, None], ["1+X", "2+X", "3+Y", "4+Z"], ["1+X"], "accelerance")
    res = identify_frfs(frfs, band=(10.0, 390.0))
    found = np.array(sorted(m.freq_hz for m in res.modes))
    assert len(found) == 3, found
    assert np.all(np.abs(found / f_k - 1) < 0.005), found
    assert all(abs(m.damping_ratio - 0.03) < 0.006 for m in res.modes)


def test_per_dof_shape_columns_give_the_mac_over_the_measured_dofs(ev):
    """A CSV row with phi_N_a columns: its MAC is the one over those DOFs of e . (v + omega x r), computed
    here from the model's eigentwists; a shape column without its node's position is one line."""
    from eigentwist.diagnose.measurements import MeasurementError, parse_csv

    pose = [0.06, -0.04, -0.6]
    modes = ev.modes(np.array([pose]), "paper", k_a=1000.0)
    k = int(np.argmin(np.abs(modes.direction[0] - 3)))  # the mode along x
    t = modes.eigentwists[0][:, k]
    nodes = {1: np.array([0.02, 0.0, 0.0]), 2: np.array([0.0, 0.1, -0.03])}
    u = {
        "1_x": (t[3:] + np.cross(t[:3], nodes[1]))[0],
        "2_y": (t[3:] + np.cross(t[:3], nodes[2]))[1],
        "2_z": (t[3:] + np.cross(t[:3], nodes[2]))[2],
    }
    measured = {"1_x": u["1_x"], "2_y": u["2_y"] + 0.3 * abs(u["1_x"]), "2_z": u["2_z"]}  # a perturbed shape
    a, b = np.array(list(u.values())), np.array(list(measured.values()))
    expected = (a @ b) ** 2 / ((a @ a) * (b @ b))
    head = "k_a,mode,freq_hz,x,y,z," + ",".join(f"phi_{c}" for c in measured)
    head += "," + ",".join(f"node{n}_{a}" for n in nodes for a in "xyz")
    row = f"1000,{modes.freq_hz[0, k]:.6f},{modes.freq_hz[0, k]:.6f},{pose[0]},{pose[1]},{pose[2]},"
    row = row.replace(f"1000,{modes.freq_hz[0, k]:.6f},", "1000,x,", 1)
    row += ",".join(f"{v:.12g}" for v in measured.values()) + "," + ",".join(f"{c:g}" for n in nodes for c in nodes[n])
    meas = parse_csv(f"{head}\n{row}\n", "dofs.csv", ev)
    cmp = compare(meas, "paper", ev=ev)
    assert cmp.mac[0] == pytest.approx(expected, abs=1e-9) and expected < 0.99
    with pytest.raises(MeasurementError, match="phi_3_y needs node 3's position"):
        parse_csv("k_a,mode,freq_hz,phi_3_y,phi_1_x\n1000,x,20,0.5,0.5\n", "bad.csv", ev)


def test_two_triaxial_nodes_label_by_axis_and_compare_over_all_six_dofs(tmp_path, ev):
    """Responses along X, Y, Z at nodes 1 and 2: labels x, y, z from node 1; the shape over all six DOFs
    goes to the CSV per DOF, and its MAC against the truth (compare) is >= 0.99."""
    import unittest.mock as mock

    from eigentwist.modal import synth as synth_module

    dofs = ("1+X", "1+Y", "1+Z", "2+X", "2+Y", "2+Z")
    layouts = dict(synth_module.LAYOUTS, two=(dofs, ("1+X", "1+Y", "1+Z")))
    with mock.patch.object(synth_module, "LAYOUTS", layouts):
        manifest = synth_campaign(
            TRUTH, [500.0, 2000.0], [LAYOUT_POSES[0]], tmp_path, ev, noise="1%", seed=8, layout="two"
        )
    res = identify_campaign(manifest, ev)
    assert res.notes == [] and all(sorted(m.label for m in r.modes) == ["x", "y", "z"] for r in res.results)
    meas = res.measurements
    assert np.all(np.isnan(meas.modal["phi_x"])) and not np.any(np.isnan(meas.modal["phi_2_z"]))
    cmp = compare(meas, "paper,payload_mass", ev=ev, values={"m_p": 0.35})
    assert np.all(cmp.mac >= 0.99), cmp.mac
