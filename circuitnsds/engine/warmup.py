"""Compile (or load from the per-user cache) the stepping loops, for the signatures a run uses
(the CSV formatter's numba kernel has its own warm-up: :func:`circuitnsds.output.floattext.main`).

Run in a background process by :func:`circuitnsds.engine.loop_choice.start_warmup`:
each loop is called once on a tiny problem whose arguments have the types, shapes and
layouts that :func:`circuitnsds.engine.integrate.integrate` passes, so numba compiles
and caches exactly the version a run then loads. ``python -m circuitnsds.engine.warmup``
does the same by hand (e.g. after an install).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from circuitnsds.engine import dense_loop, sparse_loop
from circuitnsds.solvers.linalg import factorise_sparse


def _run_arrays(steps: int, n: int, m: int, kstim: int) -> dict[str, np.ndarray]:
    """The per-run arrays, typed as the integrator's (float64 C arrays, int64 classes)."""
    return {"y": np.zeros((steps + 1, n)), "current": np.zeros((steps + 1, m)),
            "F": np.ones((steps + 1, kstim)), "step_class": np.zeros(steps, dtype=np.int64),
            "sched_state": np.zeros(steps, dtype=np.int64), "controls": np.zeros((0, n)),
            "on": np.array([]), "off": np.array([]), "switch_on": np.zeros(0, dtype=bool)}


def warm_dense() -> int:
    """Run numba's table loop on a one-unknown, one-pair mode; returns the steps done. (numba's,
    even where the C loop is built: the cache's ready marker says that numba's loops are
    cached, for a process that runs without the C library, ``CIRCUITNSDS_NATIVE=0``.)"""
    n, m, kstim, steps = 1, 1, 1, 3
    table = dense_loop.ModeTable(n, m, kstim)
    mode = dense_loop.ModeMap(P=np.array([[0.5], [0.0]]), Q1=np.array([[0.5], [1.0]]),
                              Q0=np.zeros((2, 1)), c=np.zeros(2), W=np.zeros((1, 2)),
                              e_w=np.zeros(1), resistance=np.ones(1),
                              active=np.array([0], dtype=np.int64))
    index = table.add((0, 0, 0, b"\x01"), mode)
    a = _run_arrays(steps, n, m, kstim)
    used = np.zeros(steps + 1, dtype=np.int64)
    free = dense_loop.FreeSwitches(a["controls"], a["on"], a["off"], a["switch_on"])
    done, _, _ = dense_loop.run_table(table, index, 0, 0, steps, a["y"], a["current"], a["F"],
                                      a["step_class"], a["sched_state"], 0, free, used,
                                      use_compiled=True, use_native=False)
    return done


def warm_sparse() -> int:
    """Run the compiled sparse loop on a one-unknown, one-pair mode; returns the steps done."""
    n, m, kstim, steps = 1, 1, 1, 3
    bordered = sp.csc_matrix(np.array([[2.0, -1.0], [1.0, 1.0]]))
    mode = sparse_loop.SparseModeMap(
        lu=factorise_sparse(bordered).factors, carry=sp.csr_matrix(np.ones((1, 1))),
        S_next=sp.csr_matrix(np.ones((1, 1))), S_now=sp.csr_matrix((1, 1)),
        rhs_pairs=np.zeros(1), W=sp.csr_matrix((0, 2)), e_w=np.zeros(0),
        active=np.array([0], dtype=np.int64), n=n)
    a = _run_arrays(steps, n, m, kstim)
    done, _ = sparse_loop.run_compiled_sparse(sparse_loop.compile_sparse_map(mode), 0, steps, a["y"],
                                              a["current"], a["F"], a["step_class"], a["sched_state"],
                                              a["controls"], a["on"], a["off"], a["switch_on"],
                                              use_compiled=True)
    return done


def main() -> None:
    """Compile or load both loops, then mark the cache ready for them."""
    from circuitnsds.jit import ready_marker

    warm_dense()
    warm_sparse()
    marker = ready_marker()
    if marker is not None:
        marker.touch()


if __name__ == "__main__":
    main()
