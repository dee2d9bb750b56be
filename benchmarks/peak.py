"""Flops per pose of the generated C kernels, this CPU's double-precision peak, and the
fraction of it that the raw fused kernel and the public path reach (one thread), with the
public path's thread scaling.

    PYTHONPATH=. python benchmarks/peak.py [--n N] [--repeat R] [--threads-n N] [--transcendental F]

**Flops per pose** are counted from the checked-in C source
(``eigentwist/generated/<robot>_c.c``), not guessed: every ``#pragma omp simd`` pose loop
is one lane's straight-line program, and its statements are counted token by token
(:func:`count_flops`): a binary ``+ - * /`` is 1 flop, ``sqrt`` 1 (one instruction, as the
``fp_arith_inst_retired`` counters count it), ``fabs``, unary minus, comparisons and
selects 0 (both arms of a select are counted: the vectorised loop computes both), and a
libm/libmvec call (sin, cos, asin, acos, atan2, pow) ``--transcendental`` flops (default
20, about the polynomial and range reduction of a vector sin). An FMA is 2 flops, as it
is written (``a * b + c``). The fused pass of the raw kernel runs the inverse kinematics
block, the M/K block (``*_matrices_lever_block``), the Cholesky reduction, S Jacobi sweeps
and the sort; S, the sweeps actually taken per block of 64 poses (every lane runs every
sweep of its block), is read from a copy of the library built with a sweep counter (the
same source and flags plus one counter). The public path adds the pose checks
(``et_checks``) and the Hz conversion (``et_hz*``); its NumPy input handling (rotation
vector to matrix, validation) is not counted: the fraction is of useful kernel flops.

**Peak** of one core: the clock (``cpu MHz`` of ``/proc/cpuinfo``: in a KVM guest the
nominal clock the host reports, no turbo; also measured here with a chain of dependent
integer adds, 1 cycle each) times the double-precision flops per cycle of the vector width
the library was compiled to (counted from ``objdump -d`` of the loaded library: zmm =
AVX-512, 8 lanes; ymm = AVX2, 4 lanes) with two FMA units (2 x lanes x 2); the scalar
peak (2 FMA units x 2 = 4 flops/cycle) is printed too. A short FMA loop (16 independent
accumulators, the same ``-march=native``) measures what the core really sustains.

Poses/s are poses per CPU-second of this process (``time.process_time``, BLAS on one
thread), the best of R repetitions, each on **new** reachable poses of the workspace box
(:func:`gallery.fresh_batches`). Thread scaling: wall and CPU time with 1 and 2 threads
and the load average (the machine may be shared).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import ctypes  # noqa: E402
import re  # noqa: E402
import shutil  # noqa: E402
import subprocess  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import eigentwist  # noqa: E402
from eigentwist.runtime.c_kernels import CKernels, compile_and_load, source_path  # noqa: E402
from gallery import fresh_batches  # noqa: E402

ROBOTS = (("heli4", "paper"), ("hexapod", "none"), ("delta", "paper"))
CALLS = ("sqrt", "fabs", "sin", "cos", "asin", "acos", "atan2", "pow", "exp", "log")
INT_TARGETS = {"et_left", "unreachable", "singular"}
_TOKEN = re.compile(
    r"\s*(\d+\.\d*(?:[eE][-+]?\d+)?|\d+(?:[eE][-+]?\d+)?|[A-Za-z_]\w*|\+=|-=|\*=|/=|\|=|&=|==|!=|<=|>=|&&|\|\||\S)"
)
_LOOP = re.compile(r"#pragma omp simd[^\n]*\n\s*for \(int et_i = 0; et_i < (?:ET_BLOCK|et_nb); \+\+et_i\) \{\n")
_FUNC = re.compile(r"^(?:static )?(?:void|int|double) (\w+)\(", re.M)


# ---------------------------------------------------------------- flop count
def count_flops(body: str, transcendental: float) -> dict:
    """Flops of one lane of a pose loop's body (C statements): ``{"arith": +-*/ count,
    "div": divisions, "sqrt": square roots, "calls": transcendental calls, "flops": total}``."""
    out = {"arith": 0, "div": 0, "sqrt": 0, "calls": 0}
    for stmt in body.split(";"):
        toks = _TOKEN.findall(re.sub(r"\[[^\]]*\]", "", stmt))
        prev = None
        for k, t in enumerate(toks):
            if t in "+-*/" and len(t) == 1:
                if prev is not None and (prev == ")" or re.match(r"[\w.]", prev)):
                    out["arith"] += 1
                    out["div"] += t == "/"
            elif t in ("+=", "-=", "*=", "/=") and not (k and toks[k - 1] in INT_TARGETS):
                out["arith"] += 1
                out["div"] += t == "/="
            elif t in CALLS and k + 1 < len(toks) and toks[k + 1] == "(":
                if t == "sqrt":
                    out["sqrt"] += 1
                elif t != "fabs":
                    out["calls"] += 1
            prev = t
    out["flops"] = out["arith"] + out["sqrt"] + transcendental * out["calls"]
    return out


def loop_bodies(source: str) -> dict:
    """``{function name: body of its pose loop}`` of every ``#pragma omp simd`` loop."""
    heads = [(m.start(), m.group(1)) for m in _FUNC.finditer(source)]
    bodies = {}
    for m in _LOOP.finditer(source):
        name = [n for s, n in heads if s < m.start()][-1]
        depth, i = 1, m.end()
        while depth:
            depth += {"{": 1, "}": -1}.get(source[i], 0)
            i += 1
        bodies[name] = source[m.end() : i - 1]
    return bodies


def fused_parts(source: str) -> dict:
    """The block functions the fused pass calls: ``{"ik": name, "mk": name}``."""
    return {
        "ik": re.search(r"(\w+)_block\((?:nb, )?et_x_ik", source).group(1) + "_block",
        "mk": re.search(r"(\w+)_block\((?:nb, )?et_x_m\b", source).group(1) + "_block",
    }


# --------------------------------------------------------- sweeps actually taken
def counting_kernels(robot: str, source: str) -> tuple:
    """``(kernels, taken)``: the robot's C library built with a counter of Jacobi sweeps
    (all else the same) and a function returning the sweeps counted so far."""
    src = source.replace(
        "typedef double et_block[ET_BLOCK];",
        "typedef double et_block[ET_BLOCK];\nstatic long et_peak_sweeps = 0;\n"
        "long et_peak_sweeps_taken(void) { return et_peak_sweeps; }",
        1,
    )
    src = re.sub(r"if \(!(et_sweep\d+)\((et_nb, )?ap\)\)", r"if ((++et_peak_sweeps, !\1(\2ap)))", src)
    lib, sig, build = compile_and_load(robot, src)
    fn = lib.et_peak_sweeps_taken
    fn.restype = ctypes.c_long
    return CKernels(lib, sig, build), fn


# ------------------------------------------------------------------- the peak
PEAK_C = r"""
#include <immintrin.h>
#include <string.h>
/* 16 independent FMA chains (more than latency x 2 units), lane count of the type */
#define ET_16(X) X(0) X(1) X(2) X(3) X(4) X(5) X(6) X(7) X(8) X(9) X(10) X(11) X(12) X(13) X(14) X(15)
#define DECL(k) VEC a##k = SET((double)k);
#define STEP(k) a##k = FMA(a##k, x, y);
#define SUM(k) s = ADD(s, a##k);
#define BODY                                                        \
    ET_16(DECL) const VEC x = SET(0.999999), y = SET(1e-7);         \
    for (long i = 0; i < n; ++i) { ET_16(STEP) }                    \
    VEC s = SET(0.0); ET_16(SUM)                                    \
    double o[8], r = 0; memcpy(o, &s, sizeof s);                    \
    for (unsigned k = 0; k < sizeof s / 8; ++k) r += o[k];          \
    return r;

#ifdef __AVX512F__ /* a CPU without AVX-512 (an AVX2 one) has no zmm loop: et_fma_zmm gives 0 */
#define VEC __m512d
#define SET _mm512_set1_pd
#define FMA _mm512_fmadd_pd
#define ADD _mm512_add_pd
double et_fma_zmm(long n) { BODY }
#undef VEC
#undef SET
#undef FMA
#undef ADD
#else
double et_fma_zmm(long n) { (void)n; return 0.0; }
#endif
#define VEC __m256d
#define SET _mm256_set1_pd
#define FMA _mm256_fmadd_pd
#define ADD _mm256_add_pd
double et_fma_ymm(long n) { BODY }

/* 8 dependent register adds per iteration: 1 cycle each */
long et_add_chain(long n)
{
    long r = 0, one = 1;
    for (long i = 0; i < n; ++i)
        __asm__ volatile("add %1, %0\n\tadd %1, %0\n\tadd %1, %0\n\tadd %1, %0\n\t"
                         "add %1, %0\n\tadd %1, %0\n\tadd %1, %0\n\tadd %1, %0" : "+r"(r) : "r"(one));
    return r;
}
"""


def cpu_mhz() -> float:
    for line in open("/proc/cpuinfo"):
        if line.startswith("cpu MHz"):
            return float(line.split(":")[1])
    raise RuntimeError("no 'cpu MHz' in /proc/cpuinfo")


def model_name() -> str:
    for line in open("/proc/cpuinfo"):
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return "?"


def vector_width(library: Path) -> dict:
    """Packed-double arithmetic instructions of a library by register width (objdump)."""
    asm = subprocess.run(["objdump", "-d", "--no-show-raw-insn", str(library)], capture_output=True, text=True).stdout
    op = r"\bv(?:fn?m(?:add|sub)\d+|add|sub|mul|div|sqrt)"
    return {
        "zmm": len(re.findall(op + r"pd\s+.*%zmm", asm)),
        "ymm": len(re.findall(op + r"pd\s+.*%ymm", asm)),
        "xmm": len(re.findall(op + r"pd\s+.*%xmm", asm)),
        "scalar": len(re.findall(op + r"sd\s", asm)),
    }


def measured_peak(flags: list) -> dict:
    """Clock from a dependent add chain and sustained FMA flops/cycle (zmm and ymm), one thread."""
    cc = shutil.which("cc") or shutil.which("gcc")
    march = [f for f in flags if f.startswith("-march")]
    with tempfile.TemporaryDirectory() as d:
        src, lib = Path(d) / "peak.c", Path(d) / "peak.so"
        src.write_text(PEAK_C)
        subprocess.run([cc, "-O2", "-fPIC", "-shared", *march, "-o", str(lib), str(src)], check=True)
        so = ctypes.CDLL(str(lib))
    for f in ("et_fma_zmm", "et_fma_ymm"):
        getattr(so, f).restype = ctypes.c_double
        getattr(so, f).argtypes = [ctypes.c_long]
    so.et_add_chain.restype = ctypes.c_long
    so.et_add_chain.argtypes = [ctypes.c_long]

    def best(fn, n):
        t = float("inf")
        for _ in range(5):
            t0 = time.thread_time()
            fn(n)
            t = min(t, time.thread_time() - t0)
        return t

    n = 20_000_000
    hz = 8 * n / best(so.et_add_chain, n)
    m = 5_000_000
    zmm = 16 * 8 * 2 * m / best(so.et_fma_zmm, m) if so.et_fma_zmm(1) != 0.0 else float("nan")
    ymm = 16 * 4 * 2 * m / best(so.et_fma_ymm, m)
    return {"clock_hz": hz, "fma_zmm_flops": zmm, "fma_ymm_flops": ymm}


# ---------------------------------------------------------------- throughput
def cpu_rate(fn, batches, n: int) -> float:
    """Best poses per CPU-second of ``fn(batch)`` over the batches (``n`` new poses each)."""
    best = float("inf")
    for b in batches:
        t0 = time.process_time()
        fn(b)
        best = min(best, time.process_time() - t0)
    return n / best


def robot_figures(name: str, model: str, n: int, repeat: int, transcendental: float) -> dict:
    """Flop counts, sweeps taken and CPU rates of the raw kernel and the public path of one robot."""
    ev = eigentwist.load(name, backend="c", threads=1)
    ck = ev.kernels
    stiffness = ev.stiffness_model(model)
    spec = ck.signature["fused"]
    dim = spec.get("dims", ck.signature["eigh"]["dims"])[spec["models"].index(stiffness)]
    source = source_path(name).read_text()
    bodies = loop_bodies(source)
    parts = fused_parts(source)
    fl = {k: count_flops(bodies[v], transcendental) for k, v in parts.items()}
    for k in ("reduce", "sweep", "hz"):
        fl[k] = count_flops(bodies[f"et_{k}{dim}"], transcendental)
    fl["checks"] = count_flops(bodies["et_checks"], transcendental)

    box = np.array(ev.robot.workspace)
    batches = fresh_batches(ev, box, n, repeat + 1, model)
    params = ev.parameter_values(n, model)

    def raw_args(P):
        p = {**params, **ev.kernel_pose_inputs(P)}
        return P[:, 0].copy(), P[:, 1].copy(), P[:, 2].copy(), p

    # sweeps actually taken, on the first batch, from the counting copy of the library
    counting, taken = counting_kernels(name, source)
    x, y, z, p = raw_args(batches[0])
    before = taken()
    counting.fused(x, y, z, p, matrices=(), model=stiffness)
    sweeps = (taken() - before) / -(-n // ck.BLOCK)

    args = [raw_args(P) for P in batches]
    ck.fused(*args[-1][:3], args[-1][3], matrices=(), model=stiffness)  # warm
    raw = cpu_rate(lambda a: ck.fused(*a[:3], a[3], matrices=(), model=stiffness), args[:repeat], n)
    mk_only = cpu_rate(lambda a: ck.fused(*a[:3], a[3], matrices=(), model=None), args[:repeat], n)
    ev.frequencies(batches[-1][:64], model)
    public = cpu_rate(lambda P: ev.frequencies(P, model), batches[:repeat], n)

    pose_part = fl["ik"]["flops"] + fl["mk"]["flops"]
    eigen_part = fl["reduce"]["flops"] + sweeps * fl["sweep"]["flops"]  # the sort: selects only
    raw_flops = pose_part + eigen_part
    public_flops = raw_flops + fl["checks"]["flops"] + fl["hz"]["flops"]
    out = dict(
        robot=name,
        model=model,
        stiffness=stiffness,
        dim=dim,
        counts=fl,
        sweeps=sweeps,
        flops_pose_part=pose_part,
        flops_eigen=eigen_part,
        flops_raw=raw_flops,
        flops_public=public_flops,
        raw_rate=raw,
        mk_rate=mk_only,
        public_rate=public,
    )
    return out


def thread_scaling(name: str, model: str, n: int, repeat: int) -> dict:
    """Wall and CPU time of ``frequencies`` with 1 and 2 threads on new poses each time."""
    evs = {t: eigentwist.load(name, backend="c", threads=t) for t in (1, 2)}
    batches = fresh_batches(evs[1], np.array(evs[1].robot.workspace), n, 2 * repeat + 1, model, seed=1)
    evs[2].frequencies(batches.pop()[:256], model)
    res = {t: {"wall": float("inf"), "cpu": float("inf")} for t in evs}
    loads = [os.getloadavg()[0]]
    for r in range(repeat):  # interleaved, so a busy phase of a shared machine hits both
        for t, ev in evs.items():
            P = batches.pop()
            w0, c0 = time.perf_counter(), time.process_time()
            ev.frequencies(P, model)
            res[t]["wall"] = min(res[t]["wall"], time.perf_counter() - w0)
            res[t]["cpu"] = min(res[t]["cpu"], time.process_time() - c0)
        loads.append(os.getloadavg()[0])
    return {"n": n, "times": res, "loadavg": loads}


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=50_000, help="poses per batch")
    ap.add_argument("--repeat", type=int, default=3, help="batches of new poses; the best is kept")
    ap.add_argument("--threads-n", type=int, default=200_000, help="poses per call of the thread scaling")
    ap.add_argument("--transcendental", type=float, default=20.0, help="flops counted per sin/cos/asin/acos/atan2")
    ap.add_argument("--only", default="", help="comma-separated robot names (default: all)")
    args = ap.parse_args(argv)
    only = {s for s in args.only.split(",") if s}

    ev = eigentwist.load("heli4", backend="c", threads=1)
    build = ev.kernels.build
    widths = vector_width(build.path)
    lanes = 8 if widths["zmm"] else 4 if widths["ymm"] else 2 if widths["xmm"] else 1
    mhz = cpu_mhz()
    meas = measured_peak(build.flags)
    clock = meas["clock_hz"]
    per_cycle = 2 * lanes * 2  # two FMA units, `lanes` doubles, 2 flops an FMA
    peak = clock * per_cycle
    scalar = clock * 4
    sustained = meas["fma_zmm_flops" if lanes == 8 else "fma_ymm_flops"]
    print(f"CPU: {model_name()}; cpu MHz {mhz:.0f} (/proc/cpuinfo, nominal); measured clock {clock / 1e9:.2f} GHz")
    print(f"build flags: {' '.join(build.flags)}")
    print(f"packed-double arithmetic instructions in {build.path.name}: {widths}")
    print(
        f"DP peak per core: {per_cycle} flops/cycle ({lanes} lanes x 2 FMA units x 2) x {clock / 1e9:.2f} GHz = "
        f"{peak / 1e9:.1f} GFLOP/s (at the nominal {mhz / 1e3:.2f} GHz: {mhz * 1e6 * per_cycle / 1e9:.1f}); "
        f"scalar peak {scalar / 1e9:.1f} GFLOP/s (4 flops/cycle); the FMA loop sustains "
        + (f"{meas['fma_zmm_flops'] / 1e9:.1f} (zmm) and " if meas["fma_zmm_flops"] == meas["fma_zmm_flops"] else "")
        + f"{meas['fma_ymm_flops'] / 1e9:.1f} (ymm) GFLOP/s"
    )
    print(f"load average at start: {os.getloadavg()}", flush=True)
    rows = []
    for name, model in ROBOTS:
        if only and name not in only:
            continue
        r = robot_figures(name, model, args.n, args.repeat, args.transcendental)
        rows.append(r)
        c = r["counts"]
        print(
            f"\n{name} {model} ({r['stiffness']}, {r['dim']}x{r['dim']}): flops/pose IK {c['ik']['flops']:.0f}, "
            f"M/K {c['mk']['flops']:.0f} ({c['mk']['div']} div, {c['mk']['sqrt']} sqrt, {c['mk']['calls']} calls), "
            f"reduce {c['reduce']['flops']:.0f}, sweep {c['sweep']['flops']:.0f} x {r['sweeps']:.2f} sweeps "
            f"({c['sweep']['div']} div, {c['sweep']['sqrt']} sqrt each), checks {c['checks']['flops']:.0f}, "
            f"Hz {c['hz']['flops']:.0f}"
        )
        for label, rate, flops in (
            ("raw fused kernel (CKernels.fused)", r["raw_rate"], r["flops_raw"]),
            ("  of which IK + M/K only (model=None)", r["mk_rate"], r["flops_pose_part"]),
            ("public path (Evaluator.frequencies)", r["public_rate"], r["flops_public"]),
        ):
            g = rate * flops
            print(
                f"  {label:40s} {rate:12,.0f} poses/s x {flops:6.0f} flops = {g / 1e9:5.2f} GFLOP/s: "
                f"{g / peak:6.1%} of peak ({g / sustained:6.1%} of the FMA loop's, {g / scalar:6.1%} of scalar)"
            )
        t_mk = 1 / r["mk_rate"]
        t_eig = 1 / r["raw_rate"] - t_mk
        print(
            f"  time split of the raw kernel: IK + M/K {t_mk * 1e9:.0f} ns/pose "
            f"({r['flops_pose_part'] / t_mk / 1e9:.2f} GFLOP/s), eigen-solve {t_eig * 1e9:.0f} ns/pose "
            f"({r['flops_eigen'] / t_eig / 1e9:.2f} GFLOP/s)"
        )
    for name, model in (("hexapod", "none"), ("heli4", "paper")):
        if only and name not in only:
            continue
        s = thread_scaling(name, model, args.threads_n, args.repeat)
        t1, t2 = s["times"][1], s["times"][2]
        print(
            f"\nthreads, {name} {model}, {s['n']} poses/call: 1 thread {s['n'] / t1['wall']:,.0f} poses/s wall "
            f"({s['n'] / t1['cpu']:,.0f} per CPU-s); 2 threads {s['n'] / t2['wall']:,.0f} wall "
            f"({s['n'] / t2['cpu']:,.0f} per CPU-s); wall speed-up {t1['wall'] / t2['wall']:.2f}x; "
            f"load average {', '.join(f'{v:.1f}' for v in s['loadavg'])}",
            flush=True,
        )


if __name__ == "__main__":
    main()
