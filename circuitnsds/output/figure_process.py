"""Draw the command's waveform figure in a second process, so matplotlib's import overlaps the run.

Importing matplotlib costs ~0.4 s and drawing and writing a PNG another ~0.2 s: more than a
short run itself. When ``circuitnsds run --plot`` starts, :class:`FigureProcess` starts a
child Python that imports matplotlib (and the figure code) at once, on the second core, while
this process reads the netlist and simulates. After the run, :meth:`FigureProcess.send` hands
it the plotted signals (pickled, through its standard input) and the CSV is written while the
child draws; :meth:`FigureProcess.wait` says whether the child wrote the figure.

The child is only a shortcut: whenever it cannot be used (one core, no idle core, no child
started, any error or warning in the child, which then exits non-zero) the caller draws the figure itself
with :func:`circuitnsds.output.plot.plot_waveforms`, so messages, warnings and errors are
exactly those of drawing in-process. The child ignores Ctrl-C (the parent may still send it
the partial results) and ends when the parent closes or dies (end of its input).
"""

from __future__ import annotations

import os
import pickle
import subprocess
import sys
from collections.abc import Sequence
from pathlib import Path

_CHILD = "from circuitnsds.output.figure_process import serve; serve()"


def _cores() -> int:
    """Cores this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def worth_starting() -> bool:
    """Whether a second process would run beside this one: two cores or more, and one of
    them idle on average over the last minute (the load average; taken as idle where the
    system has none). A child competing for a busy core only adds its start (~0.1 s of
    CPU) to the command."""
    cores = _cores()
    try:
        load = os.getloadavg()[0]
    except (AttributeError, OSError):
        load = 0.0
    return cores >= 2 and load <= cores - 1


class FigureProcess:
    """A child process ready to draw one figure (see the module docstring).

    Use as a context manager: leaving it ends a child that was never used or is still
    drawing (the figure then comes from the caller, see :meth:`wait`).

    Args:
        start: start the child; default :func:`worth_starting`.
    """

    def __init__(self, start: bool | None = None) -> None:
        self._child: subprocess.Popen | None = None
        if not (worth_starting() if start is None else start):  # drawing in-process is cheaper
            return
        package_root = str(Path(__file__).resolve().parents[2])  # the same circuitnsds as ours
        code = f"import sys; sys.path.insert(0, {package_root!r}); {_CHILD}"
        try:
            # -P: not the current folder first on the path (a user's pickle.py, numpy.py ...
            # there would be run instead of the module)
            self._child = subprocess.Popen([sys.executable, "-P", "-c", code], stdin=subprocess.PIPE,
                                           stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        except OSError:
            self._child = None

    def __enter__(self) -> FigureProcess:
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()

    def send(self, waves, path: str | Path, names: Sequence[str] | None, dpi: int = 120,
             events: bool = False) -> bool:
        """Hand the child the figure to draw: the signals of ``waves`` it plots (``names``,
        default :func:`~circuitnsds.output.plot.default_signals`) to write to ``path``.
        Returns ``False`` when there is no child to draw it (the caller draws it then)."""
        from circuitnsds.output.plot import default_signals

        if self._child is None or self._child.poll() is not None:
            return False
        chosen = default_signals(waves) if names is None else [n.strip().lower() for n in names]
        job = {"time": waves.time, "title": waves.title, "names": chosen, "path": str(path),
               "dpi": dpi, "events": events,
               "signals": {n: waves[n] for n in chosen if n != "time" and n in waves},
               "switchings": [tuple(event) for event in waves.events] if events else []}
        try:
            pickle.dump(job, self._child.stdin, protocol=pickle.HIGHEST_PROTOCOL)
            self._child.stdin.close()
        except (OSError, ValueError):  # the child has gone
            self.close()
            return False
        return True

    def wait(self) -> bool:
        """Whether the child drew and wrote the figure sent to it (waits for it)."""
        if self._child is None:
            return False
        done = self._child.wait() == 0
        self._child = None
        return done

    def close(self) -> None:
        """End the child if it still runs (unused, or its figure no longer wanted)."""
        if self._child is not None:
            if self._child.poll() is None:  # SIGTERM: its temporary file is removed
                self._child.terminate()
                try:
                    self._child.wait(timeout=2.0)
                except subprocess.TimeoutExpired:
                    self._child.kill()
            self._child.wait()
            if self._child.stdin is not None:
                try:
                    self._child.stdin.close()
                except OSError:
                    pass
            self._child = None


def serve() -> None:
    """The child: import matplotlib, read one pickled figure job from standard input, draw and
    write it; exit 0 when written, 1 on any error or warning, 2 when no job came."""
    import signal
    import threading
    import warnings

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(1))  # ended by the parent: clean up
    received: list[bytes] = []
    reader = threading.Thread(target=lambda: received.append(sys.stdin.buffer.read()), daemon=True)
    reader.start()  # drains the pipe at once: the parent never waits for our imports
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # a warning: the parent redraws and reports it
            import matplotlib.backends.backend_agg  # noqa: F401
            import matplotlib.figure  # noqa: F401

            from circuitnsds.output.plot import plot_waveforms
            from circuitnsds.output.waveforms import Waveforms

            reader.join()
            if not received or not received[0]:
                os._exit(2)
            job = pickle.loads(received[0])
            waves = Waveforms(job["time"], job["signals"], title=job["title"],
                              events=job["switchings"])
            plot_waveforms(waves, job["path"], job["names"], dpi=job["dpi"], events=job["events"])
    except BaseException:  # noqa: BLE001 (any failure: the parent draws it and reports)
        os._exit(1)
    sys.stdout.flush()
    os._exit(0)
