"""Block principal pivoting: the active-set update shared by the solvers that use it.

From an active set ``α``, solve the equations with the pairs of ``α`` active, then
move every pair whose sign is violated to the other side: an active pair with a
negative current leaves ``α``, an inactive pair with a negative ``w`` joins it
(Júdice & Pires' block rule). Warm-started from the previous step's active set,
a circuit's new mode is usually found in two or three trials; in a chain of
diodes that all start to conduct (a ladder's operating point) each trial moves the
conducting front some fifty pairs on. The block rule can cycle: once it would
return to an active set it has already tried, only the violated pair with the
largest index moves from then on (Murty's rule, finite for a P-matrix).
"""

from __future__ import annotations

import numpy as np

TRIALS = 40
"""Active sets tried before giving up (the caller then runs Lemke)."""


class BlockPivoting:
    """The active set of block principal pivoting (see module docstring).

    Attributes:
        mask: the current active set (boolean, one entry per pair).
    """

    def __init__(self, start: np.ndarray):
        self.mask = np.array(start, dtype=bool)
        self._seen = {self.mask.tobytes()}
        self._single = False

    def update(self, violated: np.ndarray) -> None:
        """Move the pairs ``violated`` (indices, non-empty) across."""
        if not self._single:
            block = self.mask.copy()
            block[violated] ^= True
            if block.tobytes() not in self._seen:
                self.mask = block
                self._seen.add(block.tobytes())
                return
            self._single = True  # the block rule cycles
        self.mask[violated.max()] ^= True
