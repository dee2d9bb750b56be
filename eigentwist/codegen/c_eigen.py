"""Straight-line C statements of a batched symmetric-definite eigen-solver.

Solves ``K v = lambda M v`` (Eq. 7, ``lambda = omega^2``) for small dense n x n pairs,
one pose per SIMD lane:

1. Cholesky ``M = L L^T`` and the reduction ``A = L^-1 K L^-T`` (:func:`reduce_lines`);
2. cyclic Jacobi sweeps on ``A`` in row order, optionally accumulating the rotations
   ``W`` (:func:`sweep_lines`); the caller repeats sweeps until the off-diagonal part
   is negligible for every pose of a block;
3. an odd-even transposition sort of the eigenvalues (ascending) and, with vectors,
   the back-transform ``V = L^-T W`` (M-orthonormal columns) (:func:`finish_lines`).

Every index is a compile-time constant, so the C compiler keeps the matrices in
registers and vectorises the loop over poses. The functions return lists of C
statements (no I/O); the template ``c/eigen.c.jinja`` wraps them in functions.
Symmetric matrices are stored as their upper triangle in row-major order
(:func:`upper`), the Cholesky factor as its lower triangle (:func:`lower`).
"""

from __future__ import annotations

from ..errors import DescriptionError

__all__ = ["upper", "lower", "reduce_lines", "sweep_lines", "finish_lines", "sort_pairs"]


def upper(n: int) -> list[tuple[int, int]]:
    """``(i, j)`` with ``i <= j`` in row-major order: the storage order of symmetric matrices."""
    return [(i, j) for i in range(n) for j in range(i, n)]


def lower(n: int) -> list[tuple[int, int]]:
    """``(i, j)`` with ``i >= j`` in row-major order: the storage order of the Cholesky factor."""
    return [(i, j) for i in range(n) for j in range(i + 1)]


def _check(n: int) -> None:
    if not 1 <= n <= 9:
        raise DescriptionError(f"eigen-solver dimension {n}: expected 1 to 9 (names use one digit per index)")


def _a(i: int, j: int) -> str:
    return f"a{min(i, j)}{max(i, j)}"


def _sum(terms: list[str]) -> str:
    return " - ".join(terms)


def reduce_lines(n: int) -> tuple[list[str], list[str]]:
    """Load ``M``, ``K`` (upper triangles), factor ``M = L L^T``, form ``A = L^-1 K L^-T``.

    Returns ``(pointers, body)``: pointer declarations hoisted out of the pose loop and
    the loop body. Reads ``et_mp[k]``, ``et_kp[k]`` (k over :func:`upper`), writes
    ``et_lp[k]`` (k over :func:`lower`) and ``et_ap[k]`` (upper). A matrix M that is not
    positive definite gives NaN (square root of a negative number).
    """
    _check(n)
    pointers = [f"const double *ET_RESTRICT mp{k} = et_mp[{k}];" for k in range(len(upper(n)))]
    pointers += [f"const double *ET_RESTRICT kp{k} = et_kp[{k}];" for k in range(len(upper(n)))]
    pointers += [f"double *ET_RESTRICT lp{k} = et_lp[{k}];" for k in range(len(lower(n)))]
    pointers += [f"double *ET_RESTRICT ap{k} = et_ap[{k}];" for k in range(len(upper(n)))]
    lines = []
    for k, (i, j) in enumerate(upper(n)):
        lines.append(f"const double m{i}{j} = mp{k}[et_i];")
        lines.append(f"const double k{i}{j} = kp{k}[et_i];")
    mij = lambda i, j: f"m{min(i, j)}{max(i, j)}"  # noqa: E731
    kij = lambda i, j: f"k{min(i, j)}{max(i, j)}"  # noqa: E731
    for j in range(n):  # Cholesky, column by column
        terms = [mij(j, j)] + [f"l{j}{k} * l{j}{k}" for k in range(j)]
        lines.append(f"const double l{j}{j} = sqrt({_sum(terms)});")
        lines.append(f"const double il{j} = 1.0 / l{j}{j};")
        for i in range(j + 1, n):
            terms = [mij(j, i)] + [f"l{i}{k} * l{j}{k}" for k in range(j)]
            lines.append(f"const double l{i}{j} = ({_sum(terms)}) * il{j};")
    for c in range(n):  # Y = L^-1 K (forward substitution)
        for r in range(n):
            terms = [kij(r, c)] + [f"l{r}{k} * y{k}{c}" for k in range(r)]
            lines.append(f"const double y{r}{c} = ({_sum(terms)}) * il{r};")
    for c in range(n):  # A = L^-1 Y^T, upper triangle
        for r in range(c + 1):
            terms = [f"y{c}{r}"] + [f"l{r}{k} * a{k}{c}" for k in range(r)]
            lines.append(f"const double a{r}{c} = ({_sum(terms)}) * il{r};")
    for k, (i, j) in enumerate(lower(n)):
        lines.append(f"lp{k}[et_i] = l{i}{j};")
    for k, (i, j) in enumerate(upper(n)):
        lines.append(f"ap{k}[et_i] = a{i}{j};")
    return pointers, lines


def _rotation(n: int, p: int, q: int, vectors: bool) -> list[str]:
    """One Jacobi rotation annihilating ``a_pq`` (Numerical Recipes' sign convention).

    ``t = tan(theta)`` is the smaller root of ``t^2 + 2 t (a_qq - a_pp) / (2 a_pq) - 1 = 0``,
    ``t = 2 sgn(d) a_pq / (|d| + r)`` with ``d = a_qq - a_pp``, ``r = sqrt(d^2 + 4 a_pq^2)``,
    written without division by a_pq so that ``a_pq = 0`` gives ``t = 0`` exactly. With
    ``den = |d| + r``, ``1 + t^2 = 2 r / den``, so one reciprocal square root
    ``u = 1 / sqrt(2 r den)`` gives ``c = den u``, ``s = 2 sgn(d) a_pq u`` and
    ``t = s / c = 2 r u s``: one division per rotation.
    """
    apq, app, aqq = _a(p, q), _a(p, p), _a(q, q)
    lines = [
        "{",
        f"    const double d = {aqq} - {app};",
        f"    const double r = sqrt(d * d + 4.0 * {apq} * {apq});",
        "    const double den = fabs(d) + r;",
        "    const double sd = d < 0.0 ? -1.0 : 1.0;",
        "    const double u = den > 0.0 ? 1.0 / sqrt(2.0 * r * den) : 0.0;",
        "    const double c = den > 0.0 ? den * u : 1.0;",
        f"    const double s = 2.0 * sd * {apq} * u;",
        "    const double t = 2.0 * r * u * s;",
        f"    {app} = {app} - t * {apq};",
        f"    {aqq} = {aqq} + t * {apq};",
        f"    {apq} = 0.0;",
    ]
    for r in range(n):
        if r in (p, q):
            continue
        arp, arq = _a(r, p), _a(r, q)
        lines.append(f"    {{ const double g = {arp}, h = {arq}; {arp} = c * g - s * h; {arq} = s * g + c * h; }}")
    if vectors:
        for r in range(n):
            lines.append(
                f"    {{ const double g = w{r}{p}, h = w{r}{q}; w{r}{p} = c * g - s * h; w{r}{q} = s * g + c * h; }}"
            )
    lines.append("}")
    return lines


def sweep_lines(n: int, vectors: bool) -> tuple[list[str], list[str]]:
    """One cyclic Jacobi sweep over all ``(p, q)``, p < q, of ``A`` (and ``W``).

    Returns ``(pointers, body)``. Loads ``et_ap`` (and ``et_wp``, n*n row-major), rotates,
    stores them back and adds 1 to ``et_left`` when the off-diagonal part is still above ``ET_JACOBI_TOL`` relative to
    the diagonal: ``sum a_pq^2 > ET_JACOBI_TOL * sum a_pp^2``.
    """
    _check(n)
    pointers = [f"double *ET_RESTRICT ap{k} = et_ap[{k}];" for k in range(len(upper(n)))]
    lines = [f"double a{i}{j} = ap{k}[et_i];" for k, (i, j) in enumerate(upper(n))]
    if vectors:
        pointers += [f"double *ET_RESTRICT wp{k} = et_wp[{k}];" for k in range(n * n)]
        lines += [f"double w{r}{c} = wp{r * n + c}[et_i];" for r in range(n) for c in range(n)]
    for p in range(n):
        for q in range(p + 1, n):
            lines += _rotation(n, p, q, vectors)
    off = " + ".join(f"a{i}{j} * a{i}{j}" for i, j in upper(n) if i != j) or "0.0"
    diag = " + ".join(f"a{i}{i} * a{i}{i}" for i in range(n))
    lines.append(f"et_left += ({off}) > ET_JACOBI_TOL * ({diag});")
    lines += [f"ap{k}[et_i] = a{i}{j};" for k, (i, j) in enumerate(upper(n))]
    if vectors:
        lines += [f"wp{r * n + c}[et_i] = w{r}{c};" for r in range(n) for c in range(n)]
    return pointers, lines


def sort_pairs(n: int) -> list[tuple[int, int]]:
    """Compare-exchange pairs of an odd-even transposition sort of n values (n rounds)."""
    return [(j, j + 1) for r in range(n) for j in range(r % 2, n - 1, 2)]


def finish_lines(n: int, vectors: bool) -> tuple[list[str], list[str]]:
    """Sort the eigenvalues ascending, back-transform, and write the block outputs.

    Returns ``(pointers, body)``. Writes ``et_lam[j]`` = omega^2 in (rad/s)^2, or the frequency in Hz when
    ``et_hz`` is set (``sqrt(max(lambda, 0)) / (2 pi)``), and with vectors
    ``et_vp[r * n + c]``: the M-orthonormal eigenvector of mode c (``V = L^-T W``).
    """
    _check(n)
    diag = [k for k, (i, j) in enumerate(upper(n)) if i == j]
    pointers = [f"const double *ET_RESTRICT ap{k} = et_ap[{k}];" for k in diag]
    pointers += [f"double *ET_RESTRICT lo{j} = et_lam[{j}];" for j in range(n)]
    lines = [f"double lam{j} = ap{k}[et_i];" for j, k in enumerate(diag)]
    if vectors:
        pointers += [f"const double *ET_RESTRICT wp{k} = et_wp[{k}];" for k in range(n * n)]
        pointers += [f"const double *ET_RESTRICT lp{k} = et_lp[{k}];" for k in range(len(lower(n)))]
        pointers += [f"double *ET_RESTRICT vo{k} = et_vp[{k}];" for k in range(n * n)]
        lines += [f"double w{r}{c} = wp{r * n + c}[et_i];" for r in range(n) for c in range(n)]
    for j, k in sort_pairs(n):
        lines.append("{")
        lines.append(f"    const int sw = lam{j} > lam{k};")
        lines.append(f"    const double g = lam{j}, h = lam{k};")
        lines.append(f"    lam{j} = sw ? h : g;")
        lines.append(f"    lam{k} = sw ? g : h;")
        if vectors:
            for r in range(n):
                lines.append(
                    f"    {{ const double gw = w{r}{j}, hw = w{r}{k}; "
                    f"w{r}{j} = sw ? hw : gw; w{r}{k} = sw ? gw : hw; }}"
                )
        lines.append("}")
    for j in range(n):
        lines.append(f"lo{j}[et_i] = et_hz ? sqrt(lam{j} > 0.0 ? lam{j} : 0.0) * ET_INV_TWO_PI : lam{j};")
    if vectors:
        for k, (i, j) in enumerate(lower(n)):
            lines.append(f"const double l{i}{j} = lp{k}[et_i];")
        for c in range(n):  # solve L^T v = w, bottom up
            for r in reversed(range(n)):
                terms = [f"w{r}{c}"] + [f"l{k}{r} * v{k}{c}" for k in range(r + 1, n)]
                lines.append(f"const double v{r}{c} = ({_sum(terms)}) / l{r}{r};")
        lines += [f"vo{r * n + c}[et_i] = v{r}{c};" for r in range(n) for c in range(n)]
    return pointers, lines
