"""Array helpers that numpy's own would make slower to start.

numpy 2.4's ``np.unique`` imports ``numpy.ma`` on its first call (to ask whether the array
is masked), ~0.02 s of a run's start-up; a run needs only the distinct values of plain
1-D arrays, which :func:`sorted_unique` gives without it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["sorted_unique"]


def sorted_unique(values: np.ndarray) -> np.ndarray:
    """The distinct values of a 1-D array, sorted (``np.unique(values)``; NaNs, which compare
    unequal, are each kept, at the end)."""
    ordered = np.sort(np.asarray(values).reshape(-1))
    if ordered.size < 2:
        return ordered
    return ordered[np.concatenate([[True], ordered[1:] != ordered[:-1]])]
