"""The output signals of an MLCS evaluated on a trajectory's arrays.

An output row of :attr:`MLCS.output_names` (a node voltage, a device current) is a weighted
sum of unknowns ``y`` and pair currents (the rows of ``Y_out`` and ``L_out``); these helpers
compute it on a trajectory's rows in stamped order (the same rounding wherever it is
computed) and find the few rows where its largest value can be.
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


def largest_rows(terms: list[tuple[int, int, float]], trajectory,
                  bounds: dict[int, float]) -> np.ndarray | None:
    """Rows of ``trajectory`` among which :func:`output_values` of ``terms`` takes its largest
    value (ties included), or ``None`` (every row) when they are not few.

    The term of largest magnitude (a diode's pair current; the others are its off-conductance
    times node voltages, ~1e-10 A) is computed; every other term is bounded by the largest
    ``|y|`` or ``|current|`` times its weight (``bounds`` keeps those, per trajectory), their
    sum ``B``. A row whose main term is more than ``2(B + δ)`` below the main term's largest
    value (``δ``: the rounding of the products and of the sum, a few ulps of ``B`` plus that
    largest value for each term) is below the row holding it whatever its other terms are:
    it cannot hold the maximum. The margin taken is 2.5(B + δ)."""
    def bound(source: int) -> float:
        if source not in bounds:
            array = (trajectory.y, trajectory.current)[source]
            bounds[source] = max(float(array.max(initial=0.0)), -float(array.min(initial=0.0)))
        return bounds[source]

    sizes = [abs(float(weight)) * bound(source) for source, _, weight in terms]
    main = int(np.argmax(sizes))
    source, column, weight = terms[main]
    others = sum(sizes) - sizes[main]
    values = weight * (trajectory.y, trajectory.current)[source][:, column]
    if values.size == 0 or not np.isfinite(others):
        return None
    high = float(values.max())
    rounding = 4 * len(terms) * np.finfo(float).eps * (abs(high) + sizes[main] + others)
    where = np.flatnonzero(values >= high - 2.5 * (others + rounding))
    return where if where.size <= values.size // 4 else None
