"""Input normalisation shared by the solvers (dense/sparse matrices, vectors, guesses)."""

from __future__ import annotations

import sys
from typing import Any

import numpy as np

__all__ = ["is_sparse", "as_dense", "as_vector", "as_mask", "bordered"]


def is_sparse(x: Any) -> bool:
    """True for any scipy.sparse matrix or array (without importing scipy: when it has not
    been imported, nothing can be one)."""
    sparse = sys.modules.get("scipy.sparse")
    return sparse is not None and sparse.issparse(x)


def as_dense(x: Any, shape: tuple[int, int] | None = None, name: str = "matrix") -> np.ndarray:
    """A C-contiguous float64 2-D copy-free-if-possible view of ``x`` (sparse is densified)."""
    if is_sparse(x):
        arr = np.asarray(x.toarray(), dtype=float)
    else:
        arr = np.asarray(x, dtype=float)
    if arr.ndim == 0 and shape is not None and shape[0] * shape[1] == 1:
        arr = arr.reshape(1, 1)
    if shape is not None:
        if arr.size == 0 and shape[0] * shape[1] == 0:
            arr = arr.reshape(shape)
        if arr.shape != shape:
            raise ValueError(f"{name} has shape {arr.shape}, expected {shape}")
    if arr.ndim != 2:
        raise ValueError(f"{name} must be 2-D, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or inf")
    return np.ascontiguousarray(arr)


def as_vector(x: Any, size: int | None = None, name: str = "vector") -> np.ndarray:
    """A 1-D float64 array; checks length and finiteness."""
    arr = np.asarray(x, dtype=float).reshape(-1)
    if size is not None and arr.shape[0] != size:
        raise ValueError(f"{name} has length {arr.shape[0]}, expected {size}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} contains NaN or inf")
    return arr


def as_mask(guess: Any, m: int) -> np.ndarray:
    """Boolean mask of length ``m`` from a mask or an index array (``None`` not allowed)."""
    g = np.asarray(guess)
    if g.dtype == bool:
        g = g.reshape(-1)
        if g.shape[0] != m:
            raise ValueError(f"guess mask has length {g.shape[0]}, expected {m}")
        return g
    idx = g.reshape(-1)
    if idx.size and not np.issubdtype(idx.dtype, np.integer):
        raise ValueError("guess must be a boolean mask or an integer index array")
    mask = np.zeros(m, dtype=bool)
    if idx.size:
        if idx.min() < -m or idx.max() >= m:
            raise ValueError(f"guess index out of range for {m} pairs")
        mask[idx] = True
    return mask


def bordered(A: Any, C: Any, D: Any, B: Any,
             dense_limit: int | None = None) -> tuple[np.ndarray | None, Any, int, int, bool]:
    """Check block shapes and build ``K = [[A, C], [D, B]]``.

    Args:
        dense_limit: with sparse input of more than this many rows, no dense copy is made
            (``K_dense`` is ``None``): 50,000 unknowns would take 20 GB.

    Returns:
        ``(K_dense, K_sparse_or_None, n, m, input_was_sparse)``.
    """
    blocks = [A, C, D, B]
    any_sparse = any(is_sparse(b) for b in blocks)
    shapes = []
    for blk in blocks:
        if is_sparse(blk):
            shapes.append(blk.shape)
        else:
            arr = np.asarray(blk, dtype=float)
            shapes.append(arr.shape if arr.ndim == 2 else None)
    n = shapes[0][0] if shapes[0] is not None else None
    m = shapes[3][0] if shapes[3] is not None else None
    if n is None or m is None:
        raise ValueError("A and B must be 2-D")
    Ad = as_dense(A, (n, n), "A") if not is_sparse(A) else None
    Cd = as_dense(C, (n, m), "C") if not is_sparse(C) else None
    Dd = as_dense(D, (m, n), "D") if not is_sparse(D) else None
    Bd = as_dense(B, (m, m), "B") if not is_sparse(B) else None
    exp = {"A": (n, n), "C": (n, m), "D": (m, n), "B": (m, m)}
    for name, blk in zip("ACDB", blocks, strict=True):
        if is_sparse(blk) and blk.shape != exp[name]:
            raise ValueError(f"{name} has shape {blk.shape}, expected {exp[name]}")
    Ks = None
    if any_sparse:
        import scipy.sparse as sp

        Ks = (
            sp.block_array(
                [
                    [
                        sp.csr_array(b) if is_sparse(b) else sp.csr_array(d)
                        for b, d in ((A, Ad), (C, Cd))
                    ],
                    [
                        sp.csr_array(b) if is_sparse(b) else sp.csr_array(d)
                        for b, d in ((D, Dd), (B, Bd))
                    ],
                ],
                format="csc",
            )
            if n + m > 0
            else None
        )
        if Ks is not None and dense_limit is not None and n + m > dense_limit:
            K = None
        else:
            K = as_dense(Ks, (n + m, n + m), "K") if Ks is not None else np.zeros((0, 0))
    else:
        K = np.empty((n + m, n + m))
        K[:n, :n] = Ad
        K[:n, n:] = Cd
        K[n:, :n] = Dd
        K[n:, n:] = Bd
    return K, Ks, n, m, any_sparse
