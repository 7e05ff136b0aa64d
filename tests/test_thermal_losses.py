"""Switching and conduction losses from datasheets and junction temperature (issue 35): a buck
whose switch has bilinear E_on/E_off tables, a conduction table and a two-stage Foster
network, checked against energies summed in the test at its own events and against the Foster
network driven period by period; PSS losses against a settled transient's last period; the
loss table's rows and files from the command line."""

import csv
import subprocess
import sys

import numpy as np
import pytest

import circuitnsds
from circuitnsds.output.measure import mean
from circuitnsds.thermal.junction import ThermalSetup, devices_of, steady_state, thermal_run

PERIOD = 10e-6
TCASE = 40.0
FOSTER = ((0.5, 1.0), (1e-4, 2e-3))


def e_on(i, v):
    return 1e-6 * (0.5 + 0.2 * i + 0.01 * v + 0.004 * i * v)


def e_off(i, v):
    return 1e-6 * (0.3 + 0.1 * i + 0.02 * v + 0.003 * i * v)


def v_on(i):
    return 0.4 + 0.05 * i


def _energy(tag, function):
    rows = "".join(f"<Voltage>{function(0, v) * 1e3:.17g} {function(20, v) * 1e3:.17g}</Voltage>"
                   for v in (0, 40))
    return (f"<{tag}><ComputationMethod>Table only</ComputationMethod><CurrentAxis>0 20</CurrentAxis>"
            f"<VoltageAxis>0 40</VoltageAxis><TemperatureAxis>25</TemperatureAxis>"
            f"<Energy scale=\"0.001\"><Temperature>{rows}</Temperature></Energy></{tag}>\n")


SWITCH_XML = (
    '<?xml version="1.0"?>\n<SemiconductorLibrary xmlns="http://www.plexim.com/xml/semiconductors/">'
    '<Package class="IGBT" vendor="Test" partnumber="B1"><SemiconductorData type="IGBT">\n'
    + _energy("TurnOnLoss", e_on) + _energy("TurnOffLoss", e_off)
    + "<ConductionLoss><ComputationMethod>Table only</ComputationMethod><CurrentAxis>0 20</CurrentAxis>"
    f"<TemperatureAxis>25</TemperatureAxis><VoltageDrop><Temperature>{v_on(0)} {v_on(20)}"
    "</Temperature></VoltageDrop></ConductionLoss>\n</SemiconductorData>\n<ThermalModel><Branch "
    'type="Foster">' + "".join(f'<RTauElement R="{r}" Tau="{tau}"/>' for r, tau in zip(*FOSTER))
    + "</Branch></ThermalModel></Package></SemiconductorLibrary>\n")

BUCK = f"""buck with datasheet losses
Vin in 0 DC 24
Vgate gate 0 PULSE(0 5 0 10n 10n 4.99u {PERIOD})
S1 in sw gate 0 swmod
D1 0 sw dfree
L1 sw out 100u
C1 out 0 100u
Rload out 0 5
.model swmod SW(VT=2.5 VH=0 RON=10m ROFF=1e9 thermal="sub/switch.xml")
.model dfree D(Ron=1m)
.options tcase={TCASE:g}
.tran 0.1u 1m
.end
"""


@pytest.fixture(scope="module")
def buck(tmp_path_factory):
    folder = tmp_path_factory.mktemp("buck")
    (folder / "sub").mkdir()
    (folder / "sub" / "switch.xml").write_text(SWITCH_XML)
    (folder / "buck.cir").write_text(BUCK)
    return folder


def _run(folder, *arguments):
    done = subprocess.run([sys.executable, "-m", "circuitnsds", *arguments], cwd=folder,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    return done


def test_switching_and_conduction_powers_are_the_tables_at_the_switch_events(buck):
    t0, t1 = 0.5e-3, 1e-3
    _run(buck, "run", "buck.cir", "-q", "-o", "out.csv", "--tstart", "0.5m",
         "--losses-csv", "losses.csv")
    with open(buck / "losses.csv", newline="") as handle:
        rows = {row["element"]: row for row in csv.DictReader(handle)}
    waves = circuitnsds.read_netlist(buck / "buck.cir").transient()
    time, inductor = waves.time, waves["i(l1)"]
    across = waves["v(in)"] - waves["v(sw)"]
    turn_on = turn_off = 0.0
    # (the switch's events; the exact integrator, which auto takes, lists the diode's too)
    assert {name for _, name, _ in waves.events} <= {"s1", "d1"}
    for event_time, name, closed in waves.events:
        if name != "s1" or not t0 <= event_time < t1:
            continue
        current = np.interp(event_time, time, inductor)  # the inductor's, continuous
        before = np.searchsorted(time, event_time, side="right") - 1
        if closed:
            turn_on += e_on(current, across[before])
        else:
            turn_off += e_off(current, across[before + 1])
    switch = waves["i(s1)"]
    closed = np.abs(switch) > 1e-3  # open: 24 V / 1 GΩ
    conduction = mean(time, np.where(closed, v_on(np.abs(switch)) * np.abs(switch), 0.0), t0, t1)
    s1 = rows["s1"]
    assert float(s1["turn_on_W"]) == pytest.approx(turn_on / (t1 - t0), rel=0.01)
    assert float(s1["turn_off_W"]) == pytest.approx(turn_off / (t1 - t0), rel=0.01)
    assert float(s1["conduction_W"]) == pytest.approx(conduction, rel=0.01)
    assert float(s1["power_W"]) == pytest.approx(sum(float(s1[f"{c}_W"]) for c in (
        "conduction", "turn_on", "turn_off", "recovery")), rel=1e-9)
    assert float(s1["turn_on_W"]) > 0.1 and float(s1["turn_off_W"]) > 0.1


def test_junction_temperature_is_the_foster_network_driven_by_each_periods_losses(buck):
    _run(buck, "run", "buck.cir", "-q", "-o", "out.csv")
    with open(buck / "out.csv", newline="") as handle:
        table = list(csv.DictReader(handle))
    tj = np.array([float(row["tj(s1)"]) for row in table])
    waves = circuitnsds.read_netlist(buck / "buck.cir").transient()
    time, switch = waves.time, waves["i(s1)"]
    across = waves["v(in)"] - waves["v(sw)"]
    closed = np.abs(switch) > 1e-3
    power = np.where(closed, v_on(np.abs(switch)) * np.abs(switch), 0.0)
    energy_to = np.concatenate([[0.0], np.cumsum(0.5 * (power[1:] + power[:-1]) * np.diff(time))])
    periods = int(round(time[-1] / PERIOD))
    energies = np.diff(np.interp(PERIOD * np.arange(periods + 1), time, energy_to))
    for event_time, name, on in waves.events:
        if name != "s1":  # (the exact integrator lists the diode's events too)
            continue
        after = np.searchsorted(time, event_time, side="right")
        energy = (e_on(switch[after], across[after - 1]) if on
                  else e_off(switch[after - 1], across[after]))
        energies[int(event_time // PERIOD)] += energy
    stages = np.zeros(2)
    for joules in energies:  # the exact response of each stage to a power held for a period
        decay = np.exp(-PERIOD / np.array(FOSTER[1]))
        stages = stages * decay + np.array(FOSTER[0]) * joules / PERIOD * (1 - decay)
    assert tj[0] == pytest.approx(TCASE)
    assert tj[-1] - TCASE == pytest.approx(stages.sum(), rel=0.02)
    assert tj[-1] - TCASE > 1.0


def test_pss_losses_equal_a_settled_transients_last_period(buck):
    circuit = circuitnsds.read_netlist(buck / "buck.cir")
    devices = devices_of(circuit)
    setup = ThermalSetup(TCASE, period=PERIOD)
    pss = circuit.pss(PERIOD, step=0.1e-6)
    settled = steady_state(pss.waveforms, devices, setup).losses["s1"].average(
        pss.waveforms.time[0], pss.waveforms.time[-1])
    waves = circuit.transient(0.1e-6, 12e-3)
    last = thermal_run(waves, devices, setup).losses["s1"].average(12e-3 - PERIOD, 12e-3)
    for column in ("conduction", "turn_on", "turn_off", "total"):
        assert settled[column] == pytest.approx(last[column], rel=2e-3), column


def test_pss_gives_the_thermal_steady_state_and_the_loss_columns(buck):
    done = _run(buck, "pss", "buck.cir", "-o", "pss.csv", "--losses", "rload", "--losses-csv",
                "pss_losses.csv", "--step", "0.1u")
    with open(buck / "pss_losses.csv", newline="") as handle:
        rows = {row["element"]: row for row in csv.DictReader(handle)}
    steady = TCASE + sum(FOSTER[0]) * float(rows["s1"]["power_W"])
    reported = float(done.stderr.split("tj(s1) = ")[1].split()[0])
    assert reported == pytest.approx(steady, rel=1e-3)
    assert "turn-on" in done.stdout and "efficiency" in done.stdout


def test_a_load_named_in_loads_is_an_output_whatever_its_kind(tmp_path):
    # issue 35: a current-sink load was booked as an input (efficiency 71 %)
    netlist = tmp_path / "sink.cir"
    netlist.write_text("sink load\nV1 in 0 DC 10\nR1 in out 1\nIload out 0 DC 2\n.tran 1u 10u\n.end\n")
    done = _run(tmp_path, "run", "sink.cir", "-q", "-o", "out.csv", "--losses", "iload",
                "--losses-csv", "l.csv")
    with open(tmp_path / "l.csv", newline="") as handle:
        rows = {row["element"]: row for row in csv.DictReader(handle)}
    assert rows["iload"]["kind"] == "output"
    assert float(rows["iload"]["power_W"]) == pytest.approx(8 * 2, rel=1e-9)
    assert float(rows["v1"]["power_W"]) == pytest.approx(10 * 2, rel=1e-9)
    assert "efficiency 80 %" in done.stdout


def test_without_loads_there_is_no_efficiency_line(tmp_path):
    netlist = tmp_path / "r.cir"
    netlist.write_text("divider\nV1 in 0 DC 10\nR1 in 0 5\n.tran 1u 10u\n.end\n")
    done = _run(tmp_path, "run", "r.cir", "-q", "-o", "out.csv", "--losses")
    assert "power balance" in done.stdout and "efficiency" not in done.stdout


def test_a_gate_driver_is_an_input_not_a_negative_loss(tmp_path):
    netlist = tmp_path / "drive.cir"
    netlist.write_text("driver\nV1 c 0 DC 1\nE1 g 0 c 0 10\nRg g 0 100\n.tran 1u 10u\n.end\n")
    done = _run(tmp_path, "run", "drive.cir", "-q", "-o", "out.csv", "--losses-csv", "l.csv")
    with open(tmp_path / "l.csv", newline="") as handle:
        rows = {row["element"]: row for row in csv.DictReader(handle)}
    assert rows["e1"]["kind"] == "input" and float(rows["e1"]["power_W"]) == pytest.approx(1.0)
    assert done.returncode == 0


def test_the_window_selects_the_losses(buck):
    _run(buck, "run", "buck.cir", "-q", "-o", "out.csv", "--tstop", "0.1m", "--losses-csv", "a.csv")
    _run(buck, "run", "buck.cir", "-q", "-o", "out.csv", "--tstart", "0.9m", "--losses-csv", "b.csv")
    powers = []
    for name in ("a.csv", "b.csv"):
        with open(buck / name, newline="") as handle:
            powers.append({row["element"]: float(row["power_W"]) for row in csv.DictReader(handle)})
    assert powers[0]["rload"] < 0.5 * powers[1]["rload"]  # the output still rising at 0.1 ms


def test_a_missing_thermal_file_is_an_error_at_the_model_line(tmp_path):
    netlist = tmp_path / "m.cir"
    netlist.write_text("t\nS1 a 0 c 0 sw\n.model sw SW(thermal=\"Nowhere.xml\")\nV1 a 0 1\n"
                       "V2 c 0 1\n.tran 1u 2u\n.end\n")
    done = subprocess.run([sys.executable, "-m", "circuitnsds", "run", "m.cir", "-q"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 1
    assert "m.cir:3" in done.stderr and "Nowhere.xml" in done.stderr


def e_rr(i, v):
    """Recovery energy [J] against the negative blocking voltage vendors write for diodes."""
    return 1e-6 * (0.2 + 0.05 * i - 0.01 * v - 0.002 * i * v)


DIODE_XML = (
    '<?xml version="1.0"?>\n<Package class="Diode" vendor="Test" partnumber="D1">'
    '<SemiconductorData type="Diode"><TurnOffLoss><ComputationMethod>Table only</ComputationMethod>'
    "<CurrentAxis>0 20</CurrentAxis><VoltageAxis>-40 0</VoltageAxis><TemperatureAxis>25</TemperatureAxis>"
    '<Energy scale="1e-6"><Temperature>'
    + "".join(f"<Voltage>{e_rr(0, v) * 1e6:.17g} {e_rr(20, v) * 1e6:.17g}</Voltage>" for v in (-40, 0))
    + "</Temperature></Energy></TurnOffLoss></SemiconductorData></Package>\n")


def test_diode_recovery_is_charged_at_each_turn_off(buck):
    (buck / "diode.xml").write_text(DIODE_XML)
    netlist = buck / "buck_diode.cir"
    netlist.write_text(BUCK.replace("D(Ron=1m)", 'D(Ron=1m thermal="diode.xml")'))
    circuit = circuitnsds.read_netlist(netlist)
    waves = circuit.transient()
    result = thermal_run(waves, devices_of(circuit), ThermalSetup(TCASE, period=PERIOD))
    t0, t1 = 0.5e-3, 1e-3
    current, across = waves["i(d1)"], -waves["v(sw)"]  # anode at ground, cathode at sw
    on = current > 1e-6
    expected = sum(e_rr(current[k - 1], across[k]) for k in np.flatnonzero(on[:-1] & ~on[1:]) + 1
                   if t0 <= waves.time[k - 1] < t1)
    parts = result.losses["d1"].average(t0, t1)
    assert expected > 0
    assert parts["recovery"] == pytest.approx(expected / (t1 - t0), rel=0.01)
    assert parts["turn_on"] == 0.0 and parts["turn_off"] == 0.0


def test_a_sweep_adds_each_points_losses_as_columns(buck):
    from circuitnsds.sweeps.api import sweep

    netlist = buck / "sweep.cir"
    netlist.write_text(BUCK.replace("Rload out 0 5", "Rload out 0 {rl}\n.param rl=5")
                       .replace(".tran 0.1u 1m", ".tran 0.1u 0.3m"))
    table = sweep(netlist, {"rl": [2, 5]}, workers=0, losses=["rload"])
    assert list(table["status"]) == ["ok", "ok"]
    for k, rl in enumerate((2, 5)):
        single = buck / f"single_{rl}.cir"
        single.write_text(netlist.read_text().replace(".param rl=5", f".param rl={rl}"))
        circuit = circuitnsds.read_netlist(single)
        waves = circuit.transient()
        parts = thermal_run(waves, devices_of(circuit), ThermalSetup(TCASE, period=PERIOD)
                            ).losses["s1"].average(waves.time[0], waves.time[-1])
        assert table["s1.turn_on_W"][k] == pytest.approx(parts["turn_on"], rel=1e-9)
        assert table["s1.conduction_W"][k] == pytest.approx(parts["conduction"], rel=1e-9)
    assert 0 < table["efficiency"][0] < 1 and "max(tj(s1))" in table.columns


def test_the_sic_buck_example_agrees_with_the_datasheet_estimate(tmp_path):
    # the bundled example; its PSS lost the turn-on at the period's start before the first
    # step's switching was counted (turn-on 0 W)
    import importlib.util
    from pathlib import Path

    path = Path(__file__).resolve().parent.parent / "examples" / "sic_buck_losses.py"
    spec = importlib.util.spec_from_file_location("sic_buck_losses", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    figure = tmp_path / "sic.png"
    rows = module.main(["--fast", "--out", str(figure)])
    assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    for key in ("turn_on", "turn_off", "conduction", "recovery", "switch"):
        assert rows["simulated"][key] == pytest.approx(rows["estimate"][key], rel=0.01), key
    assert rows["simulated"]["tj_switch"] == pytest.approx(rows["estimate"]["tj_switch"], abs=0.5)


def test_a_heatsink_shared_by_the_devices_sets_their_case(buck):
    (buck / "diode.xml").write_text(DIODE_XML.replace(
        "</SemiconductorData>", '</SemiconductorData><ThermalModel><Branch type="Cauer">'
        '<RCElement R="0.3" C="0.01"/><RCElement R="0.2" C="0.5"/></Branch></ThermalModel>'))
    netlist = buck / "sink.cir"
    netlist.write_text(BUCK.replace("D(Ron=1m)", 'D(Ron=1m thermal="diode.xml")')
                       .replace(f".options tcase={TCASE:g}", ".options rthsa=0.5 cthsa=2 tamb=30"))
    circuit = circuitnsds.read_netlist(netlist)
    pss = circuit.pss(PERIOD, step=0.1e-6)
    from circuitnsds.thermal.junction import analyse

    result = analyse(circuit, pss.waveforms, steady=True, period=PERIOD)
    span = pss.waveforms.time[-1] - pss.waveforms.time[0]
    power = {name: device.energy()[-1] / span for name, device in result.losses.items()}
    case = 30 + 0.5 * (power["s1"] + power["d1"])
    assert result.junction["s1"][0] == pytest.approx(case + sum(FOSTER[0]) * power["s1"], rel=1e-6)
    assert result.junction["d1"][0] == pytest.approx(case + 0.5 * power["d1"], rel=1e-6)


@pytest.mark.parametrize(("options", "words"), [
    (".options tcase=50 rthsa=1", "both fix the case temperature"),
    (".options tamb=40", "rthsa is not given"),
    (".options rthsa=0", "must be positive"),
])
def test_contradictory_thermal_options_are_errors_at_their_line(options, words):
    from circuitnsds.errors import NetlistError

    with pytest.raises(NetlistError, match=words):
        circuitnsds.read_netlist(f"t\nV1 a 0 1\nR1 a 0 1\n{options}\n.tran 1u 2u\n.end\n")


def test_mosfet_and_resistor_models_and_thermal(tmp_path):
    from circuitnsds.errors import NetlistError

    (tmp_path / "Fet.xml").write_text(SWITCH_XML)
    netlist = tmp_path / "fet.cir"
    netlist.write_text("t\nV1 d 0 10\nVg g 0 10\nM1 d g 0 fet\n"
                       ".model fet VDMOS(Rd=5m Vto=3 thermal=\"Fet.xml\")\n.tran 1u 2u\n.end\n")
    fet = circuitnsds.read_netlist(netlist).element("m1")
    assert fet.model.thermal == str(tmp_path / "Fet.xml")  # the case of the path kept
    netlist.write_text("t\nV1 a 0 1\nR1 a 0 rm\n.model rm R(R=1 thermal=\"Fet.xml\")\n"
                       ".tran 1u 2u\n.end\n")
    with pytest.raises(NetlistError, match="thermal= names a device's datasheet"):
        circuitnsds.read_netlist(netlist)


def test_junction_temperatures_get_their_own_panel_in_degrees(buck):
    from circuitnsds.output.plot import figure_data
    from circuitnsds.thermal.junction import analyse, with_junction_temperatures

    circuit = circuitnsds.read_netlist(buck / "buck.cir")
    waves = circuit.transient(0.1e-6, 0.1e-3)
    waves = with_junction_temperatures(waves, analyse(circuit, waves, steady=False, period=PERIOD))
    panels = {panel.ylabel: [name for name, _ in panel.traces] for panel in figure_data(waves).panels}
    assert panels["junction temperature [°C]"] == ["tj(s1)"]  # shown without --signals, unscaled
    line = next(values for name, values in figure_data(waves).panels[-1].traces if name == "tj(s1)")
    assert line[0] == pytest.approx(TCASE)


def test_info_names_each_devices_datasheet(buck):
    done = _run(buck, "info", "buck.cir")
    line = next(text for text in done.stdout.splitlines() if text.strip().startswith("s1 "))
    assert "datasheet losses and junction temperature from" in line and "switch.xml" in line


def test_the_networks_are_driven_per_switching_period_not_per_mains_period():
    from circuitnsds.thermal.junction import switching_period
    from tests.conftest import circuit_from

    circuit = circuit_from("Vref r 0 SIN(0 1 50)\nVtri c 0 PULSE(-1 1 2u 25u 25u 0 50u)\n"
                           "R1 r 0 1\nR2 c 0 1\nVdc d 0 DC 3\nR3 d 0 1\n.tran 1u 20m")
    assert switching_period(circuit) == (50e-6, 2e-6)
    assert switching_period(circuit_from("V1 a 0 DC 1\nR1 a 0 1\n.tran 1u 1m")) == (None, 0.0)
    # a SIN of negative frequency runs as sin(-ωt), period 1/|f| (it was left out: no period)
    assert switching_period(circuit_from("V1 a 0 SIN(0 1 -20k)\nR1 a 0 1\n.tran 1u 1m")) == (50e-6, 0.0)


def test_a_diodes_file_on_a_switch_is_an_error_naming_both(buck):
    from circuitnsds.errors import CircuitError

    (buck / "diode.xml").write_text(DIODE_XML)
    netlist = buck / "swapped.cir"
    netlist.write_text(BUCK.replace('thermal="sub/switch.xml"', 'thermal="diode.xml"'))
    with pytest.raises(CircuitError, match="s1 is a switch and its thermal description .* Diode's"):
        devices_of(circuitnsds.read_netlist(netlist))
