"""Names of the weight inputs of the reverse-mode sensitivity kernel.

The kernel (:mod:`eigentwist.codegen.adjoint`) takes the weights of ``Σ w · M + w · K`` as
inputs by name; the derivation that writes it and the runtime that fills them (without
SymPy's derivation loaded) agree on the names here.
"""

from __future__ import annotations

__all__ = ["weight_name"]


def weight_name(matrix: str, i: int, j: int) -> str:
    """The input holding the weight of entry (i, j), i ≤ j, of ``matrix`` ("M" or "K"):
    W_ii on the diagonal and W_ij + W_ji above it (each upper entry stands for both)."""
    return f"w_{matrix}_{i}_{j}"
