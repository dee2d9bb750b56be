"""Identification of modal-test campaigns: accuracy, labels, close modes, the diagnosis on top.

The synthetic campaign is the issue's: 2 poses x 4 k_a, 3x3 accelerance FRFs, modal
damping 1.5 %, 1 % complex noise, from a truth with a hidden 0.35 kg payload.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from eigentwist.cli.main import main
from eigentwist.diagnose import diagnose
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
    noise = "1%" if request.param == 58 else "0.1%"          # 55: noise on the frequencies themselves
    manifest = synth_campaign(TRUTH, K_A, POSES, out, ev, damping="1.5%", noise=noise, seed=1,
                              dataset=request.param)
    return request.param, identify_campaign(manifest, ev)


def test_every_mode_within_half_a_percent_and_labelled_right(campaign, ev):
    dataset, res = campaign
    poses = np.repeat(np.repeat(POSES, 4, axis=0), 3, axis=0)          # settings pose-major, 3 rows each
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
    d = diagnose(res.measurements, baseline="paper", ev=ev)
    assert d.selected[0] == "payload_mass"
    m_p, std = d.final.values["m_p"], d.final.std["m_p"]
    assert abs(m_p - 0.35) < 3 * std, (m_p, std)
    shapes = d.to_json()["shapes"]                           # the final model's shape term
    assert shapes["n"] == 24 and shapes["mac_min"] > 0.99


def test_two_modes_three_percent_apart_at_three_percent_noise_are_resolved():
    f_k = np.array([20.0, 20.6, 33.0])                        # modes 1 and 2 are 3 % apart
    q = np.linalg.qr(np.random.default_rng(2).standard_normal((3, 3)))[0]
    freq = np.round(np.arange(int(45 / 0.02) + 1) * 0.02, 10)
    H = frf_from_modes(freq, 2 * np.pi * f_k, q, 0.015, "accelerance")
    H = add_noise(H, 0.03, np.random.default_rng(3))
    res = identify_frfs(FrfSet(freq, H, ["1+X", "1+Y", "1+Z"], "accelerance", source="close.uff"))
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
    assert main(["synth", "--truth", TRUTH, "--k-a", "500,2000", "--pose", "0.06", "-0.04", "-0.6", "--uff", str(out),
                 "--noise", "1%", "--sensor", "0.05", "0.02", "-0.03", "--seed", "4"]) == 0
    assert main(["identify", str(out / "manifest.csv"), "-o", str(tmp_path / "id.csv"), "--band", "5:45"]) == 0
    header = (tmp_path / "id.csv").read_text().splitlines()[0]
    assert header == ("k_a,mode,freq_hz,sigma_hz,x,y,z,damping_ratio,phi_x,phi_y,phi_z,"
                      "sensor_x,sensor_y,sensor_z")
    capsys.readouterr()
    assert main(["compare", str(tmp_path / "id.csv"), "--model", "paper"]) == 0
    text = capsys.readouterr().out
    assert "MAC" in text and "1.0000" in text


def test_plots_and_report_section(campaign, tmp_path):
    from eigentwist.modal.plots import plot_frfs, plot_stabilisation
    from eigentwist.modal.report import is_manifest, render_section

    dataset, res = campaign
    assert is_manifest(res.campaign.source) and not is_manifest(DATA / "heli4_paper.csv")
    html = render_section(res, figures=False)
    assert html.startswith('<section id="campaign">') and "setting_08.uff" in html and html.count("<tr>") == 1 + 24
    if dataset == 58:
        plot_stabilisation(res.results[0], tmp_path / "stab.png")
        plot_frfs(res.results[0], tmp_path / "frf.png")
        assert (tmp_path / "stab.png").read_bytes()[:4] == b"\x89PNG" and (tmp_path / "frf.png").stat().st_size > 0
