"""XSPICE ``d_pwm`` (ngspice's duty-cycle-controlled digital oscillator) as an ideal
comparator: ``A name cntl_in out MODEL`` with ``.model MODEL d_pwm(cntl_array=[...]
dc_array=[...] frequency=F init_phase=P)``.

ngspice's model (``src/xspice/icm/digital/d_pwm/cfunc.mod``) runs a phase
``φ(t) = frac(P/360 + F·t)`` (``P`` in degrees, ``F`` in Hz); the duty cycle ``dc`` is the
piecewise-linear function of the control input through the points
``(cntl_array[k], dc_array[k])``, extrapolated with the end segments' slopes and clamped to
``[0, 1]``. In each period the output is 0 while ``φ < 1 − dc`` and 1 from there to the end
of the period: a trailing-edge PWM whose rising edge moves with the input.

Here that is a :class:`~circuitnsds.circuit.elements.behavioural.Select` on
``φ(t) + dc(in) − 1``: the sawtooth ``φ`` is an internal ideal source (``<part>.ramp``, a
:class:`~circuitnsds.system.stimuli.Sawtooth`, node ``<part>.ramp``), ``dc`` is
affine in ``max(in − x_k, 0)`` auxiliaries (and a ``min``/``max`` clamp where the table can
leave ``[0, 1]``), so every edge is an event located by the engine. What differs from
ngspice:

* no ``rise_delay``/``fall_delay`` (1 ns by default in ngspice), as for the other digital
  parts;
* ngspice's output is 0 at time 0 and, when the phase already lies beyond ``1 − dc`` then,
  stays 0 to the end of the first period; here it is 1 for that first partial period (the
  control's value at time 0 is not known when the line is read: ``docs/control.md`` names
  the case);
* ngspice holds the output at 1 to the period's end once it has risen, even if the duty
  cycle then falls below the elapsed fraction; the comparator falls then. The two agree
  whenever the threshold ``1 − dc`` moves slower than the phase (``|d dc/dt| < F``), as
  for any input much slower than the carrier.
"""

from __future__ import annotations

import math

from circuitnsds.circuit.elements.base import Element
from circuitnsds.circuit.elements.behavioural import Affine, BehaviouralSource, MinMax, Select
from circuitnsds.circuit.elements.sources import VoltageSource
from circuitnsds.frontend.cards.reader import StatementReader
from circuitnsds.frontend.cards.xspice_ports import HINT, Ports, difference
from circuitnsds.system.stimuli import Sawtooth


def check_pwm_model(reader: StatementReader, name: str, params: dict) -> None:
    """Refuse a ``d_pwm`` card whose tables or frequency have no meaning (as ngspice does)."""
    x, y = params.get("cntl_array"), params.get("dc_array")
    if x is None or y is None:
        raise reader.error(f".model {name} d_pwm: cntl_array and dc_array are both required",
                           hint="write cntl_array=[x1 x2 ...] dc_array=[d1 d2 ...] (duty cycles "
                           "0 to 1)")
    if len(x) != len(y) or len(x) < 2:
        raise reader.error(f".model {name} d_pwm: cntl_array has {len(x)} values and dc_array "
                           f"{len(y)}", hint="give the same number of values, at least two")
    if any(b <= a for a, b in zip(x, x[1:])):
        raise reader.error(f".model {name} d_pwm: cntl_array must increase",
                           hint="list the control values in increasing order")
    if any(not 0.0 <= d <= 1.0 for d in y):
        raise reader.error(f".model {name} d_pwm: dc_array values must lie in [0, 1]")
    if params.get("frequency", 1e6) < 1e-6:
        raise reader.error(f".model {name} d_pwm: frequency must be at least 1e-6 Hz")
    if not -180.0 <= params.get("init_phase", 0.0) <= 360.0:
        raise reader.error(f".model {name} d_pwm: init_phase must lie in [-180, 360] degrees")


def sawtooth(frequency: float, init_phase_deg: float) -> Sawtooth:
    """``frac(init_phase/360 + frequency·t)`` [0..1): d_pwm's phase (a negative ``init_phase``
    counts from 360°, as ngspice's model does)."""
    start = (init_phase_deg + 360.0 if init_phase_deg < 0 else init_phase_deg) / 360.0
    return Sawtooth(frequency, start - math.floor(start))


def duty_cycle(control: Affine, xs: tuple[float, ...], ys: tuple[float, ...],
               first: int) -> tuple[Affine, list[MinMax]]:
    """``dc(control)`` as ngspice's d_pwm interpolates it (end slopes extrapolated, clamped to
    [0, 1]), affine in the returned auxiliaries, numbered from ``first``."""
    slopes = [(y1 - y0) / (x1 - x0) for x0, x1, y0, y1 in zip(xs, xs[1:], ys, ys[1:])]
    voltages = {node: slopes[0] * c for node, c in control.voltages}
    auxiliaries: list[MinMax] = []
    terms: list[tuple[int, float]] = []
    for k in range(1, len(slopes)):
        change = slopes[k] - slopes[k - 1]
        if change:
            auxiliaries.append(MinMax("max", _shifted(control, -xs[k]), Affine()))
            terms.append((first + len(auxiliaries) - 1, change))
    value = Affine(voltages=tuple(voltages.items()), auxiliaries=tuple(terms),
                   constant=ys[0] - slopes[0] * xs[0] + slopes[0] * control.constant)
    if slopes[0] == 0.0 and slopes[-1] == 0.0:
        return value, auxiliaries  # the table's own values, all in [0, 1]
    floor = first + len(auxiliaries)
    auxiliaries.append(MinMax("max", value, Affine()))
    auxiliaries.append(MinMax("min", Affine(auxiliaries=((floor, 1.0),)), Affine(constant=1.0)))
    return Affine(auxiliaries=((floor + 1, 1.0),)), auxiliaries


def _shifted(value: Affine, constant: float) -> Affine:
    return Affine(voltages=value.voltages, constant=value.constant + constant)


def pwm_oscillator(reader: StatementReader, model, tokens: list[str]) -> list[Element]:
    """The elements of a ``d_pwm`` line: its output (a 0/1 V ideal source named as the part,
    whose state is the comparator) and the sawtooth source ``<part>.ramp``."""
    ports = Ports(reader, tokens)
    control = ports.port()
    out = ports.digital("out")
    if not ports.done:
        raise reader.error(f"{reader.name}: unexpected {ports.tokens[ports.position]!r} after the "
                           "ports of d_pwm", hint=HINT)
    if out.inverted:
        raise reader.error(f"{reader.name}: d_pwm's output cannot be inverted (~)",
                           hint="invert it where it is read (a d_inverter, or ~ at a dac_bridge)")
    ramp = f"{reader.name}.ramp"
    source = VoltageSource(ramp, (ramp, "0"), reader.location,
                           function=sawtooth(model.get("frequency"), model.get("init_phase")))
    dc, auxiliaries = duty_cycle(difference(control, 1.0), tuple(model.get("cntl_array")),
                                 tuple(model.get("dc_array")), first=1)
    compared = Affine(voltages=((ramp, 1.0), *dc.voltages), auxiliaries=dc.auxiliaries,
                      constant=dc.constant - 1.0)
    state = Select(compared, Affine(constant=1.0), Affine(), name=reader.name)
    controls = tuple(dict.fromkeys(n for n in (*control, ramp) if n not in {"0", out.node}))
    output = BehaviouralSource(reader.name, (out.node, "0", *controls), reader.location, output="v",
                               value=Affine(auxiliaries=((0, 1.0),)),
                               auxiliaries=(state, *auxiliaries),
                               expression=f"d_pwm {model.name}", model=model.name)
    return [output, source]
