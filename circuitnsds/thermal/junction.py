"""Junction temperatures: each device's network (junction → case) driven by its losses, the
case at a fixed temperature or on a heatsink shared by the devices.

Thermal time constants (ms to minutes) dwarf a converter's switching period, so the networks
are driven by each period's average loss (:func:`drive_intervals`; the instantaneous loss
when the circuit has no period). The tables are evaluated at the junction temperature they
produce: losses and temperatures are computed again until the temperatures change by less than
:data:`TOLERANCE` (electrothermal coupling of the tables; the circuit's own ``Ron`` is not
changed).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from circuitnsds.errors import CircuitWarning
from circuitnsds.output.waveforms import Waveforms
from circuitnsds.thermal.device_losses import DeviceLosses, device_losses
from circuitnsds.thermal.networks import FosterNetwork, as_foster
from circuitnsds.thermal.plecs import DeviceData

DEFAULT_CASE_TEMPERATURE = 25.0
"""The case temperature [°C] without ``.options tcase`` or a heatsink."""
TOLERANCE = 0.01
"""Largest change [K] of a junction temperature between two passes when they stop."""
MAX_PASSES = 30


@dataclass(frozen=True)
class ThermalSetup:
    """Where the devices' cases sit and how their networks are driven.

    Attributes:
        case_temperature: the fixed case temperature [°C] (``.options tcase``), without heatsink.
        ambient: with a heatsink, the ambient temperature [°C] (``.options tamb``).
        heatsink: the heatsink's network from its surface to ambient (``.options rthsa``,
            ``cthsa``), driven by the sum of the devices' losses; ``None``: no heatsink.
        period: the switching period [s] whose averages drive the networks (``None``: the
            instantaneous loss).
        start: the instant [s] from which the periods count.
    """

    case_temperature: float = DEFAULT_CASE_TEMPERATURE
    ambient: float = DEFAULT_CASE_TEMPERATURE
    heatsink: FosterNetwork | None = None
    period: float | None = None
    start: float = 0.0


@dataclass
class ThermalResult:
    """Every device's losses and junction temperature [°C] at each instant of the run
    (``junction`` holds the devices whose file has a thermal network), the case temperature,
    and the number of passes the coupling took."""

    losses: dict[str, DeviceLosses]
    junction: dict[str, np.ndarray]
    case: np.ndarray
    passes: int


def drive_intervals(time: np.ndarray, setup: ThermalSetup) -> np.ndarray:
    """The instants [s] between which the power is averaged: the period boundaries inside
    the run (with its first and last instant), or every instant without a period."""
    if setup.period is None:
        return time
    first = np.ceil((time[0] - setup.start) / setup.period - 1e-9)
    boundaries = setup.start + setup.period * np.arange(first, np.floor(
        (time[-1] - setup.start) / setup.period + 1e-9) + 1)
    inside = boundaries[(boundaries > time[0]) & (boundaries < time[-1])]
    return np.concatenate([[time[0]], inside, [time[-1]]])


def interval_powers(losses: DeviceLosses, breakpoints: np.ndarray) -> np.ndarray:
    """The average power [W] of each interval ``[breakpoints[k], breakpoints[k+1])``."""
    time = losses.time
    steps = 0.5 * (losses.conduction_power[1:] + losses.conduction_power[:-1]) * np.diff(time)
    conduction = np.interp(breakpoints, time, np.concatenate([[0.0], np.cumsum(steps)]))
    energy = np.diff(conduction)
    for event_time, _, joules in losses.events:
        k = int(np.searchsorted(breakpoints, event_time, side="right")) - 1
        energy[min(max(k, 0), energy.size - 1)] += joules
    return energy / np.diff(breakpoints)


def thermal_run(waves: Waveforms, devices: list[tuple[object, DeviceData]],
                setup: ThermalSetup) -> ThermalResult:
    """Losses and junction temperatures over a transient run (see the module docstring)."""
    time = np.asarray(waves.time, dtype=float)
    breakpoints = drive_intervals(time, setup)
    guess = {element.name: np.full(time.size, setup.case_temperature if setup.heatsink is None
                                    else setup.ambient) for element, _ in devices}
    for passes in range(1, MAX_PASSES + 1):
        _reset_clamps(devices)
        losses = {element.name: device_losses(waves, element, data,
                                              _interpolator(time, guess[element.name]))
                  for element, data in devices}
        powers = {name: interval_powers(result, breakpoints) for name, result in losses.items()}
        case = np.full(time.size, setup.case_temperature)
        if setup.heatsink is not None:
            total = sum(powers.values())
            case = setup.ambient + setup.heatsink.respond(breakpoints[:-1], total, time)[0]
        junction = {element.name: case + as_foster(data.network).respond(
            breakpoints[:-1], powers[element.name], time)[0]
            for element, data in devices if data.network is not None}
        estimate = {name: junction.get(name, case) for name in guess}
        change = max(float(np.max(np.abs(estimate[name] - guess[name]))) for name in guess)
        guess = estimate
        if change < TOLERANCE:
            return ThermalResult(losses, junction, case, passes)
    warnings.warn(f"the junction temperatures changed by {change:.3g} K in the last of "
                  f"{MAX_PASSES} passes of the loss tables at Tj: thermal runaway, or tables "
                  "that do not settle; the last pass is reported", CircuitWarning, stacklevel=2)
    return ThermalResult(losses, junction, case, MAX_PASSES)


def _reset_clamps(devices: list[tuple[object, DeviceData]]) -> None:
    """Forget the clamped lookups of a previous pass (only the last pass is reported)."""
    from circuitnsds.thermal.tables import Clamps

    for _, data in devices:
        for table in (data.turn_on, data.turn_off, data.conduction):
            if table is not None:
                table.clamps = Clamps()


def _interpolator(time: np.ndarray, values: np.ndarray):
    return lambda instants: np.interp(instants, time, values)


def steady_state(waves: Waveforms, devices: list[tuple[object, DeviceData]],
                 setup: ThermalSetup) -> ThermalResult:
    """The thermal steady state of a periodic steady state (``waves`` one period): each
    network at its DC rise ``Σ R_k · P`` under the period's average loss, the tables at the
    temperatures that produces."""
    time = np.asarray(waves.time, dtype=float)
    span = float(time[-1] - time[0])
    temperature = {element.name: setup.case_temperature if setup.heatsink is None else setup.ambient
                   for element, _ in devices}
    passes, change = 0, np.inf
    while change >= TOLERANCE and passes < MAX_PASSES:
        passes += 1
        _reset_clamps(devices)
        losses = {element.name: device_losses(waves, element, data,
                                              _constant(temperature[element.name]))
                  for element, data in devices}
        average = {name: (result.energy()[-1]) / span for name, result in losses.items()}
        case = setup.case_temperature
        if setup.heatsink is not None:
            case = setup.ambient + setup.heatsink.total * sum(average.values())
        estimate = {element.name: case + (as_foster(data.network).total * average[element.name]
                                          if data.network is not None else 0.0)
                    for element, data in devices}
        change = max(abs(estimate[name] - temperature[name]) for name in estimate)
        temperature = estimate
    junction = {element.name: np.full(time.size, temperature[element.name])
                for element, data in devices if data.network is not None}
    return ThermalResult(losses, junction, np.full(time.size, case), passes)


def _constant(value: float):
    return lambda instants: np.full(np.shape(instants), value)


def switching_period(circuit) -> tuple[float | None, float]:
    """The shortest period [s] among the circuit's periodic sources (a PULSE with PER, an
    undamped SIN) and that source's delay [s]: the switching period whose averages drive
    the networks (a carrier at 20 kHz, not the 50 Hz of an inverter's references, whose
    ripple of Tj stays visible); ``(None, 0)`` without one."""
    best: tuple[float, float] | None = None
    for element in circuit.elements:
        function = getattr(element, "function", None)
        period = getattr(function, "period", None)
        if not period and getattr(function, "frequency", None) and not getattr(
                function, "damping", 0.0) and getattr(function, "amplitude", 0.0):
            period = 1.0 / abs(function.frequency)  # sin(-ωt): ngspice runs it
        if period and period > 0 and (best is None or period < best[0]):
            best = (float(period), float(getattr(function, "delay", 0.0) or 0.0))
    return best if best is not None else (None, 0.0)


def setup_from_options(options: dict, period: float | None = None, start: float = 0.0) -> ThermalSetup:
    """The :class:`ThermalSetup` of a circuit's ``.options`` (``tcase``; or a heatsink:
    ``rthsa`` [K/W], ``cthsa`` [J/K], ``tamb`` [°C]) and its switching period [s]."""
    from circuitnsds.errors import CircuitError

    if "rthsa" in options and "tcase" in options:
        raise CircuitError(".options tcase and a heatsink (rthsa) both fix the case temperature",
                           where=".options", hint="keep one of them")
    if "rthsa" not in options:
        return ThermalSetup(float(options.get("tcase", DEFAULT_CASE_TEMPERATURE)),
                            period=period, start=start)
    resistance = float(options["rthsa"])
    tau = max(resistance * float(options.get("cthsa", 0.0)), 1e-300)
    return ThermalSetup(ambient=float(options.get("tamb", DEFAULT_CASE_TEMPERATURE)),
                        heatsink=FosterNetwork((resistance,), (tau,)), period=period, start=start)


def devices_of(circuit) -> list[tuple[object, DeviceData]]:
    """The circuit's devices whose model names a thermal description, with its data (each
    file read once).

    Raises:
        CircuitError: a diode given a switch's file, or a switch a diode's (``class="Diode"``).
    """
    from circuitnsds.thermal.plecs import read_thermal_description

    read: dict[str, DeviceData] = {}
    devices = []
    for element in circuit.elements:
        path = getattr(getattr(element, "model", None), "thermal", None)
        if path:
            if path not in read:
                read[path] = read_thermal_description(path)
            data = read[path]
            diode = hasattr(element.model, "forward_drop")
            if data.device_class and data.is_diode != diode:
                from circuitnsds.errors import CircuitError

                raise CircuitError(
                    f"{element.name} is a {'diode' if diode else 'switch'} and its thermal "
                    f"description {path} is a {data.device_class}'s", where=element.name,
                    hint="a diode takes a class=\"Diode\" file (its turn-off is its recovery), a "
                    "switch or MOSFET any other")
            devices.append((element, data))
    return devices


def warn_clamped(devices: list[tuple[object, DeviceData]]) -> None:
    """One warning per table that was looked up outside its axes (its edge value used)."""
    units = {"current": "A", "voltage": "V", "temperature": "°C"}
    seen = set()
    for element, data in devices:
        for label, table in (("turn-on energy", data.turn_on), ("turn-off energy", data.turn_off),
                             ("conduction", data.conduction)):
            if table is None or id(table) in seen or not table.clamps.counts:
                continue
            seen.add(id(table))
            axes = {"current": table.current, "temperature": table.temperature,
                    "voltage": getattr(table, "voltage", None)}
            warnings.warn(f"{element.name}: the {label} table of {data.path} was read outside its "
                          f"range ({table.clamps.describe(units, axes)}); its edge values were "
                          "used", CircuitWarning, stacklevel=2)


def analyse(circuit, waves: Waveforms, *, steady: bool, period: float | None = None,
            start: float = 0.0, devices: list[tuple[object, DeviceData]] | None = None
            ) -> ThermalResult:
    """The losses and junction temperatures of ``circuit``'s devices with a datasheet for
    its results ``waves``: a transient's (:func:`thermal_run`, driven period by period when
    ``period`` [s] is given) or a periodic steady state's (``steady``: :func:`steady_state`),
    with the case or heatsink of its ``.options``; one warning per table read outside its
    range."""
    devices = devices_of(circuit) if devices is None else devices
    setup = setup_from_options(circuit.options, period, start)
    result = (steady_state if steady else thermal_run)(waves, devices, setup)
    warn_clamped(devices)
    return result


def with_junction_temperatures(waves: Waveforms, result: ThermalResult) -> Waveforms:
    """``waves`` with a signal ``tj(DEVICE)`` [°C] per device with a thermal network."""
    signals = {name: waves[name] for name in waves.names}
    signals.update({f"tj({name})": values for name, values in result.junction.items()})
    return Waveforms(waves.time, signals, waves.impulses, waves.residual, waves.title, waves.stats,
                     waves.events, waves.flux_impulses)


def loss_columns(table, result: ThermalResult | None) -> dict[str, float]:
    """A sweep point's loss figures: ``efficiency`` (when the table has outputs),
    ``losses_W`` (the loss rows' sum), ``stored_W`` (energy going into L and C), each datasheet device's parts
    ``NAME.conduction_W`` … ``NAME.recovery_W`` and ``max(tj(NAME))`` [°C]."""
    columns = {}
    if table.has_outputs:
        columns["efficiency"] = table.efficiency
    columns["losses_W"] = float(sum(row.power for row in table.rows if row.kind == "loss"))
    columns["stored_W"] = table.total("stored")
    devices = result.losses if result is not None else {}
    for row in table.rows:
        if row.element in devices:
            for part in ("conduction", "turn_on", "turn_off", "recovery"):
                columns[f"{row.element}.{part}_W"] = getattr(row, part)
    for name, values in (result.junction.items() if result is not None else ()):
        columns[f"max(tj({name}))"] = float(np.max(values))
    return columns
