"""A progress bar on stderr for long runs: fraction done, simulated time, rate.

``ProgressBar`` is a callback for :meth:`Circuit.transient` (``progress=``). It
draws only when its stream is a terminal, and only once the run has lasted
``delay`` seconds (default 1 s), so short runs, pipes, files and CI logs stay clean.
The line is redrawn in place (carriage return) and ended by :meth:`ProgressBar.close`.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from typing import TextIO

from circuitnsds.units import format_si


def format_progress(t: float, stop: float, elapsed: float, step: int | None = None,
                    steps: int | None = None, width: int = 24) -> str:
    """One progress line.

    Args:
        t: simulated time reached [s].
        stop: end of the run [s].
        elapsed: wall time since the start [s].
        step, steps: steps done and in total, when known.
        width: characters of the bar.

    Example: ``[██████████░░░░░░░░░░░░░░]  42%  t = 42 ms / 100 ms  4200/10000 steps  21 ms/s
    2100 steps/s  3 s left`` (``21 ms/s``: simulated time per wall-clock second).
    """
    fraction = min(max(t / stop, 0.0), 1.0) if stop > 0 else 0.0
    if steps:
        fraction = min(max(step / steps, 0.0), 1.0)
    filled = int(round(fraction * width))
    parts = [f"[{'█' * filled}{'░' * (width - filled)}] {100 * fraction:3.0f}%",
             f"t = {format_si(t, 's', 3)} / {format_si(stop, 's', 3)}"]
    if step is not None:
        parts.append(f"{step}/{steps} steps" if steps else f"{step} steps")
    if elapsed > 0:
        parts.append(f"{format_si(t / elapsed, 's', 3)}/s")
        if step is not None:
            parts.append(f"{step / elapsed:.0f} steps/s")
        if 0 < fraction < 1:
            parts.append(f"{elapsed * (1 - fraction) / fraction:.0f} s left")
    return "  ".join(parts)


class ProgressBar:
    """Progress callback ``bar(t, stop[, step, steps])`` drawing on a terminal.

    Args:
        stream: where to draw (default ``sys.stderr``).
        enabled: force on or off; default: on when ``stream`` is a terminal.
        delay: wall seconds before the first drawing (runs shorter than that show nothing).
        clock: a ``time.monotonic``-like function (for tests).
    """

    def __init__(self, stream: TextIO | None = None, enabled: bool | None = None,
                 delay: float = 1.0, clock: Callable[[], float] = time.monotonic):
        self.stream = stream if stream is not None else sys.stderr
        if enabled is None:
            isatty = getattr(self.stream, "isatty", None)
            enabled = bool(isatty and isatty())
        self.enabled = enabled
        self.delay = delay
        self.clock = clock
        self.started = clock()
        self.shown = False
        self._width = 0

    def __call__(self, t: float, stop: float, step: int | None = None,
                 steps: int | None = None) -> None:
        if not self.enabled:
            return
        elapsed = self.clock() - self.started
        if elapsed < self.delay and not self.shown:
            return
        line = format_progress(t, stop, elapsed, step, steps)
        padding = " " * max(self._width - len(line), 0)  # wipe a longer previous line
        self._width = len(line)
        self.stream.write(f"\r{line}{padding}")
        self.stream.flush()
        self.shown = True

    def close(self) -> None:
        """End the progress line (if one was drawn)."""
        if self.shown:
            self.stream.write("\n")
            self.stream.flush()
            self.shown = False


def format_count(done: int, total: int, elapsed: float, what: str = "points", width: int = 24) -> str:
    """One progress line for work counted in items (the points of a sweep).

    Example: ``[██████████░░░░░░░░░░░░░░]  42%  8/19 points  2.1 points/s  5 s left``.
    """
    fraction = min(max(done / total, 0.0), 1.0) if total > 0 else 1.0
    filled = int(round(fraction * width))
    parts = [f"[{'█' * filled}{'░' * (width - filled)}] {100 * fraction:3.0f}%", f"{done}/{total} {what}"]
    if elapsed > 0 and done > 0:
        parts.append(f"{done / elapsed:.3g} {what}/s")
        if done < total:
            parts.append(f"{elapsed * (total - done) / done:.0f} s left")
    return "  ".join(parts)


class CountBar(ProgressBar):
    """Progress callback ``bar(done, total)`` counting finished items (sweep points); the
    same terminal rules as :class:`ProgressBar`."""

    def __init__(self, stream: TextIO | None = None, enabled: bool | None = None, delay: float = 1.0,
                 clock: Callable[[], float] = time.monotonic, what: str = "points"):
        super().__init__(stream, enabled, delay, clock)
        self.what = what

    def __call__(self, done: int, total: int, *_: object) -> None:  # type: ignore[override]
        if not self.enabled:
            return
        elapsed = self.clock() - self.started
        if elapsed < self.delay and not self.shown:
            return
        line = format_count(done, total, elapsed, self.what)
        padding = " " * max(self._width - len(line), 0)
        self._width = len(line)
        self.stream.write(f"\r{line}{padding}")
        self.stream.flush()
        self.shown = True
