"""Whether the mode table's steps run in Python or compiled: numba only when it pays.

Where the C loop was built at install (:mod:`circuitnsds.engine.dense_loop`,
``_dense_native.c``) there is nothing to weigh: it costs nothing to load, so
:meth:`LoopChoice.compiled` answers yes from the first step
(:func:`~circuitnsds.engine.dense_loop.compiled_loaded`), numba is never imported for the
table loop and no warm-up process is started for it. What follows is the choice where it
was not built (no C compiler at install, or ``CIRCUITNSDS_NATIVE=0``) and the compiled loop
is numba's.

The compiled table loop takes ~0.3-1 µs per step, the same loop in Python with numpy
~20 µs and far more for some circuits. But numba costs ~0.2 s to import and ~0.4 s to
load a cached loop (its LLVM context), and ~10 s to compile it when nothing is cached
(the first run after an install). A run of 5,000 steps (the bundled bridge rectifier)
is over in ~0.1 s in Python: loading numba would more than double the whole command's
time.

So (:class:`LoopChoice`) the choice weighs what the steps left would cost in Python
against what loading the compiled loop costs, both by a *cost model* in microseconds
of the benchmark machine (:func:`python_step_us`): a Python step costs
:data:`STEP_US`, plus :data:`SWITCH_TERM_US` per unknown and state-controlled switch
(the loop tests each switch's control term by term), and every mode change the loop
finds by searching the stored modes (:func:`circuitnsds.engine.dense_loop._find_mode_scalar`)
costs :data:`SEARCH_US` more. The counts come from the run itself (its size, the steps
the table loop took, the searches it made so far): a deterministic estimate, not a
clock, so the same netlist makes the same choice on a busy and a quiet machine (the two
loops round differently in the last bits; docs/performance.md). Calibrated on this
machine with the CPU time of the Python loop (``stepping="numpy"``; the buck converter
22 µs per step, the bridge 19, the 16-pair RF multiplier 75 with a search every 5 steps,
the peak-current XSPICE buck 109 with 5 switches watched over 40 unknowns).

A run goes compiled at once when its mapped steps left are sure to pay (:data:`SURE`
times the load, e.g. a million-step converter or a long XSPICE run), else it starts in
Python, first :data:`FIRST_CHUNK` steps (enough to see how often the mode changes), then in
chunks of ~:data:`CHUNK_US` of modelled work, and goes compiled once the modelled saving
of the steps left exceeds :data:`LOAD_US`. It then loads the compiled loop if
the per-user cache holds it for this very source (the warm-up's marker,
:func:`~circuitnsds.jit.ready_marker`); otherwise it starts a background process
(:func:`start_warmup`) that imports numba, compiles the loops into the cache and marks
it, then exits. The run goes on in Python meanwhile (a second core does the
compiling); once that process has finished, and if the steps left are still worth it,
the run loads the compiled loop (from the cache just written) and continues with it.
A run never waits for a compilation, and a short one never loads numba.
A loop already loaded in the process (an earlier run) is used at once.
"""

from __future__ import annotations

from circuitnsds import jit
from circuitnsds.engine import dense_loop
from circuitnsds.jit import numba_available, ready_marker

STEP_US = 18.0
"""Modelled cost of one step of the table loop in Python [µs]: the numpy products of the
mode's map and sign tests, the loop's bookkeeping (measured: 19-22 µs CPU for the bridge
and the buck converter, 26-31 for the 10- and 20-section diode ladders)."""
SWITCH_TERM_US = 0.45
"""Added per step for each unknown of each state-controlled switch's control [µs] (the
loop's scalar test of the switches after each step; XSPICE converters watch several)."""
SEARCH_US = 270.0
"""Modelled cost of a mode change found among the stored modes in Python [µs] (stored modes
tried with numpy: the RF multiplier's 3,967 searches in 20,000 steps)."""
COMPILED_STEP_US = 0.5
"""Modelled cost of a compiled step [µs] (searches included: a few µs each, rare)."""
LOAD_US = 600_000.0
"""What loading the compiled loop from the cache costs a process [µs]: numba's import
(0.2 s) and its LLVM context and the loop (0.4 s)."""
COMPILE_US = 12e6
"""What compiling the loops costs a process that cannot cache them [µs] (11.9 s measured)."""
FIRST_CHUNK = 1_000
"""Python steps of the first call of the table loop, before which the compiled loop is not
considered (unless :data:`SURE`): enough to see how often the modes change (ten periods
of the RF multiplier) at ~0.02-0.1 s."""
SURE = 4.0
"""A saving above this many times :data:`LOAD_US` goes compiled without waiting for
the :data:`FIRST_CHUNK` (also before any Python step: a long converter run)."""
CHUNK_US = 100_000.0
"""Modelled Python stepping per call of the table loop [µs] (how often the choice is
revisited)."""


def python_step_us(unknowns: int, watched: int) -> float:
    """Modelled cost [µs] of one Python step of the table loop without a mode search, for a
    circuit of ``unknowns`` whose loop watches ``watched`` state-controlled switches."""
    return STEP_US + SWITCH_TERM_US * unknowns * watched


WARMUP = "circuitnsds.engine.warmup"
"""The module whose ``main()`` compiles the stepping loops in the background."""


def start_warmup() -> None:
    """Start (once per process) :mod:`circuitnsds.engine.warmup` in the background
    (:func:`circuitnsds.jit.start_warmup`)."""
    jit.start_warmup(WARMUP)


def warmup_done() -> bool:
    """Whether the background compilation of the loops has finished successfully."""
    return jit.warmup_done(WARMUP)


class LoopChoice:
    """The choice of loop for the mapped steps of one run (see the module docstring).

    Args:
        mode: ``True`` always compiled (numba must be installed), ``False`` always
            Python, ``None`` automatic.
        unknowns: the circuit's unknowns ``n``.
        watched: the state-controlled switches the loop watches.
    """

    def __init__(self, mode: bool | None, unknowns: int = 0, watched: int = 0):
        self.mode = mode
        self.step_us = python_step_us(unknowns, watched)
        self.python_steps = 0  # steps the Python loop took
        self.searches = 0  # mode changes it found by searching the table
        self.cacheable = None  # whether compiled code can be cached (known when needed)
        self.cached = None  # whether it is, for this source (the warm-up's marker exists)

    def saving(self, steps_done: int, steps_left: int) -> float:
        """Modelled saving [µs] of the steps left if compiled: the mapped steps left (the steps
        left times the share the loop took so far; all of them before any) at the Python
        step's cost, with the searches at the rate seen so far."""
        share = self.python_steps / max(steps_done, 1) if self.python_steps else 1.0
        mapped = steps_left * min(share, 1.0)
        rate = self.searches / self.python_steps if self.python_steps else 0.0
        return mapped * (self.step_us - COMPILED_STEP_US + rate * SEARCH_US)

    def compiled(self, steps_done: int, steps_left: int) -> bool:
        """Whether the next call of the table loop should run compiled (``steps_done``
        steps of the run are done, ``steps_left`` to go)."""
        if self.mode is not None:
            return self.mode
        if dense_loop.compiled_loaded():
            return True
        if not numba_available():
            return False
        saving = self.saving(steps_done, steps_left)
        if saving < LOAD_US or (self.python_steps < FIRST_CHUNK and saving < SURE * LOAD_US):
            return False
        if self.cached is None:
            marker = ready_marker()
            self.cacheable = marker is not None
            self.cached = self.cacheable and marker.exists()
        if self.cached:  # compiled and cached for this source: load it here (~0.6 s)
            return True
        if not self.cacheable:  # every process compiles (~10 s): only for a long run
            return saving > COMPILE_US
        start_warmup()
        return warmup_done()

    def python_chunk(self) -> int:
        """Steps for the next call of the table loop in Python (~:data:`CHUNK_US` of modelled
        work: a count, so the points where the choice is revisited do not depend on the clock)."""
        if not self.python_steps:
            return FIRST_CHUNK
        rate = self.searches / self.python_steps
        return int(max(FIRST_CHUNK, min(100_000, CHUNK_US / (self.step_us + rate * SEARCH_US))))

    def record(self, compiled: bool, steps: int, searches: int = 0) -> None:
        """Account a call of the table loop that took ``steps`` steps and found ``searches``
        mode changes by searching the table."""
        if not compiled:
            self.python_steps += steps
            self.searches += searches
