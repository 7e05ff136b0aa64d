"""Element letter -> the card reader that makes its elements.

Which words of a line are nodes is in :data:`circuitnsds.element_letters.ELEMENT_LETTERS`;
this table says which function of :mod:`circuitnsds.frontend.cards` reads the line and what
it needs besides the line. A reader's module is imported when a netlist first uses it, so
that a netlist without MOSFETs, behavioural sources or XSPICE blocks does not load them.
``K`` lines (read after every inductor exists) and ``X`` lines (expanded before
elaboration) are not here: :mod:`circuitnsds.frontend.elaborate` handles them.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cache


@dataclass(frozen=True)
class CardContext:
    """What a card reader may need besides its line and its letter (one for the whole netlist).

    Attributes:
        models: the circuit's ``.model`` definitions by name.
        voltage_sources: names of the netlist's ``V`` elements (what ``F``/``H``/``W`` sense).
        options: the circuit's ``.options``.
        off_resistance: the default ``Roff`` [Ω] (``1/gmin``).
        bound: each reader with its arguments, made on its first line (``(module, function,
            letter)`` -> a function of the line's :class:`StatementReader`).
    """

    models: dict[str, object] = field(default_factory=dict)
    voltage_sources: set[str] = field(default_factory=set)
    options: dict[str, float | str] = field(default_factory=dict)
    off_resistance: float = 1e12
    bound: dict[tuple[str, str, str], Callable] = field(default_factory=dict, compare=False, repr=False)


@dataclass(frozen=True)
class CardReader:
    """A reader ``function(reader, *arguments)`` in ``circuitnsds.frontend.cards.<module>``;
    ``arguments`` are ``"letter"`` or names of :class:`CardContext` fields, in the order the
    function takes them. It returns one element or a list of them."""

    module: str
    function: str
    arguments: tuple[str, ...] = ()

    def load(self) -> Callable:
        """The reading function (its module imported on first use)."""
        return _function(self.module, self.function)

    def read(self, reader, letter: str, context: CardContext):
        """The element(s) of the line ``reader`` walks, whose type letter is ``letter``."""
        key = (self.module, self.function, letter)
        bound = context.bound.get(key)
        if bound is None:
            function = self.load()
            values = tuple(letter if name == "letter" else getattr(context, name) for name in self.arguments)
            bound = context.bound[key] = lambda line: function(line, *values)
        return bound(reader)


@cache
def _function(module: str, name: str) -> Callable:
    return getattr(importlib.import_module(f"circuitnsds.frontend.cards.{module}"), name)


_PASSIVE = CardReader("devices", "passive", ("letter", "models"))
_INDEPENDENT = CardReader("sources", "independent_source", ("letter",))
_CONTROLLED = CardReader("sources", "controlled_source", ("letter", "voltage_sources"))
_SWITCH = CardReader("devices", "switch", ("letter", "models", "voltage_sources"))

BEHAVIOURAL = CardReader("behavioural", "behavioural_source", ("letter", "voltage_sources"))
"""``B`` lines, and ``E``/``G`` lines written ``E1 a b VALUE={...}`` or ``TABLE`` (see
:func:`reader_for`)."""

CARD_READERS: dict[str, CardReader] = {
    "r": _PASSIVE, "c": _PASSIVE, "l": _PASSIVE,
    "v": _INDEPENDENT, "i": _INDEPENDENT,
    "e": _CONTROLLED, "f": _CONTROLLED, "g": _CONTROLLED, "h": _CONTROLLED,
    "b": BEHAVIOURAL,
    "d": CardReader("devices", "diode_line", ("models", "off_resistance")),
    "s": _SWITCH, "w": _SWITCH,
    "m": CardReader("smooth_devices", "mosfet", ("models", "options", "off_resistance")),
    "a": CardReader("xspice", "analog_block", ("models",)),
    "z": CardReader("power_devices", "power_device", ("models", "off_resistance")),
    "q": CardReader("smooth_devices", "bjt", ("models", "off_resistance")),
    "j": CardReader("smooth_devices", "jfet", ("models", "off_resistance")),
}
"""Element letter -> its card reader."""

_EXPRESSION_WORDS = frozenset({("value",), ("table",)})


def reader_for(letter: str, tokens: tuple[str, ...]) -> CardReader | None:
    """The reader of an element line with type ``letter`` and ``tokens`` (the name first), or
    ``None`` when no card reads that letter. ``E``/``G`` lines whose fourth word is ``VALUE``
    or ``TABLE`` are behavioural sources."""
    if letter in "eg" and tokens[3:4] in _EXPRESSION_WORDS:
        return BEHAVIOURAL
    return CARD_READERS.get(letter)
