"""PLECS thermal descriptions (issue 35): each computation method against hand values, the
clamping of lookups outside a table, errors at the XML's file:line, and the Foster and Cauer
networks against closed forms."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from circuitnsds.thermal.networks import CauerNetwork, FosterNetwork, cauer_to_foster
from circuitnsds.thermal.plecs import read_thermal_description
from circuitnsds.thermal.tables import ThermalDataError

CURRENTS = [0.0, 10.0, 20.0]
VOLTAGES = [0.0, 300.0, 600.0]
TEMPERATURES = [25.0, 125.0]


def energy_mj(i, v, t):
    """A deliberately non-linear energy [mJ] sampled into the table."""
    return 0.01 * i ** 1.5 * (v / 300.0) ** 1.2 * (1 + 0.004 * (t - 25))


def _rows(values):
    return " ".join(f"{x:.17g}" for x in values)


def energy_block(tag, method="Table only", formula=""):
    planes = "".join("<Temperature>" + "".join(
        f"<Voltage>{_rows(energy_mj(i, v, t) for i in CURRENTS)}</Voltage>" for v in VOLTAGES)
        + "</Temperature>\n" for t in TEMPERATURES)
    formula_line = f"<Formula>{formula}</Formula>" if formula else ""
    return (f"<{tag}><ComputationMethod>{method}</ComputationMethod>{formula_line}\n"
            f"<CurrentAxis>{_rows(CURRENTS)}</CurrentAxis><VoltageAxis>{_rows(VOLTAGES)}</VoltageAxis>\n"
            f"<TemperatureAxis>{_rows(TEMPERATURES)}</TemperatureAxis>\n"
            f"<Energy scale=\"0.001\">\n{planes}</Energy></{tag}>\n")


def description(semiconductor, thermal="", device_class="IGBT"):
    return ('<?xml version="1.0" encoding="UTF-8"?>\n'
            '<SemiconductorLibrary xmlns="http://www.plexim.com/xml/semiconductors/" version="1.1">\n'
            f'<Package class="{device_class}" vendor="Test" partnumber="T1">\n<Variables/>\n'
            f'<SemiconductorData type="{device_class}">\n{semiconductor}</SemiconductorData>\n'
            f'{thermal}</Package>\n</SemiconductorLibrary>\n')


def write(tmp_path, text, name="device.xml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def trilinear(i, v, t):
    """Linear interpolation of energy_mj's samples written out by hand [J]."""
    def bracket(axis, x):
        k = min(max(np.searchsorted(axis, x, side="right") - 1, 0), len(axis) - 2)
        return k, (x - axis[k]) / (axis[k + 1] - axis[k])
    (a, wa), (b, wb), (c, wc) = bracket(CURRENTS, i), bracket(VOLTAGES, v), bracket(TEMPERATURES, t)
    total = 0.0
    for di, fi in ((0, 1 - wa), (1, wa)):
        for dv, fv in ((0, 1 - wb), (1, wb)):
            for dt, ft in ((0, 1 - wc), (1, wc)):
                total += fi * fv * ft * energy_mj(CURRENTS[a + di], VOLTAGES[b + dv],
                                                  TEMPERATURES[c + dt])
    return 1e-3 * total


def test_table_only_is_trilinear_in_current_voltage_and_temperature(tmp_path):
    data = read_thermal_description(write(tmp_path, description(energy_block("TurnOnLoss"))))
    for i, v, t in [(7.0, 450.0, 60.0), (13.5, 120.0, 110.0), (10.0, 300.0, 25.0)]:
        assert data.turn_on(i, v, t) == pytest.approx(trilinear(i, v, t), rel=1e-12)
    assert data.turn_on(10.0, 300.0, 125.0) == pytest.approx(1e-3 * energy_mj(10, 300, 125), rel=1e-12)
    assert not data.turn_on.clamps.counts


def test_a_lookup_outside_the_table_takes_its_edge_and_is_counted(tmp_path):
    data = read_thermal_description(write(tmp_path, description(energy_block("TurnOffLoss"))))
    assert data.turn_off(35.0, 450.0, 150.0) == pytest.approx(trilinear(20.0, 450.0, 125.0), rel=1e-12)
    assert data.turn_off.clamps.counts == {"temperature": 1, "current": 1}
    assert data.turn_off.clamps.farthest["current"][1] == 35.0


def test_formula_method_against_hand_values(tmp_path):
    block = ("<TurnOnLoss><ComputationMethod>Formula</ComputationMethod>"
             "<Formula>2e-6*i*v/600*(1+0.003*(T-25))</Formula></TurnOnLoss>\n")
    data = read_thermal_description(write(tmp_path, description(block)))
    assert data.turn_on(12.0, 400.0, 75.0) == pytest.approx(2e-6 * 12 * 400 / 600 * 1.15, rel=1e-12)


def test_table_and_formula_scales_the_table_value(tmp_path):
    block = energy_block("TurnOffLoss", "Table and formula", "E*(1+0.05*(v>500))")
    data = read_thermal_description(write(tmp_path, description(block)))
    assert data.turn_off(7.0, 550.0, 60.0) == pytest.approx(1.05 * trilinear(7.0, 550.0, 60.0), rel=1e-12)
    assert data.turn_off(7.0, 450.0, 60.0) == pytest.approx(trilinear(7.0, 450.0, 60.0), rel=1e-12)


def test_conduction_table_is_bilinear_in_current_and_temperature(tmp_path):
    block = ("<ConductionLoss><ComputationMethod>Table only</ComputationMethod>"
             "<CurrentAxis>0 10 40</CurrentAxis><TemperatureAxis>25 150</TemperatureAxis>"
             "<VoltageDrop scale=\"1\"><Temperature>0 1.0 2.2</Temperature>"
             "<Temperature>0 1.2 3.0</Temperature></VoltageDrop></ConductionLoss>\n")
    data = read_thermal_description(write(tmp_path, description(block)))
    # i = 25 A: halfway 10..40 A; T = 100 °C: 0.6 of 25..150 °C
    at25, at150 = 1.0 + 0.5 * 1.2, 1.2 + 0.5 * 1.8
    assert data.conduction([25.0], 100.0)[0] == pytest.approx(0.4 * at25 + 0.6 * at150, rel=1e-12)
    temperatures = np.array([25.0, 150.0])
    assert data.conduction(np.array([5.0, 5.0]), temperatures) == pytest.approx([0.5, 0.6])


@pytest.mark.parametrize(("text", "marker", "words"), [
    (description(energy_block("TurnOnLoss", "Polynomial")), "Polynomial", "ComputationMethod"),
    (description(energy_block("TurnOnLoss").replace("<Voltage>", "<Voltage>1 ", 1)), "<Voltage>1 ",
     "4 values for 3 currents"),
    (description("<Switching/>\n"), "<Switching/>", "<Switching> inside <SemiconductorData>"),
    (description("", '<ThermalModel><Branch type="Foster">\n<RTauElement R="-1" Tau="1"/>'
                 '</Branch></ThermalModel>\n'), 'R="-1"', "positive number"),
    (description("", '<ThermalModel><Branch type="Ladder"/></ThermalModel>\n'), "Ladder",
     "Foster or Cauer"),
    ("<Package>\n<SemiconductorData>\n</Package>\n", "</Package>", "not well-formed"),
    ('<?xml version="1.0"?>\n<!DOCTYPE x [<!ENTITY a "b">]>\n<Package/>\n', "DOCTYPE", "DTD"),
])
def test_what_is_not_understood_is_an_error_at_its_line(tmp_path, text, marker, words):
    path = write(tmp_path, text)
    line = next(k for k, content in enumerate(text.splitlines(), 1) if marker in content)
    with pytest.raises(ThermalDataError) as caught:
        read_thermal_description(path)
    assert str(caught.value.where) == f"{path}:{line}"
    assert words in str(caught.value)


def test_foster_network_driven_by_a_power_step_is_its_closed_form():
    network = FosterNetwork((0.3, 0.7, 1.1), (2e-4, 3e-3, 5e-2))
    time = np.linspace(0.0, 0.2, 401)
    rise, _ = network.respond(np.array([0.0]), np.array([40.0]), time)
    closed = 40.0 * sum(r * (1 - np.exp(-time / tau)) for r, tau in zip(network.resistance, network.tau))
    assert rise == pytest.approx(closed, rel=1e-12, abs=1e-12)


def test_foster_network_driven_period_by_period():
    """Piecewise-constant power: each period's step response superposed by hand."""
    network = FosterNetwork((0.5, 1.0), (1e-4, 1e-3))
    edges = np.arange(0.0, 2e-3 + 1e-12, 1e-4)
    powers = 1.0 + 0.5 * np.sin(np.arange(edges.size - 1))
    time = np.array([5e-4, 1.234e-3, 2e-3])
    rise, _ = network.respond(edges[:-1], powers, time)
    expected = [sum((p - (powers[k - 1] if k else 0.0)) * network.step(t - edges[k])
                    for k, p in enumerate(powers) if edges[k] <= t) for t in time]
    assert rise == pytest.approx(expected, rel=1e-12)


def test_cauer_step_response_is_its_closed_form():
    """Two-stage ladder: Z(s) = (R1 + R2 + s R1 R2 C2) / (a s² + b s + 1), stepped by hand."""
    r1, r2, c1, c2 = 0.2, 0.6, 5e-3, 0.4
    a, b = r1 * r2 * c1 * c2, c1 * (r1 + r2) + r2 * c2
    poles = np.roots([a, b, 1.0])
    time = np.linspace(0.0, 3.0, 301)
    numerator = lambda s: r1 + r2 + s * r1 * r2 * c2  # noqa: E731
    closed = (r1 + r2) + sum(numerator(p) * np.exp(p * time) / (p * a * (p - q))
                             for p, q in (poles, poles[::-1]))
    foster = cauer_to_foster(CauerNetwork((r1, r2), (c1, c2)))
    assert foster.step(time) == pytest.approx(closed.real, rel=1e-9, abs=1e-12)
    single = cauer_to_foster(CauerNetwork((0.8,), (0.05,)))
    assert single.resistance == pytest.approx((0.8,)) and single.tau == pytest.approx((0.04,))


def test_cauer_network_equals_its_foster_transform_at_every_frequency():
    ladder = CauerNetwork((0.05, 0.12, 0.3, 0.5), (2e-3, 1e-2, 0.2, 3.0))
    foster = cauer_to_foster(ladder)
    for omega in np.logspace(-3, 5, 33):
        s = 1j * omega
        z = 0.0
        for r, c in zip(reversed(ladder.resistance), reversed(ladder.capacitance)):
            z = 1.0 / (s * c + 1.0 / (r + z))  # continued fraction from the case side
        transformed = sum(r / (1 + s * tau) for r, tau in zip(foster.resistance, foster.tau))
        assert transformed == pytest.approx(z, rel=1e-9)
    assert foster.total == pytest.approx(ladder.total, rel=1e-12)


def test_reader_takes_foster_and_cauer_branches(tmp_path):
    foster = read_thermal_description(write(tmp_path, description(
        "", '<ThermalModel><Branch type="Foster"><RTauElement R="0.1" Tau="1e-3"/>'
        '<RTauElement R="0.2" Tau="2e-2"/></Branch></ThermalModel>\n'), "f.xml"))
    assert foster.network == FosterNetwork((0.1, 0.2), (1e-3, 2e-2))
    cauer = read_thermal_description(write(tmp_path, description(
        "", '<ThermalModel><Branch type="Cauer"><RCElement R="0.1" C="0.01"/>'
        '</Branch></ThermalModel>\n'), "c.xml"))
    assert cauer.network == CauerNetwork((0.1,), (0.01,))


axes_values = st.lists(st.floats(-1e3, 1e3, allow_nan=False), min_size=1, max_size=4, unique=True)


@settings(max_examples=40, deadline=None)
@given(currents=axes_values, voltages=axes_values, temperatures=axes_values, data=st.data())
def test_any_table_reads_back_its_samples_and_interpolates_between_them(
        tmp_path_factory, currents, voltages, temperatures, data):
    currents, voltages, temperatures = sorted(currents), sorted(voltages), sorted(temperatures)
    energy = np.array(data.draw(st.lists(st.floats(0, 10, allow_nan=False),
                                         min_size=len(currents) * len(voltages) * len(temperatures),
                                         max_size=len(currents) * len(voltages) * len(temperatures))))
    energy = energy.reshape(len(temperatures), len(voltages), len(currents))
    planes = "".join("<Temperature>" + "".join(f"<Voltage>{_rows(row)}</Voltage>" for row in plane)
                     + "</Temperature>" for plane in energy)
    block = (f"<TurnOnLoss><CurrentAxis>{_rows(currents)}</CurrentAxis><VoltageAxis>"
             f"{_rows(voltages)}</VoltageAxis><TemperatureAxis>{_rows(temperatures)}"
             f"</TemperatureAxis><Energy scale=\"0.5\">{planes}</Energy></TurnOnLoss>")
    table = read_thermal_description(write(tmp_path_factory.mktemp("h"), description(block))).turn_on
    for t, temperature in enumerate(temperatures):
        for v, voltage in enumerate(voltages):
            for i, current in enumerate(currents):
                assert table(current, voltage, temperature) == pytest.approx(0.5 * energy[t, v, i])
    point = [data.draw(st.floats(axis[0], axis[-1])) for axis in (currents, voltages, temperatures)]
    value = table(*point)
    assert 0.5 * energy.min() - 1e-9 <= value <= 0.5 * energy.max() + 1e-9
    assert not table.clamps.counts
