"""UFF in and out through pyuff: round trips and one clear line per bad input."""
from __future__ import annotations

import re

import numpy as np
import pyuff
import pytest

from eigentwist.modal.frf import form_factor, modal_frf
from eigentwist.modal.uff_io import ModeSet, UffError, read_uff, write_frf_uff, write_modes_uff

FREQ = np.round(np.arange(401) * 0.05, 10)        # 0 ... 20 Hz, a step UFF's 6-digit abscissa holds


def _frfs(seed=0):
    rng = np.random.default_rng(seed)
    return rng.standard_normal((len(FREQ), 3, 3)) + 1j * rng.standard_normal((len(FREQ), 3, 3))


@pytest.mark.parametrize("form", ["accelerance", "mobility", "receptance"])
def test_frfs_written_then_read_give_back_the_same_arrays(tmp_path, form):
    H = _frfs()
    write_frf_uff(tmp_path / "s.uff", FREQ, H, node=7, form=form)
    back = read_uff(tmp_path / "s.uff", node=7)
    assert back.form == form and back.references == ["7+X", "7+Y", "7+Z"]
    assert np.allclose(back.freq_hz, FREQ, rtol=1e-12, atol=1e-12)
    assert np.allclose(back.H, H, rtol=1e-11, atol=1e-11 * np.abs(H).max())


def test_modes_written_then_read(tmp_path):
    shapes = np.array([[1.0, 0.1, -0.2], [0.05, 1.0, 0.0]])
    write_modes_uff(tmp_path / "m.uff", [12.5, 14.25], [0.015, 0.02], shapes, node=3)
    back = read_uff(tmp_path / "m.uff", node=3)
    assert isinstance(back, ModeSet)
    assert np.allclose(back.freq_hz, [12.5, 14.25]) and np.allclose(back.damping_ratio, [0.015, 0.02])
    assert np.allclose(back.shapes, shapes, rtol=1e-5)


def test_model_frfs_are_reciprocal_and_forms_differ_by_i_omega(ev):
    M, K = ev.stiffness(np.array([[0.06, -0.04, -0.6]]), "paper", k_a=1000.0)
    acc = modal_frf(M[0], K[0], FREQ[1:], 0.015, "accelerance", sensor=[0.05, 0.02, -0.03])
    rec = modal_frf(M[0], K[0], FREQ[1:], 0.015, "receptance", sensor=[0.05, 0.02, -0.03])
    assert np.allclose(acc, np.swapaxes(acc, 1, 2))
    assert np.allclose(acc, rec * form_factor(FREQ[1:], "accelerance")[:, None, None])


def _write58(path, sets):
    pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")


def _set58(rsp_dir, ref_dir=1, x=FREQ, node=1):
    return pyuff.prepare_58(binary=0, func_type=4, rsp_node=node, rsp_dir=rsp_dir, ref_node=1, ref_dir=ref_dir,
                            abscissa_spacing=1, abscissa_spec_data_type=18, ordinate_spec_data_type=12,
                            orddenom_spec_data_type=13, data=np.ones(len(x), dtype=complex), x=x.copy(),
                            id1="t", rsp_ent_name="EE", ref_ent_name="EE")


def test_bad_uff_input_is_one_line_naming_file_and_dataset(tmp_path):
    nodes = tmp_path / "nodes.uff"
    pyuff.UFF(str(nodes)).write_sets([pyuff.prepare_15(node_nums=[1], def_cs=[0], disp_cs=[0], color=[1],
                                                       x=[0.0], y=[0.0], z=[0.0])], mode="overwrite")
    cases = {
        nodes: "no dataset 58 (FRF) or 55 (modes)",
        tmp_path / "xy.uff": "no response at node 1 along +Z",
        tmp_path / "axes.uff": "inconsistent frequency axes",
        tmp_path / "missing.uff": "no such file",
    }
    _write58(tmp_path / "xy.uff", [_set58(1), _set58(2)])
    _write58(tmp_path / "axes.uff", [_set58(1), _set58(2, x=FREQ * 2), _set58(3)])
    for path, words in cases.items():
        with pytest.raises(UffError, match=re.escape(words)) as exc:
            read_uff(path)
        assert str(path) in str(exc.value) and "\n" not in str(exc.value)
    with pytest.raises(UffError, match=r"axes.uff, dataset 2 \(type 58\)"):
        read_uff(tmp_path / "axes.uff")
    with pytest.raises(UffError, match="dataset 58.*at node 2"):
        read_uff(tmp_path / "xy.uff", node=2)
