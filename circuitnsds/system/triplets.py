"""A sparse matrix as plain data: its non-zero entries as ``(row, column, value)`` triplets.

The MLCS holds its matrices this way (:class:`Triplets`) rather than as scipy.sparse
matrices, so that a small circuit can be built, stepped and written without importing
scipy (~0.25 s of every run's start-up: scipy's array-API layer imports ``numpy.f2py``,
``numpy.testing`` and ``numpy.ma``). The dense form (:meth:`Triplets.toarray`) serves small
systems; :meth:`Triplets.tocsr` / :meth:`Triplets.tocsc` hand large ones to scipy.sparse,
imported then.

The entries are canonical: sorted by row, then column, each position once. Stamps that
fall on one position are added one after another in the order they were stamped, and
:meth:`toarray` and :meth:`tocsr` hold the same numbers bit for bit.

Only what the package needs is offered: ``@`` with a vector or a matrix, the shape, the
dense and the scipy forms. Anything else (``*``, ``abs``, slicing) raises ``TypeError``
rather than meaning something else than it would for a scipy matrix or a numpy array.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import scipy.sparse as sp

__all__ = ["Triplets"]


@dataclass(frozen=True, eq=False)
class Triplets:
    """A ``shape[0] × shape[1]`` matrix whose entry ``(rows[i], cols[i])`` is ``values[i]``
    (every other entry zero). Build one with :meth:`from_stamps`; the arrays are read-only."""

    rows: np.ndarray
    cols: np.ndarray
    values: np.ndarray
    shape: tuple[int, int]

    @classmethod
    def from_stamps(cls, stamps: list[tuple[int, int, float]], shape: tuple[int, int]) -> Triplets:
        """The matrix that is the sum of ``stamps`` (``(row, column, value)``, repeats allowed)."""
        if not stamps:
            empty = np.zeros(0, dtype=np.int64)
            return cls._frozen(empty, empty.copy(), np.zeros(0), shape)
        rows = np.array([r for r, _, _ in stamps], dtype=np.int64)
        cols = np.array([c for _, c, _ in stamps], dtype=np.int64)
        values = np.array([v for _, _, v in stamps], dtype=float)
        if rows.min() < 0 or cols.min() < 0 or rows.max() >= shape[0] or cols.max() >= shape[1]:
            raise ValueError(f"a stamp lies outside the {shape[0]}×{shape[1]} matrix")
        order = np.lexsort((cols, rows))  # by row, then column; stable: stamps in their order
        rows, cols, values = rows[order], cols[order], values[order]
        position = rows * shape[1] + cols
        first = np.concatenate([[True], position[1:] != position[:-1]])
        slot = np.cumsum(first) - 1
        summed = np.bincount(slot, weights=values)  # in array order: one addition after another
        return cls._frozen(rows[first], cols[first], summed, shape)

    @classmethod
    def _frozen(cls, rows: np.ndarray, cols: np.ndarray, values: np.ndarray,
                shape: tuple[int, int]) -> Triplets:
        for array in (rows, cols, values):
            array.setflags(write=False)
        return cls(rows, cols, values, (int(shape[0]), int(shape[1])))

    def row(self, index: int) -> tuple[np.ndarray, np.ndarray]:
        """``(columns, values)`` of the stored entries of row ``index``, by column."""
        start, stop = np.searchsorted(self.rows, [index, index + 1])
        return self.cols[start:stop], self.values[start:stop]

    def diagonal(self) -> np.ndarray:
        """The main diagonal (length ``min(shape)``)."""
        diagonal = np.zeros(min(self.shape))
        on = self.rows == self.cols
        diagonal[self.rows[on]] = self.values[on]
        return diagonal

    @property
    def nnz(self) -> int:
        """Number of stored entries (an entry whose stamps cancel is stored as 0.0)."""
        return int(self.values.size)

    def __matmul__(self, x: np.ndarray) -> np.ndarray:
        """``M @ x`` for a real or complex vector ``(shape[1],)`` or matrix ``(shape[1], k)``;
        each row's products are added in column order, as scipy's CSR product does."""
        x = np.asarray(x)
        if np.iscomplexobj(x):  # (AC phasors) real and imaginary parts, each as below
            return self @ x.real + 1j * (self @ x.imag)
        x = x.astype(float, copy=False)
        if x.shape[:1] != (self.shape[1],) or x.ndim > 2:
            raise ValueError(f"matrix of shape {self.shape} cannot multiply an array of shape {x.shape}")
        if x.ndim == 1:
            return np.bincount(self.rows, weights=self.values * x[self.cols], minlength=self.shape[0])
        out = np.zeros((self.shape[0], x.shape[1]))
        for row, col, value in zip(self.rows.tolist(), self.cols.tolist(), self.values.tolist()):
            out[row] += value * x[col]  # no (entries × k) temporary: k may be a run's length
        return out

    def toarray(self) -> np.ndarray:
        """The dense matrix (a new, writable array)."""
        dense = np.zeros(self.shape)
        dense[self.rows, self.cols] = self.values
        return dense

    @cached_property
    def _csr(self) -> sp.csr_matrix:
        import scipy.sparse as sp

        indptr = np.concatenate([[0], np.cumsum(np.bincount(self.rows, minlength=self.shape[0]))])
        return sp.csr_matrix((np.array(self.values), np.array(self.cols), indptr), shape=self.shape)

    def tocsr(self) -> sp.csr_matrix:
        """The matrix as scipy.sparse CSR (imports scipy; made once and shared: do not modify)."""
        return self._csr

    def tocsc(self) -> sp.csc_matrix:
        """The matrix as scipy.sparse CSC (imports scipy; a new matrix)."""
        return self._csr.tocsc()

    def __repr__(self) -> str:
        return f"Triplets({self.shape[0]}×{self.shape[1]}, {self.nnz} entries)"
