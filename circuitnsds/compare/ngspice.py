"""Running a netlist in ngspice (shared library, through PySpice) and reading the result.

ngspice is loaded once per process (``libngspice.so`` via PySpice's
``NgSpiceShared``) and reused: each run loads the translated netlist, runs its
``.tran`` in the foreground, copies the vectors out, then destroys the plots and
removes the circuit, so that a failed run leaves the library ready for the next.

ngspice's messages are captured (never printed): a run that stops early ("Timestep
too small", "singular matrix", "no convergence", ...) is a result,
:class:`NgspiceRun` with ``status == "failed"``, the reason and the time reached,
not an exception. PySpice's log (including its warning that ngspice newer than 34
is "unsupported"; it works) is silenced while ngspice is in use.
"""

from __future__ import annotations

import logging
import re
import threading
import time
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np

from circuitnsds.compare.errors import INSTALL_HINT, NgspiceUnavailable
from circuitnsds.compare.translate import DiodeOverrides, ngspice_vector
from circuitnsds.output.waveforms import Waveforms

#: Message fragments that say why ngspice stopped, most specific first.
FAILURE_PATTERNS = (
    "timestep too small", "singular matrix", "no convergence", "iteration limit",
    "gmin stepping failed", "source stepping failed", "transient op failed", "doanalyses",
    "circuit not parsed", "error", "aborted",
)
_TIME = re.compile(r"\btime\s*=\s*([-+0-9.eE]+)")

_lock = threading.Lock()
_engine = None
_engine_error: NgspiceUnavailable | None = None


@dataclass
class NgspiceRun:
    """One ngspice transient.

    Attributes:
        status: ``"ok"`` (reached the stop time), ``"failed"`` (stopped early: see
            ``message`` and ``stopped_at``) or ``"rejected"`` (ngspice did not accept
            the netlist and ran nothing; ``message`` holds its parser's lines).
        message: ngspice's own words for a failure (empty when ``ok``).
        stopped_at: last time point computed [s] (``None`` when nothing was computed).
        waveforms: the vectors on ngspice's own (adaptive) time points, named as in
            circuitnsds (``v(out)``, ``i(d1)``); partial for a failed run, ``None``
            when rejected. Signs are circuitnsds's (which are SPICE's).
        seconds: wall time of ngspice's ``run`` command (parsing excluded) [s].
        version: ``"ngspice-39"``.
        overrides: the diode parameters forced on every ``D`` model.
        missing: requested signals ngspice did not provide.
        messages: ngspice's stderr lines (and stdout lines that mention errors).
        netlist: the netlist text ngspice was given.
        measurements: the ``.meas`` results ngspice printed (``name -> value``), when the
            netlist kept its ``.meas`` lines (``translate_netlist(..., measures=True)``).
    """

    status: str
    message: str = ""
    stopped_at: float | None = None
    waveforms: Waveforms | None = None
    seconds: float = 0.0
    version: str = ""
    overrides: DiodeOverrides = field(default_factory=DiodeOverrides)
    missing: list[str] = field(default_factory=list)
    messages: list[str] = field(default_factory=list)
    netlist: str = ""
    measurements: dict[str, float] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        return self.status == "ok"


@contextmanager
def quiet_pyspice() -> Iterator[None]:
    """Silence PySpice's logger (and its "Unsupported Ngspice version" warning) for a while."""
    logger = logging.getLogger("PySpice")
    level = logger.level
    logger.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        logger.setLevel(level)


def _load_engine():
    """The process-wide ngspice instance (created on first use)."""
    global _engine, _engine_error
    if _engine is not None:
        return _engine
    if _engine_error is not None:
        raise _engine_error
    try:
        from PySpice.Spice.NgSpice.Shared import NgSpiceShared
    except ImportError as exc:
        _engine_error = NgspiceUnavailable(f"PySpice is not installed ({exc})", where="ngspice comparison",
                                           hint=INSTALL_HINT)
        raise _engine_error from None

    class _Engine(NgSpiceShared):
        """NgSpiceShared that keeps every message ngspice writes."""

        def __init__(self) -> None:
            self.lines: list[str] = []
            super().__init__(ngspice_id=0, send_data=False)

        def send_char(self, message: str, ngspice_id: int) -> int:
            self.lines.append(message)
            return 0

    try:
        with _clean_start():
            _engine = _Engine()
    except OSError as exc:
        library = (NgSpiceShared.LIBRARY_PATH or "libngspice.so").format("")
        _engine_error = NgspiceUnavailable(f"ngspice's shared library {library} cannot be loaded ({exc})",
                                           where="ngspice comparison", hint=INSTALL_HINT)
        raise _engine_error from None
    return _engine


@contextmanager
def _clean_start() -> Iterator[None]:
    """Start ngspice where no start-up script of a downloaded project or of the user runs.

    ngspice 39's shared library, when it starts, runs its system ``spinit`` and then one
    ``.spiceinit``: the current folder's if there is one, else the one in the user's home
    folder (found through the password database, not ``$HOME``). Both are ngspice
    scripts (``shell``, ``write``, ...). ngspice is therefore started inside a fresh
    private folder holding an empty ``.spiceinit``: that one is read, the others are not.
    The current folder is restored at once (ngspice reads no file later: the compared
    deck has its includes inlined).
    """
    import os
    import tempfile

    try:
        previous: str | None = os.getcwd()
    except OSError:  # the current folder was removed: nothing to go back to
        previous = None
    with tempfile.TemporaryDirectory(prefix="circuitnsds-ngspice-start-") as folder:
        with open(os.path.join(folder, ".spiceinit"), "w", encoding="ascii") as init:
            init.write("* empty: no user or project start-up script runs in circuitnsds compare\n")
        os.chdir(folder)
        try:
            yield
        finally:
            if previous is not None:
                os.chdir(previous)


def ngspice_version() -> str:
    """``"ngspice-39"`` (raises :class:`NgspiceUnavailable` when ngspice or PySpice is missing)."""
    with _lock, quiet_pyspice():
        return f"ngspice-{_load_engine().ngspice_version}"


def pyspice_version() -> str:
    try:
        import PySpice
    except ImportError:
        return ""
    return str(getattr(PySpice, "__version__", ""))


def run_ngspice(
    netlist: str,
    signals: Iterable[str],
    stop: float,
    *,
    overrides: DiodeOverrides | None = None,
    title: str = "",
    ltspice: bool = False,
) -> NgspiceRun:
    """Run a translated netlist's ``.tran`` in ngspice.

    Args:
        netlist: ngspice netlist text (see :func:`circuitnsds.compare.translate.translate_netlist`,
            whose ``saves`` must list the device parameters the signals need).
        signals: circuitnsds signal names to return (``v(out)``, ``i(d1)``, ...).
        stop: the ``.tran`` stop time [s]; a run that ends earlier has failed.
        overrides: recorded in the result (already applied to ``netlist``).
        title: title of the returned waveforms.
        ltspice: read the netlist in ngspice's LTspice compatibility mode (``set
            ngbehavior=lta`` before loading, as a ``.spiceinit`` would; unset afterwards).

    Raises:
        NgspiceUnavailable: PySpice or ``libngspice.so`` is missing.
    """
    signals = [name.strip().lower() for name in signals]
    with _lock, quiet_pyspice():
        engine = _load_engine()
        result = NgspiceRun("ok", version=f"ngspice-{engine.ngspice_version}",
                            overrides=overrides or DiodeOverrides(), netlist=netlist)
        engine.lines.clear()
        try:
            if ltspice:
                _call(engine.exec_command, "set ngbehavior=lta")
            _call(engine.load_circuit, netlist)
            load_errors = [line for line in _stderr(engine.lines) if _is_load_error(line)]
            parse_messages = _stderr(engine.lines)
            before = set(engine.plot_names)
            start = time.perf_counter()
            completed = _call(engine.run)
            result.seconds = time.perf_counter() - start
            plots = [name for name in engine.plot_names if name not in before and name.startswith("tran")]
            result.messages = _messages(engine.lines)
            result.measurements = _measurements(engine.lines)
            if not plots and load_errors:
                # the circuit was not loaded (the previous one was removed: nothing ran)
                result.status = "rejected"
                result.message = "; ".join(parse_messages[:6])
                return result
            if plots:
                result.waveforms, result.missing = _read_plot(engine, plots[0], signals, title)
            reached = float(result.waveforms.time[-1]) if result.waveforms is not None \
                and result.waveforms.time.size else None
            result.stopped_at = reached
            if not plots or reached is None or reached < stop * (1 - 1e-9):
                result.status = "failed"
                result.message = _reason(engine.lines) or (
                    "ngspice stopped early" if completed else "ngspice's run command failed")
                if reached is None:
                    match = _TIME.search(result.message)
                    result.stopped_at = float(match.group(1)) if match else None
        finally:
            _reset(engine)
    return result


def _call(function, *args) -> bool:
    """Call a PySpice method; ``False`` when PySpice raised because ngspice reported an error.

    PySpice raises on any non-warning line on stderr, including harmless notes; the
    outcome is judged from the vectors and messages instead.
    """
    from PySpice.Spice.NgSpice.Shared import NgSpiceCircuitError, NgSpiceCommandError

    try:
        function(*args)
    except (NgSpiceCommandError, NgSpiceCircuitError):
        return False
    except NameError as exc:  # PySpice's "ngSpice_Circ returned 1": the circuit was not loaded
        if "returned" not in str(exc):
            raise
        return False
    return True


def _reset(engine) -> None:
    """Free the plots and the circuit so the next run starts clean (errors ignored)."""
    for command in ("destroy all", "remcirc", "unset ngbehavior"):
        _call(engine.exec_command, command)
    engine.lines.clear()


_MEASURED = re.compile(r"^(\S+)\s*=\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)(?:\s|$)")


def _measurements(lines: list[str]) -> dict[str, float]:
    """``name = value ...`` lines of ngspice's ``.meas`` output on stdout."""
    found = {}
    for line in lines:
        stream, _, content = line.partition(" ")
        match = _MEASURED.match(content.strip()) if stream == "stdout" else None
        if match:
            found[match.group(1).lower()] = float(match.group(2))
    return found


def _stderr(lines: list[str]) -> list[str]:
    return [line.partition(" ")[2].strip() for line in lines if line.startswith("stderr")]


def _messages(lines: list[str]) -> list[str]:
    """stderr lines, and stdout lines that mention an error or a warning."""
    kept = []
    for line in lines:
        stream, _, content = line.partition(" ")
        content = content.strip()
        if content and (stream == "stderr" or re.search(r"error|warning|too small|singular", content, re.I)):
            kept.append(content)
    return kept


def _is_load_error(line: str) -> bool:
    """A message of ngspice's parser that means the circuit was not loaded."""
    return line.lower().startswith("error") or "circuit not parsed" in line.lower()


def _reason(lines: list[str]) -> str:
    """The most telling failure line among ngspice's messages (empty when none)."""
    messages = _messages(lines)
    for pattern in FAILURE_PATTERNS:
        for message in messages:
            if pattern in message.lower() and not message.lower().startswith("warning: model issue"):
                return message
    return ""


def _read_plot(engine, plot: str, signals: list[str], title: str) -> tuple[Waveforms, list[str]]:
    vectors = engine.plot(None, plot)
    arrays = {name.lower(): np.real(np.asarray(vector._data)).astype(float)
              for name, vector in vectors.items()}
    time_points = arrays.get("time", np.zeros(0))
    values, missing = {}, []
    for signal in signals:
        vector = ngspice_vector(signal)[0]
        # ngspice names the vector of a node whose name starts with a digit V(1), not 1; a
        # diode's current is its ammeter's, or @d1[id] in a netlist run without ammeters
        candidates = ((vector, f"v({vector})") if signal.startswith("v(")
                      else (vector, ngspice_vector(signal, ammeter=False)[0]))
        found = [name for name in candidates
                 if name in arrays and arrays[name].shape == time_points.shape]
        if found:
            values[signal] = arrays[found[0]]
        else:
            missing.append(signal)
    return Waveforms(time_points, values, title=title, stats={"points": float(time_points.size)}), missing


def run_ngspice_ac(netlist: str, vectors: Iterable[str]) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """Run the ``.ac`` of an ngspice netlist; returns the frequencies [Hz] and each vector
    asked for (ngspice names, e.g. ``v(out)``) as complex arrays.

    Raises:
        NgspiceUnavailable: PySpice or ``libngspice.so`` is missing.
        RuntimeError: ngspice produced no AC plot (its messages say why) or lacks a vector.
    """
    with _lock, quiet_pyspice():
        engine = _load_engine()
        engine.lines.clear()
        try:
            _call(engine.load_circuit, netlist)
            before = set(engine.plot_names)
            _call(engine.run)
            plots = [name for name in engine.plot_names if name not in before and name.startswith("ac")]
            if not plots:
                raise RuntimeError("ngspice ran no .ac: " + "; ".join(_messages(engine.lines)[:6]))
            found = {name.lower(): np.asarray(vector._data) for name, vector in
                     engine.plot(None, plots[0]).items()}
            frequencies = np.real(found["frequency"]).astype(float)
            result = {}
            for name in vectors:
                key = ngspice_vector(name.lower())[0]
                if key not in found:
                    raise RuntimeError(f"ngspice's .ac has no vector {key} (it has {', '.join(found)})")
                result[name.lower()] = found[key].astype(complex)
        finally:
            _reset(engine)
    return frequencies, result
