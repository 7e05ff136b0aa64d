"""The output signals of an MLCS evaluated on a trajectory's arrays.

An output row of :attr:`MLCS.output_names` (a node voltage, a device current) is a weighted
sum of unknowns ``y`` and pair currents (the rows of ``Y_out`` and ``L_out``); these helpers
compute it on a trajectory's rows in stamped order (the same rounding wherever it is
computed).
"""

from __future__ import annotations

import numpy as np

from circuitnsds.system.mlcs import MLCS


def signal_terms(mlcs: MLCS, row: int) -> list[tuple[int, int, float]]:
    """``(source, column, weight)`` of each term of output ``row`` (``mlcs.output_names``), in
    stamped order: ``source`` 0 for the unknowns ``y``, 1 for the pair currents."""
    return [(source, column, weight)
            for source, matrix in enumerate((mlcs.Y_out, mlcs.L_out))
            for column, weight in zip(*matrix.row(row))]


def output_values(terms: list[tuple[int, int, float]], states: np.ndarray,
                   currents: np.ndarray) -> np.ndarray:
    """The output of ``terms`` (:func:`signal_terms`) at each row of ``states`` (unknowns) and
    ``currents`` (pair currents): the sum of its weighted columns, in stamped order."""
    if len(terms) == 1:  # most signals: one scaled column, no zeros array to fault in
        source, column, weight = terms[0]
        values = weight * (states, currents)[source][:, column]
        values += 0.0  # (a zero is +0.0, as the sum below makes it)
        return values
    values = np.zeros(states.shape[0])
    for source, column, weight in terms:
        values += weight * (states, currents)[source][:, column]
    return values
