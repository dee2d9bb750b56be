"""Design sweeps: spec parsing, chunking, unreachable poses, the lowest summary, writers, Dask."""

from __future__ import annotations

import inspect
import itertools
import json
import logging
import types

import numpy as np
import pytest

from eigentwist.cli.main import main
from eigentwist.robots import NAMES
from eigentwist.runtime import InputError
from eigentwist.cli.common import CliError
from eigentwist.cli.sweep_args import parse_values, parse_vary
from eigentwist.runtime import sweep as sw

from .conftest import c_cache_dir, skip_tier

# x in [0, 0.3], y = 0, z in [-0.8, -0.3]: both reachable and unreachable poses (heli4)
MIXED_BOX = (0.0, 0.3, 0.0, 0.0, -0.8, -0.3)


def concat(spec) -> dict:
    parts = [sw.evaluate_chunk(spec, i) for i in range(spec.n_chunks)]
    return {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}


def full_product(spec):
    """The sweep's rows built independently: designs (first slowest), k_a, poses (fastest)."""
    names = spec.design_names
    axes = [
        np.linspace(lo, hi, n) if n > 1 else np.array([0.5 * (lo + hi)])
        for (lo, hi), n in zip(spec.poses.box, spec.poses.shape)
    ]
    poses = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    rows = [
        (design, k_a, pose)
        for design in itertools.product(*(v for _, v in spec.vary))
        for k_a in spec.k_a
        for pose in poses
    ]
    pose = np.array([r[2] for r in rows])
    k_a = np.array([r[1] for r in rows])
    params = {name: np.array([r[0][j] for r in rows]) for j, name in enumerate(names)}
    return pose, k_a, params


# ---------------------------------------------------------------------- parsing
@pytest.mark.parametrize(
    "text, expected",
    [
        ("0.45:0.60:16", np.linspace(0.45, 0.60, 16)),
        ("500,1000,2000", [500.0, 1000.0, 2000.0]),
        ("2000", [2000.0]),
        ("1e3:2e3:3", [1000.0, 1500.0, 2000.0]),
    ],
)
def test_parse_values(text, expected):
    assert np.array_equal(parse_values(text), np.asarray(expected, dtype=float))


def test_parse_vary():
    name, values = parse_vary("l2=0.45:0.60:16")
    assert name == "l2" and len(values) == 16 and values[0] == 0.45 and values[-1] == 0.60


@pytest.mark.parametrize(
    "item, fragment",
    [
        ("l2=0.45:0.60", "'0.45:0.60' is not a range"),
        ("l2=0.45:0.60:x", "count 'x'"),
        ("l2=0.45:0.60:0", "count 0"),
        ("l2=abc", "'abc' is not a number"),
        ("l2=nan", "'nan' is not a finite number"),
        ("l2", "expected NAME=LO:HI:N"),
        ("=0.5", "expected NAME=LO:HI:N"),
        ("l2=", "empty"),
    ],
)
def test_bad_vary_names_the_value(item, fragment):
    with pytest.raises(CliError, match="--vary") as err:
        parse_vary(item)
    assert fragment in str(err.value)


@pytest.mark.parametrize(
    "kwargs, fragment",
    [
        ({"vary": [("nope", [1, 2])]}, "'nope'"),
        ({"vary": [("l2", [-0.5, 0.5])]}, "'l2' = "),
        ({"vary": [("k_a", [1, 2])]}, "its own argument"),
        ({"vary": [("l2", 0.5), ("l2", 0.6)]}, "more than once"),
        ({"vary": {"l2": 0.5}, "fixed": {"l2": 0.5}}, "both varied and fixed"),
        ({"vary": {"l2": "0.45:0.60:16"}}, "is text"),
        ({"vary": {"l2": [0.5, float("nan")]}}, "finite numbers"),
        ({"k_a": [0, 1000]}, "'k_a' = 0"),
        ({"box": (0.1, -0.1, 0, 0, -0.7, -0.6)}, "box x range"),
        ({"box": (0, 1, 2)}, "six finite numbers"),
        ({"grid": (2, 0, 2)}, "grid [2, 0, 2]"),
        ({"random": 0}, "random sample size 0"),
        ({"random": 10, "seed": -1}, "seed -1"),
        ({"model": "paper,nope"}, "'nope'"),
        ({"chunk_size": 0}, "chunk size 0"),
    ],
)
def test_bad_spec_names_the_value(kwargs, fragment):
    with pytest.raises(InputError) as err:
        sw.make_spec("heli4", **kwargs)
    assert fragment in str(err.value)


def test_spec_round_trips_through_json():
    spec = sw.make_spec(
        random=50,
        seed=3,
        k_a=parse_values("500:4000:8"),
        vary={"l2": parse_values("0.45:0.60:16"), "l1": [0.18, 0.2]},
        fixed={"m_e": 0.6},
        chunk_size=100,
    )
    again = sw.SweepSpec.from_dict(json.loads(json.dumps(spec.to_dict())))
    assert again == spec
    assert spec.n_rows == 16 * 2 * 8 * 50 and spec.n_chunks == -(-spec.n_rows // 100)
    d = json.loads(json.dumps(spec.to_dict()))
    assert d["poses"]["sampling"] == "random"
    d["poses"]["kind"] = d["poses"].pop("sampling")  # the alias a manifest may hold
    assert sw.SweepSpec.from_dict(d) == spec


# --------------------------------------------------------------------- chunking
def test_chunks_reassemble_to_the_unchunked_evaluation(ev):
    spec = sw.make_spec(
        grid=(3, 2, 3),
        k_a=parse_values("1000,2000"),
        vary=[parse_vary("l2=0.48:0.58:3"), parse_vary("l1=0.19,0.21")],
        fixed={"m_e": 0.65},
        chunk_size=25,
        backend=ev.backend,
    )  # 25 does not divide 216 rows
    cols = concat(spec)
    pose, k_a, params = full_product(spec)
    assert spec.n_rows == len(pose) == 216
    np.testing.assert_array_equal(cols["pose"], pose)
    np.testing.assert_array_equal(cols["k_a"], k_a)
    np.testing.assert_array_equal(cols["design"], np.column_stack([params["l2"], params["l1"]]))
    modes = ev.modes(pose, "paper", k_a=k_a, m_e=0.65, **params)
    np.testing.assert_array_equal(cols["freq_hz"], modes.freq_hz)  # same kernels, same bits
    np.testing.assert_array_equal(cols["direction"], modes.direction)
    assert cols["reachable"].all()
    # another chunking gives the same bits
    other = concat(
        sw.make_spec(
            grid=(3, 2, 3),
            k_a=parse_values("1000,2000"),
            vary=[parse_vary("l2=0.48:0.58:3"), parse_vary("l1=0.19,0.21")],
            fixed={"m_e": 0.65},
            chunk_size=1000,
            backend=ev.backend,
        )
    )
    for key in cols:
        np.testing.assert_array_equal(cols[key], other[key])


def test_rigid_model_has_three_modes(ev):
    spec = sw.make_spec(grid=(2, 2, 2), model="rigid", chunk_size=3)
    cols = concat(spec)
    assert cols["freq_hz"].shape == (8, 3)
    np.testing.assert_allclose(cols["freq_hz"], ev.frequencies(cols["pose"], "rigid"), rtol=1e-12)
    assert set(np.unique(cols["direction"])) <= {3, 4, 5}  # x, y, z


def test_random_poses_are_seeded_and_independent_of_chunking():
    a = sw.make_spec(random=300, seed=7, chunk_size=7)
    b = sw.make_spec(random=300, seed=7, chunk_size=300)
    c = sw.make_spec(random=300, seed=8, chunk_size=300)
    pa, pb, pc = concat(a)["pose"], concat(b)["pose"], concat(c)["pose"]
    np.testing.assert_array_equal(pa, pb)
    assert not np.allclose(pa, pc)
    lo = np.array([r[0] for r in a.poses.box])
    hi = np.array([r[1] for r in a.poses.box])
    assert ((pa >= lo) & (pa <= hi)).all()
    assert np.unique(pa, axis=0).shape[0] == 300


def test_random_poses_cross_block_boundaries():
    spec = sw.make_spec(random=sw.POSE_BLOCK + 5, seed=2, chunk_size=10)
    idx = np.arange(sw.POSE_BLOCK - 3, sw.POSE_BLOCK + 5)
    one = spec.poses.take(idx)
    two = np.concatenate([spec.poses.take(idx[:3]), spec.poses.take(idx[3:])])
    np.testing.assert_array_equal(one, two)
    assert np.unique(one, axis=0).shape[0] == len(idx)


# ------------------------------------------------------------------ reachability
def test_unreachable_poses_are_marked_not_raised(ev):
    spec = sw.make_spec(grid=(7, 1, 7), box=MIXED_BOX, vary=[parse_vary("l2=0.5,0.56")], chunk_size=16)
    cols = concat(spec)
    expected = []
    for pose, l2 in zip(cols["pose"], cols["design"][:, 0]):
        try:
            expected.append(ev.frequencies(pose, l2=l2)[0])
        except ValueError:  # UnreachablePoseError / SingularPoseError
            expected.append(None)
    ok = np.array([e is not None for e in expected])
    assert 0 < ok.sum() < len(ok)  # the box holds both kinds
    np.testing.assert_array_equal(cols["reachable"], ok)
    np.testing.assert_allclose(cols["freq_hz"][ok], np.array([e for e in expected if e is not None]), rtol=1e-12)
    assert np.isnan(cols["freq_hz"][~ok]).all() and (cols["direction"][~ok] == -1).all()


def test_reachable_rows_mirrors_the_evaluator(ev):
    poses = np.array([[0.0, 0.0, -0.625], [0.0, 0.0, -0.3], [0.3, 0.0, -0.75], [0.3, 0.0, -0.4]])
    ok = sw.reachable_rows(ev, poses, {}, "paper")
    np.testing.assert_array_equal(ok, [True, False, False, True])


# ------------------------------------------------------------------- the summary
def test_lowest_equals_brute_force():
    spec = sw.make_spec(
        grid=(5, 1, 5),
        box=MIXED_BOX,
        k_a=parse_values("1000,2000"),
        vary=[parse_vary("l2=0.5,0.53,0.56")],
        chunk_size=13,
    )
    summary = sw.run_sweep(spec)
    cols = concat(spec)
    low = summary.lowest
    assert len(low["freq_hz"]) == spec.n_cases == 6
    for case in range(spec.n_cases):
        rows = np.flatnonzero((cols["case"] == case) & cols["reachable"])
        f1 = cols["freq_hz"][rows, 0]
        best = rows[np.argmin(f1)]
        assert low["freq_hz"][case] == f1.min()
        np.testing.assert_array_equal(low["pose"][case], cols["pose"][best])
        assert low["pose_index"][case] == cols["pose_index"][best]
        assert low["direction"][case] == cols["direction"][best, 0]
        assert low["n_reachable"][case] == len(rows)
        assert low["k_a"][case] == cols["k_a"][best] and low["design"][case, 0] == cols["design"][best, 0]
    recomputed = sw.lowest(cols, spec)
    for key in low:
        np.testing.assert_array_equal(low[key], recomputed[key])


def test_lowest_of_a_design_with_no_reachable_pose_is_nan():
    spec = sw.make_spec(grid=(2, 1, 2), box=(0.0, 0.1, 0, 0, -0.35, -0.3), chunk_size=3)
    low = sw.run_sweep(spec).lowest
    assert np.isnan(low["freq_hz"]).all() and (low["pose_index"] == -1).all() and (low["n_reachable"] == 0).all()


# ------------------------------------------------------------------------ output
def test_npz_directory_round_trip(tmp_path):
    spec = sw.make_spec(grid=(4, 1, 4), box=MIXED_BOX, vary=[parse_vary("l2=0.5,0.55")], chunk_size=9)
    summary = sw.run_sweep(spec, sw.open_writer(tmp_path / "out", spec))
    data = sw.load_sweep(tmp_path / "out")
    assert data.spec == spec and data.manifest["complete"] and data.manifest["n_rows"] == 32
    expected = concat(spec)
    for key in sw.COLUMNS:
        np.testing.assert_array_equal(data.columns[key], expected[key])
    for key in summary.lowest:
        np.testing.assert_array_equal(data.lowest[key], summary.lowest[key])
    with pytest.raises(InputError, match="already holds a sweep"):
        sw.open_writer(tmp_path / "out", spec)
    sw.open_writer(tmp_path / "out", spec, overwrite=True)
    assert not list((tmp_path / "out").glob("chunk-*.npz"))


def test_parquet_round_trip(tmp_path):
    pytest.importorskip("pyarrow", reason="the parquet extra (pyarrow) is not installed")
    spec = sw.make_spec(grid=(4, 1, 4), box=MIXED_BOX, k_a=parse_values("1000,2000"), chunk_size=9)
    summary = sw.run_sweep(spec, sw.open_writer(tmp_path / "out.parquet", spec))
    data = sw.load_sweep(tmp_path / "out.parquet")
    assert data.spec == spec
    expected = concat(spec)
    for key in sw.COLUMNS:
        np.testing.assert_array_equal(data.columns[key], expected[key])
    for key in summary.lowest:
        np.testing.assert_array_equal(data.lowest[key], summary.lowest[key])


def test_parquet_without_pyarrow_names_the_extra(tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "pyarrow", None)
    spec = sw.make_spec(grid=(1, 1, 1))
    with pytest.raises(InputError, match=r'pip install "eigentwist\[parquet\]"'):
        sw.open_writer(tmp_path / "out.parquet", spec)


# --------------------------------------------------------------------------- CLI
def test_cli_sweep_writes_and_prints_lowest(tmp_path, capsys):
    out = tmp_path / "sweep"
    assert (
        main(
            [
                "sweep",
                "--grid",
                "3",
                "1",
                "3",
                "--box",
                *map(str, MIXED_BOX),
                "--k-a",
                "1000,2000",
                "--vary",
                "l2=0.5:0.56:2",
                "--set",
                "m_e=0.6",
                "--chunk-size",
                "5",
                "-o",
                str(out),
                "--lowest",
            ]
        )
        == 0
    )
    captured = capsys.readouterr()
    assert "worst-case lowest" in captured.out and "lowest Hz" in captured.out and "l2" in captured.out
    assert "36 rows" in captured.err and "reachable" in captured.err and "poses/s" in captured.err
    data = sw.load_sweep(out)
    assert data.spec.fixed == (("m_e", 0.6),) and data.spec.k_a == (1000.0, 2000.0)
    assert len(data.columns["case"]) == 36 and data.lowest["freq_hz"].shape == (4,)


def test_cli_errors_are_one_line(tmp_path, capsys):
    assert main(["sweep", "--vary", "l2=0.5:x:3", "-o", str(tmp_path / "a")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "l2=0.5:x:3" in err[0]
    assert main(["sweep", "--workers", "2", "-o", str(tmp_path / "b")]) == 2
    assert "--engine dask" in capsys.readouterr().err


def test_dask_engine_without_dask_names_the_extra(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "dask.distributed", None)
    spec = sw.make_spec(grid=(1, 1, 1))
    with pytest.raises(InputError, match=r'pip install "eigentwist\[dask\]"'):
        sw.run_sweep(spec, engine="dask")


# -------------------------------------------------------------------------- Dask
def test_dask_two_workers_equal_in_process(tmp_path):
    distributed = pytest.importorskip("dask.distributed", reason="the dask extra is not installed")
    spec = sw.make_spec(
        random=400,
        seed=11,
        box=MIXED_BOX,
        vary=[parse_vary("l2=0.5,0.56")],
        k_a=parse_values("1000,2000"),
        chunk_size=150,
    )
    local = sw.run_sweep(spec, sw.open_writer(tmp_path / "local", spec))
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        remote = sw.run_sweep(
            spec, sw.open_writer(tmp_path / "dask", spec), engine="dask", scheduler=cluster.scheduler_address
        )
    a, b = sw.load_sweep(tmp_path / "local"), sw.load_sweep(tmp_path / "dask")
    assert 0 < local.n_reachable == remote.n_reachable < spec.n_rows
    for key in sw.COLUMNS:
        np.testing.assert_array_equal(a.columns[key], b.columns[key])
    for key in local.lowest:
        np.testing.assert_array_equal(local.lowest[key], remote.lowest[key])


def test_cli_dask_local_cluster(tmp_path, capsys, monkeypatch):
    distributed = pytest.importorskip("dask.distributed", reason="the dask extra is not installed")
    registered = []
    register = distributed.Client.register_plugin
    monkeypatch.setattr(
        distributed.Client,
        "register_plugin",
        lambda self, plugin, **kw: registered.append(plugin) or register(self, plugin, **kw),
    )
    args = ["sweep", "--grid", "2", "2", "2", "--vary", "l2=0.5,0.55", "--chunk-size", "5"]
    assert main([*args, "-o", str(tmp_path / "a")]) == 0
    assert main([*args, "--engine", "dask", "--workers", "2", "-o", str(tmp_path / "b")]) == 0
    err = capsys.readouterr().err
    assert "engine dask" in err
    assert [type(p).__name__ for p in registered] == ["QuietShutdown"]
    a, b = sw.load_sweep(tmp_path / "a"), sw.load_sweep(tmp_path / "b")
    for key in sw.COLUMNS:
        np.testing.assert_array_equal(a.columns[key], b.columns[key])


def test_only_a_closing_workers_heartbeat_failure_is_dropped():
    distributed = pytest.importorskip("dask.distributed", reason="the dask extra is not installed")
    from distributed.core import Status

    from eigentwist.runtime.sweep.dask_quiet import HEARTBEAT_FAILURE, ClosingHeartbeatFilter, QuietShutdown

    # the record the filter matches is the one distributed's worker writes
    assert f'"{HEARTBEAT_FAILURE}.' in inspect.getsource(distributed.Worker.heartbeat)
    worker = types.SimpleNamespace(status=Status.running)
    logger = logging.getLogger("distributed.worker")
    before = list(logger.filters)
    try:
        QuietShutdown().setup(worker)
        (added,) = [f for f in logger.filters if f not in before]
    finally:
        logger.filters[:] = before

    def record(message):
        return logging.LogRecord("distributed.worker", logging.ERROR, __file__, 1, message, (), None)

    heartbeat = "Failed to communicate with scheduler during heartbeat."
    assert isinstance(added, ClosingHeartbeatFilter) and added.filter(record(heartbeat))
    for status in (Status.closing, Status.closing_gracefully, Status.closed):
        worker.status = status
        assert not added.filter(record(heartbeat)), status
        assert added.filter(record("Worker stream died during communication")), status


@pytest.mark.parametrize("robot", NAMES)
def test_every_shipped_robot_sweeps_its_workspace(robot):
    import eigentwist

    spec = sw.make_spec(robot, grid=(2, 2, 2), chunk_size=3)
    cols = concat(spec)
    ok = cols["reachable"]
    assert ok.any()
    ev = eigentwist.load(robot, backend="numpy")
    np.testing.assert_array_equal(cols["freq_hz"][ok], ev.frequencies(cols["pose"][ok], k_a=cols["k_a"][ok]))


@pytest.mark.compiled
def test_c_backend_sweep_agrees_with_numpy(monkeypatch):
    cb = pytest.importorskip("eigentwist.runtime.c_kernels", reason="this build has no C backend")
    try:
        cb.find_compiler()
    except cb.CompilerNotFoundError as exc:
        skip_tier("compiled", str(exc))
    monkeypatch.setenv("EIGENTWIST_CACHE", str(c_cache_dir()))
    kwargs = dict(
        grid=(6, 1, 6), box=MIXED_BOX, vary=[parse_vary("l2=0.5,0.56")], k_a=parse_values("1000,2000"), chunk_size=19
    )
    for model in ("paper", "rigid"):
        a = concat(sw.make_spec(backend="numpy", model=model, **kwargs))
        b = concat(sw.make_spec(backend="c", model=model, **kwargs))
        assert 0 < a["reachable"].sum() < len(a["reachable"])
        np.testing.assert_array_equal(a["reachable"], b["reachable"])
        np.testing.assert_array_equal(a["direction"], b["direction"])
        np.testing.assert_allclose(b["freq_hz"], a["freq_hz"], rtol=1e-10)  # NaN where unreachable, in both


# ------------------------------------------------------------------------ damping
def test_a_damped_sweep_maps_the_damped_frequencies_and_the_least_damped_mode(tmp_path):
    import eigentwist

    model = "paper,servo_damping"
    spec = sw.make_spec(grid=(3, 1, 3), box=MIXED_BOX, k_a=parse_values("125,4000"), model=model, chunk_size=7)
    summary = sw.run_sweep(spec, sw.open_writer(tmp_path / "d", spec))
    cols = concat(spec)
    ok = cols["reachable"]
    assert ok.any() and (~ok).any()
    assert np.isnan(cols["damped_hz"][~ok]).all() and np.isnan(cols["damping_ratio"][~ok]).all()
    # the public API on the same rows
    ev = eigentwist.load("heli4", backend="numpy")
    m = ev.modes(cols["pose"][ok], model, k_a=cols["k_a"][ok])
    np.testing.assert_array_equal(cols["damped_hz"][ok], m.damped_hz)
    np.testing.assert_array_equal(cols["damping_ratio"][ok], m.damping_ratio)
    # physics: no mode grows (zeta >= 0 to round-off; a mode the actuators barely move is ~0), a
    # damped mode oscillates below its natural frequency, and c_a = 3 damps k_a = 125 far more
    zeta = cols["damping_ratio"][ok]
    assert (zeta > -1e-12).all() and (cols["damped_hz"][ok] <= m.natural_hz * (1 + 1e-12)).all()
    soft = cols["k_a"][ok] == 125.0
    assert zeta[soft].max(axis=1).min() > zeta[~soft].max(axis=1).max()
    # the lowest table, against a brute force over rows and modes
    low = summary.lowest
    for case in range(spec.n_cases):
        rows = np.flatnonzero((cols["case"] == case) & ok)
        for key in ("damped_hz", "damping_ratio"):
            values = cols[key][rows]
            r, k = np.unravel_index(np.argmin(values), values.shape)
            assert low[key][case] == values.min()
            assert low[f"{key}_mode"][case] == k and low[f"{key}_pose_index"][case] == cols["pose_index"][rows[r]]
            np.testing.assert_array_equal(low[f"{key}_pose"][case], cols["pose"][rows[r]])
    data = sw.load_sweep(tmp_path / "d")
    for key in sw.DAMPED_COLUMNS:
        np.testing.assert_array_equal(data.columns[key], cols[key])
    for key in low:
        np.testing.assert_array_equal(data.lowest[key], low[key])


def test_a_damped_sweep_of_unreachable_poses_has_nan_damping():
    spec = sw.make_spec(grid=(2, 1, 2), box=(0.0, 0.1, 0, 0, -0.35, -0.3), chunk_size=3, model="paper,servo_damping")
    chunk = sw.evaluate_chunk(spec, 0)
    assert not chunk["reachable"].any()
    assert all(np.isnan(chunk[k]).all() for k in sw.DAMPED_COLUMNS)
    low = sw.run_sweep(spec).lowest
    assert np.isnan(low["damped_hz"]).all() and (low["damping_ratio_mode"] == -1).all()


def test_an_undamped_sweep_has_no_damped_columns():
    spec = sw.make_spec(grid=(2, 1, 2), box=MIXED_BOX, chunk_size=3)
    assert not set(sw.DAMPED_COLUMNS) & set(sw.evaluate_chunk(spec, 0))
    assert not any(k.startswith(("damped", "damping")) for k in sw.run_sweep(spec).lowest)


def test_damped_sweep_parquet_round_trip_and_cli_table(tmp_path, capsys):
    pytest.importorskip("pyarrow", reason="the parquet extra (pyarrow) is not installed")
    spec = sw.make_spec(grid=(2, 1, 2), box=MIXED_BOX, k_a=parse_values("250"), model="paper,servo_damping")
    summary = sw.run_sweep(spec, sw.open_writer(tmp_path / "d.parquet", spec))
    data = sw.load_sweep(tmp_path / "d.parquet")
    for key in sw.DAMPED_COLUMNS:
        np.testing.assert_array_equal(data.columns[key], concat(spec)[key])
    for key in summary.lowest:
        np.testing.assert_array_equal(data.lowest[key], summary.lowest[key])
    argv = ["sweep", "--grid", "2", "1", "2", "--box", *map(str, MIXED_BOX), "--k-a", "250"]
    assert main([*argv, "--model", "paper,servo_damping", "-o", str(tmp_path / "c"), "--lowest"]) == 0
    out = capsys.readouterr().out
    assert "lowest damped Hz" in out and "least zeta" in out and "(mode " in out
