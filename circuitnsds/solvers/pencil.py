"""Eigenvalues and right eigenvectors of a real matrix pencil ``(A, B)``: LAPACK's ``dggev``
(the QZ algorithm), as ``scipy.linalg.eig(A, B, homogeneous_eigvals=True)`` computes them,
without importing ``scipy.linalg``.

Why not just ``scipy.linalg``: importing it costs 0.25 s (scipy 1.17 on this project's
benchmark machine: ``scipy._lib`` pulls in its array-API layer and ``numpy.f2py``), and the
exact integrator needs the pencil for each mode it meets (:mod:`circuitnsds.engine.exact.mode`),
so every exact run paid it: a quarter of a short run's whole process. scipy's own compiled
LAPACK wrappers (``scipy/linalg/_flapack``) are loaded here directly from their file, 0.02 s,
and called as ``scipy.linalg.eig`` calls them. Where that module cannot be loaded (another
scipy layout), ``scipy.linalg.eig`` is used: the same LAPACK routine either way.
"""

from __future__ import annotations

import importlib.util
from pathlib import Path
from types import ModuleType

import numpy as np

__all__ = ["pencil_eigen"]

_FLAPACK: list[ModuleType | None] = []


def _flapack() -> ModuleType | None:
    """scipy's ``_flapack`` extension, loaded from its file without ``scipy.linalg``'s
    package (once per process), or ``None``."""
    if not _FLAPACK:
        module = None
        try:
            import scipy

            folder = Path(scipy.__path__[0]) / "linalg"
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


def pencil_eigen(A: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(alpha, beta, vectors)``: the generalized eigenvalues ``alpha / beta`` of
    ``A v = λ B v`` (``beta = 0``: an infinite eigenvalue) and the right eigenvectors as
    complex columns (not normalised), for real square ``A`` and ``B``.

    Raises:
        np.linalg.LinAlgError: the QZ iteration failed.
    """
    lapack = _flapack()
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    if lapack is None:
        from scipy.linalg import eig

        (alpha, beta), vectors = eig(A, B, homogeneous_eigvals=True)
        return alpha, beta, vectors
    # the optimal workspace first (as scipy.linalg.eig asks for it: the blocked QR steps
    # then round as scipy's)
    query = lapack.dggev(A, B, compute_vl=0, compute_vr=1, lwork=-1)
    lwork = max(int(query[-2][0]), 8 * A.shape[0], 1)
    alphar, alphai, beta, _, vr, _, info = lapack.dggev(A, B, compute_vl=0, compute_vr=1, lwork=lwork)
    if info != 0:
        raise np.linalg.LinAlgError(f"the QZ algorithm (LAPACK dggev) failed: info = {info}")
    alpha = alphar + 1j * alphai
    vectors = vr.astype(complex)
    # a complex pair is stored as two real columns: v_j = re + i im, v_{j+1} = its conjugate
    j = 0
    while j < alpha.size:
        if alphai[j] != 0.0 and j + 1 < alpha.size:
            vectors[:, j] = vr[:, j] + 1j * vr[:, j + 1]
            vectors[:, j + 1] = vr[:, j] - 1j * vr[:, j + 1]
            j += 2
        else:
            j += 1
    return alpha, beta, vectors
