"""UFF in and out through pyuff: round trips and one clear line per bad input."""

from __future__ import annotations

import re

import numpy as np
import pyuff
import pytest

from eigentwist.modal.frf import form_factor, modal_frf
from eigentwist.modal.uff_io import FrfSet, ModeSet, UffError, read_uff, write_frf_uff, write_modes_uff

FREQ = np.round(np.arange(401) * 0.05, 10)  # 0 ... 20 Hz, a step UFF's 6-digit abscissa holds


def _frfs(seed=0):
    rng = np.random.default_rng(seed)
    return rng.standard_normal((len(FREQ), 3, 3)) + 1j * rng.standard_normal((len(FREQ), 3, 3))


@pytest.mark.parametrize("form", ["accelerance", "mobility", "receptance"])
def test_frfs_written_then_read_give_back_the_same_arrays(tmp_path, form):
    H = _frfs()
    write_frf_uff(tmp_path / "s.uff", FrfSet.from_grid(FREQ, H, ["7+X", "7+Y", "7+Z"], ["7+X", "7+Y", "7+Z"], form))
    back = read_uff(tmp_path / "s.uff", node=7)
    assert back.form == form and back.references == ["7+X", "7+Y", "7+Z"] and back.responses == back.references
    assert np.allclose(back.freq_hz, FREQ, rtol=1e-12, atol=1e-12)
    grid = np.zeros_like(H)
    for p, (o, r) in enumerate(back.pairs):
        grid[:, o, r] = back.H[:, p]
    assert len(back.pairs) == 9 and np.allclose(grid, H, rtol=1e-11, atol=1e-11 * np.abs(H).max())


def test_any_layout_mixed_forms_and_node_coordinates(tmp_path):
    """One uniaxial sensor, hammer at three nodes (one pair along -Y), receptance and accelerance mixed,
    node coordinates in dataset 15: read as accelerance (-w^2 x receptance), -Y as +Y with the sign flipped."""
    rng = np.random.default_rng(1)
    data = rng.standard_normal((3, len(FREQ))) + 1j * rng.standard_normal((3, len(FREQ)))
    sets = [
        pyuff.prepare_15(
            node_nums=[1, 2, 3],
            def_cs=[0] * 3,
            disp_cs=[0] * 3,
            color=[1] * 3,
            x=[0.0, 0.1, 0.2],
            y=[0.0, 0.0, 0.05],
            z=[0.0, -0.01, 0.0],
        )
    ]
    for k, (ref_node, ref_dir, ordinate) in enumerate([(1, 1, 12), (2, -2, 8), (3, 3, 12)]):
        s = _set58(1, ref_dir=ref_dir, ordinate=ordinate, data=data[k])
        s["ref_node"] = ref_node
        sets.append(s)
    _write58(tmp_path / "rh.uff", sets)
    back = read_uff(tmp_path / "rh.uff")
    assert back.responses == ["1+X"] and back.references == ["1+X", "2+Y", "3+Z"] and back.form == "accelerance"
    w = 2 * np.pi * FREQ
    assert np.allclose(back.H[:, 0], data[0]) and np.allclose(back.H[:, 2], data[2])
    assert np.allclose(back.H[:, 1], -1.0 * -(w**2) * data[1])  # -Y reference, receptance
    assert np.allclose(back.coords[2], [0.1, 0.0, -0.01]) and np.allclose(back.coords[3], [0.2, 0.05, 0.0])


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


def _set58(rsp_dir, ref_dir=1, x=FREQ, node=1, ordinate=12, data=None, abscissa=18):
    data = np.ones(len(x), dtype=complex) if data is None else data
    return pyuff.prepare_58(
        binary=0,
        func_type=4,
        rsp_node=node,
        rsp_dir=rsp_dir,
        ref_node=1,
        ref_dir=ref_dir,
        abscissa_spacing=1,
        abscissa_spec_data_type=abscissa,
        ordinate_spec_data_type=ordinate,
        orddenom_spec_data_type=13,
        data=data,
        x=x.copy(),
        id1="t",
        rsp_ent_name="EE",
        ref_ent_name="EE",
    )


def test_bad_uff_input_is_one_line_naming_file_and_dataset(tmp_path):
    nodes = tmp_path / "nodes.uff"
    pyuff.UFF(str(nodes)).write_sets(
        [pyuff.prepare_15(node_nums=[1], def_cs=[0], disp_cs=[0], color=[1], x=[0.0], y=[0.0], z=[0.0])],
        mode="overwrite",
    )
    cases = {
        nodes: "no dataset 58 (FRF) or 55 (modes)",
        tmp_path / "twice.uff": "FRF 1+X / 1+X given twice (first in dataset 1)",
        tmp_path / "time.uff": "abscissa specific data type 17: expected frequency in Hz (18)",
        tmp_path / "force.uff": "ordinate specific data type 13 is not displacement (8)",
        tmp_path / "axes.uff": "inconsistent frequency axes",
        tmp_path / "missing.uff": "no such file",
    }
    _write58(tmp_path / "twice.uff", [_set58(1), _set58(-1)])
    _write58(tmp_path / "time.uff", [_set58(1, abscissa=17)])
    _write58(tmp_path / "force.uff", [_set58(1, ordinate=13)])
    _write58(tmp_path / "axes.uff", [_set58(1), _set58(2, x=FREQ * 2), _set58(3)])
    for path, words in cases.items():
        with pytest.raises(UffError, match=re.escape(words)) as exc:
            read_uff(path)
        assert str(path) in str(exc.value) and "\n" not in str(exc.value)
    with pytest.raises(UffError, match=r"axes.uff, dataset 2 \(type 58\)"):
        read_uff(tmp_path / "axes.uff")


@pytest.mark.parametrize(
    "keep, message",
    [
        (13, None),
        (
            14,
            "dataset 2: truncated: the dataset opened on line 14 has no closing -1 line (the file ends after 1 "
            "complete dataset); write the file again",
        ),
        (
            20,
            "dataset 2 (type 55): truncated: the dataset opened on line 14 has no closing -1 line (the file ends "
            "after 1 complete dataset); write the file again",
        ),
        (25, "dataset 2 (type 55): truncated: the dataset opened on line 14"),
        (
            37,
            "dataset 3 (type 55): truncated: the dataset opened on line 27 has no closing -1 line (the file ends "
            "after 2 complete datasets); write the file again",
        ),
    ],
)
def test_a_file_cut_short_names_the_dataset_and_the_file(tmp_path, keep, message):
    """Three modes, 13 lines each: a cut inside dataset 2 or 3 is an error naming it (pyuff
    reads the complete ones and drops the rest silently); a cut after a closing -1 leaves a
    well-formed file of fewer datasets (no UFF field says how many there are)."""
    write_modes_uff(tmp_path / "m.uff", [12.5, 14.25, 16.0], [0.015, 0.02, 0.01], np.eye(3), node=1)
    lines = (tmp_path / "m.uff").read_text().splitlines(keepends=True)
    assert len(lines) == 39
    (tmp_path / "cut.uff").write_text("".join(lines[:keep]))
    if message is None:
        assert len(read_uff(tmp_path / "cut.uff").freq_hz) == 1
        return
    with pytest.raises(UffError) as exc:
        read_uff(tmp_path / "cut.uff")
    assert str(exc.value).startswith(f"{tmp_path / 'cut.uff'}, {message}")


def test_frf_dataset_with_missing_points_names_the_dataset(tmp_path):
    write_frf_uff(tmp_path / "s.uff", FrfSet.from_grid(FREQ, _frfs()[:, :1, :1], ["1+X"], ["1+X"], "accelerance"))
    lines = (tmp_path / "s.uff").read_text().splitlines(keepends=True)
    (tmp_path / "s.uff").write_text("".join(lines[:20] + lines[30:]))  # ten data lines gone
    with pytest.raises(
        UffError,
        match=r"s\.uff, dataset 1 \(type 58\): \d+ data points where its header says 401: "
        r"the dataset is truncated or inconsistent$",
    ):
        read_uff(tmp_path / "s.uff")


def test_datasets_pyuff_does_not_return_are_an_error(tmp_path, monkeypatch):
    """Every dataset delimited by -1 lines must come back from pyuff (an unsupported type
    comes back as its own dict): one missing is an error naming the counts."""
    write_modes_uff(tmp_path / "m.uff", [12.5, 14.25], [0.015, 0.02], np.eye(3)[:2], node=1)
    read_sets = pyuff.UFF.read_sets
    monkeypatch.setattr(pyuff.UFF, "read_sets", lambda self, *a, **kw: read_sets(self, *a, **kw)[:1])
    with pytest.raises(UffError) as exc:
        read_uff(tmp_path / "m.uff")
    assert str(exc.value) == f"{tmp_path / 'm.uff'}: 2 datasets delimited by -1 lines, but 1 read: the file is damaged"
