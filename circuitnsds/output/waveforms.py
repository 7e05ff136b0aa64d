"""Simulation results: time and named signals as float64 numpy arrays (SI units)."""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping, MutableMapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TextIO

import numpy as np


class LazySignals(MutableMapping):
    """Signal name -> values, each computed the first time it is read, then kept.

    A transient run returns its signals this way: a run of a million steps that
    writes one signal computes one column, not every output of the circuit.
    ``dict(signals)`` computes them all; so does pickling (it pickles as a dict).
    Signals may be added, replaced or deleted as in a dict.
    """

    def __init__(self, names: Iterable[str], compute: Callable[[str], np.ndarray]):
        self._names = list(names)
        self._known = set(self._names)
        self._compute = compute
        self._values: dict[str, np.ndarray] = {}

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self._values:
            if name not in self._known:
                raise KeyError(name)
            self._values[name] = self._compute(name)
        return self._values[name]

    def __setitem__(self, name: str, values: np.ndarray) -> None:
        if name not in self._known:
            self._names.append(name)
            self._known.add(name)
        self._values[name] = values

    def __delitem__(self, name: str) -> None:
        if name not in self._known:
            raise KeyError(name)
        self._names.remove(name)
        self._known.discard(name)
        self._values.pop(name, None)

    def __iter__(self) -> Iterator[str]:
        return iter(list(self._names))

    def __len__(self) -> int:
        return len(self._names)

    def __reduce__(self):
        return dict, (dict(self),)

    def __repr__(self) -> str:
        return f"LazySignals({self._names!r}, computed: {sorted(self._values)!r})"


@dataclass
class Waveforms:
    """Signals on a common time grid.

    Signal names follow ngspice, lower case: ``v(out)`` node voltage [V],
    ``i(l1)`` inductor current [A] (from its first to its second node),
    ``i(v1)`` source current [A] (into ``n+`` through the source),
    ``i(d1)`` net diode current [A] (anode to cathode), ``i(r1)`` resistor current.

    Attributes:
        time: instants [s].
        signals: name -> values (a dict, or a :class:`LazySignals` that computes each
            signal when first read).
        impulses: device name -> charge [C] that passed in the step ending at each
            instant (``μ`` of the scheme; a dict, or a :class:`LazySignals`). Where a
            state jumps, the current is a Dirac: its weight is this charge, which does not
            shrink with the step.
        residual: scaled complementarity residual of every step.
        flux_impulses: inductor name -> flux [V·s] of a Dirac voltage across it in the step
            ending at each instant, ``L·Δi`` where its current was cut in one step (an opening
            switch with no other path), 0 elsewhere; only inductors with such a step appear.
            The voltage shown at that step (``L·Δi/h``, or ``I·Roff``) depends on the step.
        title: the netlist title.
        stats: solver counters and wall time.
        events: every switching of an ``S``, ``W`` or ``M`` switch in time order, as
            ``(time [s], element, state)`` named tuples (``state``: closed = true). A switch
            controlled by a circuit quantity switches at the located crossing of its
            threshold, between grid points; one controlled by a source at the grid point
            its threshold crossing is (docs/method.md, event location).
    """

    time: np.ndarray
    signals: Mapping[str, np.ndarray]
    impulses: Mapping[str, np.ndarray] = field(default_factory=dict)
    residual: np.ndarray | None = None
    title: str = ""
    stats: dict[str, float] = field(default_factory=dict)
    events: list[tuple[float, str, bool]] = field(default_factory=list)
    flux_impulses: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def names(self) -> list[str]:
        """Signal names, in output order."""
        return list(self.signals)

    def __getitem__(self, name: str) -> np.ndarray:
        key = name.strip().lower()
        if key == "time":
            return self.time
        if key not in self.signals:
            raise KeyError(f"no signal {name!r}; available: {', '.join(self.signals)}")
        return self.signals[key]

    def __contains__(self, name: str) -> bool:
        return name.strip().lower() in self.signals or name.strip().lower() == "time"

    def impulse(self, device: str) -> np.ndarray:
        """Charge [C] through ``device`` in each step (see ``impulses``)."""
        return self.impulses[device.lower()]

    def flux_impulse(self, inductor: str) -> np.ndarray:
        """Flux [V·s] of the Dirac voltage across ``inductor`` in each step (see
        ``flux_impulses``; zeros for an inductor whose current was never cut)."""
        return self.flux_impulses.get(inductor.lower(), np.zeros(self.time.size))

    def select(self, names: Iterable[str]) -> Waveforms:
        """A copy with only the named signals (raises ``KeyError`` for an unknown one)."""
        chosen = {name.strip().lower(): self[name] for name in names}
        return Waveforms(self.time, chosen, self.impulses, self.residual, self.title, self.stats,
                         self.events, self.flux_impulses)

    def switchings(self, element: str, state: bool | None = None) -> np.ndarray:
        """Instants [s] at which ``element`` switched (to ``state`` only, when given)."""
        name = element.strip().lower()
        return np.array([e[0] for e in self.events
                         if e[1] == name and (state is None or e[2] == state)], dtype=float)

    def events_to_csv(self, path: str | Path) -> None:
        """Write the switchings as CSV: ``time,element,state`` (state 1 = closed, 0 = open)."""
        from circuitnsds.output.files import atomic_path

        with atomic_path(path) as temporary, open(temporary, "w", encoding="utf-8") as handle:
            handle.write("time,element,state\n")
            for time, element, state in self.events:
                handle.write(f"{time:.12g},{element},{int(state)}\n")

    def to_dataframe(self):
        """A pandas DataFrame indexed by time (pandas must be installed)."""
        import pandas as pd

        return pd.DataFrame(dict(self.signals), index=pd.Index(self.time, name="time"))

    def to_raw(self, path: str | Path, names: Iterable[str] | None = None, *,
               binary: bool = True) -> None:
        """Write a SPICE raw file as ngspice's ``write`` does (see :mod:`circuitnsds.output.rawfile`)."""
        from circuitnsds.output.rawfile import write_raw

        write_raw(self, path, names, binary=binary)

    def to_csv(self, path: str | Path | TextIO, names: Iterable[str] | None = None) -> None:
        """Write ``time`` and the signals (all by default) as CSV with a header row, every
        number to full precision (:mod:`circuitnsds.output.csvfile`).

        ``path`` is a file name (written to a temporary file, then renamed over it: an
        interrupted write leaves the previous file) or an open text stream.
        """
        from circuitnsds.output.csvfile import write_csv
        from circuitnsds.output.files import atomic_path

        columns = list(names) if names is not None else self.names
        labels = [f'"{name}"' if "," in name else name  # v(a,b) quoted
                  for name in (n.strip().lower() for n in columns)]
        values = [self[name] for name in columns]
        if hasattr(path, "write"):
            write_csv(path, self.time, labels, values)
            return
        with atomic_path(path) as temporary, open(temporary, "wb") as stream:
            write_csv(stream, self.time, labels, values)
