"""Small-signal responses of an MLCS (docs/ac.md).

Two cases, both linear in a source's value perturbed by ``Re(û e^{jωt})`` (``û = 1``: the
results are transfer functions per unit of the source's value, V/V, A/V, V/A, ...):

* :func:`operating_point_response`: the circuit at an operating point with every pair
  in a fixed state (active pairs keep ``w_α = 0``, the others ``λ = 0``) and the switches
  in theirs is linear time-invariant; with ``E y' = A y + B λ + S f`` the phasors solve

      [[jωE − A, −B_α], [C_α, D_αα]] [Y; Λ_α] = [S_u; 0]

  (``S_u`` the source's column): SPICE's ``.ac`` for ideal devices.

* :func:`periodic_response`: around a periodic steady state with its mode sequence fixed,
  each implicit Euler step is ``δx_{k+1} = M_k δx_k + N_k δu`` with
  ``N_k δu = Q1_k δu_{k+1} + Q0_k δu_k`` (:class:`~circuitnsds.engine.step_maps.StepMaps`).
  With ``δu_k = e^{jω t_k}`` the steady response is ``δx_k = e^{jω t_k} p_k`` with ``p``
  periodic, so ``(e^{jωT} I − Φ) δx_0 = Σ_k (M_{N−1} ⋯ M_{k+1}) N_k``. The transfer
  function to an output is that output's Fourier coefficient at ω over the period,
  ``(1/T) Σ_k h_k δy_{k+1} e^{−jω t_{k+1}}`` (the right-end samples implicit Euler
  balances). For a circuit that does not switch this is the implicit Euler discretisation
  of the first case (it tends to it as ``ωh → 0``); above half the switching frequency the
  other sidebands ``ω + n·ωs`` of the switched response alias onto ω: physical, not an error.

A step split at a located switching of a circuit-controlled switch (a PWM comparator)
enters with its exact linearisation, the switching instant's sensitivity to the state and
to the sources included (:func:`circuitnsds.engine.step_maps.split_map`): a perturbed
control voltage moves the instant, and the response carries the saltation term.
Source-driven switches switch at grid points, which a small perturbation does not move.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from circuitnsds.engine.step_maps import StepMaps
from circuitnsds.system.mlcs import MLCS


def operating_point_response(mlcs: MLCS, states: np.ndarray, active: np.ndarray, inputs: np.ndarray,
                             frequencies: np.ndarray, outputs: sp.csr_matrix,
                             output_pairs: sp.csr_matrix) -> np.ndarray:
    """Responses of each output to the sources' phasors ``inputs``, shape
    ``(frequencies, outputs)`` (complex).

    Args:
        mlcs: the system; states: switch states (closed = true); active: the active pairs.
        inputs: complex phasor of every source's value (one per column of ``S``): a unit
            vector gives the transfer function from that source.
        frequencies: [Hz].
        outputs, output_pairs: output rows on the unknowns ``y`` and on the pair currents
            (``MLCS.Y_out``, ``MLCS.L_out`` rows).

    Raises:
        numpy.linalg.LinAlgError: the system is singular at some frequency (a node left
            floating by blocked diodes at DC, an undamped resonance hit exactly).
    """
    act = np.flatnonzero(active)
    A = mlcs.system_matrix(tuple(bool(s) for s in states)).tocsc()
    E, B, C, D = mlcs.E.tocsc(), mlcs.B.tocsc(), mlcs.C.tocsr(), mlcs.D.tocsr()
    n = mlcs.n
    rhs = np.zeros(n + act.size, dtype=complex)
    rhs[:n] = mlcs.S @ np.asarray(inputs, dtype=complex)
    result = np.empty((len(frequencies), outputs.shape[0]), dtype=complex)
    static = sp.bmat([[-A, -B[:, act]], [C[act], D[act][:, act]]], format="csc").astype(complex)
    storage = sp.block_diag([E, sp.csc_matrix((act.size, act.size))], format="csc")
    for row, frequency in enumerate(np.asarray(frequencies, dtype=float)):
        matrix = (static + (2j * np.pi * frequency) * storage).tocsc()
        with np.errstate(all="ignore"):
            solution = spla.splu(matrix).solve(rhs)
        if not np.isfinite(solution).all():
            raise np.linalg.LinAlgError(f"the small-signal system is singular at {frequency:g} Hz")
        result[row] = outputs @ solution[:n] + output_pairs[:, act] @ solution[n:]
    return result


def _periodic_steps(maps: StepMaps, inputs: np.ndarray, frequencies: np.ndarray):
    """``(k, full, active)`` for each step ``k`` of the period around the periodic steady state:
    ``full`` the steady response ``[δy_{k+1}; δλ_α]`` to the sources' phasors ``inputs``, one
    row per frequency, ``active`` the pairs of ``δλ_α`` (see :func:`periodic_response`)."""
    inputs = np.asarray(inputs, dtype=complex)
    time = maps.trajectory.time
    t0 = time[0]
    period = time[-1] - t0
    omega = 2 * np.pi * np.asarray(frequencies, dtype=float)
    state = maps.state
    size = state.size

    def drive(k: int) -> np.ndarray:
        """``[δy_{k+1}; δλ_α]`` from the input alone (δx_k = 0), one row per frequency."""
        total = 0
        for instant, G in maps.input_terms(k):
            total = total + np.outer(np.exp(1j * omega * (instant - t0)), G @ inputs)
        return total

    # one pass: the particular response from δx_0 = 0 and the homogeneous part Φ
    forced = np.zeros((omega.size, size), dtype=complex)
    phi = np.eye(size)
    for k in range(maps.steps):
        M, _ = maps.step(k)
        forced = forced @ M.T + drive(k)[:, state]
        phi = M @ phi
    start = np.empty((omega.size, size), dtype=complex)
    ring = np.exp(1j * omega * period)
    for row in range(omega.size):
        start[row] = np.linalg.solve(ring[row] * np.eye(size) - phi, forced[row])
    # second pass: every step's response
    x = start
    for k in range(maps.steps):
        Y, _ = maps.full_map(k)
        full = x @ Y.T + drive(k)  # [δy_{k+1}; δλ_α], (F, n + a)
        yield k, full, maps.active_pairs(k)
        x = full[:, state]


def periodic_response(maps: StepMaps, inputs: np.ndarray, frequencies: np.ndarray,
                      outputs: sp.csr_matrix, output_pairs: sp.csr_matrix) -> np.ndarray:
    """Responses of each output (their Fourier coefficient at each frequency) to the sources'
    phasors ``inputs`` around the periodic steady state whose one-period run is ``maps``,
    shape ``(frequencies, outputs)``.

    ``inputs``, ``outputs``, ``output_pairs`` as for :func:`operating_point_response`.
    """
    time = maps.trajectory.time
    omega = 2 * np.pi * np.asarray(frequencies, dtype=float)
    phase = np.exp(1j * np.outer(omega, time - time[0]))  # e^{jω (t_k − t0)}, (F, N + 1)
    n = maps.trajectory.y.shape[1]
    weights = np.diff(time) / (time[-1] - time[0])
    on_y, on_pairs = outputs.toarray().T, output_pairs.toarray().T
    result = np.zeros((omega.size, outputs.shape[0]), dtype=complex)
    for k, full, active in _periodic_steps(maps, inputs, frequencies):
        values = full[:, :n] @ on_y
        if active.size:
            values += full[:, n:] @ on_pairs[active]
        result += (weights[k] * np.conj(phase[:, k + 1]))[:, None] * values
    return result


def one_sided_pairs(maps: StepMaps, inputs: np.ndarray, frequencies: np.ndarray,
                    gaps: sp.csr_matrix, gap_pairs: sp.csr_matrix, degenerate: np.ndarray,
                    relative: float = 1e-6) -> np.ndarray:
    """How many steps each pair is *degenerate* (``degenerate``, shape ``(steps, m)``: neither
    current nor gap in the steady state) while the small-signal response moves the quantity
    its mode leaves free and which must stay >= 0 (an active pair's current λ, a blocking
    pair's gap ``w = C y + D λ + e``; the other one the mode holds at zero): ``gaps``,
    ``gap_pairs`` are ``C`` and ``D``; shape ``(m,)``.

    Such a pair is at the threshold of changing state: a perturbation of one sign drives that
    quantity negative, which its mode cannot follow, so the response is one-sided there and
    :func:`periodic_response` (the modes kept) is not the response of a small sine. "Moves":
    above ``relative`` of the largest response of any unknown over the period."""
    n = maps.trajectory.y.shape[1]
    count = np.zeros(degenerate.shape[1], dtype=int)
    if not degenerate.any():
        return count
    moves, scale = [], 1e-300
    on_y, on_pairs = gaps.T.toarray(), gap_pairs.T.toarray()  # (once, not per step)
    for k, full, active in _periodic_steps(maps, inputs, frequencies):
        scale = max(scale, float(np.abs(full).max(initial=0.0)))
        pairs = np.flatnonzero(degenerate[k])
        if not pairs.size:
            continue
        current = np.zeros((full.shape[0], degenerate.shape[1]), dtype=complex)
        current[:, active] = full[:, n:]
        gap = full[:, :n] @ on_y + current @ on_pairs
        held = np.where(np.isin(pairs, active), np.abs(current[:, pairs]).max(axis=0),
                        np.abs(gap[:, pairs]).max(axis=0))
        moves.append((pairs, held))
    for pairs, held in moves:
        count[pairs[held > relative * scale]] += 1
    return count
