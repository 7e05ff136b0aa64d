"""SIGTERM and SIGHUP stop a command as Ctrl-C (SIGINT) does.

Python turns SIGINT into :class:`KeyboardInterrupt`, which the commands handle: the
results computed so far are written (marked partial) and every temporary file is
removed. SIGTERM (``kill``, a batch system's time limit) and SIGHUP (the terminal
closed) would otherwise end the process at once, leaving a hidden temporary file and
no result. :func:`terminations_interrupt` makes them raise :class:`Terminated`, a
:class:`KeyboardInterrupt` naming the signal, so the same code handles all three.
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Iterator
from contextlib import contextmanager

#: The signals handled like SIGINT (those the platform has).
SIGNALS = tuple(getattr(signal, name) for name in ("SIGTERM", "SIGHUP") if hasattr(signal, name))


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP received (``signum``); handled as Ctrl-C is."""

    def __init__(self, signum: int):
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


@contextmanager
def terminations_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM and SIGHUP raise :class:`Terminated` in the main thread.

    After the first one, further SIGTERM/SIGHUP are ignored, so that the partial result
    gets written (SIGINT and SIGKILL still stop the process). A signal ignored when the
    block starts (``nohup`` ignores SIGHUP) stays ignored. Outside the main thread (where
    Python cannot set handlers) nothing changes.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def terminate(signum, frame):
        for number in SIGNALS:
            signal.signal(number, signal.SIG_IGN)
        raise Terminated(signum)

    previous = {}
    for number in SIGNALS:
        if signal.getsignal(number) is not signal.SIG_IGN:
            previous[number] = signal.signal(number, terminate)
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


def exit_status(interrupt: BaseException) -> int:
    """128 + the signal's number: 130 for Ctrl-C, 143 for SIGTERM, 129 for SIGHUP."""
    return 128 + getattr(interrupt, "signum", signal.SIGINT)


def described(interrupt: BaseException) -> str:
    """``"interrupted"`` (Ctrl-C) or ``"interrupted by SIGTERM"``."""
    return f"interrupted by {interrupt}" if isinstance(interrupt, Terminated) else "interrupted"
