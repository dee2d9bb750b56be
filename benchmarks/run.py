"""Benchmark: evaluations per second of M + K_F and of the natural frequencies (Heli4,
the paper's flexible model) for N = 1e3, 1e5, 1e6 poses, four pipelines in one run, on
one core; peak memory; generation and compile times.

    python benchmarks/run.py            # the full run recorded in benchmarks/README.md (~10 min)
    python benchmarks/run.py --quick    # N = 1e3, 1e4 only (a smoke test, ~1.5 min)
    python benchmarks/run.py --public   # public path vs raw kernel, 1 vs all threads, memory

Timings are the best of ``--repeat`` runs (one run for the per-pose loop, whose rate does
not depend on N; at N = 1e6 it is extrapolated from its N = 1e5 rate and marked so).
Peak memory is measured in a separate pass with tracemalloc (Python and NumPy
allocations; the C library allocates nothing but its stack buffers).
"""

from __future__ import annotations

import os

# one core: pin the process and keep BLAS single-threaded (set before NumPy loads)
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse
import json
import platform
import resource
import subprocess
import sys
import tempfile
import time
import tracemalloc
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import numpy as np  # noqa: E402

import pipelines  # noqa: E402


# ---------------------------------------------------------------- machine
def machine() -> dict:
    cpu = "unknown"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    flags = ""
    try:
        text = Path("/proc/cpuinfo").read_text()
        have = set(text.split("flags", 1)[1].split("\n", 1)[0].split())
        flags = " ".join(f for f in ("avx2", "fma", "avx512f") if f in have)
    except (OSError, IndexError):
        pass
    from eigentwist.runtime.ccompile import compiler_version, find_compiler

    try:
        cc = compiler_version(find_compiler()).splitlines()[0]
    except Exception as exc:  # reported, not fatal: the C rows then fail loudly
        cc = f"none ({exc})"
    import scipy
    import sympy

    return dict(
        cpu=cpu,
        nproc=os.cpu_count(),
        flags=flags,
        python=platform.python_version(),
        numpy=np.__version__,
        scipy=scipy.__version__,
        sympy=sympy.__version__,
        cc=cc,
        glibc=" ".join(platform.libc_ver()),
        affinity=sorted(os.sched_getaffinity(0)),
    )


# ------------------------------------------------------------- generation
def generation_times() -> dict:
    """derive, CSE, emit (NumPy and C separately) for the Heli4; compile; `eigentwist generate`."""
    from eigentwist.codegen.c_source import render_c
    from eigentwist.codegen.generate import _render_numpy, _template_text, kernels_for
    from eigentwist.codegen.kernel import source_hash
    from eigentwist.robots import get
    from eigentwist.runtime.ccompile import build_library, find_compiler, flag_sets
    from eigentwist.symbolic import derive

    out = {}
    t0 = time.perf_counter()
    model = derive(get("heli4"))
    t1 = time.perf_counter()
    kernels = kernels_for(model)
    t2 = time.perf_counter()
    _render_numpy(model.robot, kernels, source_hash(kernels, _template_text("numpy")))
    t3 = time.perf_counter()
    source = render_c(model.robot, kernels, source_hash(kernels, _template_text("c")))
    t4 = time.perf_counter()
    out.update(derive_s=t1 - t0, cse_s=t2 - t1, emit_numpy_s=t3 - t2, emit_c_s=t4 - t3)
    cc = find_compiler()
    for name, flags in flag_sets():
        with tempfile.TemporaryDirectory() as tmp:
            t5 = time.perf_counter()
            build_library(source, "heli4_c", cc, flags, Path(tmp))
            out[f"compile_{name}_s"] = time.perf_counter() - t5
    for label, extra in (("generate_check_all_s", []), ("generate_check_heli4_s", ["--robot", "heli4"])):
        t6 = time.perf_counter()
        # timed only: the exit status says whether the checked-in files are current, which
        # does not matter here (and may change while others edit the derivation)
        subprocess.run(
            [sys.executable, "-m", "eigentwist", "generate", "--check", *extra], check=False, capture_output=True
        )
        out[label] = time.perf_counter() - t6
    return out


# ---------------------------------------------------------------- timing
def best_time(fn, arg, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn(arg)
        best = min(best, time.perf_counter() - t0)
    return best


def peak_bytes(fn, arg) -> int:
    tracemalloc.start()
    try:
        fn(arg)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def poses_for(robot, n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    lo = np.array([a for a, _ in robot.workspace])
    hi = np.array([b for _, b in robot.workspace])
    return lo + (hi - lo) * rng.random((n, 3))


# ------------------------------------------------------------ public path
RSS_SNIPPET = """
import numpy as np, eigentwist

def hwm():  # peak RSS of this process in MiB (VmHWM: exec starts it afresh, unlike ru_maxrss)
    for line in open('/proc/self/status'):
        if line.startswith('VmHWM:'):
            return int(line.split()[1]) / 1024

ev = eigentwist.load('heli4', backend='c')
rng = np.random.default_rng(0)
lo = np.array([a for a, _ in ev.robot.workspace]); hi = np.array([b for _, b in ev.robot.workspace])
poses = lo + (hi - lo) * rng.random(({n}, 3))
base = hwm()
{body}
print(base, hwm())
"""
MEMORY_CASES = {
    "matrices": "m = ev.matrices(poses)",
    "matrices_out": "out = {'K_F': np.empty((len(poses), 6, 6))}\nm = ev.matrices(poses, out=out)",
    "iter_matrices": "worst = max(float(m['K_F'][:, 5, 5].max()) for _, m in ev.iter_matrices(poses))",
    "frequencies": "f = ev.frequencies(poses)",
}


def peak_rss(case: str, n: int) -> tuple[float, float]:
    """(baseline, peak) RSS in MiB of a fresh process running one memory case on n poses."""
    code = RSS_SNIPPET.format(n=n, body=MEMORY_CASES[case])
    res = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    base, peak = map(float, res.stdout.split()[-2:])
    return base, peak


def public_path(n: int, repeat: int, log) -> dict:
    """The public path against the raw fused kernel (one thread), 1 vs all threads,
    against the per-pose loop; memory of Evaluator.matrices, in one run (ratios from it)."""
    import eigentwist
    from eigentwist.runtime.threads import available_cores

    evs = {t: eigentwist.load("heli4", backend="c", threads=t) for t in (1, available_cores())}
    ev1, ck = evs[1], evs[1].kernels
    ev_np = eigentwist.load("heli4", backend="numpy")
    poses = poses_for(ev1.robot, n)
    x, y, z = (np.ascontiguousarray(poses[:, k]) for k in range(3))
    params = ev1.parameter_values(n, "paper")
    rows = {
        "raw_1": (
            "raw fused kernel, frequencies only, no checks (`CKernels.fused`), 1 thread",
            lambda: ck.fused(x, y, z, params, matrices=(), model="flexible"),
        ),
        "raw_all": (
            f"raw fused kernel, {available_cores()} threads",
            lambda: ck.fused(x, y, z, params, matrices=(), model="flexible", threads=available_cores()),
        ),
        "public_1": (
            "`Evaluator.frequencies` (validated: inputs, reachability, lever, stability), 1 thread",
            lambda: ev1.frequencies(poses),
        ),
        "public_all": (
            f"`Evaluator.frequencies`, default threads ({available_cores()})",
            lambda: evs[available_cores()].frequencies(poses),
        ),
        "modes_1": ("`Evaluator.modes` with eigentwists, 1 thread", lambda: ev1.modes(poses)),
        "modes_all": (
            f"`Evaluator.modes` with eigentwists, {available_cores()} threads",
            lambda: evs[available_cores()].modes(poses),
        ),
        "matrices_1": ("`Evaluator.matrices` (M, K_R, K_F), 1 thread", lambda: ev1.matrices(poses)),
        "numpy_public": ("`Evaluator.frequencies`, NumPy backend", lambda: ev_np.frequencies(poses)),
    }
    rates: dict = {k: [] for k in rows}
    cpu: dict = {k: [] for k in rows}
    load = [os.getloadavg()[0]]
    for r in range(repeat):  # interleaved, so slow phases of a shared machine hit all rows
        for key, (_, fn) in rows.items():
            if key == "numpy_public" and r > 0:
                continue
            t0, c0 = time.perf_counter(), time.process_time()
            fn()
            t1, c1 = time.perf_counter(), time.process_time()
            rates[key].append(n / (t1 - t0))
            cpu[key].append(n / (c1 - c0))  # poses per CPU-second of this process (all its threads)
            log(f"[bench] public N={n} {key}: {rates[key][-1]:.3g} poses/s, {cpu[key][-1]:.3g} per CPU-s")
        load.append(os.getloadavg()[0])
    ref = pipelines.per_pose(ev1.defaults)
    m_pp = 2000
    _, _, t_pp = ref.timed(poses[:m_pp])
    out = dict(
        n=n,
        labels={k: v[0] for k, v in rows.items()},
        rates=rates,
        cpu_rates=cpu,
        loadavg=load,
        best={k: max(v) for k, v in rates.items()},
        per_pose_per_s=m_pp / t_pp,
        per_pose_n=m_pp,
    )
    log("[bench] peak RSS (fresh processes)")
    out["rss_mb"] = {case: peak_rss(case, n) for case in MEMORY_CASES}
    tracemalloc.start()
    for _, m in ev1.iter_matrices(poses):
        pass
    out["iter_matrices_traced_mb"] = tracemalloc.get_traced_memory()[1] / 2**20
    tracemalloc.stop()
    return out


def public_report(out: dict) -> str:
    b, pp = out["best"], out["per_pose_per_s"]
    lines = [
        f"## Public path at N = {out['n']:.0e} (best of {len(out['rates']['raw_1'])}, poses/s)",
        "",
        "| pipeline | poses/s | time / raw kernel's (1 thread) | vs per-pose loop |",
        "|---|---|---|---|",
    ]
    for key, label in out["labels"].items():
        lines.append(f"| {label} | {b[key]:.3g} | {b['raw_1'] / b[key]:.2f} | {b[key] / pp:.0f}× |")
    lines += [
        f"| per-pose NumPy loop (reference_loop.py, {out['per_pose_n']} poses) | {pp:.3g} | | 1× |",
        "",
        f"Threads: raw kernel {b['raw_all'] / b['raw_1']:.2f}×, public path {b['public_all'] / b['public_1']:.2f}× "
        "the one-thread rate.",
        "",
        "| memory case (N poses) | baseline RSS | peak RSS | added |",
        "|---|---|---|---|",
    ]
    for case, (base, peak) in out["rss_mb"].items():
        lines.append(f"| {case} | {base:.0f} MiB | {peak:.0f} MiB | {peak - base:.0f} MiB |")
    lines.append(f"\n`iter_matrices` (default chunk) traced peak: {out['iter_matrices_traced_mb']:.1f} MiB.")
    lines.append(f"\nLoad average (1 min) during the run: {', '.join(f'{v:.1f}' for v in out['loadavg'])}.")
    lines.append("\nAll rates per run: " + json.dumps({k: [round(v) for v in vs] for k, vs in out["rates"].items()}))
    return "\n".join(lines)


# ------------------------------------------------------------------ main
def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="N = 1e3, 1e4 only")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per measurement (best is kept)")
    ap.add_argument("--json", type=Path, help="also write the results here")
    ap.add_argument("--no-pin", action="store_true", help="do not pin the process to one CPU")
    ap.add_argument(
        "--public",
        action="store_true",
        help="only the public-path rows: Evaluator vs raw kernel, 1 vs all threads, memory",
    )
    ap.add_argument("--n", type=int, default=1_000_000, help="poses for --public")
    args = ap.parse_args(argv)
    if args.public:  # every core: the thread rows need them (1-thread rows set threads=1)
        out = public_path(args.n, args.repeat, lambda *a: print(*a, file=sys.stderr, flush=True))
        print(public_report(out))
        if args.json:
            args.json.write_text(json.dumps(out, indent=1))
        return 0
    if not args.no_pin and hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})

    import eigentwist
    from eigentwist.runtime import load
    from eigentwist.runtime.c_kernels import load_c_kernels
    from eigentwist.symbolic import derive

    sizes = [1_000, 10_000] if args.quick else [1_000, 100_000, 1_000_000]
    per_pose_max = 1_000 if args.quick else 100_000
    log = lambda *a: print(*a, file=sys.stderr, flush=True)  # noqa: E731

    info = machine()
    log(f"[bench] machine: {info}")
    log("[bench] generation and compile times")
    gen = generation_times()
    ev = eigentwist.load("heli4", backend="numpy")
    t0 = time.perf_counter()
    ck = load_c_kernels("heli4", ev.module)
    load_s = time.perf_counter() - t0
    evc = load("heli4", backend="c", threads=1)
    params = ev.parameter_values(1, "paper")
    log("[bench] lambdify (expand + lambdify with cse=True)")
    lam = pipelines.lambdify_pipeline(derive(ev.robot), params)
    pipes = [
        pipelines.per_pose(ev.defaults),
        lam,
        pipelines.numpy_pipeline(ev.module, params),
        pipelines.c_pipeline(ck, params),
    ]
    extras = pipelines.extra_pipelines(ev, evc, ck, params)

    # agreement at N = 1e3 (every pipeline against the C library)
    check = poses_for(ev.robot, 1000, seed=1)
    ref_m, ref_f = pipes[3].matrices(check), pipes[3].frequencies(check)
    agreement = {}
    for p in pipes[:3]:
        m, f = p.matrices(check), p.frequencies(check)
        agreement[p.key] = max(float(np.abs(m[k] - ref_m[k]).max() / np.abs(ref_m[k]).max()) for k in ("M", "K_F"))
        agreement[p.key + "_freq"] = float(np.abs(f / ref_f - 1).max())
    for p in extras:
        agreement[p.key + "_freq"] = float(np.abs(p.frequencies(check) / ref_f - 1).max())
    log(f"[bench] max relative deviation from the C results: {agreement}")

    results = []
    for n in sizes:
        poses = poses_for(ev.robot, n)
        for p in pipes + extras:
            row = dict(pipeline=p.key, label=p.label, n=n)
            if p.key == "per_pose":
                if n > per_pose_max:
                    prev = next(r for r in results if r["pipeline"] == "per_pose" and r["n"] == per_pose_max)
                    row.update(mk_per_s=prev["mk_per_s"], e2e_per_s=prev["e2e_per_s"], extrapolated=True)
                    results.append(row)
                    continue
                log(f"[bench] {p.key} N={n} (one pass, matrices and eigen timed separately)")
                _, t_mk, t_e2e = p.timed(poses)
                row.update(mk_per_s=n / t_mk, e2e_per_s=n / t_e2e)
                if n == sizes[0]:
                    row.update(
                        mk_peak_mb=peak_bytes(p.matrices, poses) / 2**20,
                        e2e_peak_mb=peak_bytes(p.frequencies, poses) / 2**20,
                    )
            else:
                log(f"[bench] {p.key} N={n}")
                reps = args.repeat if n < 1_000_000 else max(1, args.repeat - 1)
                for kind, fn in (("mk", p.matrices), ("e2e", p.frequencies)):
                    if fn is None:
                        continue
                    fn(poses[: min(n, 2048)])  # warm-up
                    row[f"{kind}_per_s"] = n / best_time(fn, poses, reps)
                    row[f"{kind}_peak_mb"] = peak_bytes(fn, poses) / 2**20
            results.append(row)
    out = dict(
        machine=info,
        generation=gen,
        c_load_s=load_s,
        lambdify_setup=lam.setup,
        agreement=agreement,
        results=results,
        max_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        command=" ".join([Path(sys.executable).name, "benchmarks/run.py", *(argv or sys.argv[1:])]),
    )
    print(report(out))
    if args.json:
        args.json.write_text(json.dumps(out, indent=1))
    return 0


def _fmt_rate(v):
    return "—" if v is None else f"{v:.3g}"


def report(out: dict) -> str:
    """Markdown tables of the results (what benchmarks/README.md records)."""
    res = out["results"]
    sizes = sorted({r["n"] for r in res})
    base = {(r["n"]): r for r in res if r["pipeline"] == "per_pose"}
    lines = ["## Throughput (poses/s, one core) and ratio to the per-pose loop", ""]
    for kind, title in (
        ("mk", "M + K_F (from poses, IK included)"),
        ("e2e", "end to end: poses -> 6 natural frequencies"),
    ):
        lines += [
            f"### {title}",
            "",
            "| pipeline | " + " | ".join(f"N = {n:.0e}" for n in sizes) + " |",
            "|---|" + "---|" * len(sizes),
        ]
        for key in dict.fromkeys(r["pipeline"] for r in res):
            cells = []
            label = next(r["label"] for r in res if r["pipeline"] == key)
            for n in sizes:
                r = next((r for r in res if r["pipeline"] == key and r["n"] == n), None)
                v = r.get(f"{kind}_per_s") if r else None
                if v is None:
                    cells.append("—")
                    continue
                b = base[n][f"{kind}_per_s"]
                mark = " (extrap.)" if r.get("extrapolated") else ""
                cells.append(f"{v:.3g}{mark}" if key == "per_pose" else f"{v:.3g} ({v / b:.0f}×)")
            if any(c != "—" for c in cells):
                lines.append(f"| {label} | " + " | ".join(cells) + " |")
        lines.append("")
    lines += [
        "## Peak traced memory (MiB; tracemalloc, separate pass)",
        "",
        "| pipeline | kind | " + " | ".join(f"N = {n:.0e}" for n in sizes) + " |",
        "|---|---|" + "---|" * len(sizes),
    ]
    for key in dict.fromkeys(r["pipeline"] for r in res):
        for kind in ("mk", "e2e"):
            cells = []
            for n in sizes:
                r = next((r for r in res if r["pipeline"] == key and r["n"] == n), None)
                v = r.get(f"{kind}_peak_mb") if r else None
                cells.append("—" if v is None else f"{v:.1f}")
            if any(c != "—" for c in cells):
                lines.append(f"| {key} | {kind} | " + " | ".join(cells) + " |")
    g = out["generation"]
    lines += ["", "## Generation and compile times (s)", "", "| step | s |", "|---|---|"]
    lines += [f"| {k[:-2]} | {v:.2f} |" for k, v in g.items()]
    lines += [f"| C library load (compile or cache hit, first call) | {out['c_load_s']:.2f} |"]
    lines += [f"| lambdify: {k[:-2]} | {v:.1f} |" for k, v in out["lambdify_setup"].items()]
    lines += [
        "",
        "## Agreement at N = 1e3 (max relative deviation from the C results)",
        "",
        "| pipeline | deviation |",
        "|---|---|",
    ]
    lines += [f"| {k} | {v:.1e} |" for k, v in out["agreement"].items()]
    m = out["machine"]
    lines += [
        "",
        f"Process peak RSS: {out['max_rss_mb']:.0f} MiB.",
        "",
        f"Machine: {m['cpu']}, nproc {m['nproc']} (pinned to CPU {m['affinity']}), flags {m['flags']}; "
        f"{m['cc']}; {m['glibc']}; Python {m['python']}, NumPy {m['numpy']}, SciPy {m['scipy']}, "
        f"SymPy {m['sympy']}.",
        f"Command: `{out['command']}`.",
    ]
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
