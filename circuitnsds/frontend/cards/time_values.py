"""Element values written as expressions of ``time``: ``R1 a b {time < 12m ? 10 : 5}``,
``V1 a 0 {time > 1m ? 5 : 0}``.

The ideal engine is exact for a value that is *piecewise constant* in time with known
corners: ``time`` may appear only compared with a constant (``time < 12m``, ``2m >= time``),
inside conditions (``? :``, ``&&``, ``||``, ``!``). The constants are the corners; between
them the value is constant and is found by evaluating the expression there.

* a resistor becomes a :class:`~circuitnsds.circuit.elements.time_switched.TimeSwitchedResistor`;
* a V or I source becomes the PWL of the same steps (vertical corners);
* a capacitor or inductor is refused (what a stepping C or L does to its charge or flux is a
  modelling choice circuitnsds does not make for the user), as is a value that varies
  continuously (``1 + time*1k``): the engine's matrices are constant in time, and an
  approximation would give a wrong answer without saying so. Each refusal says what to
  write instead.
"""

from __future__ import annotations

from circuitnsds.circuit.elements.base import Element
from circuitnsds.frontend.cards.reader import StatementReader
from circuitnsds.netlist.behavioural import Node, parse, to_text
from circuitnsds.netlist.expressions import ExpressionError, evaluate
from circuitnsds.system.stimuli import Pwl

_COMPARISONS = frozenset({"<", ">", "<=", ">=", "==", "!="})
_QUANTITY = {"r": "resistance", "c": "capacitance", "l": "inductance", "v": "voltage", "i": "current"}


class _Continuous(ValueError):
    """``time`` appears outside a comparison with a constant."""


def time_valued_element(reader: StatementReader, letter: str) -> Element:
    """The element of ``R|V|I name n1 n2 {expr of time}`` (see the module docstring).

    Raises:
        NetlistError: a C or L, a value varying continuously with time, or a non-positive
            resistance, naming the element and what to write instead.
    """
    from circuitnsds.circuit.elements.sources import CurrentSource, VoltageSource

    name, nodes = reader.name, reader.nodes(2)
    text = reader.next(_QUANTITY[letter])[1:-1]
    if not reader.done():
        raise reader.error(f"{name}: unexpected {reader.peek()!r} after the value {{{text}}}")
    nonlinear = _probes(parse(text))
    if nonlinear:
        raise reader.error(f"{name}: a {_QUANTITY[letter]} that depends on {', '.join(nonlinear)} is a "
                           "smooth nonlinear element: not supported (smooth nonlinear devices are "
                           "the next step, issue 33)", hint="write a constant value, or model the "
                           "change as values that step: separate elements switched in and out by S "
                           "switches")
    if letter in "cl":
        raise reader.error(f"{name}: a {_QUANTITY[letter]} that depends on time ({{{text}}}) is not "
                           "supported", hint="write the values as separate elements switched in and "
                           "out by an S switch driven by a PULSE or PWL source")
    steps = _steps(reader, name, _QUANTITY[letter], text)
    if letter in "vi":
        source = VoltageSource if letter == "v" else CurrentSource
        return source(name, nodes, reader.location, function=_pwl(steps))
    return _resistor(reader, name, nodes, text, steps)


def _steps(reader: StatementReader, name: str, quantity: str, text: str) -> list[tuple[float, float]]:
    """``[(corner, value after it), ...]`` from time 0 (the first corner is 0), a corner
    only where the value changes."""
    try:
        corners: set[float] = set()
        _corners(parse(text), corners)
        times = sorted(c for c in corners if c > 0)
        probes = [times[0] / 2] if times else [0.0]
        probes += [(a + b) / 2 for a, b in zip(times, times[1:])]
        probes += [2 * times[-1]] if times else []
        values = [evaluate(text, {"time": t}) for t in probes]
    except _Continuous:
        raise reader.error(
            f"{name}: {quantity} {{{text}}} varies continuously with time: not "
            "supported (circuitnsds is exact for values that step at known instants, where time "
            "is only compared with constants; its matrices cannot change between steps)",
            hint="write it as steps, e.g. {time < 1m ? 1k : time < 2m ? 1.5k : 2k}, or, for a "
            "source, as PWL(t1 v1 t2 v2 ...) or SIN(...)") from None
    except ExpressionError as exc:
        raise reader.error(f"{name}: {exc}", hint=f"in: {reader.statement.text}") from None
    steps = [(0.0, values[0])]
    for corner, value in zip(times, values[1:]):
        if value != steps[-1][1]:
            steps.append((corner, value))
    return steps


def _corners(tree: Node, corners: set[float]) -> None:
    """Collect the constants ``time`` is compared with; :class:`_Continuous` if it appears
    otherwise."""
    kind = tree[0]
    if kind == "name" and tree[1] == "time":
        raise _Continuous
    if kind == "op" and tree[1] in _COMPARISONS:
        left, right = tree[2], tree[3]
        for side, other in ((left, right), (right, left)):
            if side == ("name", "time") and not _uses_time(other):
                corners.add(evaluate(to_text(other)))
                return
    for child in tree[1:]:
        if isinstance(child, tuple):
            if child and isinstance(child[0], str):
                _corners(child, corners)
            else:  # the arguments of a call
                for argument in child:
                    _corners(argument, corners)


def _probes(tree: Node) -> list[str]:
    """The probes ``v(a)``, ``v(a,b)``, ``i(v1)`` of an expression tree, in order, once each."""
    found: list[str] = []

    def walk(item: Node) -> None:
        if item[0] in {"v", "i"}:
            text = to_text(item)
            if text not in found:
                found.append(text)
            return
        for child in item[1:]:
            if isinstance(child, tuple) and child:
                if isinstance(child[0], str):
                    walk(child)
                else:
                    for argument in child:
                        walk(argument)

    walk(tree)
    return found


def _uses_time(tree: Node) -> bool:
    if tree[0] == "name":
        return tree[1] == "time"
    return any(_uses_time(c) if c and isinstance(c[0], str) else any(_uses_time(a) for a in c)
               for c in tree[1:] if isinstance(c, tuple))


def _pwl(steps: list[tuple[float, float]]) -> Pwl:
    """The PWL of ``steps`` with vertical corners (left-continuous, as every corner of a
    circuitnsds source: the new value holds from the step that starts at the corner)."""
    times, values = [0.0], [steps[0][1]]
    for corner, value in steps[1:]:
        times += [corner, corner]
        values += [values[-1], value]
    return Pwl(tuple(times), tuple(values))


def _resistor(reader: StatementReader, name: str, nodes: tuple[str, ...], text: str,
              steps: list[tuple[float, float]]) -> Element:
    from circuitnsds.circuit.elements.passive import Resistor
    from circuitnsds.circuit.elements.time_switched import TimeSwitchedResistor

    resistances = tuple(dict.fromkeys(value for _, value in steps))
    for value in resistances:
        if not value > 0 or value == float("inf"):
            raise reader.error(f"{name}: resistance {{{text}}} takes the value {value:g}; it must be "
                               "positive and finite at every instant",
                               hint="use a switch (S) for an open or a short circuit")
    if len(resistances) == 1:
        return Resistor(name, nodes, reader.location, resistance=resistances[0])
    selectors = tuple(_pwl([(t, 1.0 if value == r else 0.0) for t, value in steps]) for r in resistances)
    return TimeSwitchedResistor(name, nodes, reader.location, resistances=resistances,
                                selectors=selectors, expression=text)
