"""The stepping loop for the sparse (factorised) modes of large circuits.

A mode of a circuit with more than ``DENSE_MAP_LIMIT`` unknowns and pairs is kept
as a SuperLU factorisation of its bordered matrix (:class:`SparseModeMap`). Run
as Python around scipy (three sparse products, one SuperLU ``solve`` and a few
numpy temporaries per step), a 1000-section diode-RC ladder (2003 unknowns and
active pairs) cost ~180 µs per step, ~150 µs of it inside SuperLU's ``solve``
(its supernodal triangular solves are slow when the supernodes are tiny).

This module takes the mode apart into plain arrays (:class:`CompiledSparseMap`:
CSR matrices, the SuperLU factors ``L`` and ``U`` and their permutations) once,
with :func:`compile_sparse_map`, and runs the loop as scalar code compiled by
numba (:func:`run_compiled_sparse`). One step is then

* the right-hand side ``carry·y_k + S_next·f_{k+1} + S_now·f_k`` (CSR products),
  scattered straight into SuperLU's row order;
* a forward substitution with the unit lower triangle ``L`` and a back
  substitution with ``U``, then SuperLU's column permutation;
* the complementarity checks ``λ_α >= 0`` and ``W·x + e_w >= 0`` (CSR product,
  strict signs), and the free switches' controls (kept as CSR too);

so its cost is proportional to ``nnz(L) + nnz(U) + nnz(carry) + nnz(S_next) +
nnz(S_now) + nnz(W) + nnz(controls)`` plus the size, with no allocation per
step: ~10 µs per 1000 unknowns for the ladder. The triangular solves dominate;
they are bound by the latency of their chain of dependent operations (~7 ns per
row for a ladder), not by the number of operations.

SuperLU's convention (checked numerically by the tests): with
``Pr[perm_r[i], i] = 1`` and ``Pc[i, perm_c[i]] = 1``, ``Pr·A·Pc = L·U``. So
``A·x = b`` is solved by ``c[perm_r[i]] = b[i]``, ``L·U·z = c``,
``x[i] = z[perm_c[i]]``.

The results agree with SuperLU's own ``solve`` to rounding (~1e-15 relative on
the ladder; the tests compare the loop with a plain scipy one), not bit for bit:
SuperLU sums by supernodes, and the loop multiplies by the reciprocals of ``U``'s
pivots. ``use_compiled=False`` (or no numba) runs the same scalar loop in Python.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from circuitnsds.engine.dense_loop import STOP_END, STOP_LEFT_MODE, STOP_SCHEDULE, STOP_SWITCH
from circuitnsds.engine.step_system import ModeBlocks
from circuitnsds.jit import AVAILABLE, jit, python_version
from circuitnsds.solvers.linalg import factorise_sparse


@dataclass
class SparseModeMap:
    """The step map of one mode of a large circuit, kept factorised (sparse LU).

    Each step solves ``bordered · x = [carry·y_k + Sw f_{k+1} + Si f_k; -e_α]``: the
    cost grows with the number of non-zeros, not with the square of the size.
    :func:`compile_sparse_map` takes it apart into the arrays the loop runs on.
    """

    lu: object
    carry: object
    S_next: object
    S_now: object
    rhs_pairs: np.ndarray
    W: object
    e_w: np.ndarray
    active: np.ndarray
    n: int


class CompiledSparseMap(NamedTuple):
    """A :class:`SparseModeMap` as plain numpy arrays (a named tuple: the loop takes it as one
    argument).

    Every matrix is CSR: ``<name>_indptr`` (int64, rows + 1), ``<name>_indices``
    (int64 column indices, sorted within a row) and ``<name>_data`` (float64).
    With ``N = n + a`` unknowns (``n`` circuit unknowns, ``a`` active pairs):

    Attributes:
        carry: ``(n, n)``, the rows of the right-hand side multiplying ``y_k``
            (units as in the MLCS rows divided by ``h``: amperes per unit of ``y``).
        S_next, S_now: ``(n, number of sources)``, multiplying ``f_{k+1}`` and ``f_k``.
        W: ``(m - a, N)``; with ``e_w`` ``(m - a,)`` the inactive pairs' ``w = W·x + e_w``.
        L: ``(N, N)`` strictly lower part of SuperLU's unit lower factor (the unit
            diagonal is implied, not stored).
        U: ``(N, N)`` strictly upper part of SuperLU's upper factor; ``U_diag`` its
            diagonal ``(N,)`` and ``U_diag_inverse`` the reciprocals (what the back
            substitution uses: a multiplication instead of a division shortens the
            chain of dependent operations the solve is, ~25% faster).
        perm_r, perm_c: SuperLU's row and column permutations (int64): ``Pr·A·Pc = L·U``
            with ``Pr[perm_r[i], i] = 1`` and ``Pc[i, perm_c[i]] = 1``.
        rhs_pairs: ``(a,)``, the last ``a`` rows of every right-hand side (``-e_α``).
        active: ``(a,)`` int64, the active pairs (columns of ``current``).
        n: number of circuit unknowns (columns of ``y``).
    """

    carry_indptr: np.ndarray
    carry_indices: np.ndarray
    carry_data: np.ndarray
    S_next_indptr: np.ndarray
    S_next_indices: np.ndarray
    S_next_data: np.ndarray
    S_now_indptr: np.ndarray
    S_now_indices: np.ndarray
    S_now_data: np.ndarray
    W_indptr: np.ndarray
    W_indices: np.ndarray
    W_data: np.ndarray
    L_indptr: np.ndarray
    L_indices: np.ndarray
    L_data: np.ndarray
    U_indptr: np.ndarray
    U_indices: np.ndarray
    U_data: np.ndarray
    U_diag: np.ndarray
    U_diag_inverse: np.ndarray
    perm_r: np.ndarray
    perm_c: np.ndarray
    rhs_pairs: np.ndarray
    e_w: np.ndarray
    active: np.ndarray
    n: int

    @property
    def size(self) -> int:
        """``N = n + a``, the number of unknowns of each step's linear system."""
        return int(self.U_diag.size)

    @property
    def factor_nnz(self) -> int:
        """``nnz(L) + nnz(U)`` counting both diagonals (as scipy's ``lu.L.nnz + lu.U.nnz`` does
        once explicit zeros are dropped); the triangular solves cost about this many
        multiply-adds per step."""
        return int(self.L_data.size + self.U_data.size + 2 * self.U_diag.size)


def _csr_arrays(matrix: object, shape: tuple[int, int]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(indptr, indices, data)`` of ``matrix`` as canonical CSR (int64 indices, float64 data)."""
    import scipy.sparse as sp

    csr = sp.csr_matrix(matrix, dtype=np.float64)  # copies or converts csc/coo/dense alike
    if csr.shape != shape:
        raise ValueError(f"expected a {shape[0]}x{shape[1]} matrix, got {csr.shape[0]}x{csr.shape[1]}")
    csr.sum_duplicates()  # also sorts the indices
    return (np.ascontiguousarray(csr.indptr, dtype=np.int64),
            np.ascontiguousarray(csr.indices, dtype=np.int64),
            np.ascontiguousarray(csr.data, dtype=np.float64))


def compile_sparse_map(mode: SparseModeMap) -> CompiledSparseMap:
    """Take ``mode`` (its SuperLU factorisation and sparse matrices, csr or csc) apart
    into the arrays of a :class:`CompiledSparseMap`. ``mode`` is not modified."""
    n = int(mode.n)
    active = np.ascontiguousarray(mode.active, dtype=np.int64)
    size = n + active.size
    lu = mode.lu
    if tuple(lu.shape) != (size, size):
        raise ValueError(f"the factorisation is {lu.shape[0]}x{lu.shape[1]}, expected {size}x{size} "
                         f"({n} unknowns + {active.size} active pairs)")
    import scipy.sparse as sp

    L = sp.csr_matrix(lu.L, dtype=np.float64)
    U = sp.csr_matrix(lu.U, dtype=np.float64)
    if not np.array_equal(L.diagonal(), np.ones(size)):
        raise ValueError("SuperLU's L is expected to have a unit diagonal")
    if sp.triu(L, 1).nnz or sp.tril(U, -1).nnz:
        raise ValueError("SuperLU's L and U are expected to be lower and upper triangular")
    lower = sp.tril(L, -1, format="csr")
    upper = sp.triu(U, 1, format="csr")
    lower.eliminate_zeros()  # SuperLU's supernodes may store zeros: no work for them
    upper.eliminate_zeros()
    kstim = mode.S_next.shape[1]
    carry = _csr_arrays(mode.carry, (n, n))
    s_next = _csr_arrays(mode.S_next, (n, kstim))
    s_now = _csr_arrays(mode.S_now, (n, kstim))
    e_w = np.ascontiguousarray(mode.e_w, dtype=np.float64)
    W = _csr_arrays(mode.W, (e_w.size, size))
    lower_arrays = _csr_arrays(lower, (size, size))
    upper_arrays = _csr_arrays(upper, (size, size))
    rhs_pairs = np.ascontiguousarray(mode.rhs_pairs, dtype=np.float64)
    if rhs_pairs.shape != (active.size,):
        raise ValueError(f"rhs_pairs has shape {rhs_pairs.shape}, expected ({active.size},)")
    diagonal = np.ascontiguousarray(U.diagonal(), dtype=np.float64)
    if not (np.isfinite(diagonal).all() and (diagonal != 0.0).all()):
        raise ValueError("SuperLU's U has a zero or non-finite pivot")
    return CompiledSparseMap(
        *carry, *s_next, *s_now, *W, *lower_arrays, *upper_arrays,
        U_diag=diagonal, U_diag_inverse=1.0 / diagonal,
        perm_r=np.ascontiguousarray(lu.perm_r, dtype=np.int64),
        perm_c=np.ascontiguousarray(lu.perm_c, dtype=np.int64),
        rhs_pairs=rhs_pairs, e_w=e_w, active=active, n=n)


def sparse_mode_map(blocks: ModeBlocks, n: int) -> CompiledSparseMap | None:
    """The :class:`CompiledSparseMap` of a mode's step system (``n`` circuit unknowns);
    ``None`` when its bordered matrix is singular by the MLCP solver's test, or SuperLU
    leaves a zero or non-finite pivot (such a mode is left to the MLCP solver)."""
    # SuperLU with a minimum degree ordering on A + Aᵀ (the same fill as COLAMD on a ladder,
    # triangular solves ~1.5x faster)
    lu = factorise_sparse(blocks.bordered)
    if not lu.ok:
        return None
    mode = SparseModeMap(lu=lu.factors, carry=blocks.carry, S_next=blocks.S_next, S_now=blocks.S_now,
                         rhs_pairs=blocks.rhs_pairs, W=blocks.W, e_w=blocks.e_w, active=blocks.active, n=n)
    try:
        return compile_sparse_map(mode)
    except ValueError:
        return None


def _solve_factors(c, x, L_indptr, L_indices, L_data, U_indptr, U_indices, U_data, U_diag_inverse,
                   perm_c):
    """Solve ``L·U·z = c`` in place in ``c`` (already in SuperLU's row order), then
    ``x[i] = z[perm_c[i]]``. ``L`` has a unit diagonal (not stored), ``U`` the reciprocals
    of its diagonal in ``U_diag_inverse``; both CSR without diagonal entries."""
    size = c.shape[0]
    for i in range(size):  # forward: L unit lower
        acc = c[i]
        for p in range(L_indptr[i], L_indptr[i + 1]):
            acc -= L_data[p] * c[L_indices[p]]
        c[i] = acc
    for i in range(size - 1, -1, -1):  # back: U upper
        acc = c[i]
        for p in range(U_indptr[i], U_indptr[i + 1]):
            acc -= U_data[p] * c[U_indices[p]]
        c[i] = acc * U_diag_inverse[i]
    for i in range(size):
        x[i] = c[perm_c[i]]


class SparseControls(NamedTuple):
    """The state-controlled switches for the sparse loop: their controls as a CSR triple
    ``(switches, n)``, thresholds (V or A) and current states (closed = true)."""

    indptr: np.ndarray
    indices: np.ndarray
    data: np.ndarray
    on_threshold: np.ndarray
    off_threshold: np.ndarray
    switch_on: np.ndarray


def _run_sparse_loop(k0, k_end, y, current, F, step_class, schedule, cmap, free):
    """Step the factorised mode ``cmap`` (the fields of a :class:`CompiledSparseMap`) from
    ``k0``, watching the switches ``free`` (the fields of :class:`SparseControls`); returns
    ``(k, reason)`` as described in :func:`run_compiled_sparse` (``k`` the first grid point not computed).

    Writes ``y[k0+1 .. k]`` and the active columns of ``current[k0+1 .. k]``; nothing for a
    step that leaves the mode.
    """
    # plain tuples in the order of CompiledSparseMap and SparseControls (named tuples would be
    # typed by numba's slow path at every call, ~0.1 ms)
    (carry_indptr, carry_indices, carry_data, S_next_indptr, S_next_indices, S_next_data,
     S_now_indptr, S_now_indices, S_now_data, W_indptr, W_indices, W_data,
     L_indptr, L_indices, L_data, U_indptr, U_indices, U_data, U_diag, U_diag_inverse,
     perm_r, perm_c, rhs_pairs, e_w, active, _) = cmap
    controls_indptr, controls_indices, controls_data, on_threshold, off_threshold, switch_on = free
    n = y.shape[1]
    size = U_diag_inverse.shape[0]
    pairs = size - n
    nw = e_w.shape[0]
    ns = on_threshold.shape[0]
    c = np.empty(size)  # the right-hand side in SuperLU's row order, then z
    x = np.empty(size)  # [y_{k+1}; λ_α]
    k = k0
    while k < k_end:
        if k > k0 and (step_class[k] != step_class[k0] or schedule[k] != schedule[k0]):
            return k, STOP_SCHEDULE
        for i in range(n):
            # the three products summed in the order scipy's would be
            a = 0.0
            for p in range(carry_indptr[i], carry_indptr[i + 1]):
                a += carry_data[p] * y[k, carry_indices[p]]
            b = 0.0
            for p in range(S_next_indptr[i], S_next_indptr[i + 1]):
                b += S_next_data[p] * F[k + 1, S_next_indices[p]]
            d = 0.0
            for p in range(S_now_indptr[i], S_now_indptr[i + 1]):
                d += S_now_data[p] * F[k, S_now_indices[p]]
            c[perm_r[i]] = a + b + d
        for r in range(pairs):
            c[perm_r[n + r]] = rhs_pairs[r]
        _solve_factors(c, x, L_indptr, L_indices, L_data, U_indptr, U_indices, U_data, U_diag_inverse,
                       perm_c)
        for r in range(n, size):
            if x[r] < 0.0:
                return k, STOP_LEFT_MODE
        for r in range(nw):
            acc = 0.0
            for p in range(W_indptr[r], W_indptr[r + 1]):
                acc += W_data[p] * x[W_indices[p]]
            if acc + e_w[r] < 0.0:
                return k, STOP_LEFT_MODE
        for j in range(n):
            y[k + 1, j] = x[j]
        for r in range(pairs):
            current[k + 1, active[r]] = x[n + r]
        k += 1
        for s in range(ns):
            value = 0.0
            for p in range(controls_indptr[s], controls_indptr[s + 1]):
                value += controls_data[p] * y[k, controls_indices[p]]
            if switch_on[s]:
                if value < off_threshold[s]:
                    return k, STOP_SWITCH
            elif value > on_threshold[s]:
                return k, STOP_SWITCH
    return k, STOP_END


_solve_factors = jit(_solve_factors)
_compiled = jit(_run_sparse_loop)
_python_loop = python_version(_run_sparse_loop)  # Python all through, triangular solves included


def compiled() -> bool:
    """Whether :func:`run_compiled_sparse` runs compiled (numba installed)."""
    return AVAILABLE


def solve_compiled(cmap: CompiledSparseMap, rhs: np.ndarray) -> np.ndarray:
    """``A⁻¹·rhs`` from the stored factors (``A`` the mode's bordered matrix), as
    ``mode.lu.solve(rhs)`` computes it; for checks, the loop does this in place."""
    rhs = np.asarray(rhs, dtype=np.float64)
    if rhs.shape != (cmap.size,):
        raise ValueError(f"rhs has shape {rhs.shape}, expected ({cmap.size},)")
    c = np.empty(cmap.size)
    c[cmap.perm_r] = rhs
    x = np.empty(cmap.size)
    _solve_factors(c, x, cmap.L_indptr, cmap.L_indices, cmap.L_data, cmap.U_indptr, cmap.U_indices,
                   cmap.U_data, cmap.U_diag_inverse, cmap.perm_c)
    return x


_NO_CONTROLS = (np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0))
"""The CSR triple of no controls."""


def run_compiled_sparse(cmap: CompiledSparseMap, k0: int, k_end: int, y: np.ndarray, current: np.ndarray,
                        F: np.ndarray, step_class: np.ndarray, schedule: np.ndarray,
                        controls: np.ndarray, on_threshold: np.ndarray, off_threshold: np.ndarray,
                        switch_on: np.ndarray, use_compiled: bool = True) -> tuple[int, int]:
    """Apply one sparse mode from step ``k0`` until it is left; returns ``(k, reason)``.

    ``reason``: :data:`~circuitnsds.engine.dense_loop.STOP_LEFT_MODE` step ``k`` left the mode,
    ``STOP_SWITCH`` a state-controlled switch must change after step ``k - 1``,
    ``STOP_SCHEDULE`` the step class or scheduled switch state changes at ``k``,
    ``STOP_END`` ``k_end`` reached. Steps ``k0 .. k-1`` are
    done, ``y[k0+1 .. k]`` (float64, ``(grid points, n)``) and the active columns of
    ``current[k0+1 .. k]`` (the pair currents λ [A]) written. ``F`` holds the sources'
    values at every grid point, ``step_class`` and ``schedule`` one integer per step
    (the run stops where either differs from its value at ``k0``); ``controls``
    ``(switches, n)`` dense, the thresholds in the controls' units (V or A) and
    ``switch_on`` the free switches' states. ``controls`` is converted to CSR once
    per call, so the per-step cost is proportional to its non-zeros (a zero weight
    then ignores its unknown even when that is inf or NaN, where ``controls @ y``
    would give NaN; the caller stops on non-finite values anyway).

    ``y``, ``current`` and ``F`` are float64 arrays (C order), ``step_class`` and
    ``schedule`` integer arrays; other dtypes make numba compile another version.
    """
    controls = np.asarray(controls, dtype=np.float64).reshape(-1, y.shape[1])
    if controls.shape[0]:
        import scipy.sparse as sp

        controls_csr = sp.csr_matrix(controls)
        controls_csr.eliminate_zeros()
        controls_csr.sort_indices()
        csr = (controls_csr.indptr.astype(np.int64), controls_csr.indices.astype(np.int64), controls_csr.data)
    else:  # no state-controlled switch (the usual case): no scipy call on every entry
        csr = _NO_CONTROLS
    loop = _compiled if use_compiled and AVAILABLE else _python_loop
    free = SparseControls(*csr, np.asarray(on_threshold, dtype=np.float64),
                          np.asarray(off_threshold, dtype=np.float64), np.asarray(switch_on, dtype=np.bool_))
    k, reason = loop(int(k0), int(k_end), y, current, F, step_class, schedule, tuple(cmap), tuple(free))
    return int(k), int(reason)
