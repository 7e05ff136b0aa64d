"""Mode reuse: cached factorisations of the bordered system of an active set.

For an active set ``α`` (pairs with ``w_α = 0``; ``z_ᾱ = 0``) the MLCP reduces to
the linear system::

    [[A,      C[:, α] ],   [u  ]     [ a  ]
     [D[α,:], B[α, α] ]] · [z_α]  = - [ b_α]

whose matrix (the *bordered* matrix ``K_α``) depends only on ``α``. The cache
keeps the LU factors of the most recently used ``K_α`` (least recently used
evicted first), keyed by the bytes of the boolean mask, so that a time step
whose active set did not change costs one pair of triangular solves and one
matrix-vector product for the verification. Numerically singular ``K_α`` are
cached too (as unusable), so they are not refactorised on every call.
"""

from __future__ import annotations

from collections import OrderedDict

import numpy as np

from .linalg import LU, SPARSE_MIN, SparseLU, factorise, factorise_sparse

__all__ = ["Mode", "ModeCache"]


class Mode:
    """One active set with the LU factors of its bordered matrix.

    Attributes:
        mask: boolean mask of the active pairs (do not modify).
        sel: indices into ``x = [u; z]`` of the unknowns of the linear system.
        lu: :class:`~circuitnsds.solvers.linalg.LU` of ``K_α`` (a
            :class:`~circuitnsds.solvers.linalg.SparseLU` for large sparse ``K``).
    """

    __slots__ = ("mask", "sel", "lu")

    def __init__(self, mask: np.ndarray, sel: np.ndarray, lu: LU | SparseLU) -> None:
        self.mask = mask
        self.sel = sel
        self.lu = lu

    def solve(self, c: np.ndarray, size: int) -> np.ndarray:
        """``x = [u; z]`` (length ``size``) of this mode for the right-hand side ``c = [a; b]``."""
        x = np.zeros(size)
        sel = self.sel
        if sel.size:
            x[sel] = self.lu.solve(-c[sel])
        return x


class ModeCache:
    """LRU cache of :class:`Mode` objects for a fixed bordered matrix ``K``.

    Args:
        K: dense ``[[A, C], [D, B]]``; ``None`` for a large sparse problem (``K_sparse``
            then gives every factorisation).
        n: number of free unknowns.
        size: maximum number of cached modes (>= 1).
        stats: dict whose ``cache_hits``, ``cache_misses``, ``factorisations`` and
            ``evictions`` counters are incremented.
        K_sparse: the same ``K`` as a sparse matrix, when the input was sparse: bordered
            systems of :data:`~circuitnsds.solvers.linalg.SPARSE_MIN` unknowns or more
            are then factorised with SuperLU.
    """

    def __init__(self, K: np.ndarray, n: int, size: int, stats: dict[str, int],
                 K_sparse=None) -> None:
        if size < 1:
            raise ValueError("cache_size must be >= 1")
        self._K = K
        self._Ks = None if K_sparse is None else K_sparse.tocsr()
        self._n = n
        self._size = size
        self._modes: OrderedDict[bytes, Mode] = OrderedDict()
        self._free = np.arange(n)
        self.stats = stats

    def __len__(self) -> int:
        return len(self._modes)

    def get(self, mask: np.ndarray) -> Mode:
        """The mode of ``mask``, factorising ``K_α`` on a miss."""
        key = mask.tobytes()
        mode = self._modes.get(key)
        if mode is not None:
            self._modes.move_to_end(key)
            self.stats["cache_hits"] += 1
            return mode
        self.stats["cache_misses"] += 1
        return self._insert(key, mask)

    def _insert(self, key: bytes, mask: np.ndarray) -> Mode:
        sel = np.concatenate([self._free, self._n + np.flatnonzero(mask)])
        if self._Ks is not None and (sel.size >= SPARSE_MIN or self._K is None):
            lu = factorise_sparse(self._Ks[sel][:, sel])
        else:
            lu = factorise(self._K[np.ix_(sel, sel)])
        self.stats["factorisations"] += 1
        mode = Mode(mask.copy(), sel, lu)
        self._modes[key] = mode
        if len(self._modes) > self._size:
            self._modes.popitem(last=False)
            self.stats["evictions"] += 1
        return mode

    def modes(self) -> list[Mode]:
        """Cached modes, most recently used last."""
        return list(self._modes.values())
