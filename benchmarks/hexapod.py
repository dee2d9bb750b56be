"""Figures of issue 15: the hexapod's frequencies, generation time, C throughput (one core).

    PYTHONPATH=. python benchmarks/hexapod.py [N]

Derives the hexapod from its joint lists, runs the code generator's CSE on M and K_R,
prints the CSE'd program as one C function, compiles it with ``cc -O2`` beside a 6x6
generalised eigensolver (Cholesky + cyclic Jacobi), and times poses -> six frequencies
on one core. (The hexapod is not in the generated backends yet: this is a standalone
measurement of what they would run.)
"""
from __future__ import annotations

import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import sympy as sp

from eigentwist.codegen.kernel import Output, build_kernel
from eigentwist.robots import hexapod
from eigentwist.runtime.chain import ChainEvaluator
from eigentwist.symbolic.chain import POSE6, ROTATION, derive_chain

HOME = [0.0, 0.0, 0.80, 0.0, 0.0, 0.0]
TILTED = [0.0, 0.0, 0.80, 0.10, 0.0, 0.0]

EIGEN_C = r"""
static int eig6(const double *K, const double *M, double *freq)
{   /* frequencies (Hz) of K v = w^2 M v, 6x6 row-major: M = L L^T, A = L^-1 K L^-T, Jacobi */
    double L[36] = {0}, A[36], B[36];
    for (int i = 0; i < 6; ++i)
        for (int j = 0; j <= i; ++j) {
            double s = M[6 * i + j];
            for (int k = 0; k < j; ++k) s -= L[6 * i + k] * L[6 * j + k];
            if (i == j) { if (s <= 0) return -1; L[6 * i + i] = sqrt(s); }
            else L[6 * i + j] = s / L[6 * j + j];
        }
    for (int c = 0; c < 6; ++c)            /* B = L^-1 K */
        for (int i = 0; i < 6; ++i) {
            double s = K[6 * i + c];
            for (int k = 0; k < i; ++k) s -= L[6 * i + k] * B[6 * k + c];
            B[6 * i + c] = s / L[6 * i + i];
        }
    for (int r = 0; r < 6; ++r)            /* A = B L^-T */
        for (int i = 0; i < 6; ++i) {
            double s = B[6 * r + i];
            for (int k = 0; k < i; ++k) s -= A[6 * r + k] * L[6 * i + k];
            A[6 * r + i] = s / L[6 * i + i];
        }
    for (int sweep = 0; sweep < 30; ++sweep) {
        double off = 0, tot = 0;
        for (int i = 0; i < 6; ++i) for (int j = 0; j < 6; ++j) { double a = A[6*i+j] * A[6*i+j]; tot += a; if (i != j) off += a; }
        if (off <= 1e-30 * tot) break;
        for (int p = 0; p < 5; ++p)
            for (int q = p + 1; q < 6; ++q) {
                double apq = A[6 * p + q];
                if (apq == 0) continue;
                double th = (A[6 * q + q] - A[6 * p + p]) / (2 * apq);
                double t = (th >= 0 ? 1 : -1) / (fabs(th) + sqrt(th * th + 1)), c = 1 / sqrt(t * t + 1), s = t * c;
                for (int k = 0; k < 6; ++k) {
                    double akp = A[6 * k + p], akq = A[6 * k + q];
                    A[6 * k + p] = c * akp - s * akq; A[6 * k + q] = s * akp + c * akq;
                }
                for (int k = 0; k < 6; ++k) {
                    double apk = A[6 * p + k], aqk = A[6 * q + k];
                    A[6 * p + k] = c * apk - s * aqk; A[6 * q + k] = s * apk + c * aqk;
                }
            }
    }
    for (int i = 0; i < 6; ++i) freq[i] = sqrt(fmax(A[7 * i], 0)) / (2 * M_PI);
    for (int i = 1; i < 6; ++i) for (int j = i; j > 0 && freq[j - 1] > freq[j]; --j) { double t = freq[j]; freq[j] = freq[j - 1]; freq[j - 1] = t; }
    return 0;
}
"""


def c_source(kernel, values: dict) -> str:
    ins = kernel.input_names
    lines = ["#define _DEFAULT_SOURCE", "#include <math.h>", "#include <stdio.h>", "#include <stdlib.h>",
             "#include <time.h>", EIGEN_C, "static void matrices(const double *in, double *out) {"]
    lines += [f"    const double {n} = in[{i}];" for i, n in enumerate(ins)]
    for item in kernel.body:
        if item[0] == "let":
            lines.append(f"    const double {item[1].name} = {sp.ccode(item[2])};")
        else:
            out, (i, j), e = item[1], item[2], item[3]
            base = 0 if out.name == "M" else 36
            lines.append(f"    out[{base + 6 * i + j}] = out[{base + 6 * j + i}] = {sp.ccode(e)};")
    lines.append("}")
    fill = "\n".join(f"    in[{i}] = {float(values.get(n, 0.0))!r};" for i, n in enumerate(ins))
    rot = {f"R_{i}{j}": k for k, (i, j) in enumerate((i, j) for i in range(3) for j in range(3))}
    lines.append(f"""
static void rodrigues(const double *r, double *R) {{
    double t2 = r[0]*r[0] + r[1]*r[1] + r[2]*r[2], t = sqrt(t2);
    double a = t2 < 1e-12 ? 1 - t2 / 6 : sin(t) / t, b = t2 < 1e-12 ? 0.5 - t2 / 24 : (1 - cos(t)) / t2;
    double K[9] = {{0, -r[2], r[1], r[2], 0, -r[0], -r[1], r[0], 0}};
    for (int i = 0; i < 3; ++i) for (int j = 0; j < 3; ++j) {{
        double kk = 0; for (int k = 0; k < 3; ++k) kk += K[3*i+k] * K[3*k+j];
        R[3*i+j] = (i == j) + a * K[3*i+j] + b * kk; }}
}}

int main(int argc, char **argv) {{
    int n = atoi(argv[1]);
    double in[{len(ins)}], out[72], f[6], R[9], acc = 0;
{fill}
    double pose[6] = {{{', '.join(map(str, TILTED))}}};
    struct timespec t0, t1; clock_gettime(CLOCK_MONOTONIC, &t0);
    for (int k = 0; k < n; ++k) {{
        pose[0] = 0.05 * ((k % 1000) / 1000.0 - 0.5); pose[5] = 0.2 * ((k % 997) / 997.0 - 0.5);
        in[{ins.index('x')}] = pose[0]; in[{ins.index('y')}] = pose[1]; in[{ins.index('z')}] = pose[2];
        rodrigues(pose + 3, R);
""" + "\n".join(f"        in[{ins.index(n)}] = R[{k}];" for n, k in rot.items() if n in ins) + f"""
        matrices(in, out);
        if (eig6(out + 36, out, f)) return 1;
        acc += f[0];
    }}
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double s = (t1.tv_sec - t0.tv_sec) + 1e-9 * (t1.tv_nsec - t0.tv_nsec);
    pose[0] = 0; pose[5] = 0; in[{ins.index('x')}] = 0; rodrigues(pose + 3, R);   /* back at TILTED */
""" + "\n".join(f"    in[{ins.index(n)}] = R[{k}];" for n, k in rot.items() if n in ins) + """
    matrices(in, out); eig6(out + 36, out, f);
    printf("%.17g %.17g %.17g %.17g %.17g %.17g\\n", f[0], f[1], f[2], f[3], f[4], f[5]);
    printf("%d poses in %.3f s: %.0f poses/s to six frequencies, one core (checksum %.6g)\\n", n, s, n / s, acc);
    return 0;
}""")
    return "\n".join(lines) + "\n"


def main(n: int = 200_000) -> None:
    robot = hexapod.describe()
    t0 = time.perf_counter()
    model = derive_chain(robot)
    t1 = time.perf_counter()
    pose = list(POSE6) + [ROTATION[i, j] for i in range(3) for j in range(3)]
    params = [s.name for s in model.program.inputs if s not in pose]
    outs = [Output(k, sh, ex, symmetric=True) for k, (sh, ex) in model.outputs["matrices"].items()]
    kernel = build_kernel("matrices", "M and K_R of the hexapod", model.program, outs, pose, [], params)
    t2 = time.perf_counter()
    print(f"generation: derive {t1 - t0:.1f} s + CSE {t2 - t1:.1f} s = {t2 - t0:.1f} s ({len(kernel.body)} statements)")
    ev = ChainEvaluator(robot)
    np.set_printoptions(precision=2, suppress=True)
    for name, p in (("home", HOME), ("tilted, rot_x = 0.10 rad", TILTED)):
        print(f"{name:26s} {p}: {ev.frequencies(p)[0]} Hz")
    values = ev.values()
    with tempfile.TemporaryDirectory() as tmp:
        src, exe = Path(tmp) / "hexapod.c", Path(tmp) / "hexapod"
        src.write_text(c_source(kernel, values))
        subprocess.run(["cc", "-O2", "-o", str(exe), str(src), "-lm"], check=True)
        res = subprocess.run([str(exe), str(n)], check=True, capture_output=True, text=True).stdout.splitlines()
    tilted_c = np.array(res[0].split(), dtype=float)
    assert np.allclose(tilted_c, ev.frequencies(TILTED)[0], rtol=1e-9), (tilted_c, ev.frequencies(TILTED)[0])
    print(f"C at the tilted pose: {tilted_c} Hz (= NumPy to 1e-9)")
    print(res[1])


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 200_000)
