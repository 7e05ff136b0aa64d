"""Whether the mode table's steps run in Python or compiled: numba only when it pays.

The compiled table loop takes ~0.3 µs per step, the same loop in Python with numpy
~15-30 µs. But numba costs ~0.2 s to import and ~0.4 s to load a cached loop (its
LLVM context), and ~10 s to compile it when nothing is cached (the first run after
an install). A run of 5,000 steps (the bundled bridge rectifier) is over in ~0.1 s
in Python: loading numba would more than double the whole command's time.

So (:class:`LoopChoice`) a run starts in Python, in chunks of ~0.1 s. Once the
mapped steps it has left (the steps left times the share the loop took so far) exceed
:data:`LOAD_STEPS`, what loading the compiled loop costs counted in Python steps (a
ratio of two costs that both scale with the machine's speed, so the choice does not
depend on how busy the machine is), and it has taken :data:`PATIENCE_STEPS` in Python
(or at once when they exceed :data:`SURE` times that), it loads the compiled loop if the
per-user cache holds it for this very source (the warm-up's marker,
:func:`~circuitnsds.engine.jit.ready_marker`); otherwise it starts a background process
(:func:`start_warmup`) that imports numba, compiles the loops into the cache and marks
it, then exits. The run goes on in Python meanwhile (a second core does the
compiling); once that process has finished, and if the steps left are still worth it,
the run loads the compiled loop (from the cache just written) and continues with it.
A run never waits for a compilation, and a short one never loads numba.
A loop already loaded in the process (an earlier run) is used at once.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from circuitnsds.engine import dense_loop
from circuitnsds.engine.jit import numba_available, ready_marker

LOAD_STEPS = 40_000
"""What loading the compiled loop from the cache costs a process, in steps of the Python
loop: numba's import (0.2 s) and its LLVM context and the loop (0.4 s) against ~15 µs per
Python step (the buck converter), measured on the benchmark machine."""
PATIENCE_STEPS = 10_000
"""Python steps before the compiled loop is considered (unless :data:`SURE`)."""
SURE = 4.0
"""Mapped steps left above this many times :data:`LOAD_STEPS` go compiled without
waiting for :data:`PATIENCE_STEPS`."""
CHUNK_SECONDS = 0.1
"""Python stepping per call of the table loop [s] (how often the choice is revisited)."""

_warmup: list[subprocess.Popen] = []  # the process's background compilation, if started


def start_warmup() -> None:
    """Start (once per process) ``python -m`` :mod:`circuitnsds.engine.warmup` in the
    background, on this very package (not whatever ``circuitnsds`` the child would
    find first on its path)."""
    if _warmup:
        return
    package_parent = str(Path(__file__).resolve().parents[2])
    code = (f"import sys; sys.path.insert(0, {package_parent!r}); "
            "from circuitnsds.engine.warmup import main; main()")
    try:
        _warmup.append(subprocess.Popen(
            [sys.executable, "-c", code], stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL, close_fds=True))
    except OSError:  # no process can be started here: stay in Python
        _warmup.append(None)


def warmup_done() -> bool:
    """Whether the background compilation has finished successfully."""
    return bool(_warmup) and _warmup[0] is not None and _warmup[0].poll() == 0


class LoopChoice:
    """The choice of loop for the mapped steps of one run (see the module docstring).

    Args:
        mode: ``True`` always compiled (numba must be installed), ``False`` always
            Python, ``None`` automatic.
    """

    def __init__(self, mode: bool | None):
        self.mode = mode
        self.python_seconds = 0.0  # the calls of the Python loop
        self.python_steps = 0
        self.cacheable = None  # whether compiled code can be cached (known when needed)
        self.cached = None  # whether it is, for this source (the warm-up's marker exists)

    def compiled(self, steps_done: int, steps_left: int) -> bool:
        """Whether the next call of the table loop should run compiled (``steps_done``
        steps of the run are done, ``steps_left`` to go)."""
        if self.mode is not None:
            return self.mode
        if dense_loop.compiled_loaded():
            return True
        if not self.python_steps or not numba_available():
            return False
        # the mapped steps left: the steps left times the share the loop took so far
        predicted = steps_left * self.python_steps / max(steps_done, 1)
        if predicted < LOAD_STEPS or (self.python_steps < PATIENCE_STEPS
                                      and predicted < SURE * LOAD_STEPS):
            return False
        if self.cached is None:
            marker = ready_marker()
            self.cacheable = marker is not None
            self.cached = self.cacheable and marker.exists()
        if self.cached:  # compiled and cached for this source: load it here (~0.6 s)
            return True
        if not self.cacheable:  # every process compiles (~10 s): only for a long run
            return predicted > 50 * LOAD_STEPS
        start_warmup()
        return warmup_done()

    def python_chunk(self) -> int:
        """Steps for the next call of the table loop in Python (~:data:`CHUNK_SECONDS`)."""
        rate = self.python_seconds / self.python_steps if self.python_steps else 20e-6
        return int(max(500, min(100_000, CHUNK_SECONDS / max(rate, 1e-9))))

    def record(self, compiled: bool, seconds: float, steps: int) -> None:
        """Account a call of the table loop that took ``seconds`` for ``steps`` steps."""
        if not compiled:
            self.python_seconds += seconds
            self.python_steps += steps

