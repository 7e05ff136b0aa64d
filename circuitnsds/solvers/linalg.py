"""Linear algebra shared by the solvers and the engine: LU factorisations with a
condition estimate (dense and sparse), and the tolerances that go with them.

* :func:`factorise` — dense LU with partial pivoting (LAPACK ``getrf``'s) and the
  reciprocal 1-norm condition estimate of ``gecon``; :class:`LU` solves with the factors
  at a cost of a few microseconds (the cache-hit path of the mode-reuse solver). Both run
  in C (``_lu_native.c``, built at install, see :mod:`circuitnsds.native`), so that a
  small circuit's run needs no scipy; without the library, scipy's LAPACK does the same
  (imported then).
* :func:`factorise_sparse` — SuperLU for large bordered matrices, with the same
  interface (:class:`SparseLU`) and a condition estimate of the same meaning.
* :data:`RCOND_MIN` (singularity), :data:`SIGN_TOL` (sign test of a guessed mode),
  :data:`SPARSE_MIN` (where the sparse LU takes over).

The C library computes what LAPACK's unblocked ``getf2``, ``getrs`` and ``gecon`` (with
``lacn2``, Hager's method as refined by Higham) compute; the results differ from scipy's
at the rounding level (tests/test_lu_native.py).

Sparse LU (scipy's SuperLU, imported when a sparse matrix is factorised): A circuit's
bordered matrix ``K_α`` has a few non-zeros per row. Beyond :data:`SPARSE_MIN` unknowns a
dense LU costs O(N³) (0.14 s at N = 2000, the 1000-section diode ladder) where SuperLU
takes milliseconds. The reciprocal condition number is estimated as LAPACK's ``gecon``
does, from the 1-norm of ``K`` and an estimate of the 1-norm of ``K⁻¹`` (Hager's method,
a few solves), so :attr:`SparseLU.ok` means what :attr:`LU.ok` means.
"""

from __future__ import annotations

import ctypes
import functools
import warnings
from typing import TYPE_CHECKING

import numpy as np

from circuitnsds import native

if TYPE_CHECKING:
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

__all__ = ["LU", "SparseLU", "factorise", "factorise_sparse", "RCOND_MIN", "SIGN_TOL", "SPARSE_MIN"]

RCOND_MIN = 1e-15
"""Below this reciprocal condition number (1-norm estimate) a matrix is treated as singular."""
SIGN_TOL = 1e-7
"""Largest relative sign violation accepted from a guessed mode: a complementarity value
counts as ``>= 0`` when it is negative by less than ``SIGN_TOL`` times the sum of the
magnitudes of the terms that make it up (rounding noise of a pair at zero on both sides).
Used by the MLCP solver's test of a guessed mode and by the engine's mode loops."""

LIBRARY = "solvers/_lu_native"
"""The C library of the dense LU (:mod:`circuitnsds.native`)."""
NATIVE_MAX = 64
"""Largest order factorised by the C library: the matrices of the circuits stepped with
dense mode maps (``n + m <= 64``, :data:`circuitnsds.engine.integrate.DENSE_MAP_LIMIT`).
Larger circuits are stepped by the sparse loop, which imports scipy anyway, and scipy's
LAPACK (blocked, vectorised with AVX and fused multiply-adds, threaded) is faster there
(``benchmarks/lu_native.py``: factorise + estimate equal at n = 100, C 2.4 times slower
at 200, 3.4 times at 1000; a solve of 5 columns 3 times slower from n = 100 on)."""

_DOUBLE = ctypes.c_double
_INT32 = ctypes.c_int32


@functools.cache  # (on the path of every factorisation)
def _native_functions():
    """The C library's ``(factor, solve)`` with their argument types declared, or ``None``
    (not built, disabled, or stale: :func:`circuitnsds.native.library`)."""
    matrix, pivots, size = ctypes.POINTER(_DOUBLE), ctypes.POINTER(_INT32), ctypes.c_int64
    factor = native.function(LIBRARY, "circuitnsds_lu_factor", [size, matrix, pivots], ctypes.c_double)
    if factor is None:
        return None
    solve = native.function(LIBRARY, "circuitnsds_lu_solve", [size, size, matrix, pivots, matrix], None)
    return factor, solve


def native_loaded() -> bool:
    """Whether the dense LU runs in C (else by scipy's LAPACK)."""
    return _native_functions() is not None


class LU:
    """LU factors ``K = P L U`` of a square matrix with its reciprocal condition estimate.

    Attributes:
        lu: ``(size, size)`` float64, the factors as LAPACK ``getrf`` stores them: ``L``
            below the diagonal (its unit diagonal not stored), ``U`` on and above it. In C
            order from the C library, in Fortran order from scipy's LAPACK (the fallback);
            not to be modified.
        piv: ``(size,)`` int32, LAPACK's pivots 0-based: row ``k`` was interchanged with
            row ``piv[k]`` (``>= k``), for ``k = 0, 1, …`` in turn.
        rcond: reciprocal 1-norm condition estimate (``gecon``'s), 0 when singular.
        size: the order of ``K``.

    ``solve(b)`` calls the C solve with the factors' addresses taken once (or LAPACK
    ``getrs`` directly, without scipy's checks, in the fallback), which is what makes the
    cache-hit path of the mode-reuse solver cheap.
    """

    __slots__ = ("lu", "piv", "rcond", "size", "_call")

    def __init__(self, lu: np.ndarray, piv: np.ndarray, rcond: float) -> None:
        """Factors of the C library (see the attributes); the C solve's function and the
        factors' addresses are taken here, once (held with the arrays they point into)."""
        size = lu.shape[0]
        functions = _native_functions()
        if (functions is None or lu.shape != (size, size) or piv.shape != (size,)
                or lu.dtype != np.float64 or piv.dtype != np.int32
                or not (lu.flags.c_contiguous and piv.flags.c_contiguous)):
            raise ValueError("LU: C-ordered float64 factors and int32 pivots of the C library expected")
        self.lu = lu
        self.piv = piv
        self.rcond = rcond
        self.size = size
        self._call = (functions[1], _DOUBLE.from_buffer(lu), _INT32.from_buffer(piv)) if size else None

    @classmethod
    def _made(cls, lu: np.ndarray, piv: np.ndarray, rcond: float, call: tuple | None) -> LU:
        """The constructor without its checks, for :func:`factorise` (``call``: the C solve
        and the factors as ctypes objects sharing their memory, which keep them alive;
        ``None`` for size 0)."""
        self = cls.__new__(cls)
        self.lu, self.piv, self.rcond, self.size, self._call = lu, piv, rcond, lu.shape[0], call
        return self

    def __reduce__(self):
        """Copied and pickled as its arrays: a copy takes the addresses of its own (and is
        solved by scipy's LAPACK in a process without the C library)."""
        return _rebuilt, (self.lu, self.piv, self.rcond)

    @property
    def ok(self) -> bool:
        """True when the matrix is not numerically singular."""
        return self.rcond >= RCOND_MIN

    def solve(self, b: np.ndarray) -> np.ndarray:
        """Solve ``K x = b`` (``b`` 1-D or 2-D, ``size`` rows); ``x`` is a new C-ordered array."""
        size = self.size
        x = np.array(b, dtype=np.float64, order="C")
        if not 0 < x.ndim < 3 or x.shape[0] != size:
            raise ValueError(f"LU.solve: b of shape {x.shape} for a {size}x{size} matrix")
        if x.size:
            solve, lu_buffer, piv_buffer = self._call
            solve(size, x.size // size, lu_buffer, piv_buffer, _DOUBLE.from_buffer(x))
        return x


class _LapackLU(LU):
    """:class:`LU` by scipy's LAPACK (``getrf`` factors in Fortran order): the fallback
    without the C library."""

    __slots__ = ()

    def __init__(self, lu: np.ndarray, piv: np.ndarray, rcond: float) -> None:
        self.lu = lu
        self.piv = piv
        self.rcond = rcond
        self.size = lu.shape[0]
        self._call = None

    def solve(self, b: np.ndarray) -> np.ndarray:
        """Solve ``K x = b`` (``b`` 1-D or 2-D) by LAPACK ``getrs``."""
        if self.size == 0:
            return np.zeros_like(b, dtype=float)
        x, _ = _getrs()(self.lu, self.piv, b)
        return x


_lapack_getrs: list = []  # [scipy.linalg.lapack.dgetrs], imported at the first fallback solve


def _getrs():
    """scipy's LAPACK ``dgetrs``."""
    if not _lapack_getrs:
        from scipy.linalg import lapack

        _lapack_getrs.append(lapack.dgetrs)
    return _lapack_getrs[0]


def _rebuilt(lu: np.ndarray, piv: np.ndarray, rcond: float) -> LU:
    """The :class:`LU` of the factors ``lu`` (either order) and pivots ``piv``: the C
    library's when it is loaded, else scipy's (unpickling, copying)."""
    piv = np.ascontiguousarray(piv, dtype=np.int32)
    if _native_functions() is not None:
        return LU(np.ascontiguousarray(lu, dtype=np.float64), piv, rcond)
    return _LapackLU(np.asfortranarray(lu, dtype=np.float64), piv, rcond)


def factorise(K: np.ndarray) -> LU:
    """LU-factorise a dense square ``K`` (not modified) with partial pivoting; ``rcond`` is
    0 when a pivot is exactly zero, when ``K`` or its factors are not finite, or when the
    estimate is not. By the C library when it is built (:func:`native_loaded`) and ``K``
    is at most :data:`NATIVE_MAX` square, else by scipy's LAPACK (``getrf``, ``gecon``),
    imported then."""
    functions = _native_functions()
    if np.ndim(K) == 2 and np.shape(K)[0] > NATIVE_MAX:
        functions = None
    lu = np.array(K, dtype=np.float64, order="C" if functions is not None else "F")
    if lu.ndim != 2 or lu.shape[0] != lu.shape[1]:
        raise ValueError(f"factorise: a square matrix expected, not one of shape {lu.shape}")
    if functions is None:
        return _factorise_lapack(lu)
    size = lu.shape[0]
    piv = np.zeros(size, dtype=np.int32)
    if size == 0:
        return LU._made(lu, piv, 1.0, None)
    lu_buffer, piv_buffer = _DOUBLE.from_buffer(lu), _INT32.from_buffer(piv)
    rcond = functions[0](size, lu_buffer, piv_buffer)
    return LU._made(lu, piv, rcond, (functions[1], lu_buffer, piv_buffer))


def _factorise_lapack(K: np.ndarray) -> LU:
    """:func:`factorise` by scipy's LAPACK (``K``: a square float64 array, overwritten)."""
    import scipy.linalg as sla
    from scipy.linalg import lapack

    size = K.shape[0]
    if size == 0:
        return _LapackLU(np.zeros((0, 0)), np.zeros(0, dtype=np.int32), 1.0)
    anorm = float(np.abs(K).sum(axis=0).max())  # (before K is overwritten)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        lu, piv = sla.lu_factor(K, overwrite_a=True, check_finite=False)
    if not np.all(np.isfinite(lu)):
        return _LapackLU(lu, piv, 0.0)
    diag = np.abs(np.diag(lu))
    if diag.min() == 0.0:
        return _LapackLU(lu, piv, 0.0)
    rcond, info = lapack.dgecon(lu, anorm, norm="1")
    if info != 0 or not np.isfinite(rcond):
        rcond = 0.0
    return _LapackLU(lu, piv, float(rcond))


SPARSE_MIN = 300
"""Bordered systems with at least this many unknowns are factorised sparse (when ``K`` is)."""


class SparseLU:
    """SuperLU factors of a square sparse matrix with its reciprocal condition estimate."""

    __slots__ = ("factors", "rcond", "size")

    def __init__(self, factors: spla.SuperLU | None, rcond: float, size: int) -> None:
        self.factors = factors
        self.rcond = rcond
        self.size = size

    @property
    def ok(self) -> bool:
        """True when the matrix is not numerically singular."""
        return self.rcond >= RCOND_MIN

    def solve(self, b: np.ndarray) -> np.ndarray:
        """Solve ``K x = b`` (``b`` 1-D or 2-D)."""
        return self.factors.solve(np.asarray(b, dtype=float))


def factorise_sparse(K: sp.spmatrix | sp.sparray) -> SparseLU:
    """Factorise ``K``; ``rcond`` is 0 when it is exactly singular or not finite."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    K = sp.csc_matrix(K)
    size = K.shape[0]
    if not np.isfinite(K.data).all():
        return SparseLU(None, 0.0, size)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            factors = spla.splu(K, permc_spec="MMD_AT_PLUS_A")
    except RuntimeError:  # exactly singular
        return SparseLU(None, 0.0, size)
    inverse = spla.LinearOperator((size, size), matvec=factors.solve,
                                  rmatvec=lambda b: factors.solve(b, trans="T"), dtype=float)
    with np.errstate(all="ignore"):  # t = 1 (Hager's method): deterministic, no random columns
        inverse_norm = spla.onenormest(inverse, t=1)
    anorm = float(abs(K).sum(axis=0).max())
    rcond = 1.0 / (anorm * inverse_norm) if anorm > 0 and np.isfinite(inverse_norm) else 0.0
    return SparseLU(factors, rcond, size)
