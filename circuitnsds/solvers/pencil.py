"""Eigenvalues and right eigenvectors of a real matrix pencil ``(A, B)``: LAPACK's ``dggev``
(the QZ algorithm), as ``scipy.linalg.eig(A, B, homogeneous_eigvals=True)`` computes them,
without importing ``scipy.linalg``.

First choice: the ``dggev`` of the LAPACK numpy itself is linked with (its OpenBLAS build,
``numpy.libs/libscipy_openblas64_*.so``, through its C interface ``LAPACKE_dggev_work``,
with ctypes), which the process has loaded already: 0.1 ms, where loading scipy's
``_flapack`` (below) took 13 ms of CPU, 8 % of what the three-phase inverter's 116 modes
cost. On the modes of nine netlists (532 pencils, balanced and not) it gave scipy's results
to the bit. Where numpy has no such library (another build), scipy's follows.

Why not just ``scipy.linalg``: importing it costs 0.25 s (scipy 1.17 on this project's
benchmark machine: ``scipy._lib`` pulls in its array-API layer and ``numpy.f2py``), and the
exact integrator needs the pencil for each mode it meets (:mod:`circuitnsds.engine.exact.mode`),
so every exact run paid it: a quarter of a short run's whole process. scipy's own compiled
LAPACK wrappers (``scipy/linalg/_flapack``) are loaded here directly from their file (scipy's
package found, not imported), 0.02 s, and called as ``scipy.linalg.eig`` calls them. Where
that module cannot be loaded (another scipy layout), ``scipy.linalg.eig`` is used: the same
LAPACK routine either way.
"""

from __future__ import annotations

import ctypes
import importlib.util
from pathlib import Path
from types import ModuleType

import numpy as np

__all__ = ["balancing", "pencil_eigen"]

_FLAPACK: list[ModuleType | None] = []
_NUMPY_DGGEV: list = []
_LWORK: dict[int, int] = {}
"""dggev's optimal workspace per order of the pencil (LAPACK's query: ``ilaenv``'s block
sizes, which depend on the order alone)."""


def _flapack() -> ModuleType | None:
    """scipy's ``_flapack`` extension, loaded from its file without ``scipy.linalg``'s
    package (once per process), or ``None``."""
    if not _FLAPACK:
        module = None
        try:
            # (found, not imported: ``import scipy`` alone costs 0.02 s, its test utilities)
            folder = Path(importlib.util.find_spec("scipy").submodule_search_locations[0]) / "linalg"
            candidates = sorted(folder.glob("_flapack.*"))
            spec = importlib.util.spec_from_file_location("scipy.linalg._flapack", candidates[0])
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
            if not hasattr(module, "dggev"):
                module = None
        except Exception:  # (any failure: scipy.linalg.eig does the same)
            module = None
        _FLAPACK.append(module)
    return _FLAPACK[0]


def _numpy_dggev():
    """``LAPACKE_dggev_work`` of numpy's own OpenBLAS (64-bit integers) as a ctypes function,
    or ``None`` (once per process)."""
    if not _NUMPY_DGGEV:
        function = None
        try:
            folder = Path(np.__file__).resolve().parent.parent / "numpy.libs"
            for path in sorted(folder.glob("libscipy_openblas64_*.so")):
                function = getattr(ctypes.CDLL(str(path)), "scipy_LAPACKE_dggev_work64_", None)
                if function is not None:
                    pointer, integer = ctypes.c_void_p, ctypes.c_int64
                    function.argtypes = [ctypes.c_int, ctypes.c_char, ctypes.c_char, integer, pointer,
                                         integer, pointer, integer, pointer, pointer, pointer, pointer,
                                         integer, pointer, integer, pointer, integer]
                    function.restype = integer
                    break
        except Exception:  # (any failure: scipy's dggev does the same)
            function = None
        _NUMPY_DGGEV.append(function)
    return _NUMPY_DGGEV[0]


_COLUMN_MAJOR = 102
"""LAPACKE's ``LAPACK_COL_MAJOR``."""


def _numpy_eigen(function, A: np.ndarray, B: np.ndarray):
    """``(alphar, alphai, beta, vr, info)`` of ``dggev`` (right vectors only) through
    :func:`_numpy_dggev`'s function, with scipy's workspace (the optimal one, at least ``8 n``)."""
    n = A.shape[0]
    a = np.array(A, dtype=float, order="F")
    b = np.array(B, dtype=float, order="F")
    alphar, alphai, beta = np.empty(n), np.empty(n), np.empty(n)
    vr = np.empty((n, n), order="F")
    unused = np.empty((1, 1))
    lwork = _LWORK.get(n)
    if lwork is None:
        query = np.zeros(1)
        info = function(_COLUMN_MAJOR, b"N", b"V", n, a.ctypes.data, max(n, 1), b.ctypes.data, max(n, 1),
                        alphar.ctypes.data, alphai.ctypes.data, beta.ctypes.data, unused.ctypes.data, 1,
                        vr.ctypes.data, max(n, 1), query.ctypes.data, -1)
        if info != 0:
            return alphar, alphai, beta, vr, info
        lwork = _LWORK[n] = max(int(query[0]), 8 * n, 1)
    work = np.empty(lwork)
    info = function(_COLUMN_MAJOR, b"N", b"V", n, a.ctypes.data, max(n, 1), b.ctypes.data, max(n, 1),
                    alphar.ctypes.data, alphai.ctypes.data, beta.ctypes.data, unused.ctypes.data, 1,
                    vr.ctypes.data, max(n, 1), work.ctypes.data, lwork)
    return alphar, alphai, beta, vr, info


def pencil_eigen(A: np.ndarray, B: np.ndarray, *, balance: bool = True
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(alpha, beta, vectors)``: the generalized eigenvalues ``alpha / beta`` of
    ``A v = λ B v`` (``beta = 0``: an infinite eigenvalue) and the right eigenvectors as
    complex columns (not normalised), for real square ``A`` and ``B``, computed on the
    balanced pencil (:func:`balancing`) unless ``balance`` is false.

    Raises:
        np.linalg.LinAlgError: the QZ iteration failed.
    """
    lapack = _numpy_dggev() or _flapack()
    if not balance:
        return _eigen(lapack, np.asarray(A, dtype=float), np.asarray(B, dtype=float))
    rows, columns = balancing(A, B)
    A = np.asarray(A, dtype=float) * rows[:, None] * columns[None, :]
    B = np.asarray(B, dtype=float) * rows[:, None] * columns[None, :]
    alpha, beta, vectors = _eigen(lapack, A, B)
    return alpha, beta, vectors * columns[:, None]


def balancing(A: np.ndarray, B: np.ndarray, sweeps: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Powers of two ``(r, c)`` that scale the rows and columns of ``|A| + |B|`` towards a
    largest entry of 1 each (alternating sweeps): ``(diag(r) A diag(c), diag(r) B diag(c))``
    has the eigenvalues of ``(A, B)`` and the right eigenvectors ``diag(c)⁻¹ v``, and being
    powers of two the scaling itself rounds nothing.

    Why: a circuit's pencil mixes 1 H with a blocked diode's 1e-12 S. The transformer-fed
    bridge with all four diodes blocking has the eigenvalues −0.1, −10 and −1.8e17 /s; QZ on
    the pencil as it is gave +32 /s for the first (its error ε times the largest entries), a
    magnetising current growing instead of decaying, and the exact integrator missed every
    diode turn-on after 63 ms. Balanced, QZ gives −0.1 and −10 to round-off (LAPACK's
    ``dggbal`` does the same for ``dggevx``, which scipy does not wrap)."""
    size = np.abs(np.asarray(A, dtype=float)) + np.abs(np.asarray(B, dtype=float))
    r = np.ones(size.shape[0])
    c = np.ones(size.shape[1])
    for _ in range(sweeps):
        largest = (size * r[:, None] * c[None, :]).max(axis=1)
        largest[largest == 0] = 1.0
        r = r / np.exp2(np.round(np.log2(largest)))
        largest = (size * r[:, None] * c[None, :]).max(axis=0)
        largest[largest == 0] = 1.0
        c = c / np.exp2(np.round(np.log2(largest)))
    return r, c


def _eigen(lapack, A: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``pencil_eigen`` of an already balanced pencil (``lapack``: :func:`_numpy_dggev`'s
    function, scipy's ``_flapack`` or ``None``: ``scipy.linalg.eig``)."""
    if lapack is None:
        from scipy.linalg import eig

        (alpha, beta), vectors = eig(A, B, homogeneous_eigvals=True)
        return alpha, beta, vectors
    if not isinstance(lapack, ModuleType):
        alphar, alphai, beta, vr, info = _numpy_eigen(lapack, A, B)
    else:
        # the optimal workspace first (as scipy.linalg.eig asks for it: the blocked QR steps
        # then round as scipy's)
        lwork = _LWORK.get(A.shape[0])
        if lwork is None:  # (it depends on the order only: asked once per order)
            query = lapack.dggev(A, B, compute_vl=0, compute_vr=1, lwork=-1)
            lwork = _LWORK[A.shape[0]] = max(int(query[-2][0]), 8 * A.shape[0], 1)
        alphar, alphai, beta, _, vr, _, info = lapack.dggev(A, B, compute_vl=0, compute_vr=1, lwork=lwork)
    if info != 0:
        raise np.linalg.LinAlgError(f"the QZ algorithm (LAPACK dggev) failed: info = {info}")
    alpha = alphar + 1j * alphai
    vectors = vr.astype(complex)
    # a complex pair is stored as two real columns: v_j = re + i im, v_{j+1} = its conjugate
    # (the complex ones only visited: LAPACK stores a pair's two at j and j + 1)
    after = -1
    for j in alphai.nonzero()[0].tolist():
        if j <= after:
            continue
        if j + 1 < alpha.size:
            vectors[:, j] = vr[:, j] + 1j * vr[:, j + 1]
            vectors[:, j + 1] = vr[:, j] - 1j * vr[:, j + 1]
            after = j + 1
    return alpha, beta, vectors
